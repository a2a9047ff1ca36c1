// Shared paths, splitting at the first film and guided diffuse reflection
// (sim/scatterer/scatterer.h, sim/tracer.h) through the two wrappers the species study puts around
// the tracer: MountedScatterer (sim/scatterer/mounted_scatterer.h) and PeriodCellEntry
// (sim/scatterer/period_cell_entry.h).
//  - Against the plain per-wavelength walk through the same wrapper (sample(), tested on its
//    own): goniometer cells with every feature on read the same, by a χ² per wavelength and the
//    Šidák bound on every |z|, and the record says the features took effect.
//  - A mounted quantum is the inner scatterer's quantum with its directions, beam position and
//    detector axes turned by −ψ (Eigen's rotation, not the wrapper's), the escapes turned back:
//    the same numbers to round-off on the same stream. A guide left in the instrument's frame
//    would be unbiased too, so only this identity sees it.
//  - A period-cell quantum is the inner scatterer's at the entry drawn first from its stream.
//  - The species arrangement, a mount of a period cell, gives the same bits on 1 and 2 threads.
#include <omp.h>

#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/metrics/statistics.h"
#include "common/constants.h"
#include "geometry/barbule.h"
#include "sim/scatterer/mounted_scatterer.h"
#include "sim/scatterer/period_cell_entry.h"
#include "sim/tracer.h"
#include "tests/virtual_gonio/record_agreement.h"
#include "virtual_gonio/goniometer.h"

