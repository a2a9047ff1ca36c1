#include "virtual_gonio/record_provenance.h"

#include <unistd.h>

#include <array>
#include <chrono>
#include <ctime>

#include <fmt/chrono.h>
#include <fmt/format.h>

#include "common/build_info.h"
#include "common/version.h"

namespace plumage::gonio {
namespace {

// The current time, UTC, ISO 8601 to the second ("2026-11-25T17:10:55Z").
std::string utc_now() {
    const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
    return fmt::format("{:%Y-%m-%dT%H:%M:%SZ}", fmt::gmtime(now));
}

std::string host_name() {
    std::array<char, 256> name{};
    if (::gethostname(name.data(), name.size() - 1) != 0 || name[0] == '\0') return "unknown";
    return name.data();
}

}  // namespace

void write_provenance(record::Hdf5Writer& h5, const Provenance& p) {
    h5.create_group("provenance");
    h5.set_attribute("/provenance", "scatterer", p.scatterer);
    h5.set_attribute("/provenance", "plumage_version", kVersion);
    h5.set_attribute("/provenance", "git_commit", std::string(git_commit()));
    h5.set_attribute("/provenance", "date", utc_now());
    h5.set_attribute("/provenance", "host", host_name());
    h5.set_attribute("/provenance", "compiler", std::string(compiler()));
    for (const LibraryVersion& library : library_versions()) {
        h5.set_attribute("/provenance", fmt::format("{}_version", library.name),
                         std::string(library.version));
    }
    h5.set_unsigned_attribute("/provenance", "seed", p.seed);
    h5.set_integer_attribute("/provenance", "threads", p.threads);
    h5.set_attribute("/provenance", "wall_time_s", p.wall_time_s);
    h5.set_attribute("/provenance", "cpu_time_s", p.cpu_time_s);
    h5.set_attribute("/provenance", "cpu_per_wall",
                     p.wall_time_s > 0.0 ? p.cpu_time_s / p.wall_time_s : 0.0);
    h5.set_attribute("/provenance", "config", p.config);
}

void write_polarisation(record::Hdf5Writer& h5) {
    h5.create_group("instrument");
    h5.set_attribute("/instrument", "polarisation",
                     "unpolarised: the light is unpolarised and the detector polarisation-blind; "
                     "the tracer and the models carry no polarisation state (an interface takes "
                     "the mean of the s and p Fresnel intensities)");
}

void write_path_options(record::Hdf5Writer& h5, bool shared, bool split, bool split_reflections) {
    h5.set_attribute("/instrument", "wavelength_paths",
                     shared ? "shared: one path per quantum for every wavelength, re-weighted per "
                              "wavelength (sim/tracer.h, spectral path sharing)"
                            : "separate: one path per quantum and wavelength");
    h5.set_attribute("/instrument", "path_splitting",
                     split_reflections
                         ? "first film and the reflected branch's next film: each quantum's path "
                           "split at its first film event into a reflected and a transmitted "
                           "branch, the reflected one again at its next event if that is a film "
                           "(sim/tracer.h)"
                     : split ? "first film: each quantum's path split at its first film event into "
                               "a reflected and a transmitted branch (sim/tracer.h)"
                             : "none");
}

record::Attributes convergence_attributes(const std::string& columns) {
    return {{"columns", columns},
            {"units", "1, s, 1, 1 (per column)"},
            {"description",
             "how the estimate settled, one row per pass: pass number, wall time since the "
             "start, quanta (counted as `columns` says), estimated relative error"}};
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
