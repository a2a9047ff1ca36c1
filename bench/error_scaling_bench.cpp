// How the explicit patch's time to 1 % grows with the measurement (issue 15, acceptance 3):
// the rock-dove patch through the goniometer's photon estimator, on subsets of the 61 × 60
// Filip 2024 set, on 1 to 7 wavelengths and on patches of 1/4 to 4 times the area, each
// projected to 1 % from a few passes by the measured 1/√t convergence,
// t(1 %) = t · (ε / 1 %)², ε the record's estimated relative RMS error over its signal cells
// (value ≥ 10 % of the mean at that wavelength, GoniometerConfig::signal_fraction), with the
// wavelengths sharing their paths (share_wavelength_paths) unless --separate. One axis varies at a
// time; the exponent of each is the least-squares slope of log t(1 %) against log n. Not a Google
// Benchmark program: the figures are a table and its fits, not a rate.
//
//   build/bench/plumage_bench_error_scaling [--quick] [--separate] [--csv FILE]
//
// --quick runs each point with a tenth of the quanta (a smoke test of the program; its
// projections are noisier).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <fmt/core.h>

#include "common/constants.h"
#include "geometry/barbule.h"
#include "sim/tracer.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/goniometer.h"

namespace plumage::gonio {
namespace {

struct Point {
    std::string axis;  // "light directions", "wavelengths", "patch area"
    double n;          // the axis' value
    std::size_t pairs, wavelengths;
    double patch_side_um, wall_s, error, projected_s;
};

// The default measurement of the instruments benchmark: 48 barbules × 30 cells (about
// 0.6 × 0.6 mm), beam radius 60 µm, 5° detectors, 550 nm. `scale` multiplies the patch's
// side and the beam's radius alike, so the lit share of the patch stays the same.
Point measure(const std::string& axis, double n, std::size_t lights, std::size_t wavelengths,
              double scale, std::uint64_t quanta, bool shared) {
    geometry::BarbuleRowParams row;
    row.barbules = static_cast<int>(std::lround(48 * scale));
    row.cells_per_barbule = static_cast<int>(std::lround(30 * scale));
    const geometry::BarbuleRow built = geometry::build_barbule_row(row, {0.01, 0.02});
    const sim::ExplicitScatterer patch(sim::barbule_row_scene(built));
    GoniometerConfig c;
    c.direction_set = "custom";
    const auto all = filip2024_btf_pairs();  // light-major: 60 views per light
    const std::size_t views = filip2024_view_directions().size();
    c.pairs.assign(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(lights * views));
    c.wavelengths_nm.clear();
    for (std::size_t k = 0; k < wavelengths; ++k)
        c.wavelengths_nm.push_back(wavelengths == 1
                                       ? 550.0
                                       : 400.0 + 300.0 * static_cast<double>(k) /
                                                     static_cast<double>(wavelengths - 1));
    c.detector_half_angle_rad = 5.0 * kDeg;
    c.beam_radius_um = 60.0 * scale;
    c.estimator = Estimator::photon;
    c.quanta_per_pass = quanta;
    c.max_passes = 2;
    c.share_wavelength_paths = shared;
    c.signal_fraction = 0.1;
    const BrdfRecord r = measure_brdf(patch, c);
    const double error = r.convergence.back().estimated_relative_rms_error;
    return {axis,
            n,
            c.pairs.size(),
            wavelengths,
            built.bounds().sizes().x(),
            r.wall_time_s,
            error,
            r.wall_time_s * std::pow(error / 0.01, 2)};
}

// Least-squares slope of log y against log x.
double exponent(const std::vector<Point>& points, const std::string& axis) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int m = 0;
    for (const Point& p : points) {
        if (p.axis != axis) continue;
        const double x = std::log(p.n), y = std::log(p.projected_s);
        sx += x, sy += y, sxx += x * x, sxy += x * y, ++m;
    }
    return (m * sxy - sx * sy) / (m * sxx - sx * sx);
}

}  // namespace
}  // namespace plumage::gonio

int main(int argc, char** argv) {
    using namespace plumage::gonio;
    bool quick = false, shared = true;
    std::string csv;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--quick") {
            quick = true;
        } else if (a == "--separate") {
            shared = false;
        } else if (a == "--csv" && i + 1 < argc) {
            csv = argv[++i];
        } else {
            std::fprintf(stderr, "usage: %s [--quick] [--separate] [--csv FILE]\n", argv[0]);
            return 2;
        }
    }
    const std::uint64_t quanta = quick ? 2000 : 20000;
    std::vector<Point> points;
    for (std::size_t lights : {8u, 15u, 30u, 61u})
        points.push_back(measure("light directions", static_cast<double>(lights), lights, 1, 1.0,
                                 quanta, shared));
    for (std::size_t wl : {1u, 3u, 7u})
        points.push_back(
            measure("wavelengths", static_cast<double>(wl), 61, wl, 1.0, quanta, shared));
    for (double scale : {0.5, 1.0, 2.0})
        points.push_back(measure("patch area", scale * scale, 61, 1, scale, quanta, shared));

    fmt::print(
        "| axis | value | pairs | wavelengths | patch side (µm) | wall (s) | ε | t(1 %) (s) |\n"
        "|---|---|---|---|---|---|---|---|\n");
    for (const Point& p : points)
        fmt::print("| {} | {:g} | {} | {} | {:.0f} | {:.2f} | {:.4f} | {:.0f} |\n", p.axis, p.n,
                   p.pairs, p.wavelengths, p.patch_side_um, p.wall_s, p.error, p.projected_s);
    fmt::print(
        "\nexponents of t(1 %): light directions {:.2f}, wavelengths {:.2f}, patch area "
        "{:.2f}\n",
        exponent(points, "light directions"), exponent(points, "wavelengths"),
        exponent(points, "patch area"));
    if (!csv.empty()) {
        std::ofstream out(csv);
        out << "axis,value,pairs,wavelengths,patch_side_um,wall_s,relative_rms_error,"
               "projected_s_to_1pct\n";
        for (const Point& p : points)
            out << fmt::format("{},{},{},{},{},{},{},{}\n", p.axis, p.n, p.pairs, p.wavelengths,
                               p.patch_side_um, p.wall_s, p.error, p.projected_s);
    }
    return 0;
}
