// Spectral path sharing (sim/tracer.h): one path for several wavelengths must give, at every
// wavelength, the same expectations as one path per wavelength. Checked by a χ² test of the
// two estimators on cells of (wavelength, lobe, hemisphere) and (wavelength, escape polar
// angle), with their combined standard errors, on the rock-dove barbule row (film in air over
// melanin: nothing depends on λ but the weights) and on a keratin sphere (dispersive
// refraction: the hero wavelength carries the path); and through the goniometer on a patch,
// cell by cell, with the same bits on 1 and 2 threads.
#include <omp.h>

#include <cmath>

#include <gtest/gtest.h>

#include "analysis/metrics/statistics.h"
#include "common/constants.h"
#include "common/error.h"
#include "geometry/barbule.h"
#include "sim/optics/material.h"
#include "sim/tracer.h"
#include "tests/sim/sim_test_util.h"
#include "tests/sim/small_barbule_row.h"
#include "tests/virtual_gonio/record_agreement.h"
#include "virtual_gonio/goniometer.h"

namespace plumage::sim {
namespace {

const std::vector<double> kSeven = {400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0};
constexpr int kThetaBins = 9;

Vec3d from_angle(double theta_deg, double phi_deg = 0.0) {
    const double t = theta_deg * kDeg, p = phi_deg * kDeg;
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

// Σx and Σx² per cell: per wavelength, (lobe, up/down) then polar-angle bins of ω_o.
struct Cells {
    std::size_t per_wavelength;
    std::vector<double> sum, sum_sq;
    std::size_t quanta = 0;

    Cells(std::size_t wavelengths, std::size_t lobes)
        : per_wavelength(2 * lobes + kThetaBins),
          sum(wavelengths * per_wavelength, 0.0),
          sum_sq(wavelengths * per_wavelength, 0.0) {}
    void add(std::size_t k, int lobe, const Vec3d& wo, double w) {
        const std::size_t base = k * per_wavelength;
        const std::size_t a = base + 2 * static_cast<std::size_t>(lobe) + (wo.z() > 0.0 ? 0 : 1);
        const auto bin = std::min<std::size_t>(
            kThetaBins - 1,
            static_cast<std::size_t>(std::acos(std::clamp(wo.z(), -1.0, 1.0)) / kPi * kThetaBins));
        for (std::size_t c : {a, base + per_wavelength - kThetaBins + bin}) {
            sum[c] += w;
            sum_sq[c] += w * w;
        }
    }
    double mean(std::size_t c) const { return sum[c] / static_cast<double>(quanta); }
    double error(std::size_t c) const {
        const double n = static_cast<double>(quanta), m = mean(c);
        return std::sqrt(std::max(0.0, sum_sq[c] / n - m * m) / (n - 1.0));
    }
};

Vec2 position(const BeamFootprint& fp, Rng& rng) {
    const double u = rng.uniform(), v = rng.uniform();
    return fp.min_um + Vec2(u * (fp.max_um - fp.min_um).x(), v * (fp.max_um - fp.min_um).y());
}

Cells separate_paths(const ExplicitScatterer& tracer, const Vec3d& wi, const BeamFootprint& fp,
                     std::size_t quanta) {
    Cells cells(kSeven.size(), tracer.lobe_names().size());
    cells.quanta = quanta;
    for (std::size_t k = 0; k < kSeven.size(); ++k) {
        for (std::size_t i = 0; i < quanta; ++i) {
            Rng rng(11, (k << 40) + i);
            const Vec2 p = position(fp, rng);
            const auto e = tracer.sample(wi, kSeven[k], p, rng);
            if (e) cells.add(k, e->lobe, e->wo, e->weight);
        }
    }
    return cells;
}

Cells shared_paths(const ExplicitScatterer& tracer, const Vec3d& wi, const BeamFootprint& fp,
                   std::size_t quanta, std::size_t* collapsed = nullptr) {
    Cells cells(kSeven.size(), tracer.lobe_names().size());
    cells.quanta = quanta;
    std::vector<double> w(kSeven.size());
    for (std::size_t i = 0; i < quanta; ++i) {
        Rng rng(12, i);
        const Vec2 p = position(fp, rng);
        const PathResult path = tracer.trace_spectral(wi, kSeven, p, rng, w);
        if (!path.event) continue;
        std::size_t alive = 0;
        for (std::size_t k = 0; k < kSeven.size(); ++k) {
            alive += w[k] > 0.0;
            cells.add(k, path.event->lobe, path.event->wo, w[k]);
        }
        if (collapsed != nullptr && alive == 1) ++*collapsed;
    }
    return cells;
}

// χ² of the two estimators over the cells either reaches; p-value and largest |z| against the
// Šidák bound for a 1 % family-wise error.
void expect_agreement(const Cells& a, const Cells& b, const std::string& what) {
    double chi2 = 0.0, max_z = 0.0;
    int dof = 0;
    for (std::size_t c = 0; c < a.sum.size(); ++c) {
        const double var = std::pow(a.error(c), 2) + std::pow(b.error(c), 2);
        if (!(var > 0.0)) continue;
        const double z = (a.mean(c) - b.mean(c)) / std::sqrt(var);
        chi2 += z * z;
        max_z = std::max(max_z, std::abs(z));
        ++dof;
    }
    ASSERT_GT(dof, 30) << what;
    const double p = analysis::chi_square_p_value(chi2, dof);
    const double bound =
        analysis::two_sided_normal_quantile(analysis::sidak_significance(0.01, dof));
    EXPECT_GT(p, 1e-3) << what << ": chi2/dof " << chi2 / dof << " over " << dof;
    EXPECT_LT(max_z, bound) << what;
    ::testing::Test::RecordProperty(what + "_chi2_per_dof", std::to_string(chi2 / dof));
    ::testing::Test::RecordProperty(what + "_max_z", std::to_string(max_z));
}

TEST(TracerSpectral, KeratinDispersionBendsRefractedRaysApart) {
    // Why the hero is needed: keratin's n(λ) turns a ray refracted at 45° by a measurable angle
    // between 400 and 700 nm, so a path through a keratin body cannot serve every λ.
    const double n400 = optics::keratin()->index(400.0).real();
    const double n700 = optics::keratin()->index(700.0).real();
    const double s = std::sin(45.0 * kDeg);
    const double spread = std::asin(s / n700) - std::asin(s / n400);
    RecordProperty("refraction_spread_deg", std::to_string(spread / kDeg));
    EXPECT_GT(spread, 1e-3);
}

TEST(TracerSpectral, SharedPathsMatchSeparatePathsOnTheRockDoveRow) {
    const geometry::BarbuleRow row = geometry::build_barbule_row({}, {0.01, 0.02});
    const ExplicitScatterer tracer(barbule_row_scene(row));
    const double period = row.params.H * row.params.cell.semi_major_um;
    const BeamFootprint fp{{-period, -30.0}, {period, 30.0}};
    for (double theta : {10.0, 50.0}) {
        const Vec3d wi = from_angle(theta, 20.0);
        std::size_t collapsed = 0;
        const Cells shared = shared_paths(tracer, wi, fp, 20000, &collapsed);
        expect_agreement(separate_paths(tracer, wi, fp, 20000), shared,
                         "rock_dove_" + std::to_string(static_cast<int>(theta)));
        // Film in air and a diffuse layer: no path needs its hero (absorption aside).
        EXPECT_LT(collapsed, 200u);
    }
}

// Light at 20° from azimuth 30° on a sphere of radius 10 µm at the origin: the entry square (on
// the scene's top plane) whose rays cover the sphere.
constexpr double kSphereTheta = 20.0, kSpherePhi = 30.0;
BeamFootprint sphere_footprint(const ExplicitScatterer& tracer) {
    const double shift = tracer.top_z_um() * std::tan(kSphereTheta * kDeg);
    const Vec2 centre = shift * Vec2(std::cos(kSpherePhi * kDeg), std::sin(kSpherePhi * kDeg));
    return {centre - Vec2(11.0, 11.0), centre + Vec2(11.0, 11.0)};
}

TEST(TracerSpectral, HeroWavelengthKeepsADispersiveSphereUnbiased) {
    const ExplicitScatterer tracer(single_mesh_scene(
        testing::sphere_mesh(10.0, 4), dielectric_interface(optics::keratin()), "keratin sphere"));
    const Vec3d wi = from_angle(kSphereTheta, kSpherePhi);
    const BeamFootprint fp = sphere_footprint(tracer);
    std::size_t collapsed = 0;
    const Cells shared = shared_paths(tracer, wi, fp, 30000, &collapsed);
    expect_agreement(separate_paths(tracer, wi, fp, 30000), shared, "keratin_sphere");
    EXPECT_GT(collapsed, 10000u);  // most quanta meet the sphere: their hero carries them
}

// Reflection stays shared (sim/tracer.h): a keratin film over a melanin sphere (the rooster's
// barbules: a coherent cortex over a melanin core) has λ-dependent indices inside, yet every λ
// reflects off it into one direction. The shared path chooses the side with the mean p̄ and takes
// the hero only when it enters the melanin, so the reflected paths, nearly all that escape,
// keep every wavelength; the estimates match one path per wavelength.
TEST(TracerSpectral, ReflectionStaysSharedAtAFilmOverMelanin) {
    const ExplicitScatterer tracer(single_mesh_scene(
        testing::sphere_mesh(10.0, 4),
        thin_film_interface(optics::keratin(), 0.174, optics::air(), optics::melanin()),
        "film over melanin"));
    const Vec3d wi = from_angle(kSphereTheta, kSpherePhi);
    const BeamFootprint fp = sphere_footprint(tracer);
    std::size_t collapsed = 0;
    const Cells shared = shared_paths(tracer, wi, fp, 30000, &collapsed);
    expect_agreement(separate_paths(tracer, wi, fp, 30000), shared, "film_over_melanin");
    // Melanin absorbs what enters it (k = 0.11 at 450 nm, 0.05 at 650 nm: the intensity falls by
    // e within 0.3–1 µm, and the sphere is 20 µm across), so an escaping path was reflected off
    // the film: none of them needs its hero.
    RecordProperty("collapsed_escapes", std::to_string(collapsed));
    EXPECT_LT(collapsed, 30u);
}

TEST(TracerSpectral, RefusesBadRequests) {
    const ExplicitScatterer tracer(barbule_row_scene(geometry::build_barbule_row({}, {0.1, 0.2})));
    Rng rng(1, 1);
    std::vector<double> w(2);
    EXPECT_THROW(tracer.sample_spectral(Vec3d::UnitZ(), kSeven, Vec2::Zero(), rng, w), InputError);
    std::vector<double> none;
    EXPECT_THROW(tracer.sample_spectral(Vec3d::UnitZ(), none, Vec2::Zero(), rng, none), InputError);
    const std::vector<double> bad = {550.0, -1.0};
    EXPECT_THROW(tracer.sample_spectral(Vec3d::UnitZ(), bad, Vec2::Zero(), rng, w), InputError);
}

gonio::GoniometerConfig patch_config(bool share) {
    gonio::GoniometerConfig c;
    c.pairs = gonio::filip2024_in_plane_pairs();
    c.wavelengths_nm = kSeven;
    c.detector_half_angle_rad = 8.0 * kDeg;
    c.beam_radius_um = 20.0;
    c.estimator = gonio::Estimator::photon;
    c.share_wavelength_paths = share;
    c.seed = 3;
    c.quanta_per_pass = 6000;
    c.max_passes = 1;
    return c;
}

using testing::small_barbule_row;

TEST(TracerSpectral, GoniometerCellsAgreeAndDoNotDependOnThreads) {
    const ExplicitScatterer patch = small_barbule_row();
    const int before = omp_get_max_threads();
    omp_set_num_threads(1);
    const gonio::BrdfRecord one = gonio::measure_brdf(patch, patch_config(true));
    omp_set_num_threads(2);
    const gonio::BrdfRecord two = gonio::measure_brdf(patch, patch_config(true));
    const gonio::BrdfRecord separate = gonio::measure_brdf(patch, patch_config(false));
    omp_set_num_threads(before);
    EXPECT_TRUE(one.wavelength_paths_shared);
    EXPECT_FALSE(separate.wavelength_paths_shared);
    EXPECT_EQ(one.value, two.value);
    EXPECT_EQ(one.standard_error, two.standard_error);
    EXPECT_EQ(one.lobe_values, two.lobe_values);
    double chi2 = 0.0, max_z = 0.0;
    int dof = 0;
    for (std::size_t i = 0; i < one.value.size(); ++i) {
        const double var =
            std::pow(one.standard_error[i], 2) + std::pow(separate.standard_error[i], 2);
        if (!(var > 0.0)) continue;
        const double z = (one.value[i] - separate.value[i]) / std::sqrt(var);
        chi2 += z * z;
        max_z = std::max(max_z, std::abs(z));
        ++dof;
    }
    ASSERT_GT(dof, 300);
    RecordProperty("cells", std::to_string(dof));
    RecordProperty("chi2_per_dof", std::to_string(chi2 / dof));
    RecordProperty("max_z", std::to_string(max_z));
    EXPECT_GT(analysis::chi_square_p_value(chi2, dof), 1e-3) << chi2 / dof;
    EXPECT_LT(max_z, analysis::two_sided_normal_quantile(analysis::sidak_significance(0.01, dof)));
}

// Splitting at the first film (and the reflected branch again at its next film), guided diffuse
// reflection and guided diffuse branches (sim/tracer.h) against the plain shared walk, cell by
// cell: χ² per wavelength at 0.1 %/7 and no |z| beyond the Šidák bound at 1 %; each alone and
// together; and the same bits on 1 and 2 threads.
TEST(TracerSpectral, SplitAndGuidedPathsAgreeWithThePlainWalk) {
    const ExplicitScatterer patch = small_barbule_row();
    const int before = omp_get_max_threads();
    omp_set_num_threads(2);
    gonio::GoniometerConfig plain_config = patch_config(true);
    plain_config.seed = 4;
    // The reference with 5× the quanta: a cell of the plain walk with few hits reads low and
    // precise at once, which a Wald z misreads (few hits of unequal weight); with more hits
    // its error estimate holds.
    plain_config.quanta_per_pass = 30000;
    const gonio::BrdfRecord plain = gonio::measure_brdf(patch, plain_config);
    struct Variant {
        const char* name;
        bool split;
        double guided;
        std::size_t branches;
        bool reflections = false;  // split_reflections
    };
    for (const Variant v :
         {Variant{"split", true, 0.0, 0}, Variant{"guided", false, 0.8, 0},
          Variant{"split_guided", true, 0.8, 0}, Variant{"guided_branches", false, 0.0, 2},
          Variant{"split_guided_branches", true, 0.0, 3},
          Variant{"split_reflections", true, 0.0, 0, true},
          Variant{"split_reflections_guided_branches", true, 0.0, 3, true}}) {
        gonio::GoniometerConfig c = patch_config(true);
        c.split_paths = v.split;
        c.split_reflections = v.reflections;
        c.guided_fraction = v.guided;
        c.guided_branches = v.branches;
        const gonio::BrdfRecord r = gonio::measure_brdf(patch, c);
        EXPECT_EQ(r.paths_split, v.split) << v.name;
        EXPECT_EQ(r.diffuse_guided, v.guided > 0.0 || v.branches > 0) << v.name;
        // One quantum's wavelengths are correlated (a shared path), so the χ² is taken per
        // wavelength, over pairs (independent quanta), each at 0.1 %/7; max |z| over all cells.
        const std::size_t nl = kSeven.size();
        const testing::RecordAgreement agreement = testing::compare_per_wavelength(r, plain);
        for (std::size_t k = 0; k < nl; ++k) {
            const double chi2 = agreement.chi2[k];
            const int dof = agreement.dof[k];
            ASSERT_GT(dof, 40) << v.name;
            RecordProperty(std::string(v.name) + "_chi2_per_dof_" + std::to_string(k),
                           std::to_string(chi2 / dof));
            EXPECT_GT(analysis::chi_square_p_value(chi2, dof), 1e-3 / static_cast<double>(nl))
                << v.name << ' ' << kSeven[k] << " nm: chi2/dof " << chi2 / dof;
        }
        RecordProperty(std::string(v.name) + "_max_z", std::to_string(agreement.max_z));
        EXPECT_LT(agreement.max_z, analysis::two_sided_normal_quantile(
                                       analysis::sidak_significance(0.01, agreement.cells)))
            << v.name;
        if (v.split && (v.guided > 0.0 || v.branches > 0 || v.reflections)) {
            omp_set_num_threads(1);
            const gonio::BrdfRecord one = gonio::measure_brdf(patch, c);
            omp_set_num_threads(2);
            EXPECT_EQ(one.value, r.value);
            EXPECT_EQ(one.standard_error, r.standard_error);
            EXPECT_EQ(one.lobe_values, r.lobe_values);
        }
    }
    omp_set_num_threads(before);
}

// BranchOptions::split_aimed_reflections on a lossless keratin slab, from the detector: where the
// top face's mirror direction lies within the light's cone, every walk leaves the reflection as a
// branch of its own, towards the mirror direction with each λ's Fresnel R_λ (keratin's n(λ): the
// shared response), and goes on into the slab with T_λ, refracted for its hero h alone (× N, the
// others 0). The slab absorbs nothing, so whatever the transmitted walk does after, a quantum's
// branches add up to R_λ + N T_λ at λ = h and to R_λ at the others. With the light elsewhere, no
// walk splits: one branch per quantum.
TEST(TracerSpectral, AnAimedReflectionSplitsOffWithItsFresnelWeight) {
    const ExplicitScatterer slab(
        single_mesh_scene(testing::box_mesh({-500, -500, -20}, {500, 500, 0}),
                          dielectric_interface(optics::keratin()), "keratin slab"));
    const std::vector<double> lambdas = {450.0, 550.0, 650.0};
    const std::size_t n = lambdas.size();
    const Vec3d view = from_angle(30.0), mirror = from_angle(30.0, 180.0);
    std::vector<double> fresnel;
    for (double lambda : lambdas) {
        const double index = optics::keratin()->index(lambda).real();
        fresnel.push_back(
            lossless_fresnel_unpolarised(1.0, index, std::cos(30.0 * kDeg)).reflectance);
    }
    std::array<SpectralScatterEvent, PathTracing::kMaxBranches> events;
    std::vector<double> weights(PathTracing::kMaxBranches * n);
    for (const double light_phi : {180.0, 0.0}) {  // the mirror direction's cone, and another
        const Vec3d light = from_angle(30.0, light_phi);
        BranchOptions options;
        options.adjoint = true;
        options.detector_axes = std::span<const Vec3d>(&light, 1);
        options.detector_half_angle_rad = 10.0 * kDeg;
        options.split_aimed_reflections = true;
        std::size_t split = 0;
        for (std::uint64_t q = 0; q < 2000; ++q) {
            Rng rng(23, q);
            const std::size_t count = slab.sample_spectral_branches(view, lambdas, Vec2(0.0, 0.0),
                                                                    rng, options, events, weights);
            if (light_phi != 180.0) {
                EXPECT_EQ(count, 1u);  // one walk, which chose its side at the top face
                continue;
            }
            std::vector<double> total(n, 0.0);
            for (std::size_t b = 0; b < count; ++b) {
                for (std::size_t k = 0; k < n; ++k) total[k] += weights[b * n + k];
                // The reflection leaves where the walk entered (within the top plane's margin);
                // light that the bottom face sends back leaves parallel to it, further on.
                if ((events[b].wo - mirror).norm() > 1e-9 ||
                    events[b].exit_position_um.norm() > 5.0)
                    continue;
                ++split;
                for (std::size_t k = 0; k < n; ++k)
                    EXPECT_NEAR(weights[b * n + k], fresnel[k], 1e-12) << lambdas[k] << " nm";
            }
            std::size_t heroes = 0;
            for (std::size_t k = 0; k < n; ++k) {
                const double hero = fresnel[k] + static_cast<double>(n) * (1.0 - fresnel[k]);
                if (std::abs(total[k] - hero) < 1e-12) {
                    ++heroes;
                } else {
                    EXPECT_NEAR(total[k], fresnel[k], 1e-12) << lambdas[k] << " nm";
                }
            }
            EXPECT_EQ(heroes, 1u);
        }
        if (light_phi == 180.0) {
            EXPECT_EQ(split, 2000u);
        }
    }
}

// BranchOptions::split_reflections: a reflected branch whose next event is a film leaves its
// transmitted side as a third branch, so that some quanta escape with three branches (never more
// without guided branches). That the branches' weights are right is the χ² test above.
TEST(TracerSpectral, AReflectedBranchSplitsAgainAtItsNextFilm) {
    const ExplicitScatterer patch = small_barbule_row();
    BranchOptions options;
    options.split_first_film = true;
    options.split_reflections = true;
    const std::size_t n = kSeven.size();
    std::array<SpectralScatterEvent, PathTracing::kMaxBranches> events;
    std::vector<double> weights(PathTracing::kMaxBranches * n);
    const Vec3d wi = Vec3d(std::sin(60.0 * kDeg), 0.0, std::cos(60.0 * kDeg));
    int third = 0;
    for (std::uint64_t q = 0; q < 20000; ++q) {
        Rng rng(11, q);
        const Vec2 position(40.0 * (rng.uniform() - 0.5), 40.0 * (rng.uniform() - 0.5));
        const std::size_t count =
            patch.sample_spectral_branches(wi, kSeven, position, rng, options, events, weights);
        ASSERT_LE(count, 3u);
        if (count == 3) ++third;
    }
    RecordProperty("quanta_with_three_branches", std::to_string(third));
    EXPECT_GT(third, 100);
}

}  // namespace
}  // namespace plumage::sim
