// The judge of the cheaper 2D levels (sim/wave/levels_against_full_wave.h): its arithmetic on
// curves whose answer is known.
#include "sim/wave/levels_against_full_wave.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "common/error.h"
#include "sim/wave/ray_optics_validity.h"

namespace plumage::sim::wave {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

Row2d small_barbule() { return barbule_row_2d(3.0, 0.4, -0.37, 2.64, 0.59, 0.3, 1.25, 0.0, 1); }

FullWaveCurves2d curves_from_physical_optics(const Row2d& row, double lambda_nm, double scale) {
    FullWaveCurves2d c;
    c.lambda_nm = lambda_nm;
    c.coarse_px_per_um = 45.0;
    c.fine_px_per_um = 67.5;
    for (int m = 0; m < 720; ++m) c.theta_s_rad.push_back((-179.5 + 0.5 * m) * kDeg);
    const PhysicalOpticsOptions o;
    c.fine[0] = scattering_width(row, {lambda_nm, 0.0, Polarisation2d::te}, c.theta_s_rad, o);
    c.fine[1] = scattering_width(row, {lambda_nm, 0.0, Polarisation2d::tm}, c.theta_s_rad, o);
    for (auto& pol : c.fine)
        for (double& s : pol) s *= scale;
    c.coarse = c.fine;
    return c;
}

// Physical optics judged by its own σ: no error, and none from the reference's resolution.
TEST(LevelsAgainstFullWave, PhysicalOpticsAgainstItselfHasNoError) {
    const Row2d row = small_barbule();
    const std::vector<FullWaveCurves2d> curves{curves_from_physical_optics(row, 550.0, 1.0)};
    const FullWaveVerdict2d v = judge_against_full_wave(row, curves);
    ASSERT_EQ(v.wavelengths.size(), 1u);
    EXPECT_EQ(v.wavelengths[0].physical_optics.relative_l1, 0.0);
    EXPECT_EQ(v.wavelengths[0].physical_optics.power_error, 0.0);
    EXPECT_EQ(v.wavelengths[0].full_wave_resolution.relative_l1, 0.0);
    EXPECT_NE(v.level, "full wave");
}

// A reference twice PO's σ: PO then sits at half the reference everywhere: L1 = 1/2, power
// −1/2, and the verdict falls to full wave.
TEST(LevelsAgainstFullWave, ScaledReferenceGivesTheScaledError) {
    const Row2d row = small_barbule();
    const std::vector<FullWaveCurves2d> curves{curves_from_physical_optics(row, 550.0, 2.0)};
    const FullWaveVerdict2d v = judge_against_full_wave(row, curves);
    EXPECT_NEAR(v.wavelengths[0].physical_optics.power_error, -0.5, 1e-12);
    EXPECT_NEAR(v.wavelengths[0].physical_optics.relative_l1, 0.5, 1e-12);
    EXPECT_EQ(v.level, "full wave");
}

TEST(LevelsAgainstFullWave, RefusesMismatchedCurves) {
    const Row2d row = small_barbule();
    std::vector<FullWaveCurves2d> curves{curves_from_physical_optics(row, 550.0, 1.0)};
    curves[0].coarse[1].pop_back();
    EXPECT_THROW(judge_against_full_wave(row, curves), InputError);
    EXPECT_THROW(judge_against_full_wave(row, {}), InputError);
}

}  // namespace
}  // namespace plumage::sim::wave
