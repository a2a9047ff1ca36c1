// Records compared as a bird sees them: a record against itself (and scaled) is 0 JND, and a
// record against a noisy copy of itself sits at the noise floor the comparison reports (the
// floor's claim, checked by a Monte Carlo of the same noise). And pavo's layout.
#include "analysis/metrics/avian_compare.h"

#include <gtest/gtest.h>

#include "virtual_gonio/direction_sets.h"

#include <cmath>
#include <iostream>
#include <numbers>
#include <random>

#include <fmt/format.h>

namespace plumage::analysis {
namespace {

gonio::BrdfRecord synthetic_record(std::size_t pairs, const std::vector<double>& wl) {
    gonio::BrdfRecord r;
    r.config.wavelengths_nm = wl;
    for (std::size_t p = 0; p < pairs; ++p) {
        const double t = 0.01 * static_cast<double>(p);
        r.config.pairs.push_back({Vec3d(std::sin(t), 0.0, std::cos(t)), Vec3d(0.0, 0.0, 1.0)});
        for (double l : wl) {
            r.value.push_back(0.05 + 0.04 * std::exp(-std::pow((l - 420.0 - 300.0 * t) / 60.0, 2)));
        }
    }
    r.standard_error.assign(r.value.size(), 0.0);
    return r;
}

TEST(AvianCompare, ZeroForTheSameRecordAndAtTheNoiseFloorForANoisyCopy) {
    const auto wl = optics::WavelengthGrid::uniform(300.0, 700.0, 20.0);
    const std::vector<double> grid(wl.nm().begin(), wl.nm().end());
    const gonio::BrdfRecord reference = synthetic_record(200, grid);
    gonio::BrdfRecord scaled = reference;
    for (double& v : scaled.value) v *= 3.0;
    for (const AvianVisualSystem* system :
         {&ultraviolet_sensitive_system(), &violet_sensitive_system()}) {
        const AvianRecordComparison same = compare_records_avian(reference, reference, *system);
        EXPECT_EQ(same.pairs_with_signal, 200u);
        EXPECT_EQ(same.max, 0.0);
        const AvianRecordComparison brighter = compare_records_avian(scaled, reference, *system);
        EXPECT_LT(brighter.max, 1e-9);
        // Three times the light is ln 3 / 0.1 = 11.0 JND brighter to the double cone, every pair.
        ASSERT_TRUE(brighter.has_double_cone);
        EXPECT_NEAR(brighter.rms_delta_l, std::log(3.0) / 0.1, 1e-9);
        EXPECT_NEAR(brighter.max_delta_l, std::log(3.0) / 0.1, 1e-9);
        // Noise of 2 % per cell on the test record: ΔS² per pair is (to first order) a
        // quadratic form of normals whose mean is the floor²; over 200 pairs the RMS has a
        // relative standard error of about √(2/3)/(2√200) = 2.9 % (three chromatic dimensions),
        // so 12 % is 4 σ.
        gonio::BrdfRecord noisy = reference;
        std::mt19937_64 rng(11);  // test-only stream, fixed
        std::normal_distribution<double> normal;
        for (std::size_t i = 0; i < noisy.value.size(); ++i) {
            noisy.standard_error[i] = 0.02 * reference.value[i];
            noisy.value[i] += noisy.standard_error[i] * normal(rng);
        }
        const AvianRecordComparison c = compare_records_avian(noisy, reference, *system);
        EXPECT_NEAR(c.rms / c.rms_noise_floor, 1.0, 0.12) << system->name;
        // ΔL is one normal per pair: the RMS of 200 has a relative standard error of
        // √2/(2√200) = 5 %, so 20 % is 4 σ.
        EXPECT_NEAR(c.rms_delta_l / c.rms_delta_l_noise_floor, 1.0, 0.2) << system->name;
        EXPECT_GT(c.rms_noise_floor, 0.05);  // the test is not trivially about zero
    }
}

// A thin film's fringes (period ~180 nm): sampling them every 25 nm costs a bird a measurable
// ΔS, every 5 nm about 25 times less (the linear interpolation's error goes as the step²), and a
// spectrum that is linear between the grid's points costs nothing.
TEST(AvianCompare, QuadratureErrorIsZeroForPiecewiseLinearSpectraAndFallsAsTheStepSquared) {
    auto fringes = [](std::size_t i, double l) {
        return 0.3 +
               0.2 * std::cos(2.0 * std::numbers::pi * l / (170.0 + 10.0 * static_cast<double>(i)));
    };
    const auto coarse = optics::WavelengthGrid::uniform(300.0, 700.0, 25.0);
    const auto fine = optics::WavelengthGrid::uniform(300.0, 700.0, 5.0);
    for (const AvianVisualSystem* system :
         {&ultraviolet_sensitive_system(), &violet_sensitive_system()}) {
        const AvianQuadratureError e25 = avian_quadrature_error(4, coarse, *system, fringes);
        const AvianQuadratureError e5 = avian_quadrature_error(4, fine, *system, fringes);
        EXPECT_EQ(e25.spectra, 4u);
        EXPECT_GT(e25.max_delta_s, 0.05) << system->name;
        EXPECT_GT(e25.rms_delta_s / e5.rms_delta_s, 10.0) << system->name;
        EXPECT_GT(e25.rms_delta_l / e5.rms_delta_l, 10.0) << system->name;
        std::cout << system->name << ": 25 nm ΔS RMS " << e25.rms_delta_s << ", 5 nm "
                  << e5.rms_delta_s << "; ΔL " << e25.rms_delta_l << ", " << e5.rms_delta_l << "\n";
        const AvianQuadratureError linear = avian_quadrature_error(
            2, coarse, *system,
            [](std::size_t i, double l) { return 0.1 + 0.001 * static_cast<double>(i) * l; });
        EXPECT_LT(linear.max_delta_s, 1e-12);
        EXPECT_LT(linear.max_delta_l, 1e-12);
    }
}

TEST(AvianCompare, CatchesCsvGivesAWhiteOneForEveryConeOfEveryBird) {
    const std::vector<double> wl{300.0, 500.0, 700.0};
    const std::string csv =
        avian_catches_csv(wl, {"white", "grey"}, {{100.0, 100.0, 100.0}, {50.0, 50.0, 50.0}});
    EXPECT_EQ(csv.rfind("bird,sample,q_short,q_sws,q_mws,q_lws,q_double_cone\n", 0), 0u);
    for (const char* bird : {"bluetit", "pfowl", "avg.uv", "avg.v"}) {
        EXPECT_NE(csv.find(fmt::format("\n{},white,1,1,1,1,1\n", bird)), std::string::npos) << csv;
        EXPECT_NE(csv.find(fmt::format("\n{},grey,0.5,0.5,0.5,0.5,0.5\n", bird)), std::string::npos)
            << csv;
    }
}

TEST(AvianCompare, PavoLayoutHasAWavelengthColumnAndOneColumnPerSample) {
    const std::string csv = pavo_csv_text({300.0, 310.0}, {"a", "b"}, {{1.0, 2.0}, {3.5, 4.0}});
    EXPECT_EQ(csv, "wl,a,b\n300,1,3.5\n310,2,4\n");
    const gonio::DirectionPair pair{
        gonio::direction_from_angles(std::numbers::pi / 6.0, std::numbers::pi),
        gonio::direction_from_angles(std::numbers::pi / 4.0, 0.0)};
    EXPECT_EQ(pavo_pair_name("model", pair), "model_i30a180_o45a0");
}

}  // namespace
}  // namespace plumage::analysis
