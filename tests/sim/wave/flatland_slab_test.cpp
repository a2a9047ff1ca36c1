// Flatland slab Monte Carlo (sim/wave/volume/flatland_slab.h): the white furnace (R + T = 1 per
// path), thread-count independence, the optically thin index-matched slab against the
// single-scattering closed form, the clear slab against the incoherent two-interface
// formula, and the input checks.
#include "sim/wave/volume/flatland_slab.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "common/error.h"
#include "tests/test_util.h"

namespace plumage::sim::wave {
namespace {

// A slab with the phase function p(θ) ∝ shape(θ) tabulated at 361 points.
template <typename F>
FlatlandSlab make_slab(double d, double n_eff, double mu_s, Polarisation2d pol, F shape) {
    FlatlandSlab s;
    s.thickness_um = d;
    s.n_eff = n_eff;
    s.mu_s_per_um = mu_s;
    s.polarisation = pol;
    for (int i = 0; i <= 360; ++i) {
        const double th = kPi * i / 360.0;
        s.theta_rad.push_back(th);
        s.phase_per_rad.push_back(shape(th));
    }
    return s;
}

double isotropic(double) { return 1.0; }
double forward_peaked(double th) { return std::exp(2.0 * std::cos(th)); }
double back_peaked(double th) { return 0.2 + std::exp(-std::pow((th - kPi) / 0.5, 2)); }

TEST(FlatlandSlab, WhiteFurnaceConservesEveryPath) {
    for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        const FlatlandSlab slab = make_slab(3.0, 1.3, 2.0, pol, forward_peaked);
        FlatlandSlabOptions o;
        o.paths = 20000;
        o.seed = 11;
        const FlatlandSlabResult r = simulate_flatland_slab(slab, o);
        EXPECT_EQ(r.lost, 0u);
        // Every path leaves through one face, so the sum is 1 to round-off.
        EXPECT_NEAR(r.reflectance + r.transmittance, 1.0, 1e-12) << polarisation_name(pol);
        EXPECT_NEAR(r.specular, std::pow(0.3 / 2.3, 2), 1e-15);
        EXPECT_GT(r.mean_events, 6.0);  // τ = 6: a multiple-scattering regime
    }
}

TEST(FlatlandSlab, ResultIsIdenticalForAnyThreadCount) {
    const FlatlandSlab slab = make_slab(2.0, 1.25, 1.5, Polarisation2d::tm, back_peaked);
    FlatlandSlabOptions o;
    o.paths = 3 * 4096 + 17;  // more than one block, a partial last one
    o.seed = 5;
    const FlatlandSlabResult one = simulate_flatland_slab(slab, o);
    o.threads = 3;
    const FlatlandSlabResult three = simulate_flatland_slab(slab, o);
    EXPECT_EQ(one.reflectance, three.reflectance);
    EXPECT_EQ(one.transmittance, three.transmittance);
    EXPECT_EQ(one.reflectance_single, three.reflectance_single);
    EXPECT_EQ(one.mean_events, three.mean_events);
    o.seed = 6;  // and a different seed gives a different sample
    EXPECT_NE(simulate_flatland_slab(slab, o).reflectance, one.reflectance);
}

TEST(FlatlandSlab, ThinMatchedSlabFollowsSingleScattering) {
    // n_eff = 1 (no faces): the once-scattered part of R is R_1 of the header exactly, at any
    // τ; the whole R approaches it as τ → 0 (higher orders are O(τ²)).
    for (auto shape : {&isotropic, &forward_peaked, &back_peaked}) {
        for (double tau : {0.05, 0.5}) {
            const FlatlandSlab slab = make_slab(1.0, 1.0, tau, Polarisation2d::te, shape);
            FlatlandSlabOptions o;
            o.paths = 200000;
            const FlatlandSlabResult r = simulate_flatland_slab(slab, o);
            const double r1 = single_scattering_reflectance_matched(slab);
            const double se = std::sqrt(r1 * (1.0 - r1) / static_cast<double>(o.paths));
            EXPECT_NEAR(r.reflectance_single, r1, 4.0 * se) << "tau " << tau;
            EXPECT_EQ(r.specular, 0.0);
            if (tau == 0.05) {
                // Multiple orders are O(τ²) of the whole R.
                EXPECT_NEAR(r.reflectance, r1, 4.0 * se + tau * tau);
            }
        }
        // Thin limit of the closed form: R_1 → τ × (backscattered fraction). The next order
        // is −(τ²/2) ∫ p (1 + 1/|cos θ|) dθ over the back half, whose 1/|cos θ| is cut off at
        // |cos θ| ~ τ: a relative correction below τ (1 + ln(1/τ)).
        const double tau = 1e-4;
        const FlatlandSlab thin = make_slab(1.0, 1.0, tau, Polarisation2d::te, shape);
        double back = 0.0, all = 0.0;
        for (std::size_t i = 0; i + 1 < thin.theta_rad.size(); ++i) {
            const double m = 0.5 * (thin.phase_per_rad[i] + thin.phase_per_rad[i + 1]);
            all += m;
            if (thin.theta_rad[i] >= 0.5 * kPi - 1e-12) back += m;
        }
        EXPECT_NEAR(single_scattering_reflectance_matched(thin) / (tau * back / all), 1.0,
                    tau * (1.0 + std::log(1.0 / tau)));
    }
}

TEST(FlatlandSlab, ClearSlabIsTheIncoherentTwoInterfaceSlab) {
    for (double mu_s : {0.0, 1e-7}) {
        for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
            const FlatlandSlab slab = make_slab(3.0, 1.5, mu_s, pol, isotropic);
            FlatlandSlabOptions o;
            o.paths = 100000;
            const FlatlandSlabResult r = simulate_flatland_slab(slab, o);
            const SlabIntensities clear = incoherent_slab(1.5, 0.0);
            EXPECT_NEAR(clear.reflectance, 2.0 * 0.04 / 1.04, 1e-15);
            EXPECT_NEAR(clear.reflectance + clear.transmittance, 1.0, 1e-15);
            EXPECT_NEAR(r.reflectance, clear.reflectance, 4.0 * r.reflectance_se + 1e-12);
            EXPECT_NEAR(r.transmittance, clear.transmittance, 4.0 * r.transmittance_se + 1e-12);
        }
    }
    // With extinction the ballistic beam alone: R → R_0 for τ → ∞.
    EXPECT_NEAR(incoherent_slab(1.5, 50.0).reflectance, 0.04, 1e-15);
}

