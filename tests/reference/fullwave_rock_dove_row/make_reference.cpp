// Writes the full-wave reference of the rock dove's barbule ROW with its air gap (README.md
// beside this file): the reflected and transmitted diffraction orders of the periodic row, at two
// resolutions, TE and TM, from the suite's own full-wave level (sim/fullwave, full_wave_row). Not
// run in CI (tens of minutes on 2 cores); the committed CSVs are what the tests read.
//   plumage_fullwave_row_reference OUT_DIR RESOLUTION_PX_PER_UM te|tm|both exact|fitted DECAY
//                                  [LAMBDA_NM ...]
// computes at RESOLUTION and 1.5 × RESOLUTION; exact: one run per wavelength with the indices
// exact there; fitted: one run for all wavelengths (Lorentz poles, their index error stated in
// fits.csv); DECAY: stop when the field under the row has fallen to DECAY of its peak.
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
    if (argc < 6) {
        std::fprintf(stderr,
                     "usage: %s OUT_DIR RESOLUTION_PX_PER_UM te|tm|both exact|fitted DECAY "
                     "[LAMBDA_NM ...]\n",
                     argv[0]);
        return 2;
    }
    const std::filesystem::path out = argv[1];
    const double coarse = std::stod(argv[2]);
    const std::string which = argv[3];
    std::vector<fw::Polarisation2d> pols;
    if (which != "tm") pols.push_back(fw::Polarisation2d::te);
    if (which != "te") pols.push_back(fw::Polarisation2d::tm);
    const bool fitted = std::string(argv[4]) == "fitted";
    const double decay = std::stod(argv[5]);
    std::vector<double> lambdas{400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0};
    if (argc > 6) {
        lambdas.clear();
        for (int i = 6; i < argc; ++i) lambdas.push_back(std::stod(argv[i]));
    }
    constexpr double kDeg = std::numbers::pi / 180.0;
    // studies/rock_dove.toml: A = 10 µm, b = 0.25, film 0.59 µm over a 0.3 µm gap, μ = −20.05°,
    // barbules H·A = 12.5 µm apart: one barbule per period
    constexpr double kPeriodUm = 12.5;
    const fw::CrossSection2d period =
        fw::barbule_row(10.0, 0.25, 0.59, 0.3, kPeriodUm, -20.05 * kDeg, 1);
    std::filesystem::create_directories(out);
    std::ofstream orders(out / "orders.csv"), totals(out / "totals.csv"), fits(out / "fits.csv");
    fits << "polarisation,resolution_px_per_um,material,max_index_error\n";
    orders << "polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,side,m,theta_s_deg,"
              "efficiency\n";
    totals << "polarisation,theta_i_deg,lambda_nm,resolution_px_per_um,reflectance,transmittance,"
              "absorptance,reflected_orders,time_steps,run_wall_s\n";
    for (const double res : {coarse, 1.5 * coarse}) {
        for (const auto pol : pols) {
            fw::FullWave2dOptions o;
            o.resolution_px_per_um = res;
            o.decay = decay;
            o.threads = 1;
            if (fitted) o.dispersion = fw::Dispersion::fitted;
            const fw::FullWaveRowResult r =
                fw::full_wave_row(period, kPeriodUm, pol, 0.0, lambdas, o);
            const std::string p(plumage::sim::wave::polarisation_name(pol));
            for (const fw::LorentzFit& f : r.dispersion_fits)
                fits << fmt::format("{},{:g},{},{:.3g}\n", p, res, f.material, f.max_index_error);
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
