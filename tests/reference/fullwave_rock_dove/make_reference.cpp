// Writes the full-wave reference of the rock dove's barbule cross-section with its air gap
// (README.md beside this file): σ(θ_s) and the widths at two resolutions, TE and TM, from the
// suite's own full-wave level (sim/fullwave). Not run in CI (about an hour on 2 cores); the
// committed CSVs are what the rock-dove study and the tests read.
//   plumage_fullwave_reference OUT_DIR [RESOLUTION_PX_PER_UM]
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "sim/fullwave/full_wave_2d.h"

namespace fw = plumage::sim::fullwave;

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s OUT_DIR [RESOLUTION_PX_PER_UM]\n", argv[0]);
        return 2;
    }
    const std::filesystem::path out = argv[1];
    const double coarse = argc > 2 ? std::stod(argv[2]) : 45.0;
    constexpr double kDeg = std::numbers::pi / 180.0;
    // studies/rock_dove.toml: A = 10 µm, b = 0.25, film 0.59 µm over a 0.3 µm gap, μ = −20.05°
    const fw::CrossSection2d section =
        fw::barbule_row(10.0, 0.25, 0.59, 0.3, 12.5, -20.05 * kDeg, 1);
    const std::vector<double> lambdas{400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0};
    std::vector<double> theta;
    for (int m = 0; m < 720; ++m) theta.push_back((-179.5 + 0.5 * m) * kDeg);
    std::filesystem::create_directories(out);
    std::ofstream far(out / "far_field.csv"), totals(out / "totals.csv");
    far << "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,theta_s_deg,sigma_um_per_"
           "rad\n";
    totals
        << "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,back_scattering_width_um,"
           "scattering_width_um,absorption_width_um,extinction_width_um,time_steps,run_wall_s\n";
    for (const double res : {coarse, 1.5 * coarse}) {
        for (const auto pol : {fw::Polarisation2d::te, fw::Polarisation2d::tm}) {
            fw::FullWave2dOptions o;
            o.resolution_px_per_um = res;
            const fw::FullWave2dResult r =
                fw::full_wave_far_field(section, pol, 0.0, lambdas, theta, o);
            const std::string p(plumage::sim::wave::polarisation_name(pol));
            for (const fw::FarField2d& f : r.wavelengths) {
                for (std::size_t m = 0; m < theta.size(); ++m)
                    far << fmt::format("single,{},0,{:g},{:g},{:g},{:.6g}\n", p, f.lambda_nm, res,
                                       -179.5 + 0.5 * static_cast<double>(m),
                                       f.sigma_um_per_rad[m]);
                totals << fmt::format(
                    "single,{},0,{:g},{:g},{:.6g},{:.6g},{:.6g},{:.6g},{:g},{:.1f}\n", p,
                    f.lambda_nm, res, f.back_scattering_width_um, f.scattering_width_um,
                    f.absorption_width_um, f.extinction_width_um, f.time_steps, r.seconds);
            }
            far.flush();
            totals.flush();
            std::fprintf(stderr, "%s at %g px/µm: %.0f s (%zu cells)\n", p.c_str(), res, r.seconds,
                         r.grid_cells);
        }
    }
    return 0;
}