namespace plumage::sim {
namespace {

const std::vector<double> kFive = {420.0, 490.0, 560.0, 630.0, 700.0};
constexpr double kDetectorHalfAngle = 8.0 * kDeg;
constexpr double kMountAzimuth = 35.0 * kDeg;

// The rock-dove barbule row of tracer_spectral_test.cpp at 12 × 8 cells (film in air over
// melanin: nothing bends with λ, so shared paths stay shared), as the wrappers hold it.
struct Row {
    geometry::BarbuleRow row;
    std::shared_ptr<const ExplicitScatterer> tracer;
    // One period of the row: barbule spacing H·A along the tilted barbule axis u = (cos μ, 0,
    // sin μ), seen from above; the cells' length along +y.
    double pitch_x_um() const {
        return row.params.H * row.params.cell.semi_major_um * std::cos(row.params.mu);
    }
    double period_y_um() const { return row.params.cell.cell_length_um; }
};

Row small_row() {
    geometry::BarbuleRowParams params;
    params.barbules = 12;
    params.cells_per_barbule = 8;
    Row r{geometry::build_barbule_row(params, {0.01, 0.02}), nullptr};
    r.tracer = std::make_shared<const ExplicitScatterer>(barbule_row_scene(r.row));
    return r;
}

Vec3d from_deg(double theta_deg, double phi_deg) {
    return gonio::direction_from_angles(theta_deg * kDeg, phi_deg * kDeg);
}

// Four light directions, each with its specular view, the retro view, the normal and two more.
std::vector<gonio::DirectionPair> few_pairs() {
    std::vector<gonio::DirectionPair> pairs;
    for (const auto [theta, phi] :
         std::array<std::array<double, 2>, 4>{{{15, 0}, {35, 60}, {50, 150}, {60, 250}}}) {
        const Vec3d wi = from_deg(theta, phi);
        for (const Vec3d& wo : {from_deg(theta, phi + 180.0), wi, from_deg(0.0, 0.0),
                                from_deg(25.0, phi + 90.0), from_deg(45.0, phi + 220.0)})
            pairs.push_back({wi, wo});
    }
    return pairs;
}

gonio::GoniometerConfig few_pairs_config(gonio::Aperture aperture, bool features) {
    gonio::GoniometerConfig c;
    c.pairs = few_pairs();
    c.wavelengths_nm = kFive;
    c.detector_half_angle_rad = kDetectorHalfAngle;
    c.beam_radius_um = 30.0;
    c.aperture = aperture;
    c.estimator = gonio::Estimator::photon;
    c.share_wavelength_paths = features;
    c.split_paths = features;
    c.guided_fraction = features ? 0.8 : 0.0;
    c.seed = features ? 21 : 22;
    // The plain walk with 5× the quanta (tracer_spectral_test.cpp's reason): its diffuse cells
    // see few hits per quantum, and a mean of few heavy-tailed hits reads low with a small error
    // more often than a Wald z allows.
    c.quanta_per_pass = features ? 20000 : 100000;
    c.max_passes = 1;
    return c;
}

// The wrapped scatterer with shared paths, splitting and an 80 % guide against its plain
// per-wavelength walk: χ² per wavelength over the pairs (a shared quantum's wavelengths are
// correlated; its pairs hardly, a quantum's branches entering at most two of the 8° cones), each
// against its 0.1 % quantile, and every |z| under the Šidák bound for a 1 % family-wise error.
void expect_features_agree_with_plain_walk(const Scatterer& wrapped, gonio::Aperture aperture,
                                           const std::string& what) {
    const gonio::BrdfRecord plain = gonio::measure_brdf(wrapped, few_pairs_config(aperture, false));
    const gonio::BrdfRecord featured =
        gonio::measure_brdf(wrapped, few_pairs_config(aperture, true));
    EXPECT_FALSE(plain.wavelength_paths_shared || plain.paths_split || plain.diffuse_guided);
    EXPECT_TRUE(featured.wavelength_paths_shared) << what;
    EXPECT_TRUE(featured.paths_split) << what;
    EXPECT_TRUE(featured.diffuse_guided) << what;
    const testing::RecordAgreement agreement = testing::compare_per_wavelength(featured, plain);
    for (std::size_t k = 0; k < kFive.size(); ++k) {
        const double chi2 = agreement.chi2[k];
        const int dof = agreement.dof[k];
        ASSERT_EQ(dof, static_cast<int>(plain.config.pairs.size())) << what << ": empty cells";
        const double p = analysis::chi_square_p_value(chi2, dof);
        ::testing::Test::RecordProperty(what + "_chi2_" + std::to_string(k),
                                        std::to_string(chi2) + " dof " + std::to_string(dof));
        EXPECT_GT(p, 1e-3) << what << ' ' << kFive[k] << " nm: chi2 " << chi2 << " on " << dof;
    }
    ::testing::Test::RecordProperty(what + "_max_z", std::to_string(agreement.max_z));
    EXPECT_LT(agreement.max_z, analysis::two_sided_normal_quantile(
                                   analysis::sidak_significance(0.01, agreement.cells)))
        << what;
}

TEST(WrapperBranches, MountedFeaturesAgreeWithThePlainWalk) {
    const Row row = small_row();
    const MountedScatterer mounted(row.tracer, kMountAzimuth);
    EXPECT_NE(mounted.path_tracing(), nullptr);
    EXPECT_TRUE(mounted.can_split_paths());
    expect_features_agree_with_plain_walk(mounted, gonio::Aperture::both_cones, "mounted");
}

TEST(WrapperBranches, PeriodCellFeaturesAgreeWithThePlainWalk) {
    const Row row = small_row();
    const PeriodCellEntry cell(row.tracer, row.pitch_x_um(), row.period_y_um(), 0.0);
    EXPECT_NE(cell.path_tracing(), nullptr);
    EXPECT_TRUE(cell.can_split_paths());
    expect_features_agree_with_plain_walk(cell, gonio::Aperture::view_cone, "period_cell");
}

using Branches = std::array<SpectralScatterEvent, PathTracing::kMaxBranches>;
using BranchWeights = std::array<double, PathTracing::kMaxBranches * 5>;

TEST(WrapperBranches, MountedBranchesAreTheInnerBranchesTurned) {
    const Row row = small_row();
    const MountedScatterer mounted(row.tracer, kMountAzimuth);
    const Eigen::AngleAxisd to_sample(-kMountAzimuth, Vec3d::UnitZ());
    const Eigen::AngleAxisd to_instrument(kMountAzimuth, Vec3d::UnitZ());
    // Detector axes in the instrument's frame: five views of each light, and once more than the
    // wrapper keeps on the stack (its heap path).
    Rng axes_rng(31, 0);
    std::vector<Vec3d> many(MountedScatterer::kStackAxes + 20);
    for (Vec3d& a : many) a = from_deg(70.0 * axes_rng.uniform(), 360.0 * axes_rng.uniform());
    const std::vector<gonio::DirectionPair> pairs = few_pairs();
    int two_branches = 0, guided_hits = 0, diffuse = 0;
    for (std::uint64_t q = 0; q < 4000; ++q) {
        const std::size_t light = q % 4;
        std::vector<Vec3d> axes;
        for (std::size_t v = 0; v < 5; ++v) axes.push_back(pairs[5 * light + v].wo);
        if (q % 8 == 7) axes = many;
        BranchOptions options;
        options.split_first_film = true;
        options.detector_axes = axes;
        options.detector_half_angle_rad = kDetectorHalfAngle;
        options.guided_fraction = 0.8;
        std::vector<Vec3d> turned_axes;
        for (const Vec3d& a : axes) turned_axes.push_back(to_sample * a);
        BranchOptions turned = options;
        turned.detector_axes = turned_axes;

        const Vec3d wi = pairs[5 * light].wi;
        Rng where(32, q);
        const Vec2 position(80.0 * where.uniform() - 40.0, 80.0 * where.uniform() - 40.0);
        const Vec3d p3 = to_sample * Vec3d(position.x(), position.y(), 0.0);
        Rng stream(33, q);
        Rng same = stream;
        Branches got{}, want{};
        BranchWeights got_w{}, want_w{};
        const std::size_t n =
            mounted.sample_spectral_branches(wi, kFive, position, stream, options, got, got_w);
        ASSERT_EQ(n, row.tracer->sample_spectral_branches(to_sample * wi, kFive, p3.head<2>(), same,
                                                          turned, want, want_w))
            << "quantum " << q;
        two_branches += n == 2;
        for (std::size_t b = 0; b < n; ++b) {
            ASSERT_EQ(got[b].lobe, want[b].lobe) << "quantum " << q;
            ASSERT_LT((got[b].wo - to_instrument * want[b].wo).norm(), 1e-12) << "quantum " << q;
            const Vec3d exit = to_instrument * Vec3d(want[b].exit_position_um.x(),
                                                     want[b].exit_position_um.y(), 0.0);
            ASSERT_LT((got[b].exit_position_um - exit.head<2>()).norm(), 1e-10) << "quantum " << q;
            for (std::size_t k = 0; k < kFive.size(); ++k) {
                const double w = want_w[b * kFive.size() + k];
                ASSERT_NEAR(got_w[b * kFive.size() + k], w, 1e-12 * (1.0 + w)) << "quantum " << q;
            }
            // The guide aims at the instrument's detectors: most TRT escapes enter one.
            if (got[b].lobe != ExplicitScatterer::kTRT || axes.size() != 5) continue;
            ++diffuse;
            for (const Vec3d& a : axes) {
                if (got[b].wo.dot(a) >= std::cos(kDetectorHalfAngle)) {
                    ++guided_hits;
                    break;
                }
            }
        }
    }
    RecordProperty("two_branch_quanta", two_branches);
    RecordProperty("trt_escapes", diffuse);
    RecordProperty("trt_escapes_in_a_detector", guided_hits);
    EXPECT_GT(two_branches, 400);
    ASSERT_GT(diffuse, 200);
    // 80 % are drawn towards a cone; what the film and the row let through keeps most of them
    // there, against ~2 % of cosine directions for five 8° cones.
    EXPECT_GT(guided_hits, diffuse / 2);
}

TEST(WrapperBranches, PeriodCellQuantumIsTheInnerQuantumAtItsDrawnEntry) {
    const Row row = small_row();
    const PeriodCellEntry cell(row.tracer, row.pitch_x_um(), row.period_y_um(), 0.0);
    const std::vector<Vec3d> axes = {from_deg(30.0, 200.0), from_deg(0.0, 0.0)};
    BranchOptions options;
    options.split_first_film = true;
    options.detector_axes = axes;
    options.detector_half_angle_rad = kDetectorHalfAngle;
    options.guided_fraction = 0.8;
    for (std::uint64_t q = 0; q < 500; ++q) {
        const Vec3d wi = from_deg(30.0, 20.0);
        Rng stream(41, q);
        Rng same = stream;
        const Vec2 ignored(1e3, -1e3);  // the beam position: not used
        Branches got{}, want{};
        BranchWeights got_w{}, want_w{};
        const std::size_t n =
            cell.sample_spectral_branches(wi, kFive, ignored, stream, options, got, got_w);
        const Vec2 entry = cell.draw_entry(same);
        ASSERT_EQ(
            n, row.tracer->sample_spectral_branches(wi, kFive, entry, same, options, want, want_w));
        for (std::size_t b = 0; b < n; ++b) {
            EXPECT_EQ(got[b].wo, want[b].wo);
            EXPECT_EQ(got[b].exit_position_um, want[b].exit_position_um);
        }
        EXPECT_EQ(got_w, want_w);
        // The shared path alone, likewise.
        Rng shared(42, q);
        Rng shared_same = shared;
        std::array<double, 5> sw{}, sw_want{};
        const auto e = cell.sample_spectral(wi, kFive, ignored, shared, sw);
        const Vec2 shared_entry = cell.draw_entry(shared_same);
        const auto e_want =
            row.tracer->sample_spectral(wi, kFive, shared_entry, shared_same, sw_want);
        ASSERT_EQ(e.has_value(), e_want.has_value());
        if (e) {
            EXPECT_EQ(e->wo, e_want->wo);
        }
        EXPECT_EQ(sw, sw_want);
    }
}

// The species study's arrangement: a mount of a period cell of the tracer.
TEST(WrapperBranches, MountedPeriodCellIsBitIdenticalOnOneAndTwoThreads) {
    const Row row = small_row();
    const auto cell = std::make_shared<const PeriodCellEntry>(row.tracer, row.pitch_x_um(),
                                                              row.period_y_um(), 0.0);
    const MountedScatterer sample(cell, kMountAzimuth);
    gonio::GoniometerConfig c = few_pairs_config(gonio::Aperture::both_cones, true);
    c.quanta_per_pass = 8000;  // four work items per light direction
    const int before = omp_get_max_threads();
    omp_set_num_threads(1);
    const gonio::BrdfRecord one = gonio::measure_brdf(sample, c);
    omp_set_num_threads(2);
    const gonio::BrdfRecord two = gonio::measure_brdf(sample, c);
    omp_set_num_threads(before);
    EXPECT_TRUE(one.paths_split && one.diffuse_guided && one.wavelength_paths_shared);
    EXPECT_EQ(one.threads, 1);
    EXPECT_EQ(two.threads, 2);
    EXPECT_EQ(one.value, two.value);
    EXPECT_EQ(one.standard_error, two.standard_error);
    EXPECT_EQ(one.lobe_values, two.lobe_values);
    EXPECT_EQ(one.lobe_standard_error, two.lobe_standard_error);
}

}  // namespace
}  // namespace plumage::sim
