// The pieces of the species study that moved down to sim/: the period-cell entry and the albedo
// Monte Carlo, each against a closed form.
#include "sim/albedo.h"

#include <omp.h>

#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "common/error.h"
#include "sim/optics/material.h"
#include "sim/scatterer/period_cell_entry.h"
#include "tests/sim/sim_test_util.h"

namespace plumage::sim {
namespace {

// A clear keratin slab at normal incidence reflects, summed incoherently over its internal
// bounces, R_slab = R + (1 − R)² R / (1 − R²) = 2R / (1 + R), with R = ((n − 1)/(n + 1))².
TEST(Albedo, ClearSlabReflectsTheIncoherentSlabSum) {
    const double lambda = 550.0;
    auto tracer = std::make_shared<const ExplicitScatterer>(
        single_mesh_scene(testing::box_mesh({-2000, -2000, -50}, {2000, 2000, 0}),
                          dielectric_interface(optics::keratin()), "slab"));
    const PeriodCellEntry cell(tracer, 10.0, 10.0, 0.0);
    const AlbedoEstimate e = measure_albedo(*tracer, cell, Vec3d(0, 0, 1), lambda, 200000, 7);
    const double n = optics::keratin()->index(lambda).real();
    const double r = std::pow((n - 1.0) / (n + 1.0), 2);
    const double expected = 2.0 * r / (1.0 + r);
    EXPECT_GT(e.standard_error, 0.0);
    EXPECT_LT(std::abs(e.albedo - expected), 4.0 * e.standard_error)
        << e.albedo << " vs " << expected << " ± " << e.standard_error;
    EXPECT_EQ(e.mismatched_paths, 0.0);
    // The same bits on any thread count: one thread against the default.
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    const AlbedoEstimate one = measure_albedo(*tracer, cell, Vec3d(0, 0, 1), lambda, 200000, 7);
    omp_set_num_threads(threads);
    EXPECT_EQ(one.albedo, e.albedo);
    EXPECT_EQ(one.standard_error, e.standard_error);
}

// Entry points are uniform over the cell: inside it, with the mean and variance of a uniform.
TEST(PeriodCellEntry, EntriesAreUniformOverTheCell) {
    auto inner = std::make_shared<const ExplicitScatterer>(
        single_mesh_scene(testing::square_mesh(100.0), absorber(), "black"));
    const double px = 4.0, py = 10.0, y0 = 5.0;
    const PeriodCellEntry cell(inner, px, py, y0);
    const int n = 100000;
    double sx = 0.0, sy = 0.0, sxx = 0.0;
    for (int i = 0; i < n; ++i) {
        Rng rng(1, static_cast<std::uint64_t>(i));
        const Vec2 e = cell.draw_entry(rng);
        ASSERT_LE(std::abs(e.x()), 0.5 * px);
        ASSERT_LE(std::abs(e.y() - y0), 0.5 * py);
        sx += e.x();
        sy += e.y();
        sxx += e.x() * e.x();
    }
    const double sigma_mean = px / std::sqrt(12.0 * n);
    EXPECT_LT(std::abs(sx / n), 5.0 * sigma_mean);
    EXPECT_LT(std::abs(sy / n - y0), 5.0 * py / std::sqrt(12.0 * n));
    EXPECT_NEAR(sxx / n, px * px / 12.0, 0.02 * px * px / 12.0);
    EXPECT_THROW(PeriodCellEntry(inner, 0.0, 1.0, 0.0), InputError);
}

}  // namespace
}  // namespace plumage::sim
