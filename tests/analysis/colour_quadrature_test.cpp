// The colour error of a spectral grid, against spectra whose colour error is known: a flat
// spectrum (none on any grid, the whites are normalised on the grid) and the rock-dove keratin
// film of Huang 2022 (d = 0.59 µm), whose interference fringes a 50 nm grid cannot follow.
#include "analysis/metrics/colour_quadrature.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/error.h"
#include "sim/optics/material.h"
#include "sim/optics/thin_film.h"

namespace plumage::analysis {
namespace {

TEST(ColourQuadratureError, IsZeroForAFlatSpectrumOnAnyGrid) {
    const auto grid = optics::WavelengthGrid::uniform(400.0, 700.0, 50.0);
    const ColourQuadratureError e = colour_quadrature_error(
        3, grid, [](std::size_t i, double) { return 0.2 + 0.3 * static_cast<double>(i); });
    EXPECT_EQ(e.spectra, 3u);
    EXPECT_LT(e.max, 1e-9);
}

// Film reflectance of keratin in air at incidence angle i·15° (i = 0 … 5).
double rock_dove_film(std::size_t i, double lambda_nm) {
    static const auto keratin = optics::keratin();
    const optics::FilmMedia media{1.0, keratin->index(lambda_nm), optics::Complex(1.0)};
    return optics::airy_film_intensities_unpolarised(media, 0.59, lambda_nm,
                                                     std::cos(static_cast<double>(i) * 0.2618))
        .reflectance;
}

TEST(ColourQuadratureError, FiftyNanometresMissTheRockDoveFilmsHueAndTwentyFiveKeepIt) {
    const ColourQuadratureError coarse = colour_quadrature_error(
        6, optics::WavelengthGrid::uniform(400.0, 700.0, 50.0), rock_dove_film);
    const ColourQuadratureError fine = colour_quadrature_error(
        6, optics::WavelengthGrid::uniform(400.0, 700.0, 25.0), rock_dove_film);
    EXPECT_GT(coarse.max, 4.0);  // the ΔE ≈ 8 at 50 nm
    EXPECT_LT(fine.max, 1.0);    // a just-noticeable difference
    EXPECT_LE(fine.mean, fine.p95);
    EXPECT_LE(fine.p95, fine.max);
}

TEST(ColourQuadratureError, RefusesAGridOfOneWavelength) {
    EXPECT_THROW(colour_quadrature_error(1, optics::WavelengthGrid({550.0}),
                                         [](std::size_t, double) { return 1.0; }),
                 InputError);
}

}  // namespace
}  // namespace plumage::analysis
