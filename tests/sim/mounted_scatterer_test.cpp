// MountedScatterer (sim/scatterer/mounted_scatterer.h) against a closed form: Filip 2024's model
// depends on the sample's azimuth only through U(φa) (its D terms use φi − φo), so turning a sample
// with anisotropy angle φa by ψ about the normal gives exactly the model with φa − ψ.
#include "sim/scatterer/mounted_scatterer.h"
#include "common/constants.h"

#include <array>
#include <cmath>
#include <memory>
#include <numbers>

#include <gtest/gtest.h>

#include "analysis/models/filip2024.h"
#include "analysis/models/huang2022.h"
#include "common/error.h"
#include "sim/scatterer/random.h"

namespace plumage {
namespace {

Vec3d random_upper(Rng& rng) {
    const double z = 0.05 + 0.95 * rng.uniform();
    const double phi = 2.0 * std::numbers::pi * rng.uniform();
    const double s = std::sqrt(1.0 - z * z);
    return {s * std::cos(phi), s * std::sin(phi), z};
}

TEST(MountedScatterer, TurnedFilipSampleIsFilipWithShiftedAnisotropyAngle) {
    for (const double psi_deg : {0.0, 20.0, 80.0, -135.0, 390.0}) {
        analysis::Filip2024Parameters p = analysis::filip2024_preset("rooster");
        const auto inner = std::make_shared<analysis::Filip2024Brdf>(p);
        const MountedScatterer mounted(inner, psi_deg * kDeg);
        p.phi_a_rad = std::remainder(p.phi_a_rad - psi_deg * kDeg, 2.0 * std::numbers::pi);
        const analysis::Filip2024Brdf shifted(p);
        Rng rng(7, static_cast<std::uint64_t>(psi_deg + 1000));
        for (int k = 0; k < 2000; ++k) {
            const Vec3d wi = random_upper(rng), wo = random_upper(rng);
            const double lambda = 400.0 + 300.0 * rng.uniform();
            const double expected = shifted.eval(wi, wo, lambda);
            ASSERT_NEAR(mounted.eval(wi, wo, lambda), expected, 1e-12 * (1.0 + expected))
                << "psi " << psi_deg;
            const double expected_pdf = shifted.pdf(wi, wo, lambda);
            ASSERT_NEAR(mounted.pdf(wi, wo, lambda), expected_pdf, 1e-12 * (1.0 + expected_pdf));
        }
    }
}

// Sampled directions come back in the instrument frame: each weight must be f cos θo / pdf
// of the mounted scatterer at the returned direction, and the exit point must be the entry
// point (an analytic model returns where the light arrived) in the instrument frame.
TEST(MountedScatterer, SamplesAreConsistentWithEvalInTheInstrumentFrame) {
    const auto inner =
        std::make_shared<analysis::Filip2024Brdf>(analysis::filip2024_preset("parrot"));
    const MountedScatterer mounted(inner, 33.0 * kDeg);
    Rng rng(11, 0);
    int returned = 0;
    for (int k = 0; k < 5000; ++k) {
        const Vec3d wi = random_upper(rng);
        const Vec2 position(100.0 * rng.uniform() - 50.0, 100.0 * rng.uniform() - 50.0);
        const auto event = mounted.sample(wi, 550.0, position, rng);
        if (!event) continue;
        ++returned;
        const double f = mounted.eval(wi, event->wo, 550.0);
        const double pdf = mounted.pdf(wi, event->wo, 550.0);
        ASSERT_NEAR(event->weight, f * event->wo.z() / pdf, 1e-9 * (1.0 + event->weight));
        ASSERT_NEAR((event->exit_position_um - position).norm(), 0.0, 1e-9);
    }
    EXPECT_GT(returned, 4000);
}

// A mounted model whose lobes are evaluated apart (Huang's) stays so, each lobe the one eval()
// gives in the instrument frame, so the goniometer's lobe-by-lobe cubature applies to it; one
// that does not (Filip's) does not claim it.
TEST(MountedScatterer, ForwardsTheLobesOfAModelThatEvaluatesThemApart) {
    const auto huang = std::make_shared<analysis::Huang2022Bsdf>(analysis::Huang2022Params{});
    const MountedScatterer mounted(huang, 37.0 * kDeg);
    ASSERT_TRUE(mounted.evaluates_lobes_apart());
    EXPECT_FALSE(MountedScatterer(std::make_shared<analysis::Filip2024Brdf>(
                                      analysis::filip2024_preset("parrot")),
                                  37.0 * kDeg)
                     .evaluates_lobes_apart());
    Rng rng(13, 0);
    int lit = 0;
    for (int k = 0; k < 500; ++k) {
        const Vec3d wi = random_upper(rng), wo = random_upper(rng);
        const double lambda = 400.0 + 300.0 * rng.uniform();
        std::array<double, 3> all{}, one{};
        const double total = mounted.eval(wi, wo, lambda, all);
        for (const int lobe : {analysis::Huang2022Bsdf::kR, analysis::Huang2022Bsdf::kTRT}) {
            const auto l = static_cast<std::size_t>(lobe);
            one.fill(-1.0);
            EXPECT_EQ(mounted.eval_lobes(wi, wo, lambda, 1u << lobe, one), all[l]);
            EXPECT_EQ(one[l], all[l]);
        }
        EXPECT_EQ(mounted.eval_lobes(wi, wo, lambda, ~0u, one), total);
        lit += total > 0.0;
    }
    EXPECT_GT(lit, 100);
}

TEST(MountedScatterer, RejectsMissingScattererAndNonFiniteAzimuth) {
    const auto inner =
        std::make_shared<analysis::Filip2024Brdf>(analysis::filip2024_preset("stork"));
    EXPECT_THROW(MountedScatterer(nullptr, 0.0), InputError);
    EXPECT_THROW(MountedScatterer(inner, std::nan("")), InputError);
}

}  // namespace
}  // namespace plumage
