// The goniometer against the Lambertian plate: every cell reads albedo/π within its
// error, the errors are honest across seeds, results do not depend on thread count,
// and an interrupted run resumes to the same bits.
#include "virtual_gonio/goniometer.h"
#include "common/constants.h"

#include <omp.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>

#include <gtest/gtest.h>

#include "tests/test_util.h"

#include "analysis/models/lambertian.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::gonio {
namespace {

std::vector<std::pair<std::string, std::vector<DirectionPair>>> direction_sets() {
    std::vector<DirectionPair> custom;
    for (double t : {0.1, 0.6, 1.1}) {
        custom.push_back(
            {Vec3d(std::sin(t), 0.0, std::cos(t)), Vec3d(-std::sin(0.5), 0.0, std::cos(0.5))});
        custom.push_back({Vec3d(0.0, std::sin(t), std::cos(t)), Vec3d(0.3, 0.4, std::sqrt(0.75))});
    }
    return {{"filip2024_btf", filip2024_btf_pairs()},
            {"filip2024_in_plane", filip2024_in_plane_pairs()},
            {"custom", custom}};
}

GoniometerConfig lambertian_config(const std::vector<DirectionPair>& pairs, std::uint64_t seed) {
    GoniometerConfig c;
    c.pairs = pairs;
    c.detector_half_angle_rad = 10.0 * kPi / 180.0;  // wide cones: a fast, well-populated test
    c.estimator = Estimator::photon;
    c.seed = seed;
    c.quanta_per_pass = 6000;
    c.max_passes = 2;
    return c;
}

TEST(Goniometer, LambertianPlateReadsAlbedoOverPiOnEveryDirectionSet) {
    const analysis::LambertianScatterer plate(0.6);
    const double truth = 0.6 / kPi;
    for (const auto& [name, pairs] : direction_sets()) {
        const BrdfRecord r = measure_brdf(plate, lambertian_config(pairs, 1));
        double worst_sigma = 0.0;
        for (std::size_t p = 0; p < pairs.size(); ++p) {
            ASSERT_GT(r.error_at(p, 0), 0.0);
            worst_sigma = std::max(worst_sigma, std::abs(r.at(p, 0) - truth) / r.error_at(p, 0));
        }
        // Largest deviation among n cells at family-wise significance 0.1 %: the
        // Gaussian tail bound P(|Z| > z) <= exp(−z²/2) gives z = sqrt(2 ln(n / 0.001))
        // (5.5σ for 3660 cells, 4.7σ for 55).
        const double n = static_cast<double>(pairs.size());
        const double bound = std::sqrt(2.0 * std::log(n / 1e-3));
        EXPECT_LT(worst_sigma, bound) << name;
        RecordProperty(name + "_worst_sigma", std::to_string(worst_sigma));
        // The eval estimator is exact for a constant BRDF.
        GoniometerConfig eval = lambertian_config(pairs, 1);
        eval.estimator = Estimator::eval;
        const BrdfRecord e = measure_brdf(plate, eval);
        for (std::size_t p = 0; p < pairs.size(); ++p) EXPECT_NEAR(e.at(p, 0), truth, 1e-12);
    }
}

TEST(Goniometer, ReportedErrorsAreHonestAcrossSeeds) {
    // Over 20 seeds the truth lies within ±2σ in about 95 % of cells (95.45 % for a
    // normal estimator; each cell averages ~100–400 detections).
    const analysis::LambertianScatterer plate(0.6);
    const double truth = 0.6 / kPi;
    const auto pairs = filip2024_btf_pairs();
    std::size_t inside = 0, total = 0;
    for (std::uint64_t seed = 1; seed <= 20; ++seed) {
        GoniometerConfig c = lambertian_config(pairs, seed);
        c.max_passes = 1;
        const BrdfRecord r = measure_brdf(plate, c);
        for (std::size_t p = 0; p < pairs.size(); ++p) {
            inside += std::abs(r.at(p, 0) - truth) <= 2.0 * r.error_at(p, 0);
            ++total;
        }
    }
    const double fraction = static_cast<double>(inside) / static_cast<double>(total);
    RecordProperty("fraction_within_2_sigma", std::to_string(fraction));
    EXPECT_GT(fraction, 0.93);
    EXPECT_LT(fraction, 0.975);
}

TEST(Goniometer, ThreadCountDoesNotChangeResults) {
    const analysis::LambertianScatterer plate(0.6);
    const auto pairs = filip2024_in_plane_pairs();
    const int before = omp_get_max_threads();
    omp_set_num_threads(1);
    const BrdfRecord one = measure_brdf(plate, lambertian_config(pairs, 5));
    omp_set_num_threads(2);
    const BrdfRecord two = measure_brdf(plate, lambertian_config(pairs, 5));
    omp_set_num_threads(before);
    EXPECT_EQ(one.value, two.value);
    EXPECT_EQ(one.standard_error, two.standard_error);
}

TEST(Goniometer, InterruptedRunLeavesNoRecordAndResumesToTheSameResult) {
    const auto dir =
        std::filesystem::temp_directory_path() / ("plumage_gonio_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const auto checkpoint = dir / "brdf.h5.checkpoint";
    const auto record_path = dir / "brdf.h5";
    const analysis::LambertianScatterer plate(0.6);
    GoniometerConfig c = lambertian_config(filip2024_in_plane_pairs(), 9);
    c.max_passes = 5;
    const BrdfRecord uninterrupted = measure_brdf(plate, c);

    auto run = [&](bool interrupt_after_second_pass) {
        ScopedInterruptHandler handler;
        RunControl control;
        control.interrupt = &handler.flag();
        control.checkpoint = checkpoint;
        if (interrupt_after_second_pass) {
            control.on_pass = [](const ConvergenceRow& row) {
                if (row.pass == 2) std::raise(SIGINT);  // as if the user pressed Ctrl-C
            };
        }
        BrdfRecord r = measure_brdf(plate, c, control);
        if (!r.interrupted) write_brdf_record(r, record_path);
        return r;
    };
    const BrdfRecord first = run(true);
    EXPECT_TRUE(first.interrupted);
    EXPECT_EQ(first.passes, 2);
    // A different study (another scene under the same instrument) must not resume these sums,
    // nor be stopped by them (issue 43): it starts afresh, saying why; stopped before its first
    // pass, it leaves the checkpoint as it was.
    {
        GoniometerConfig other = c;
        other.config_text = c.config_text + "\n# the scene changed";
        const std::atomic<bool> stop_at_once{true};
        RunControl control;
        control.checkpoint = checkpoint;
        control.interrupt = &stop_at_once;
        const std::string before = testing::read_text_file(checkpoint);
        ::testing::internal::CaptureStderr();
        const BrdfRecord r = measure_brdf(plate, other, control);
        const std::string said = ::testing::internal::GetCapturedStderr();
        EXPECT_EQ(r.passes, 0);
        EXPECT_NE(said.find("not resuming " + checkpoint.string() + ": the study file changed"),
                  std::string::npos)
            << said;
        EXPECT_EQ(testing::read_text_file(checkpoint), before);
    }
    EXPECT_FALSE(std::filesystem::exists(record_path));  // no partial record
    EXPECT_TRUE(std::filesystem::exists(checkpoint));
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        EXPECT_EQ(entry.path().string().find(".partial-"), std::string::npos) << entry.path();
    }
    // CPU time, like wall time, is kept in the checkpoint and added to the resuming run's.
    const double checkpointed_cpu = record::read_number_attribute(checkpoint, "/", "cpu_time_s");
    EXPECT_GT(checkpointed_cpu, 0.0);
    const BrdfRecord resumed = run(false);
    EXPECT_GE(resumed.cpu_time_s, checkpointed_cpu);
    EXPECT_EQ(record::read_number_attribute(record_path, "/provenance", "cpu_time_s"),
              resumed.cpu_time_s);
    EXPECT_FALSE(resumed.interrupted);
    EXPECT_EQ(resumed.passes, 5);
    EXPECT_EQ(resumed.convergence.size(), 5u);
    EXPECT_EQ(resumed.value, uninterrupted.value);  // bit for bit
    EXPECT_TRUE(std::filesystem::exists(record_path));
    const auto stored = record::read_dataset(record_path, "brdf/value");
    EXPECT_EQ(stored.values, uninterrupted.value);
    EXPECT_NEAR(
        record::read_number_attribute(record_path, "/instrument", "detector_solid_angle_sr"),
        2.0 * kPi * (1.0 - std::cos(c.detector_half_angle_rad)), 1e-15);
    std::filesystem::remove_all(dir);
}

TEST(Goniometer, ConvergenceFollowsOneOverRootTime) {
    const analysis::LambertianScatterer plate(0.6);
    GoniometerConfig c = lambertian_config(filip2024_in_plane_pairs(), 3);
    c.max_passes = 16;
    const BrdfRecord r = measure_brdf(plate, c);
    ASSERT_EQ(r.convergence.size(), 16u);
    // Estimated error after 16 passes is 1/4 of that after 1 (√16), within MC noise.
    const double ratio = r.convergence.back().estimated_relative_rms_error /
                         r.convergence.front().estimated_relative_rms_error;
    EXPECT_NEAR(ratio, 0.25, 0.03);
    // Stopping rule: a target error ends the run early.
    c.target_relative_error = r.convergence[3].estimated_relative_rms_error * 1.001;
    EXPECT_LE(measure_brdf(plate, c).passes, 5);
}

TEST(Goniometer, RejectsBadConfigurations) {
    const analysis::LambertianScatterer plate(0.6);
    GoniometerConfig c;
    EXPECT_THROW(measure_brdf(plate, c), InputError);  // no pairs
    c.pairs = {{Vec3d(0, 0, 1), Vec3d(0, 0, 1)}};
    c.detector_half_angle_rad = 0.0;
    EXPECT_THROW(measure_brdf(plate, c), InputError);
    c.detector_half_angle_rad = 0.05;
    c.pairs = {{Vec3d(0, 0, -1), Vec3d(0, 0, 1)}};
    EXPECT_THROW(measure_brdf(plate, c), InputError);
    c.pairs = {{Vec3d(0, 0, 1), Vec3d(0, 0, 1)}};
    c.guided_branches = 4;  // at most BranchOptions::kMaxGuidedBranches
    EXPECT_THROW(measure_brdf(plate, c), InputError);
    c.guided_branches = 1;
    c.guided_fraction = 0.5;  // both guide the first diffuse event
    const std::string message = testing::input_error_message([&] { measure_brdf(plate, c); });
    EXPECT_NE(message.find("guided_fraction = 0.5 and guided_branches = 1"), std::string::npos)
        << message;
}

}  // namespace
}  // namespace plumage::gonio
