// Stiff cases (issue 4, acceptance 5) and ray spawning across scales: grazing incidence,
// total internal reflection inside keratin, a k = 10 absorber, films of 0 and 50 µm,
// 1e-4 µm features in a 1e3 µm scene; thin shells and close sheets far from the origin
// must not leak.
#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <string>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "geometry/barbule.h"
#include "sim/optics/material.h"
#include "sim/optics/multilayer.h"
#include "sim/tracer.h"
#include "tests/sim/sim_test_util.h"

namespace plumage::sim {
namespace {

using optics::Complex;
using testing::binomial_sigma;

constexpr double kSigmas = 3.0;

Vec3d from_angle(double theta_deg, double phi_deg = 0.0) {
    const double t = theta_deg * kPi / 180.0, p = phi_deg * kPi / 180.0;
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

struct Summary {
    std::size_t paths = 0;
    double up = 0.0, down = 0.0, max_weight = 0.0;
    std::size_t returned = 0, absorbed = 0, not_finite = 0;
    long mismatches = 0, self_hits = 0, reached_max = 0, roulette = 0;
    std::array<long, 8> kinds{};
    std::array<std::size_t, 4> lobes{};
    double total() const { return (up + down) / static_cast<double>(paths); }
};

Summary summarise(const ExplicitScatterer& tracer, const Vec3d& wi, double lambda, Vec2 lo, Vec2 hi,
                  std::size_t n, std::uint64_t seed = 99) {
    Summary s;
    s.paths = n;
    for (std::size_t i = 0; i < n; ++i) {
        Rng rng(seed, i);
        const Vec2 p =
            lo + Vec2(rng.uniform() * (hi.x() - lo.x()), rng.uniform() * (hi.y() - lo.y()));
        const PathResult path = tracer.trace(wi, lambda, p, rng);
        s.mismatches += path.medium_mismatches;
        s.self_hits += path.self_hits_rejected;
        s.reached_max += path.reached_max_events;
        s.roulette += path.ended_by_roulette;
        for (int k = 0; k < std::min(path.events, PathResult::kRecordedEvents); ++k) {
            ++s.kinds[static_cast<int>(path.kinds[k])];
        }
        if (!path.event) {
            ++s.absorbed;
            continue;
        }
        const ScatterEvent& e = *path.event;
        if (!std::isfinite(e.weight) || !e.wo.allFinite() || !e.exit_position_um.allFinite() ||
            std::abs(e.wo.norm() - 1.0) > 1e-12 || e.weight < 0.0) {
            ++s.not_finite;
            continue;
        }
        ++s.returned;
        ++s.lobes[static_cast<std::size_t>(e.lobe)];
        s.max_weight = std::max(s.max_weight, e.weight);
        (e.wo.z() > 0.0 ? s.up : s.down) += e.weight;
    }
    return s;
}

// Nothing NaN, no weight above 1, no more light out than in.
void expect_sane(const Summary& s, const std::string& where) {
    EXPECT_EQ(s.not_finite, 0u) << where;
    EXPECT_LE(s.max_weight, 1.0) << where;
    EXPECT_LE(s.total(), 1.0) << where;
}

SceneDescription film_slab(double d_um, optics::Coherence coherence = optics::Coherence::coherent) {
    return single_mesh_scene(
        testing::square_mesh(1000.0),
        thin_film_interface(optics::keratin(), d_um, optics::air(), optics::air(), coherence),
        "film");
}

TEST(TracerStiff, GrazingIncidence) {
    constexpr std::size_t kPaths = 20'000;
    const double lambda = 550.0;
    const Vec3d wi = from_angle(89.9, 10.0);
    const ExplicitScatterer slab(film_slab(0.59));
    const optics::StackLayer layer{optics::keratin()->index(lambda), 0.59};
    const auto tmm = optics::transfer_matrix_intensities_unpolarised(
        {1.0, std::span(&layer, 1), Complex(1.0)}, lambda, wi.z());
    const Summary s = summarise(slab, wi, lambda, {-1, -1}, {1, 1}, kPaths);
    expect_sane(s, "film slab at 89.9 deg");
    EXPECT_NEAR(s.up / kPaths, tmm.reflectance, kSigmas * binomial_sigma(tmm.reflectance, kPaths));
    RecordProperty("grazing_slab_R",
                   std::to_string(s.up / kPaths) + " vs " + std::to_string(tmm.reflectance));

    const ExplicitScatterer row(barbule_row_scene(geometry::build_barbule_row({}, {0.01, 0.02})));
    for (double phi : {0.0, 90.0, 180.0}) {
        const Summary r =
            summarise(row, from_angle(89.9, phi), lambda, {-20, -20}, {20, 20}, kPaths / 4);
        expect_sane(r, "barbule row at 89.9 deg, phi " + std::to_string(phi));
        EXPECT_EQ(r.mismatches, 0);
    }
}

TEST(TracerStiff, TotalInternalReflectionInsideKeratin) {
    constexpr std::size_t kPaths = 10'000;
    // Light entering the top of a keratin cube at 80° refracts to 39.4° and meets the
    // side faces at 50.6°, beyond the critical angle (40.2°).
    const ExplicitScatterer cube(single_mesh_scene(testing::box_mesh({-10, -10, -10}, {10, 10, 10}),
                                                   dielectric_interface(optics::keratin()),
                                                   "cube"));
    const Vec3d wi = from_angle(80.0);
    const double shift =
        (cube.top_z_um() - 10.0) * std::tan(80.0 * kPi / 180.0);  // onto the top face
    const Summary s = summarise(cube, wi, 550.0, {shift - 9.0, -9.0}, {shift + 9.0, 9.0}, kPaths);
    expect_sane(s, "keratin cube");
    EXPECT_GT(s.kinds[static_cast<int>(EventKind::total_internal_reflection)],
              static_cast<long>(kPaths / 4));
    EXPECT_NEAR(s.total(), 1.0, 1e-3);  // lossless: TIR returns everything
    EXPECT_EQ(s.reached_max, 0);
    EXPECT_EQ(s.mismatches, 0);
    RecordProperty("tir_events",
                   std::to_string(s.kinds[static_cast<int>(EventKind::total_internal_reflection)]));
}

TEST(TracerStiff, StrongAbsorberKEquals10) {
    constexpr std::size_t kPaths = 20'000;
    const double lambda = 550.0;
    const Complex n(1.5, 10.0);
    const auto metal = std::make_shared<optics::ConstantMaterial>("k = 10", n);
    const ExplicitScatterer block(
        single_mesh_scene(testing::box_mesh({-500, -500, -20}, {500, 500, 0}),
                          dielectric_interface(metal), "absorber"));
    for (double theta : {0.0, 60.0, 89.0}) {
        const Vec3d wi = from_angle(theta);
        const double r = optics::fresnel_intensities_unpolarised(1.0, n, wi.z()).reflectance;
        const Summary s = summarise(block, wi, lambda, {-1, -1}, {1, 1}, kPaths);
        expect_sane(s, "k = 10 at " + std::to_string(theta));
        EXPECT_NEAR(s.up / kPaths, r, kSigmas * binomial_sigma(r, kPaths)) << theta;
        EXPECT_EQ(s.down, 0.0);  // exp(−4π k d / λ) = exp(−4570) underflows to 0, not NaN
        EXPECT_EQ(s.mismatches, 0);
    }
}

TEST(TracerStiff, FilmsOfZeroAndFiftyMicrometres) {
    constexpr std::size_t kPaths = 20'000;
    const double lambda = 550.0;
    const Complex keratin = optics::keratin()->index(lambda);
    // d = 0 on the barbule row: a film of nothing never reflects.
    geometry::BarbuleRowParams bare;
    bare.cell.film_thickness_um = 0.0;
    const ExplicitScatterer row(barbule_row_scene(geometry::build_barbule_row(bare, {0.01, 0.02})));
    const Summary r0 =
        summarise(row, from_angle(20.0), lambda, {-12.5, -20}, {12.5, 20}, kPaths / 2);
    expect_sane(r0, "row with d = 0");
    EXPECT_EQ(r0.kinds[static_cast<int>(EventKind::film_reflect)], 0);
    EXPECT_EQ(r0.lobes[ExplicitScatterer::kR], 0u);
    EXPECT_GT(r0.lobes[ExplicitScatterer::kTRT], 0u);

    // 50 µm: incoherent (phase-averaged, the physical choice) against the transfer matrix
    // with the layer flagged incoherent; coherent (direct Airy: the table is refused)
    // against Airy's fringes.
    for (auto coherence : {optics::Coherence::incoherent, optics::Coherence::coherent}) {
        const ExplicitScatterer slab(film_slab(50.0, coherence));
        const optics::StackLayer layer{keratin, 50.0, coherence};
        for (double theta : {0.0, 45.0, 85.0}) {
            const Vec3d wi = from_angle(theta);
            const auto tmm = optics::transfer_matrix_intensities_unpolarised(
                {1.0, std::span(&layer, 1), Complex(1.0)}, lambda, wi.z());
            const Summary s = summarise(slab, wi, lambda, {-1, -1}, {1, 1}, kPaths);
            const std::string where =
                std::string(coherence == optics::Coherence::coherent ? "coherent" : "incoherent") +
                " 50 um at " + std::to_string(theta);
            expect_sane(s, where);
            EXPECT_NEAR(s.up / kPaths, tmm.reflectance,
                        kSigmas * binomial_sigma(tmm.reflectance, kPaths))
                << where;
            EXPECT_NEAR(s.down / kPaths, tmm.transmittance,
                        kSigmas * binomial_sigma(tmm.transmittance, kPaths))
                << where;
        }
    }
}

// Features of 1e-4 µm (tiny film tiles and keratin cubes, and a 1e-4 µm thick keratin
// sheet) inside a 1e3 µm scene (a diffuse floor 1 mm wide), near the origin and 450 µm
// away. Near the origin the float grid (≈1e-11 µm) resolves them; 450 µm away it is
// 3e-5 µm, a third of the feature, and the spawn offset (≈1e-3 µm there) exceeds it: the
// paths there are geometrically wrong by design of single precision, but must stay finite
// and energy-bounded.
TEST(TracerStiff, TenthNanometreFeaturesInAMillimetreScene) {
    constexpr double kTiny = 1e-4;
    SceneDescription d;
    d.units.push_back(
        {"floor",
         {{"floor", testing::square_mesh(500.0, -1.0), diffuse_layer(constant_albedo(0.5))}}});
    d.units.push_back({"tile",
                       {{"tile", testing::square_mesh(0.5 * kTiny),
                         thin_film_interface(optics::keratin(), 0.59)}}});
    d.units.push_back(
        {"cube",
         {{"cube", testing::box_mesh(Vec3d::Constant(-0.5 * kTiny), Vec3d::Constant(0.5 * kTiny)),
           dielectric_interface(optics::keratin())}}});
    d.units.push_back({"sheet",
                       {{"sheet", testing::box_mesh({-2.0, -2.0, -kTiny}, {2.0, 2.0, 0.0}),
                         dielectric_interface(optics::keratin())}}});
    d.instances.push_back({0, Eigen::Affine3d::Identity()});
    for (double centre : {0.0, 450.0}) {
        for (int i = 0; i < 4; ++i) {
            for (int j = 0; j < 4; ++j) {
                const Vec3d at(centre + 2.0 * kTiny * i, centre + 2.0 * kTiny * j, 0.0);
                d.instances.push_back({1, Eigen::Affine3d(Eigen::Translation3d(at))});
                d.instances.push_back(
                    {2, Eigen::Affine3d(Eigen::Translation3d(at + Vec3d(kTiny, 0, -3 * kTiny)))});
            }
        }
        d.instances.push_back(
            {3, Eigen::Affine3d(Eigen::Translation3d(centre + 10.0, centre, -0.5))});
    }
    const ExplicitScatterer tracer(std::move(d));
    for (double centre : {0.0, 450.0}) {
        for (double theta : {0.0, 60.0}) {
            const Vec3d wi = from_angle(theta, 45.0);
            const double shift = tracer.top_z_um() * std::tan(theta * kPi / 180.0) / std::sqrt(2.0);
            const Vec2 c(centre + shift, centre + shift);
            const std::string where =
                "features at " + std::to_string(centre) + " um, " + std::to_string(theta);
            // On the tiny tiles and cubes, and on the thin sheet.
            const Summary tiny =
                summarise(tracer, wi, 550.0, c, c + Vec2(8 * kTiny, 8 * kTiny), 4000);
            expect_sane(tiny, where);
            EXPECT_GT(tiny.returned, 0u);
            const Summary sheet =
                summarise(tracer, wi, 550.0, c + Vec2(9.0, -1.0), c + Vec2(11.0, 1.0), 4000);
            expect_sane(sheet, where + " (sheet)");
            RecordProperty(
                "tiny_mismatches_" + std::to_string(int(centre)) + "_" + std::to_string(int(theta)),
                std::to_string(tiny.mismatches) + " / " + std::to_string(sheet.mismatches));
        }
    }
}

// --- Ray spawning: thin shells and close sheets, near and far from the origin -------------

// A film 0.3 µm above an absorber (the barbule's film and melanin gap, with the melanin
// made black): everything the film transmits must be absorbed, so nothing may leave
// downward and every escaping path is one film reflection. Also with a 0.01 µm gap.
TEST(TracerSpawn, FilmOverAbsorberNeverLeaks) {
    constexpr std::size_t kPaths = 10'000;
    for (double gap : {0.3, 0.01}) {
        SceneDescription d;
        d.units.push_back({"sandwich",
                           {{"film", testing::square_mesh(100.0, gap),
                             thin_film_interface(optics::keratin(), 0.59)},
                            {"black", testing::square_mesh(100.0, 0.0), absorber()}}});
        // Far away and turned about z: a transform Embree applies in float.
        Eigen::Affine3d far = Eigen::Affine3d::Identity();
        far.translate(Vec3d(500.0, 500.0, 0.0));
        far.rotate(Eigen::AngleAxisd(0.3, Vec3d::UnitZ()));
        d.instances = {{0, Eigen::Affine3d::Identity()}, {0, far}};
        const ExplicitScatterer tracer(std::move(d));
        for (double theta : {0.0, 45.0, 85.0}) {
            const Vec3d wi = from_angle(theta, 30.0);
            for (const Vec2& centre : {Vec2(0.0, 0.0), Vec2(500.0, 500.0)}) {
                const std::string where = "gap " + std::to_string(gap) + " at (" +
                                          std::to_string(centre.x()) + "), " +
                                          std::to_string(theta);
                // Aim at the sandwich's middle: start above it, shifted against the light.
                const double shift = (tracer.top_z_um() - 1.0) * std::tan(theta * kPi / 180.0);
                const Vec2 c = centre + shift * Vec2(std::cos(kPi / 6), std::sin(kPi / 6));
                const Summary s =
                    summarise(tracer, wi, 550.0, c - Vec2(5, 5), c + Vec2(5, 5), kPaths);
                expect_sane(s, where);
                EXPECT_EQ(s.down, 0.0) << where << ": light leaked through the absorber";
                EXPECT_EQ(s.lobes[ExplicitScatterer::kMulti], 0u) << where;
                EXPECT_EQ(s.mismatches, 0) << where;
                EXPECT_EQ(s.self_hits, 0) << where;
                EXPECT_GT(s.up, 0.0) << where;
            }
        }
    }
}

// Two film sheets 0.01 µm apart (neighbouring barbules nearly touching) over an absorber,
// 500 µm from the origin: light bounces between the films and must still end in the
// absorber or go back up.
TEST(TracerSpawn, CloseFilmSheetsFarFromTheOriginDoNotLeak) {
    constexpr std::size_t kPaths = 10'000;
    SceneDescription d;
    d.units.push_back(
        {"stack",
         {{"upper", testing::square_mesh(50.0, 0.31), thin_film_interface(optics::keratin(), 0.59)},
          {"lower", testing::square_mesh(50.0, 0.30), thin_film_interface(optics::keratin(), 0.59)},
          {"black", testing::square_mesh(50.0, 0.0), absorber()}}});
    d.instances = {{0, Eigen::Affine3d(Eigen::Translation3d(500.0, -500.0, 0.0))}};
    const ExplicitScatterer tracer(std::move(d));
    for (double theta : {0.0, 70.0}) {
        const Vec3d wi = from_angle(theta);
        const double shift = (tracer.top_z_um() - 0.3) * std::tan(theta * kPi / 180.0);
        const Vec2 c(500.0 + shift, -500.0);
        const Summary s = summarise(tracer, wi, 550.0, c - Vec2(5, 5), c + Vec2(5, 5), kPaths);
        expect_sane(s, "close sheets");
        EXPECT_EQ(s.down, 0.0);
        EXPECT_EQ(s.mismatches, 0);
        EXPECT_EQ(s.self_hits, 0);
        // Some light is trapped between the films and bounces several times.
        EXPECT_GT(s.lobes[ExplicitScatterer::kMulti], 0u);
    }
}

// A closed keratin sheet 0.01 µm thick, 500 µm from the origin: light must refract in and
// out through both faces (no ray slips through a face unseen), and energy is conserved.
TEST(TracerSpawn, ThinClosedShellFarFromTheOriginConservesEnergy) {
    constexpr std::size_t kPaths = 10'000;
    SceneDescription d = single_mesh_scene(testing::box_mesh({-100, -100, -0.01}, {100, 100, 0}),
                                           dielectric_interface(optics::keratin()), "sheet");
    d.instances[0].transform = Eigen::Translation3d(500.0, 500.0, 0.0);
    const ExplicitScatterer tracer(std::move(d));
    for (double theta : {0.0, 60.0, 88.0}) {
        const Vec3d wi = from_angle(theta);
        const double shift = tracer.top_z_um() * std::tan(theta * kPi / 180.0);
        const Vec2 c(500.0 + shift, 500.0);
        const Summary s = summarise(tracer, wi, 550.0, c - Vec2(5, 5), c + Vec2(5, 5), kPaths);
        expect_sane(s, "thin shell");
        EXPECT_NEAR(s.total(), 1.0, 1e-3);
        EXPECT_EQ(s.mismatches, 0) << theta;
        EXPECT_EQ(s.self_hits, 0) << theta;
        EXPECT_EQ(s.lobes[ExplicitScatterer::kT], 0u);
    }
}

}  // namespace
}  // namespace plumage::sim
