// Peak memory of `plumage fit --model filip2024` on large BRDF tables (issue 43: the residual map
// had one row and column per distinct direction, N² cells: 20 000 CSV rows needed 6.3 GB and
// 30 000 ended in bad_alloc). Each run forks, so the child's peak resident set (getrusage) is the
// fit's alone; the parent reads it through a pipe. Rows: random light and view directions (every
// one distinct), three wavelengths, the Filip 2024 parrot preset with 3 % Gaussian noise.
// Reported: peak_rss_MB of the whole command (reading, fit, residual map, report), and
// max_parameter_difference between the command's parameters and analysis::fit_filip2024 called
// directly on the same observations (the map must not change the fit: 0, bit for bit).
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "analysis/fits/filip2024_fit.h"
#include "analysis/fits/user_data.h"
#include "analysis/models/filip2024.h"
#include "common/constants.h"
#include "sim/scatterer/random.h"
#include "studies/fit_command.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

Vec3d upper_direction(Rng& rng) {
    const double z = 0.05 + 0.95 * rng.uniform(), phi = 2.0 * std::numbers::pi * rng.uniform();
    const double s = std::sqrt(1.0 - z * z);
    return {s * std::cos(phi), s * std::sin(phi), z};
}

void write_csv(const fs::path& path, std::size_t rows) {
    const analysis::Filip2024Brdf model(analysis::filip2024_preset("parrot"));
    Rng rng(kDefaultSeed, 43);
    std::ofstream csv(path);
    csv << "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,wavelength_nm,value_per_sr,"
           "sigma_per_sr\n";
    const double deg = 180.0 / std::numbers::pi;
    for (std::size_t r = 0; r < rows; ++r) {
        const Vec3d wi = upper_direction(rng), wo = upper_direction(rng);
        const double lambda = 450.0 + 100.0 * static_cast<double>(r % 3);
        const double f = model.eval(wi, wo, lambda);
        const double sigma = 0.03 * f + 0.002;
        const double noise = std::sqrt(-2.0 * std::log(1.0 - rng.uniform())) *
                             std::cos(2.0 * std::numbers::pi * rng.uniform());
        csv << fmt::format("{:.12g},{:.12g},{:.12g},{:.12g},{},{:.12g},{:.12g}\n",
                           std::acos(wi.z()) * deg, std::atan2(wi.y(), wi.x()) * deg,
                           std::acos(wo.z()) * deg, std::atan2(wo.y(), wo.x()) * deg, lambda,
                           f + sigma * noise, sigma);
    }
}

struct ChildResult {
    double peak_rss_mb = 0.0;
    double max_parameter_difference = 0.0;
};

// In a child process: the command, then fit_filip2024 on the same observations.
ChildResult run_in_child(const fs::path& csv, const fs::path& out) {
    int channel[2];
    if (::pipe(channel) != 0) return {};
    const pid_t pid = ::fork();
    if (pid == 0) {
        FitCommand c;
        c.model = "filip2024";
        c.data = csv;
        const FitCommandResult r = run_fit_command(c, out);
        rusage usage{};
        ::getrusage(RUSAGE_SELF, &usage);
        const analysis::BrdfData data = analysis::read_brdf_data(csv);
        analysis::Filip2024FitOptions options;
        const auto direct = analysis::fit_filip2024(data.observations,
                                                    analysis::filip2024_preset("parrot"), options);
        const auto values = analysis::to_vector(direct.parameters);
        double difference = 0.0;
        for (const auto& p : r.summary.parameters) {
            for (int i = 0; i < analysis::kFilip2024ParameterCount; ++i) {
                if (analysis::kFilip2024ParameterTable[i].name == p.name)
                    difference = std::max(difference, std::abs(p.value - values[i]));
            }
        }
        const ChildResult result{static_cast<double>(usage.ru_maxrss) / 1024.0, difference};
        (void)!::write(channel[1], &result, sizeof result);
        ::_exit(0);
    }
    ::close(channel[1]);
    ChildResult result;
    (void)!::read(channel[0], &result, sizeof result);
    ::close(channel[0]);
    int status = 0;
    ::waitpid(pid, &status, 0);
    return result;
}

void BM_FilipFitCsvPeakMemory(benchmark::State& state) {
    const fs::path dir =
        fs::temp_directory_path() / fmt::format("plumage_fit_memory_{}", ::getpid());
    fs::create_directories(dir);
    const auto rows = static_cast<std::size_t>(state.range(0));
    write_csv(dir / "table.csv", rows);
    ChildResult result;
    for (auto _ : state) {
        fs::remove_all(dir / "out");
        result = run_in_child(dir / "table.csv", dir / "out");
    }
    state.counters["peak_rss_MB"] = result.peak_rss_mb;
    state.counters["max_parameter_difference"] = result.max_parameter_difference;
    fs::remove_all(dir);
}
BENCHMARK(BM_FilipFitCsvPeakMemory)
    ->Arg(20000)
    ->Arg(100000)
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

}  // namespace
}  // namespace plumage::studies

BENCHMARK_MAIN();
