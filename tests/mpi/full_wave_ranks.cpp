// Issue 35 (acceptance 4): one 2D far field through the full-wave level, for
// tests/mpi/full_wave_across_ranks.sh, which runs it through Meep's MPI build (library
// plumage_fullwave_mpi) under `mpirun -np 1` and `-np 2`, and through the serial build, and
// compares the numbers. The case covers the code paths a rank could take differently: a tilted
// melanin core in a keratin cortex lit obliquely (the grid turned), TE with one run per
// wavelength (conductivities), TM with fitted dispersion (Lorentz poles), the incident run.
//   full_wave_ranks RANKS OUT [RES]  runs the case (at RES px/µm, default 32: a finer grid for
//                                    timing, bench/README.md) and writes (rank 0) one
//                                    "name value" a line; refused unless Meep sees RANKS processes
//   full_wave_ranks --compare A B    prints the largest relative difference of the values of
//                                    two such files; exit code 1 above 1e-9
//   full_wave_ranks RANKS --stop     the last rank alone sets its stop flag (Ctrl-C reaching one
//                                    process) 1 s into the case: every rank must end with
//                                    Interrupted, none left stepping (a deadlock, which the
//                                    calling script's timeout catches)
#include <dlfcn.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <numbers>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <meep.hpp>

#include "common/interrupt.h"
#include "sim/fullwave/full_wave_2d.h"
#include "sim/optics/material.h"

