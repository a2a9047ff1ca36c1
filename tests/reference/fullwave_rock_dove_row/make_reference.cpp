// Writes the full-wave reference of the rock dove's barbule ROW with its air gap (README.md
// beside this file): the reflected and transmitted diffraction orders of the periodic row, at two
// resolutions, TE and TM, from the suite's own full-wave level (sim/fullwave, full_wave_row). Not
// run in CI (tens of minutes on 2 cores); the committed CSVs are what the tests read.
//   plumage_fullwave_row_reference OUT_DIR [RESOLUTION_PX_PER_UM [LAMBDA_NM ...]]
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
        std::fprintf(stderr, "usage: %s OUT_DIR [RESOLUTION_PX_PER_UM [LAMBDA_NM ...]]\n", argv[0]);
        return 2;
    }
    const std::filesystem::path out = argv[1];
    const double coarse = argc > 2 ? std::stod(argv[2]) : 45.0;
    std::vector<double> lambdas{400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0};
    if (argc > 3) {
        lambdas.clear();
        for (int i = 3; i < argc; ++i) lambdas.push_back(std::stod(argv[i]));
    }
    constexpr double kDeg = std::numbers::pi / 180.0;
    // studies/rock_dove.toml: A = 10 µm, b = 0.25, film 0.59 µm over a 0.3 µm gap, μ = −20.05°,
    // barbules H·A = 12.5 µm apart: one barbule per period
    constexpr double kPeriodUm = 12.5;
    const fw::CrossSection2d period =
        fw::barbule_row(10.0, 0.25, 0.59, 0.3, kPeriodUm, -20.05 * kDeg, 1);
    std::filesystem::create_directories(out);
    std::ofstream orders(out / "orders.csv"), totals(out / "totals.csv");
    orders << "polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,side,m,theta_s_deg,"
              "efficiency\n";
    totals << "polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,reflectance,transmittance,"
              "absorptance,reflected_orders,time_steps,run_wall_s\n";
    for (const double res : {coarse, 1.5 * coarse}) {
        for (const auto pol : {fw::Polarisation2d::te, fw::Polarisation2d::tm}) {
            fw::FullWave2dOptions o;
            o.resolution_px_per_um = res;
            const fw::FullWaveRowResult r =
                fw::full_wave_row(period, kPeriodUm, pol, 0.0, lambdas, o);
            const std::string p(plumage::sim::wave::polarisation_name(pol));
            for (const fw::RowSpectrum& w : r.wavelengths) {
                for (const auto& [side, list] : {std::pair{"reflected", &w.reflected},
                                                 std::pair{"transmitted", &w.transmitted}})
                    for (const fw::DiffractionOrder& d : *list)
                        orders << fmt::format("{},0,{:g},{:g},{},{},{:.4f},{:.6g}\n", p,
                                              w.lambda_nm, res, side, d.m, d.theta_s_rad / kDeg,
                                              d.efficiency);
                totals << fmt::format("{},0,{:g},{:g},{:.6g},{:.6g},{:.6g},{},{:g},{:.1f}\n", p,
                                      w.lambda_nm, res, w.reflectance, w.transmittance,
                                      1.0 - w.reflectance - w.transmittance, w.reflected.size(),
                                      w.time_steps, r.seconds);
            }
            orders.flush();
            totals.flush();
            std::fprintf(stderr, "%s at %g px/µm (grid %g): %.0f s (%zu cells)\n", p.c_str(), res,
                         r.resolution_px_per_um, r.seconds, r.grid_cells);
        }
    }
    return 0;
}
