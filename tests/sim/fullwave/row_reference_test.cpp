// Full wave as a live judge of a periodic row (sim/fullwave/row_reference.h): its cost is the
// grids its runs use, its reflectances are full_wave_row's own (bit for bit, whatever the thread
// count), and a grid the λ/(10 n) rule refuses is refused before any run.
#include "sim/fullwave/row_reference.h"

#include <array>
#include <complex>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "common/error.h"
#include "sim/fullwave/full_wave_2d.h"

namespace plumage::sim::fullwave {
namespace {

// One period of a lossless grating: an ellipse 0.6 × 0.3 µm turned by 0.4 rad, n = 1.55.
CrossSection2d grating() {
    CrossSection2d s;
    s.bodies.push_back({ellipse({0.0, 0.0}, 0.3, 0.15, 0.4),
                        std::make_shared<optics::ConstantMaterial>("keratin-like", 1.55)});
    return s;
}

TEST(FullWaveRowReference, CostAndReflectanceAreFullWaveRowsOwn) {
    const CrossSection2d period = grating();
    const std::array<double, 2> lambdas{550.0, 650.0};
    RowReferenceRequest request;
    request.resolution_px_per_um = 30.0;
    request.decay = 1e-4;
    request.threads = 2;
    const RowReference ref = row_reference(period, 1.0, 0.0, lambdas, request);
    FullWave2dOptions o;
    o.resolution_px_per_um = 30.0;
    o.decay = 1e-4;
    o.dispersion = Dispersion::fitted;
    const FullWaveRowResult te = full_wave_row(period, 1.0, Polarisation2d::te, 0.0, lambdas, o);
    EXPECT_EQ(ref.cost.coarse_cells, te.grid_cells);
    EXPECT_EQ(ref.cost.runs_per_grid, 1u);
    EXPECT_GT(ref.cost.fine_cells, 2 * ref.cost.coarse_cells);  // 1.5² more, the margins alike
    EXPECT_EQ(ref.cost.cell_runs, 2.0 * static_cast<double>(ref.cost.coarse_cells) +
                                      2.0 * static_cast<double>(ref.cost.fine_cells));
    EXPECT_EQ(ref.coarse_px_per_um, te.resolution_px_per_um);
    EXPECT_NEAR(ref.fine_px_per_um, 46.0, 1e-12);  // 45 cells per 1 µm period, made even
    ASSERT_EQ(ref.reflectance.size(), lambdas.size());
    for (std::size_t k = 0; k < lambdas.size(); ++k) {
        EXPECT_EQ(ref.reflectance[k].lambda_nm, lambdas[k]);
        EXPECT_EQ(ref.reflectance[k].coarse[0], te.wavelengths[k].reflectance);  // bit for bit
        // the two grids agree to the grid error of a 2-cell-per-λ/(10 n) interface
        for (std::size_t p = 0; p < 2; ++p)
            EXPECT_NEAR(ref.reflectance[k].fine[p], ref.reflectance[k].coarse[p],
                        0.1 * ref.reflectance[k].fine[p]);
    }
    EXPECT_GT(ref.seconds, 0.0);
    EXPECT_GT(ref.max_time_steps, 0.0);
}

TEST(FullWaveRowReference, CoarseGridIsRefusedBeforeAnyRun) {
    const std::array<double, 1> lambdas{400.0};
    RowReferenceRequest request;
    request.resolution_px_per_um = 20.0;  // λ/(10 n) at 400 nm, n = 1.55: 38.75 px/µm
    try {
        row_reference_cost(grating(), 1.0, 0.0, lambdas, request);
        FAIL() << "accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("λ/(10 n)"), std::string::npos) << e.what();
    }
    // oblique: one run per wavelength and grid
    request.resolution_px_per_um = 40.0;
    const std::array<double, 3> three{450.0, 550.0, 650.0};
    EXPECT_EQ(row_reference_cost(grating(), 1.0, 0.3, three, request).runs_per_grid, 3u);
}

}  // namespace
}  // namespace plumage::sim::fullwave