TEST(FlatlandSlab, RefusesBadInput) {
    using testing::input_error_message;
    FlatlandSlabOptions o;
    FlatlandSlab slab = make_slab(-1.0, 1.3, 1.0, Polarisation2d::te, isotropic);
    EXPECT_EQ(input_error_message([&] { simulate_flatland_slab(slab, o); }),
              "flatland slab: thickness_um = -1: expected a finite thickness > 0");
    slab = make_slab(1.0, 0.8, 1.0, Polarisation2d::te, isotropic);
    EXPECT_EQ(input_error_message([&] { simulate_flatland_slab(slab, o); }),
              "flatland slab: n_eff = 0.8: expected a real index in [1, 10]");
    slab = make_slab(1.0, 1.3, 1.0, Polarisation2d::te, isotropic);
    slab.theta_rad[5] = slab.theta_rad[4];
    EXPECT_NE(input_error_message([&] {
                  simulate_flatland_slab(slab, o);
              }).find("expected strictly increasing angles"),
              std::string::npos);
    slab = make_slab(1.0, 1.3, 1.0, Polarisation2d::te, [](double) { return 0.0; });
    EXPECT_NE(input_error_message([&] { simulate_flatland_slab(slab, o); }).find("all zero"),
              std::string::npos);
    slab = make_slab(1.0, 1.3, 1.0, Polarisation2d::te, isotropic);
    o.paths = 0;
    EXPECT_EQ(input_error_message([&] { simulate_flatland_slab(slab, o); }),
              "flatland slab: paths = 0: expected 1 to 1e9");
    EXPECT_NE(input_error_message([] { incoherent_slab(1.5, -1.0); }).find("tau = -1"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::sim::wave
