// The judge of the cheaper 2D levels (sim/wave/compare/levels_against_full_wave.h): its arithmetic
// on curves whose answer is known.
#include "sim/wave/compare/levels_against_full_wave.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "common/error.h"
#include "sim/optics/material.h"
#include "sim/optics/multilayer.h"
#include "sim/wave/compare/ray_optics_validity.h"

namespace plumage::sim::wave {
namespace {

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

// A row of flat strips 3 µm wide, 5 µm apart, lit at normal incidence: no strip shades another,
// so ray optics reflects the fill factor times the stack's reflectance (the transfer matrix, a
// closed form) from an endless row, which the judge's two finite rows must recover. Judged
// against that closed form as the "full-wave" reference, ray optics has no error and is the
// level chosen.
TEST(LevelsAgainstFullWave, RowOfFlatStripsReflectsItsFillFactorTimesItsStack) {
    const SurfaceStack2d stack{{{optics::keratin(), 0.59}}, optics::melanin()};
    Row2d row;
    row.cell = flat_strip(3.0, stack);
    row.spacing_um = 5.0;
    std::vector<RowReflectanceFullWave> reference;
    for (const double lambda : {450.0, 550.0, 650.0}) {
        const std::array<optics::StackLayer, 1> layers{
            optics::StackLayer{optics::keratin()->index(lambda), 0.59}};
        const double r = optics::transfer_matrix_intensities_unpolarised(
                             {1.0, layers, optics::melanin()->index(lambda)}, lambda, 1.0)
                             .reflectance;
        reference.push_back({lambda, {0.6 * r, 0.6 * r}, {0.6 * r, 0.6 * r}});
    }
    const RowVerdict2d v = judge_row_against_full_wave(row, 0.0, reference);
    for (std::size_t k = 0; k < reference.size(); ++k)
        EXPECT_NEAR(v.ray_optics[k], reference[k].fine[0], 1e-9 * reference[k].fine[0]);
    EXPECT_NEAR(v.go_error, 0.0, 1e-9);
    EXPECT_EQ(v.resolution_error, 0.0);
    EXPECT_EQ(v.level, "ray optics + thin film");
    // physical optics diffracts at the strips' edges, but a 3 µm strip at 450–650 nm keeps its
    // reflected power in the back half-space to a few per cent
    EXPECT_NEAR(v.po_error, 0.0, 0.05);
}

TEST(LevelsAgainstFullWave, RowJudgeRefusesAnEmptyOrUnsortedReference) {
    Row2d row;
    row.cell = flat_strip(3.0, {{{optics::keratin(), 0.59}}, optics::melanin()});
    row.spacing_um = 5.0;
    EXPECT_THROW(judge_row_against_full_wave(row, 0.0, {}), InputError);
    const std::vector<RowReflectanceFullWave> unsorted{{550.0, {0.1, 0.1}, {0.1, 0.1}},
                                                       {450.0, {0.1, 0.1}, {0.1, 0.1}}};
    EXPECT_THROW(judge_row_against_full_wave(row, 0.0, unsorted), InputError);
}

}  // namespace
}  // namespace plumage::sim::wave
