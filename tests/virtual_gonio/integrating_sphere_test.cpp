// The integrating sphere (virtual_gonio/integrating_sphere.h) against closed forms: a Lambertian
// reflector of albedo ρ gives R = ρ, T = 0 with no variance; a coin that sends each quantum up
// with probability p and down otherwise gives R = p, T = 1 − p within its binomial error, which
// the instrument's standard error must state; bits the same on 1 and 2 threads; the stop rule.
#include "virtual_gonio/integrating_sphere.h"

#include <cmath>

#include <gtest/gtest.h>
#include <omp.h>

#include "analysis/models/lambertian.h"
#include "common/error.h"

namespace plumage::gonio {
namespace {

// Up along the mirror direction with probability p(λ) = λ / 1000, else straight down.
class Coin final : public Scatterer {
public:
    std::string name() const override { return "coin"; }
    const std::vector<std::string>& lobe_names() const override {
        static const std::vector<std::string> names = {"R"};
        return names;
    }
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm, const Vec2& position_um,
                                       Rng& rng) const override {
        const bool up = rng.uniform() < lambda_nm / 1000.0;
        const Vec3d wo = up ? Vec3d(-wi.x(), -wi.y(), wi.z()) : Vec3d(0.0, 0.0, -1.0);
        return ScatterEvent{wo, 1.0, 0, position_um};
    }
};

TEST(IntegratingSphere, LambertianAlbedoExactly) {
    const analysis::LambertianScatterer white(0.73);
    IntegratingSphereConfig c;
    c.wavelengths_nm = {450.0, 650.0};
    c.light = Vec3d(0.3, 0.1, std::sqrt(1.0 - 0.1)).normalized();
    c.quanta_per_pass = 5000;
    const IntegratingSphereRecord r = measure_integrating_sphere(white, c);
    for (std::size_t k = 0; k < 2; ++k) {
        EXPECT_NEAR(r.reflectance[k], 0.73, 1e-12);  // a sum of 5000 equal terms
        EXPECT_EQ(r.transmittance[k], 0.0);
        EXPECT_NEAR(r.reflectance_error[k], 0.0, 1e-12);  // every quantum carries ρ
    }
    EXPECT_EQ(r.passes, 1);  // error 0 <= the 1 % target after the first pass
}

TEST(IntegratingSphere, CoinWithinItsStatedErrorAndTheErrorIsBinomial) {
    const Coin coin;
    IntegratingSphereConfig c;
    c.wavelengths_nm = {200.0, 500.0, 900.0};
    c.quanta_per_pass = 40000;
    c.max_passes = 3;
    c.target_relative_error = 0.0;  // run all three passes
    const IntegratingSphereRecord r = measure_integrating_sphere(coin, c);
    ASSERT_EQ(r.passes, 3);
    ASSERT_EQ(r.convergence.size(), 3u);
    const double n = 120000.0;
    for (std::size_t k = 0; k < 3; ++k) {
        const double p = c.wavelengths_nm[k] / 1000.0;
        const double sigma = std::sqrt(p * (1.0 - p) / n);
        // Every quantum goes up or down with weight 1: R + T = 1 exactly.
        EXPECT_NEAR(r.reflectance[k] + r.transmittance[k], 1.0, 1e-12);
        // 4.5σ: three wavelengths, a false alarm below 2e-5.
        EXPECT_NEAR(r.reflectance[k], p, 4.5 * sigma) << "λ = " << c.wavelengths_nm[k];
        // The stated error is the binomial one, to the relative error of an error (1/√(2n)).
        EXPECT_NEAR(r.reflectance_error[k], sigma, 0.02 * sigma);
        EXPECT_NEAR(r.transmittance_error[k], sigma, 0.02 * sigma);
    }
    EXPECT_LT(r.convergence[2].estimated_relative_rms_error,
              r.convergence[0].estimated_relative_rms_error);
}

TEST(IntegratingSphere, SameBitsOnOneAndTwoThreads) {
    const Coin coin;
    IntegratingSphereConfig c;
    c.wavelengths_nm = {400.0, 600.0};
    c.quanta_per_pass = 20000;
    c.max_passes = 2;
    c.target_relative_error = 0.0;
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    const IntegratingSphereRecord one = measure_integrating_sphere(coin, c);
    omp_set_num_threads(2);
    const IntegratingSphereRecord two = measure_integrating_sphere(coin, c);
    omp_set_num_threads(threads);
    EXPECT_EQ(one.reflectance, two.reflectance);
    EXPECT_EQ(one.reflectance_error, two.reflectance_error);
    EXPECT_EQ(one.transmittance, two.transmittance);
}

TEST(IntegratingSphere, StopsAtTheTargetError) {
    const Coin coin;
    IntegratingSphereConfig c;
    c.wavelengths_nm = {500.0};
    c.quanta_per_pass = 10000;
    c.max_passes = 100;
    // σ/R = sqrt((1 − p)/(p n)) = 1/√n at p = ½: 0.5 % needs n >= 40000, i.e. about 4 passes.
    c.target_relative_error = 0.005;
    const IntegratingSphereRecord r = measure_integrating_sphere(coin, c);
    EXPECT_GE(r.passes, 3);
    EXPECT_LE(r.passes, 6);
    EXPECT_LE(r.convergence.back().estimated_relative_rms_error, 0.005);
    EXPECT_GT(r.convergence[r.passes - 2].estimated_relative_rms_error, 0.005);
}

TEST(IntegratingSphere, RefusesBadInputByName) {
    const Coin coin;
    IntegratingSphereConfig c;
    c.light = Vec3d(0.0, 0.0, -1.0);
    try {
        measure_integrating_sphere(coin, c);
        FAIL() << "a light below the patch was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("light"), std::string::npos) << e.what();
    }
    c = IntegratingSphereConfig{};
    c.quanta_per_pass = 0;
    EXPECT_THROW(measure_integrating_sphere(coin, c), InputError);
}

}  // namespace
}  // namespace plumage::gonio
