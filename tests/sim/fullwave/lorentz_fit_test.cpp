// The Lorentz-pole fit of a material's index (sim/fullwave/lorentz_fit.h): its stated error
// over 380–780 nm for the project's keratin and melanin, the constraints that make it causal,
// passive and stable in Meep, and its formula against Meep's own susceptibility (so that the
// run sees the ε the fit states).
#include "sim/fullwave/lorentz_fit.h"

#include <cmath>

#include <gtest/gtest.h>
#include <meep.hpp>

#include "common/error.h"

namespace plumage::sim::fullwave {
namespace {

void expect_physical(const LorentzFit& fit, double cap) {
    EXPECT_GE(fit.model.eps_infinity, 1.0);
    for (const LorentzPole& p : fit.model.poles) {
        EXPECT_GT(p.strength, 0.0);
        EXPECT_GE(p.damping_per_um, 0.0);
        EXPECT_LE(p.frequency_per_um, cap);
        // damped unless the material is lossless: no pole rings on after the pulse
        if (p.damping_per_um > 0.0) {
            EXPECT_GE(p.damping_per_um, p.frequency_per_um / 10.0);
        }
    }
    // passive everywhere, not only in the band: Im ε ≥ 0 from the IR to the cap's wavelength
    for (double lambda = 1e3 / cap; lambda < 5000.0; lambda *= 1.01)
        EXPECT_GE(fit.model.epsilon(lambda).imag(), 0.0) << lambda;
}

TEST(LorentzFit, KeratinWithinItsStatedErrorOverTheVisible) {
    const double cap = 15.0;
    const LorentzFit fit = fit_lorentz(*optics::keratin(), 380.0, 780.0, cap);
    EXPECT_LT(fit.max_index_error, 4e-4);  // 3.3e-4
    expect_physical(fit, cap);
    for (const LorentzPole& p : fit.model.poles) EXPECT_EQ(p.damping_per_um, 0.0);  // lossless
    for (double lambda = 380.0; lambda <= 780.0; lambda += 10.0)
        EXPECT_EQ(fit.model.epsilon(lambda).imag(), 0.0);
}

TEST(LorentzFit, MelaninWithinItsStatedErrorOverTheVisible) {
    const double cap = 15.0;
    const LorentzFit fit = fit_lorentz(*optics::melanin(), 380.0, 780.0, cap);
    EXPECT_LT(fit.max_index_error, 4.5e-3);  // 4.2e-3
    EXPECT_EQ(fit.model.poles.size(), 3u);
    expect_physical(fit, cap);
    // the absorption is there, not only the index: k within the same error at both ends
    for (const double lambda : {380.0, 580.0, 780.0})
        EXPECT_NEAR(std::sqrt(fit.model.epsilon(lambda)).imag(),
                    optics::melanin()->index(lambda).imag(), 4.5e-3);
}

TEST(LorentzFit, ADispersionFreeMaterialIsExact) {
    const optics::ConstantMaterial glass("glass", {1.5, 0.0});
    const LorentzFit fit = fit_lorentz(glass, 400.0, 700.0, 10.0);
    EXPECT_LT(fit.max_index_error, 1e-12);
    EXPECT_NEAR(fit.model.eps_infinity, 2.25, 1e-12);
}

TEST(LorentzFit, SameFormulaAsMeepsSusceptibility) {
    const LorentzFit fit = fit_lorentz(*optics::melanin(), 380.0, 780.0, 15.0);
    for (const double lambda : {400.0, 550.0, 700.0}) {
        const double f = 1e3 / lambda;
        std::complex<double> eps = fit.model.eps_infinity;
        for (const LorentzPole& p : fit.model.poles) {
            meep::lorentzian_susceptibility chi(p.frequency_per_um, p.damping_per_um);
            eps += std::complex<double>(chi.chi1(f, p.strength));
        }
        EXPECT_NEAR(std::abs(eps - fit.model.epsilon(lambda)), 0.0, 1e-12 * std::abs(eps));
    }
}

TEST(LorentzFit, RefusesBadBandsAndCaps) {
    EXPECT_THROW(fit_lorentz(*optics::keratin(), 700.0, 400.0, 15.0), InputError);
    EXPECT_THROW(fit_lorentz(*optics::keratin(), 100.0, 400.0, 15.0), InputError);
    EXPECT_THROW(fit_lorentz(*optics::keratin(), 400.0, 700.0, 2.0), InputError);  // in band
    EXPECT_THROW(fit_lorentz(*optics::keratin(), 400.0, 700.0, 15.0, 4), InputError);
    EXPECT_THROW(fit_lorentz(*optics::keratin(), 400.0, 700.0, NAN), InputError);
}

}  // namespace
}  // namespace plumage::sim::fullwave
