// The goniometer measures the 2.5D physical-optics level (sim/wave/surface/physical_optics_25d.h)
// without bias (issue 36, acceptance 3): its photon estimator, which plays quanta through the
// level's importance sampler, against its eval estimator, a cubature of eval() over the same
// detector cones, per wavelength. tests/sim/wave/physical_optics_25d_test.cpp checks the sampler
// alone (tests/analysis/chi_square.h: directions against pdf(), weights against eval()); this
// checks what a study reads from the instrument.
//
// Cells: three light directions (in the cross-section's plane, along the barbules, oblique),
// each with views along its reflection cone ε_o = −ε_i and 6° off it (within the band of
// ±2θ_d = ±9° the cells' tilts reach), θ_o from −70° to 70° in steps of 5°: the row's
// diffraction lobes and the dark between them. Detector cones of 2.5° half-angle, so that no two
// cells share a direction (cells that overlapped would share quanta, and their errors would be
// correlated, which χ² does not allow). Per wavelength, over the cells whose cubature value is
// above 1 % of that wavelength's largest (a cell the photons rarely reach has a σ that the
// per-quantum variance does not yet know):
// z = (photon − eval) / sqrt(σ_photon² + ε_eval²), ε_eval the cubature's own error (against half
// its rings), and Pearson's χ² = Σ z² over n cells, p = Q(n/2, χ²/2), Šidák-corrected for the
// three wavelengths at a 1 % family-wise level (tests/analysis/chi_square.h's constants). The
// summed power over those cells within 4 of its standard errors as well. Measured (60 000 quanta
// per light and wavelength, 16 rings against 8): χ² 116.7 over 165 cells at 450 nm, 84.3 over
// 111 at 550 nm, 74.7 over 85 at 650 nm (p 0.998, 0.97, 0.78); other seeds gave χ²/n 0.6–1.0, and
// the spread of the cells over 12 seeds matched their stated σ (variance ratio 1.05). The
// cubature's own error is about 1 % of each σ².
#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/metrics/statistics.h"
#include "common/constants.h"
#include "common/seed.h"
#include "sim/wave/surface/physical_optics_25d.h"
#include "tests/analysis/chi_square.h"
#include "tests/sim/wave/physical_optics_25d_test_util.h"
#include "virtual_gonio/goniometer.h"

namespace plumage::sim::wave {
namespace {

using po25d_test::direction;
using po25d_test::small_row;

std::vector<gonio::DirectionPair> cone_pairs() {
    const std::vector<Vec3d> lights = {direction(30.0 * kDeg, 0.0), direction(0.0, 40.0 * kDeg),
                                       direction(-25.0 * kDeg, 20.0 * kDeg)};
    std::vector<gonio::DirectionPair> pairs;
    for (const Vec3d& wi : lights) {
        const double cone = -std::asin(wi.y());
        for (double off : {0.0, 6.0 * kDeg})
            for (int t = -14; t <= 14; ++t)
                pairs.push_back({wi, direction(5.0 * t * kDeg, cone + off)});
    }
    return pairs;
}

struct WavelengthChiSquare {
    double chi_square = 0.0, photon_sum = 0.0, eval_sum = 0.0, variance = 0.0;
    int cells = 0;
};

WavelengthChiSquare compare(const gonio::BrdfRecord& photon, const gonio::BrdfRecord& eval,
                            std::size_t k) {
    double largest = 0.0;
    for (std::size_t p = 0; p < eval.config.pairs.size(); ++p)
        largest = std::max(largest, eval.at(p, k));
    WavelengthChiSquare out;
    for (std::size_t p = 0; p < eval.config.pairs.size(); ++p) {
        if (!(eval.at(p, k) > 1e-2 * largest)) continue;
        const double sigma2 = std::pow(photon.error_at(p, k), 2) + std::pow(eval.error_at(p, k), 2);
        EXPECT_GT(sigma2, 0.0) << "pair " << p;
        if (!(sigma2 > 0.0)) continue;
        out.chi_square += std::pow(photon.at(p, k) - eval.at(p, k), 2) / sigma2;
        out.photon_sum += photon.at(p, k);
        out.eval_sum += eval.at(p, k);
        out.variance += sigma2;
        ++out.cells;
    }
    return out;
}

TEST(PhysicalOptics25dGoniometer, PhotonEstimatorAgreesWithEvalPerWavelength) {
    const PhysicalOptics25d model(small_row());
    gonio::GoniometerConfig c;
    c.direction_set = "custom: views along the reflection cone";
    c.pairs = cone_pairs();
    c.wavelengths_nm = {450.0, 550.0, 650.0};
    c.detector_half_angle_rad = 2.5 * kDeg;
    c.estimator = gonio::Estimator::photon;
    c.seed = derive_seed(kDefaultSeed, "tests/physical_optics_25d/goniometer");
    c.quanta_per_pass = 60000;
    c.max_passes = 1;
    const gonio::BrdfRecord photon = gonio::measure_brdf(model, c);
    c.estimator = gonio::Estimator::eval;
    c.eval_rings = 16;  // its error: against 8 rings
    const gonio::BrdfRecord eval = gonio::measure_brdf(model, c);
    const int wavelengths = static_cast<int>(c.wavelengths_nm.size());
    const double significance =
        analysis::sidak_significance(plumage::testing::kChiSquareSignificance, wavelengths);
    for (std::size_t k = 0; k < c.wavelengths_nm.size(); ++k) {
        const WavelengthChiSquare w = compare(photon, eval, k);
        const double p = analysis::chi_square_p_value(w.chi_square, w.cells);
        const std::string what = fmt::format(
            "{:.0f} nm: χ² {:.1f} over {} cells (p = {:.3g}), power {:.5g} against "
            "{:.5g} ± {:.2g}",
            c.wavelengths_nm[k], w.chi_square, w.cells, p, w.photon_sum, w.eval_sum,
            std::sqrt(w.variance));
        RecordProperty(fmt::format("chi_square_{:.0f}nm", c.wavelengths_nm[k]), what);
        EXPECT_GT(w.cells, 40) << what;
        EXPECT_GT(p, significance) << what;
        EXPECT_LT(std::abs(w.photon_sum - w.eval_sum), 4.0 * std::sqrt(w.variance)) << what;
    }
}

}  // namespace
}  // namespace plumage::sim::wave
