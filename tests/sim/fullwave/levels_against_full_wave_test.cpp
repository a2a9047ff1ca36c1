// The judge of the cheaper 2D levels (sim/wave/compare/levels_against_full_wave.h): its arithmetic
// on curves whose answer is known.
#include "sim/wave/compare/levels_against_full_wave.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "common/error.h"
#include "sim/optics/material.h"
#include "sim/optics/multilayer.h"
#include "sim/wave/compare/ray_optics_validity.h"
#include "sim/wave/surface/physical_optics_hybrid_2d.h"

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

// The committed rock-dove row (tests/reference/fullwave_rock_dove_row: A = 10 µm, b = 0.25, a
// 0.59 µm film over a 0.3 µm gap over melanin, period 12.5 µm, μ = −20.05°, θ_i = 0), every 100
// nm of 400–700 (the hybrid at a 0.02 µm step costs seconds a wavelength): TE and TM at both grids.
std::vector<RowReflectanceFullWave> rock_dove_row_reference() {
    std::ifstream in(std::string(PLUMAGE_SOURCE_DIR) +
                     "/tests/reference/fullwave_rock_dove_row/totals.csv");
    EXPECT_TRUE(in.good());
    std::string line;
    std::getline(in, line);
    std::map<double, RowReflectanceFullWave> by_lambda;
    std::vector<double> grids;
    while (std::getline(in, line)) {
        std::stringstream ss(line);
        std::vector<std::string> c;
        for (std::string cell; std::getline(ss, cell, ',');) c.push_back(cell);
        const double lambda = std::stod(c[2]), res = std::stod(c[3]);
        if (std::fmod(lambda, 100.0) != 0.0 || std::stod(c[1]) != 0.0) continue;
        if (std::find(grids.begin(), grids.end(), res) == grids.end()) grids.push_back(res);
        RowReflectanceFullWave& r = by_lambda[lambda];
        r.lambda_nm = lambda;
        const std::size_t pol = c[0] == "TE" ? 0 : 1;
        (res == *std::max_element(grids.begin(), grids.end()) ? r.fine : r.coarse)[pol] =
            std::stod(c[4]);
    }
    EXPECT_EQ(grids.size(), 2u);
    std::vector<RowReflectanceFullWave> out;
    for (const auto& [lambda, r] : by_lambda) out.push_back(r);
    return out;
}

// The GO–PO hybrid as a level of the row judge, on the rock dove's row, where its gap follows the
// film: the rays carry film and gap as separate interfaces and miss the depth of the stack's
// interference minima, so it is far above full wave in band mean (+27 % over these four
// wavelengths, +38 % over 31: docs/full_wave.md), beyond the planar stack's levels (+6 %, +8 %
// here), and is not the level chosen. The other levels' numbers do not depend on whether the
// hybrid is asked.
TEST(LevelsAgainstFullWave, RowJudgeWeighsTheHybridAndKeepsTheCheapestLevel) {
    const std::vector<RowReflectanceFullWave> reference = rock_dove_row_reference();
    ASSERT_EQ(reference.size(), 4u);
    const Row2d row = barbule_row_2d(10.0, 0.25, -0.37, 2.64, 0.59, 0.3, 1.25, -20.05 * kDeg, 1);
    const CrossSection2d gap_cell = barbule_with_gap(10.0, 0.25, 0.59, 0.3);
    // Neighbouring barbules of this row come within 0.039 µm of each other (the hybrid refuses a
    // step coarser than that); 0.02 µm samples the gap between them.
    const RowVerdict2d with =
        judge_row_against_full_wave(row, 0.0, reference, 0.05, 0.02, &gap_cell);
    ASSERT_EQ(with.hybrid.size(), reference.size());
    const RowVerdict2d without = judge_row_against_full_wave(row, 0.0, reference, 0.05, 0.02);
    EXPECT_TRUE(without.hybrid.empty());
    EXPECT_EQ(with.po_error, without.po_error);
    EXPECT_EQ(with.go_error, without.go_error);
    for (std::size_t k = 0; k < reference.size(); ++k)
        std::printf(
            "%.0f nm: R full wave %.4f, ray optics %.4f, physical optics %.4f, hybrid %.4f\n",
            with.lambda_nm[k], with.full_wave[k], with.ray_optics[k], with.physical_optics[k],
            with.hybrid[k]);
    std::printf("band-mean errors: ray optics %+.3f, physical optics %+.3f, hybrid %+.3f\n",
                with.go_error, with.po_error, with.hybrid_error);
    EXPECT_GT(with.hybrid_error, 0.2);
    EXPECT_GT(with.hybrid_error, with.go_error + 0.1);
    EXPECT_NE(with.level, "GO–PO hybrid");
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
