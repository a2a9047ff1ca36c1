// Full wave in 3D (full_wave_slab, sim/fullwave/full_wave_slab.h) against what is known without
// it: a uniform slab (the inside test always true) against the transfer matrix, with no diffuse
// light; a lossless lattice of spheres, whose specular and diffuse reflectance and transmittance
// add to one; and the two polarisations of a body symmetric under x ↔ y giving the same
// answer. Small cells (seconds); tolerances are the runs' own two-grid error.
#include "sim/fullwave/full_wave_slab.h"

#include <cmath>
#include <memory>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/error.h"
#include "sim/optics/multilayer.h"

namespace plumage::sim::fullwave {
namespace {

FullWave2dOptions small_cell(double res) {
    FullWave2dOptions o;
    o.resolution_px_per_um = res;
    o.pml_um = 0.5;
    o.gap_um = 0.25;
    return o;
}

// A keratin slab 0.4 µm thick in air, four columns each way: R and T against the transfer matrix
// within 2 |fine − coarse| and the interfaces' wobble (full_wave_2d_test.cpp: 2e-4), no diffuse
// light (a uniform slab has one order).
TEST(FullWaveSlab, UniformSlabMatchesTransferMatrix) {
    Slab3d slab;
    slab.thickness_um = 0.4;
    slab.thinnest_um = 0.4;
    slab.inside = [](const Eigen::Vector3d&) { return true; };
    slab.material = optics::keratin();
    const std::array<double, 2> lambdas{450.0, 650.0};
    slab.period_um = 4.0 / 90.0;
    const FullWaveSlabResult coarse = full_wave_slab(slab, lambdas, small_cell(90.0));
    slab.period_um = 4.0 / 135.0;
    const FullWaveSlabResult fine = full_wave_slab(slab, lambdas, small_cell(135.0));
    for (std::size_t k = 0; k < lambdas.size(); ++k) {
        const SlabSpectrum& f = fine.wavelengths[k];
        const std::array<optics::StackLayer, 1> layers{
            optics::StackLayer{optics::keratin()->index(lambdas[k]), 0.4}};
        const optics::StackIntensities tmm =
            optics::transfer_matrix_intensities_unpolarised({1.0, layers, 1.0}, lambdas[k], 1.0);
        const double r_error =
            2.0 * std::abs(f.specular_reflectance - coarse.wavelengths[k].specular_reflectance) +
            2e-4;
        fmt::print(
            "{} nm: R {:.5f} (transfer matrix {:.5f}, ±{:.1e}), T {:.5f} ({:.5f}), "
            "diffuse {:.1e} / {:.1e}; {:.1f} s\n",
            lambdas[k], f.specular_reflectance, tmm.reflectance, r_error, f.specular_transmittance,
            tmm.transmittance, f.diffuse_reflectance, f.diffuse_transmittance, fine.seconds);
        EXPECT_NEAR(f.specular_reflectance, tmm.reflectance, r_error);
        EXPECT_NEAR(f.specular_transmittance, tmm.transmittance, r_error);
        EXPECT_NEAR(f.diffuse_reflectance, 0.0, 1e-6);
        EXPECT_NEAR(f.diffuse_transmittance, 0.0, 1e-6);
    }
    // Dispersion::fitted on the same grid: one run for both wavelengths, keratin as its Lorentz
    // pole (index error 3.3e-4, which moves R by about 1e-4 here): R within 1e-3 of the exact
    // indices' run.
    FullWave2dOptions fitted = small_cell(135.0);
    fitted.dispersion = Dispersion::fitted;
    const FullWaveSlabResult one_run = full_wave_slab(slab, lambdas, fitted);
    for (std::size_t k = 0; k < lambdas.size(); ++k)
        EXPECT_NEAR(one_run.wavelengths[k].specular_reflectance,
                    fine.wavelengths[k].specular_reflectance, 1e-3)
            << lambdas[k] << " nm";
}

// A simple cubic lattice of dielectric spheres (n = 1.5, radius 0.25 µm, period 0.8 µm) in a
// slab 0.6 µm thick.
Slab3d sphere_lattice() {
    Slab3d slab;
    slab.period_um = 0.8;
    slab.thickness_um = 0.6;
    slab.thinnest_um = 0.5;
    slab.inside = [](const Eigen::Vector3d& p) {
        return (p - Eigen::Vector3d(0.4, 0.4, 0.3)).norm() < 0.25;
    };
    slab.material =
        std::make_shared<optics::ConstantMaterial>("n1.5", std::complex<double>(1.5, 0.0));
    return slab;
}

// The lattice at 600 nm: diffraction orders carry light sideways (the period exceeds λ), nothing
// absorbs, so the four parts add to one within the runs' error; the sphere is symmetric under
// x ↔ y, so E_x and E_y see the same lattice (their mean is what is returned; the test of the
// sum covers both).
TEST(FullWaveSlab, LosslessSphereLatticeConservesPower) {
    Slab3d slab = sphere_lattice();
    const std::array<double, 1> lambdas{600.0};
    const SlabSpectrum coarse = full_wave_slab(slab, lambdas, small_cell(25.0)).wavelengths[0];
    const FullWaveSlabResult fine_run = full_wave_slab(slab, lambdas, small_cell(37.5));
    const SlabSpectrum& fine = fine_run.wavelengths[0];
    const auto sum = [](const SlabSpectrum& s) {
        return s.specular_reflectance + s.diffuse_reflectance + s.specular_transmittance +
               s.diffuse_transmittance;
    };
    const double error = 2.0 * std::abs(sum(fine) - sum(coarse)) + 1e-3;
    fmt::print("R {:.5f} + {:.5f} (diffuse), T {:.5f} + {:.5f}: sum {:.6f} (±{:.1e}); {:.1f} s\n",
               fine.specular_reflectance, fine.diffuse_reflectance, fine.specular_transmittance,
               fine.diffuse_transmittance, sum(fine), error, fine_run.seconds);
    EXPECT_NEAR(sum(fine), 1.0, error);
    EXPECT_GT(fine.diffuse_transmittance + fine.diffuse_reflectance, 1e-3);
}

// E_x alone (Slab3d::e_x_only: half the runs) on the lattice above, symmetric under x ↔ y: the
// unpolarised answer (measured: equal to 5 digits; 1e-4 asserted, for the Yee cell's staggering
// of E_x and E_y), and the steps of the longest run reported.
TEST(FullWaveSlab, ExAloneGivesTheUnpolarisedAnswerOfASymmetricBody) {
    Slab3d slab = sphere_lattice();
    const std::array<double, 1> lambdas{600.0};
    const FullWaveSlabResult both = full_wave_slab(slab, lambdas, small_cell(25.0));
    slab.e_x_only = true;
    const FullWaveSlabResult e_x = full_wave_slab(slab, lambdas, small_cell(25.0));
    const SlabSpectrum &a = both.wavelengths[0], &x = e_x.wavelengths[0];
    fmt::print(
        "R {:.5f} + {:.5f} (E_x {:.5f} + {:.5f}), T {:.5f} + {:.5f} (E_x {:.5f} + {:.5f}); "
        "{:.0f} steps\n",
        a.specular_reflectance, a.diffuse_reflectance, x.specular_reflectance,
        x.diffuse_reflectance, a.specular_transmittance, a.diffuse_transmittance,
        x.specular_transmittance, x.diffuse_transmittance, e_x.time_steps);
    EXPECT_GT(e_x.time_steps, 0.0);
    EXPECT_NEAR(x.specular_reflectance, a.specular_reflectance, 1e-4);
    EXPECT_NEAR(x.diffuse_reflectance, a.diffuse_reflectance, 1e-4);
    EXPECT_NEAR(x.specular_transmittance, a.specular_transmittance, 1e-4);
    EXPECT_NEAR(x.diffuse_transmittance, a.diffuse_transmittance, 1e-4);
}

// max_time ends a run whose probe has not decayed (decay 1e-12 here, far below what the lattice
// reaches in that time): the run stops max_time after the source has ended, within one check of
// the source's length (a Gaussian pulse over 600 nm alone lasts under 20 time units).
TEST(FullWaveSlab, MaxTimeEndsARunThatHasNotDecayed) {
    Slab3d slab = sphere_lattice();
    slab.e_x_only = true;
    const std::array<double, 1> lambdas{600.0};
    FullWave2dOptions o = small_cell(25.0);
    o.decay = 1e-12;
    o.max_time = 15.0;
    const FullWaveSlabResult r = full_wave_slab(slab, lambdas, o);
    const double run_time = r.time_steps * 0.5 / r.resolution_px_per_um;  // Courant 0.5
    fmt::print("{:.0f} steps: {:.2f} time units\n", r.time_steps, run_time);
    EXPECT_GE(run_time, o.max_time);
    EXPECT_LE(run_time, o.max_time + 20.0);
    o.max_time = -1.0;
    EXPECT_THROW(full_wave_slab(slab, lambdas, o), InputError);
}

TEST(FullWaveSlab, RefusesWhatItCannotDo) {
    Slab3d slab;
    slab.period_um = 1.0;
    slab.thickness_um = 0.5;
    slab.thinnest_um = 0.02;  // under two cells at 40 px/µm
    slab.inside = [](const Eigen::Vector3d&) { return true; };
    slab.material = optics::keratin();
    const std::array<double, 1> lambdas{500.0};
    FullWave2dOptions o;
    o.resolution_px_per_um = 40.0;
    EXPECT_THROW(full_wave_slab(slab, lambdas, o), InputError);
    slab.thinnest_um = 0.2;
    o.resolution_px_per_um = 20.0;  // coarser than λ/(10 n)
    EXPECT_THROW(full_wave_slab(slab, lambdas, o), InputError);
    slab.inside = nullptr;
    o.resolution_px_per_um = 40.0;
    EXPECT_THROW(full_wave_slab(slab, lambdas, o), InputError);
}

}  // namespace
}  // namespace plumage::sim::fullwave