namespace {

using namespace plumage;
using namespace plumage::sim::fullwave;

constexpr double kTolerance = 1e-9;

CrossSection2d coated_core() {
    const double tilt = 0.3;  // rad: no symmetry of the grid left
    CrossSection2d s;
    s.bodies.push_back({ellipse_shell({0.05, 0.0}, 0.4, 0.3, 0.1, tilt), optics::keratin()});
    s.bodies.push_back({ellipse({0.05, 0.0}, 0.4, 0.3, tilt), optics::melanin()});
    return s;
}

void write_result(std::FILE* out, std::string_view name, const FullWave2dResult& r) {
    for (const FarField2d& w : r.wavelengths) {
        const std::string at = fmt::format("{}.{:.0f}nm", name, w.lambda_nm);
        for (std::size_t i = 0; i < w.sigma_um_per_rad.size(); ++i)
            fmt::print(out, "{}.sigma[{}] {:.17g}\n", at, i, w.sigma_um_per_rad[i]);
        fmt::print(out, "{}.scattering {:.17g}\n", at, w.scattering_width_um);
        fmt::print(out, "{}.absorption {:.17g}\n", at, w.absorption_width_um);
        fmt::print(out, "{}.extinction {:.17g}\n", at, w.extinction_width_um);
        fmt::print(out, "{}.back {:.17g}\n", at, w.back_scattering_width_um);
        fmt::print(out, "{}.steps {:.17g}\n", at, w.time_steps);
    }
}

// Which libmeep this process loaded: the serial and the MPI build share a soname, and only the
// RPATH tells them apart.
std::string meep_library() {
    Dl_info info{};
    if (dladdr(reinterpret_cast<void*>(&meep::count_processors), &info) == 0 || !info.dli_fname)
        return "?";
    return info.dli_fname;
}

bool meep_sees(int ranks) {
    if (meep::count_processors() == ranks) return true;
    fmt::print(stderr,
               "full_wave_ranks: Meep sees {} process(es), {} asked: {} is not the MPI build "
               "(or mpirun was not used)\n",
               meep::count_processors(), ranks, meep_library());
    return false;
}

std::vector<double> directions() {
    std::vector<double> theta_s;
    for (int i = 0; i < 72; ++i)
        theta_s.push_back(-std::numbers::pi + (i + 0.5) * std::numbers::pi / 36);
    return theta_s;
}

FullWave2dOptions case_options() {
    FullWave2dOptions o;
    o.resolution_px_per_um = 32.0;  // λ/(10 n) for melanin at 550 nm: 31.4
    o.decay = 1e-5;                 // short runs: the ranks are compared, not the series
    o.threads = 1;
    return o;
}

constexpr std::array<double, 2> kLambdas{550.0, 700.0};
constexpr double kThetaI = 0.2;

int run_case(int ranks, const char* out_path, double resolution) {
    if (!meep_sees(ranks)) return 1;
    const CrossSection2d section = coated_core();
    const std::vector<double> theta_s = directions();
    FullWave2dOptions o = case_options();
    if (resolution > 0.0) o.resolution_px_per_um = resolution;
    const FullWave2dResult te =
        full_wave_far_field(section, Polarisation2d::te, kThetaI, kLambdas, theta_s, o);
    o.dispersion = Dispersion::fitted;
    const FullWave2dResult tm =
        full_wave_far_field(section, Polarisation2d::tm, kThetaI, kLambdas, theta_s, o);
    if (!meep::am_master()) return 0;
    std::FILE* out = std::fopen(out_path, "w");
    if (out == nullptr) {
        fmt::print(stderr, "full_wave_ranks: cannot write {}\n", out_path);
        return 1;
    }
    write_result(out, "te", te);
    write_result(out, "tm_fitted", tm);
    std::fclose(out);
    fmt::print("{} rank(s), {}: TE {:.2f} s, TM (fitted) {:.2f} s, {} cells\n", ranks,
               meep_library(), te.seconds, tm.seconds, te.grid_cells);
    return 0;
}

int run_stop_case(int ranks) {
    if (!meep_sees(ranks)) return 1;
    std::atomic<bool> stop{false};
    std::thread signal;
    if (meep::my_rank() == ranks - 1)
        signal = std::thread([&stop] {
            std::this_thread::sleep_for(std::chrono::seconds(1));
            stop = true;
        });
    FullWave2dOptions o = case_options();
    // A grid three times finer and a longer decay, so that the run lasts well beyond the flag's
    // 1 s on any machine (the case itself ends near 1 s on two idle cores).
    o.resolution_px_per_um *= 3.0;
    o.decay = 1e-9;
    o.stop = &stop;
    const auto started = std::chrono::steady_clock::now();
    bool interrupted = false;
    try {
        full_wave_far_field(coated_core(), Polarisation2d::te, kThetaI, kLambdas, directions(), o);
    } catch (const Interrupted&) {
        interrupted = true;
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    if (signal.joinable()) signal.join();
    fmt::print("rank {} (flag {}): {} after {:.2f} s\n", meep::my_rank(), stop ? "set" : "not set",
               interrupted ? "interrupted" : "NOT interrupted", seconds);
    return interrupted ? 0 : 1;
}

struct Value {
    std::string name;
    double value = 0.0;
};

std::vector<Value> read_values(const char* path) {
    std::ifstream in(path);
    std::vector<Value> v;
    for (Value x; in >> x.name >> x.value;) v.push_back(x);
    return v;
}

int compare(const char* path_a, const char* path_b) {
    const std::vector<Value> a = read_values(path_a), b = read_values(path_b);
    if (a.empty() || a.size() != b.size()) {
        fmt::print("FAIL: {} holds {} values, {} holds {}\n", path_a, a.size(), path_b, b.size());
        return 1;
    }
    double worst = 0.0;
    std::string worst_name = a.front().name;
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (a[i].name != b[i].name) {
            fmt::print("FAIL: value {} is {} in one file, {} in the other\n", i, a[i].name,
                       b[i].name);
            return 1;
        }
        const double scale = std::max({std::abs(a[i].value), std::abs(b[i].value), 1e-300});
        const double diff = std::abs(a[i].value - b[i].value) / scale;
        const double rel = std::isnan(diff) ? HUGE_VAL : diff;  // a NaN on one side fails
        if (rel > worst) {
            worst = rel;
            worst_name = a[i].name;
        }
    }
    const bool ok = worst <= kTolerance;
    fmt::print("{}: {} values, largest relative difference {:.3g}{}, limit {:.0e}\n",
               ok ? "ok" : "FAIL", a.size(), worst,
               worst > 0.0 ? fmt::format(" ({})", worst_name) : std::string(), kTolerance);
    return ok ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc == 4 && std::string_view(argv[1]) == "--compare") return compare(argv[2], argv[3]);
    if (argc != 3 && argc != 4) {
        fmt::print(stderr, "usage: {} RANKS OUT [RES] | RANKS --stop | --compare A B\n", argv[0]);
        return 2;
    }
    meep::initialize mpi(argc, argv);  // MPI_Init in the MPI build; nothing in the serial one
    try {
        if (std::string_view(argv[2]) == "--stop") return run_stop_case(std::stoi(argv[1]));
        return run_case(std::stoi(argv[1]), argv[2], argc == 4 ? std::stod(argv[3]) : 0.0);
    } catch (const std::exception& e) {
        // every rank runs the same deterministic code, so every rank throws alike
        fmt::print(stderr, "full_wave_ranks: {}\n", e.what());
        return 1;
    }
}
