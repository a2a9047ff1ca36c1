// Writes the full-wave reference for physical optics' transmission (README.md beside this
// file): σ(θ_s) and the widths of the two cross-sections of structures.h at θ_i = 30°,
// 450/550/650 nm, TE and TM, on two grids, from the suite's own full-wave level (sim/fullwave).
// Not run in CI (about an hour on one core); the committed CSVs are what the tests read.
//   plumage_po_transmission_reference OUT_DIR CASE [RESOLUTION_PX_PER_UM]
// CASE: film_over_melanin or semi_transparent_body. The files are written whole at the end.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "sim/fullwave/full_wave_2d.h"
#include "tests/reference/po_transmission/structures.h"

namespace fw = plumage::sim::fullwave;
namespace ref = plumage::reference::po_transmission;

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: %s OUT_DIR CASE [RESOLUTION_PX_PER_UM]\n", argv[0]);
        return 2;
    }
    const std::filesystem::path out = argv[1];
    const std::string name = argv[2];
    const double coarse = argc > 3 ? std::stod(argv[3]) : 40.0;
    fw::CrossSection2d section;
    if (name == "film_over_melanin") {
        section = ref::film_over_melanin_fullwave();
    } else if (name == "semi_transparent_body") {
        section = ref::semi_transparent_body_fullwave();
    } else {
        std::fprintf(stderr, "CASE must be film_over_melanin or semi_transparent_body\n");
        return 2;
    }
    constexpr double kDeg = std::numbers::pi / 180.0;
    std::vector<double> theta;
    for (int m = 0; m < 720; ++m) theta.push_back((-179.5 + 0.5 * m) * kDeg);
    std::ostringstream far, totals;
    for (const double res : {coarse, 1.5 * coarse}) {
        for (const auto pol : {fw::Polarisation2d::te, fw::Polarisation2d::tm}) {
            fw::FullWave2dOptions o;
            o.resolution_px_per_um = res;
            o.threads = 1;
            const fw::FullWave2dResult r = fw::full_wave_far_field(
                section, pol, ref::kThetaIDeg * kDeg, ref::kLambdasNm, theta, o);
            const std::string p(plumage::sim::wave::polarisation_name(pol));
            for (const fw::FarField2d& f : r.wavelengths) {
                for (std::size_t m = 0; m < theta.size(); ++m)
                    far << fmt::format(
                        "{},{},{:g},{:g},{:g},{:g},{:.6g}\n", name, p, ref::kThetaIDeg, f.lambda_nm,
                        res, -179.5 + 0.5 * static_cast<double>(m), f.sigma_um_per_rad[m]);
                totals << fmt::format(
                    "{},{},{:g},{:g},{:g},{:.6g},{:.6g},{:.6g},{:.6g},{:g},{:.1f}\n", name, p,
                    ref::kThetaIDeg, f.lambda_nm, res, f.back_scattering_width_um,
                    f.scattering_width_um, f.absorption_width_um, f.extinction_width_um,
                    f.time_steps, r.seconds);
            }
            std::fprintf(stderr, "%s %s at %g px/um: %.0f s (%zu cells)\n", name.c_str(), p.c_str(),
                         res, r.seconds, r.grid_cells);
        }
    }
    std::filesystem::create_directories(out);
    std::ofstream(out / ("far_field_" + name + ".csv"))
        << "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,theta_s_deg,"
           "sigma_um_per_rad\n"
        << far.str();
    std::ofstream(out / ("totals_" + name + ".csv"))
        << "case,polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,back_scattering_width_um,"
           "scattering_width_um,absorption_width_um,extinction_width_um,time_steps,run_wall_s\n"
        << totals.str();
    return 0;
}
