#include "virtual_gonio/record_provenance.h"

#include <fmt/format.h>

#include "common/version.h"

namespace plumage::gonio {

void write_provenance(record::Hdf5Writer& h5, const Provenance& p) {
    h5.create_group("provenance");
    h5.set_attribute("/provenance", "scatterer", p.scatterer);
    h5.set_attribute("/provenance", "plumage_version", kVersion);
    h5.set_attribute("/provenance", "seed", fmt::format("{}", p.seed));
    h5.set_attribute("/provenance", "threads", static_cast<double>(p.threads));
    h5.set_attribute("/provenance", "wall_time_s", p.wall_time_s);
    h5.set_attribute("/provenance", "cpu_time_s", p.cpu_time_s);
    h5.set_attribute("/provenance", "cpu_per_wall",
                     p.wall_time_s > 0.0 ? p.cpu_time_s / p.wall_time_s : 0.0);
    h5.set_attribute("/provenance", "config", p.config);
}

void write_convergence(record::Hdf5Writer& h5, std::span<const ConvergenceRow> rows,
                       const record::Attributes& attributes) {
    std::vector<double> table;
    for (const auto& row : rows) {
        table.insert(table.end(),
                     {static_cast<double>(row.pass), row.wall_time_s,
                      static_cast<double>(row.quanta), row.estimated_relative_rms_error});
    }
    h5.write("convergence", std::span<const double>(table),
             std::vector<std::uint64_t>{rows.size(), 4}, attributes);
}

std::vector<ConvergenceRow> read_convergence(const std::filesystem::path& file) {
    std::vector<ConvergenceRow> rows;
    const auto table = record::read_dataset(file, "convergence");
    for (std::size_t i = 0; i + 3 < table.values.size(); i += 4) {
        rows.push_back({static_cast<int>(table.values[i]), table.values[i + 1],
                        static_cast<std::uint64_t>(table.values[i + 2]), table.values[i + 3]});
    }
    return rows;
}

}  // namespace plumage::gonio
