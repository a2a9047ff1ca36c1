// Interface events one at a time (no Embree): geometry of reflection and refraction,
// event probabilities against Fresnel and Airy (binomial 3σ), the shading-normal
// fallback, diffuse sampling, and the film tables against direct evaluation.
#include "sim/interface_events.h"
#include "common/constants.h"

#include <array>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "common/error.h"
#include "sim/film_table.h"
#include "sim/optics/material.h"
#include "tests/sim/sim_test_util.h"

namespace plumage::sim {
namespace {

using optics::Complex;
using testing::binomial_sigma;

constexpr double kSigmas = 3.0;

Vec3d incoming(double theta_deg) {  // propagation direction hitting a +z facet from above
    const double t = theta_deg * kPi / 180.0;
    return {std::sin(t), 0.0, -std::cos(t)};
}

const SurfaceNormals kFlat{{0.0, 0.0, 1.0}, {0.0, 0.0, 1.0}};

TEST(InterfaceEvents, SnellAndMirrorGeometry) {
    const double eta = 1.0 / 1.55;
    for (double theta : {0.0, 10.0, 45.0, 80.0, 89.9}) {
        const Vec3d d = incoming(theta);
        const Vec3d r = reflect(d, kFlat.geometric);
        EXPECT_NEAR(r.x(), d.x(), 1e-15);
        EXPECT_NEAR(r.z(), -d.z(), 1e-15);
        Vec3d t;
        ASSERT_TRUE(refract(d, kFlat.geometric, eta, &t));
        EXPECT_NEAR(t.norm(), 1.0, 1e-15);
        EXPECT_LT(t.z(), 0.0);
        const double sin_i = std::hypot(d.x(), d.y()), sin_t = std::hypot(t.x(), t.y());
        EXPECT_NEAR(sin_i, 1.55 * sin_t, 1e-14) << theta;
        EXPECT_NEAR(t.y(), 0.0, 1e-15);  // stays in the plane of incidence
    }
    // From inside keratin beyond the critical angle: no refracted direction.
    const Vec3d up(std::sin(0.9), 0.0, std::cos(0.9));
    Vec3d t;
    EXPECT_FALSE(refract(up, kFlat.geometric, 1.55, &t));
    EXPECT_TRUE(refract(up, kFlat.geometric, 1.0, &t));
    EXPECT_EQ(t, up);  // index-matched: exactly straight on
}

TEST(InterfaceEvents, RefractedConeAxisLeavesAlongTheAxis) {
    // Inside keratin under a tilted facet, the aim for a light axis: refracting it out through
    // that facet (Snell's law forwards, refract()) gives the axis back.
    const Vec3d out = Vec3d(0.3, -0.2, 1.0).normalized();
    for (double theta : {0.0, 20.0, 50.0, 80.0}) {
        for (double phi : {0.0, 90.0, 225.0}) {
            const double t = theta * kDeg, p = phi * kDeg;
            const Vec3d a(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
            if (!(a.dot(out) > 0.0)) continue;
            const Vec3d d = refracted_cone_axis(a, out, 1.55);
            EXPECT_NEAR(d.norm(), 1.0, 1e-15);
            EXPECT_GE(d.dot(out), a.dot(out) - 1e-15);  // bent towards the normal inside
            Vec3d leaving;
            // refract() takes the normal on the arriving side: -out, from inside.
            ASSERT_TRUE(refract(d, -out, 1.55, &leaving)) << theta << " " << phi;
            EXPECT_NEAR((leaving - a).norm(), 0.0, 1e-14) << theta << " " << phi;
        }
    }
    // In air, or behind the interface: the axis itself.
    const Vec3d a(0.5, 0.0, std::sqrt(0.75));
    EXPECT_EQ(refracted_cone_axis(a, out, 1.0), a);
    EXPECT_EQ(refracted_cone_axis(a, -out, 1.55), a);
}

TEST(InterfaceEvents, DielectricReflectsWithFresnelProbability) {
    const Complex keratin = optics::keratin()->index(550.0);
    constexpr int kDraws = 100'000;
    for (double theta : {0.0, 45.0, 75.0}) {
        const Vec3d d = incoming(theta);
        const double expected =
            optics::fresnel_intensities_unpolarised(1.0, keratin, std::cos(theta * kPi / 180.0))
                .reflectance;
        Rng rng(7, static_cast<std::uint64_t>(theta));
        int reflected = 0;
        for (int i = 0; i < kDraws; ++i) {
            const InterfaceEvent e = dielectric_event(d, kFlat, Complex(1.0), keratin, rng);
            ASSERT_NEAR(e.throughput, 1.0, 1e-12);  // lossless: R + T = 1
            if (e.kind == EventKind::specular_reflect) {
                ++reflected;
                ASSERT_TRUE(e.to_outside);
                ASSERT_GT(e.direction.z(), 0.0);
            } else {
                ASSERT_EQ(e.kind, EventKind::refract);
                ASSERT_FALSE(e.to_outside);
                ASSERT_LT(e.direction.z(), 0.0);
            }
        }
        const double fraction = static_cast<double>(reflected) / kDraws;
        EXPECT_NEAR(fraction, expected, kSigmas * binomial_sigma(expected, kDraws))
            << "theta = " << theta;
    }
}

// The real-arithmetic Fresnel that dielectric_event takes between lossless media is the optics
// library's unpolarised Fresnel with k = 0: both sides denser, index-matched, normal to grazing
// and beyond the critical angle. (At exactly grazing incidence on an index-matched pair the
// library reports no flux at all, R = T = 0; events never arrive at cos θ = 0.)
TEST(InterfaceEvents, LosslessFresnelMatchesTheOpticsLibrary) {
    for (const auto& [n_in, n_out] : std::vector<std::pair<double, double>>{
             {1.0, 1.55}, {1.55, 1.0}, {1.55, 1.3}, {1.3, 1.55}, {1.2, 1.2}, {1.0, 3.5}}) {
        for (int i = n_in == n_out ? 1 : 0; i <= 1000; ++i) {
            const double c = i / 1000.0;
            const optics::FresnelIntensities fast = lossless_fresnel_unpolarised(n_in, n_out, c);
            const optics::FresnelIntensities reference =
                optics::fresnel_intensities_unpolarised(n_in, Complex(n_out), c);
            ASSERT_NEAR(fast.reflectance, reference.reflectance, 1e-12)
                << n_in << " -> " << n_out << " at cos " << c;
            ASSERT_NEAR(fast.transmittance, reference.transmittance, 1e-12)
                << n_in << " -> " << n_out << " at cos " << c;
        }
    }
}

TEST(InterfaceEvents, TotalInternalReflectionInsideKeratin) {
    const Complex keratin = optics::keratin()->index(550.0);
    const double critical = std::asin(1.0 / keratin.real());
    Rng rng(3, 0);
    for (double theta : {critical + 1e-6, 0.9, 1.3, 0.5 * kPi - 1e-3}) {
        // Travelling up from inside (below the +z facet, the inside of a keratin body).
        const Vec3d d(std::sin(theta), 0.0, std::cos(theta));
        for (int i = 0; i < 100; ++i) {
            const InterfaceEvent e = dielectric_event(d, kFlat, Complex(1.0), keratin, rng);
            ASSERT_EQ(e.kind, EventKind::total_internal_reflection) << theta;
            ASSERT_EQ(e.throughput, 1.0);
            ASSERT_FALSE(e.to_outside);
            ASSERT_NEAR((e.direction - Vec3d(d.x(), 0.0, -d.z())).norm(), 0.0, 1e-15);
        }
    }
    // Just inside the critical angle light still gets out.
    const double theta = critical - 1e-3;
    const Vec3d d(std::sin(theta), 0.0, std::cos(theta));
    int out = 0;
    for (int i = 0; i < 1000; ++i) {
        out += dielectric_event(d, kFlat, Complex(1.0), keratin, rng).kind == EventKind::refract;
    }
    EXPECT_GT(out, 0);
}

TEST(InterfaceEvents, FilmChoosesByAiryProbabilities) {
    const double lambda = 530.0;
    const Complex keratin = optics::keratin()->index(lambda);
    const Complex melanin = optics::melanin()->index(lambda);
    constexpr int kDraws = 100'000;
    struct Case {
        FilmOptics film;
        bool from_outside;
        double theta_deg;
    };
    const Case cases[] = {
        {{Complex(1.0), keratin, Complex(1.0), 0.59}, true, 0.0},
        {{Complex(1.0), keratin, Complex(1.0), 0.59}, false, 60.0},  // from the gap below
        {{Complex(1.0), keratin, Complex(1.5), 0.3}, false, 20.0},   // from the substrate
        {{Complex(1.0), melanin, Complex(1.0), 0.1}, true, 30.0},    // absorbing film
    };
    for (const Case& c : cases) {
        const double cos_t = std::cos(c.theta_deg * kPi / 180.0);
        Vec3d d = incoming(c.theta_deg);
        if (!c.from_outside) d.z() = -d.z();
        const FilmResponse expected = film_response(c.film, c.from_outside, lambda, cos_t);
        const double total = expected.reflectance + expected.transmittance;
        const double p_reflect = expected.reflectance / total;
        Rng rng(11, static_cast<std::uint64_t>(c.theta_deg));
        int reflected = 0;
        for (int i = 0; i < kDraws; ++i) {
            const InterfaceEvent e = thin_film_event(d, kFlat, c.film, lambda, rng);
            ASSERT_NEAR(e.throughput, total, 1e-15);
            if (e.kind == EventKind::film_reflect) {
                ++reflected;
                ASSERT_EQ(e.to_outside, c.from_outside);
            } else {
                ASSERT_EQ(e.kind, EventKind::film_transmit);
                ASSERT_NE(e.to_outside, c.from_outside);
            }
        }
        EXPECT_NEAR(static_cast<double>(reflected) / kDraws, p_reflect,
                    kSigmas * binomial_sigma(p_reflect, kDraws))
            << "theta " << c.theta_deg << " from outside " << c.from_outside;
    }
    // The absorbing film keeps R + T < 1: the path weight carries the loss.
    const FilmResponse absorbing =
        film_response({Complex(1.0), melanin, Complex(1.0), 0.1}, true, lambda, 1.0);
    EXPECT_LT(absorbing.reflectance + absorbing.transmittance, 0.9);
}

TEST(InterfaceEvents, ZeroThicknessFilmInAirIsNoSurface) {
    const FilmOptics film{Complex(1.0), optics::keratin()->index(500.0), Complex(1.0), 0.0};
    Rng rng(5, 0);
    for (double theta : {0.0, 30.0, 89.0}) {
        const Vec3d d = incoming(theta);
        for (int i = 0; i < 1000; ++i) {
            const InterfaceEvent e = thin_film_event(d, kFlat, film, 500.0, rng);
            ASSERT_EQ(e.kind, EventKind::film_transmit);
            ASSERT_EQ(e.direction, d);  // straight on, bit for bit
            ASSERT_NEAR(e.throughput, 1.0, 1e-15);
        }
    }
}

TEST(InterfaceEvents, ShadingNormalFallsBackWhenItWouldCrossTheFacet) {
    // Grazing light on a +z facet whose interpolated normal leans 8.6° towards −x: the
    // mirror direction about the shading normal would go into the facet.
    const Vec3d d = Vec3d(-0.98, 0.0, -0.196).normalized();
    const SurfaceNormals tilted{Vec3d(-0.15, 0.0, 0.989).normalized(), Vec3d(0.0, 0.0, 1.0)};
    ASSERT_LT(reflect(d, tilted.shading).z(), 0.0);  // the case this test is about
    const Complex keratin = optics::keratin()->index(550.0);
    Rng rng(13, 0);
    for (int i = 0; i < 10'000; ++i) {
        const InterfaceEvent e = dielectric_event(d, tilted, Complex(1.0), keratin, rng);
        ASSERT_TRUE(e.used_geometric_normal);
        if (e.kind == EventKind::specular_reflect) {
            ASSERT_GT(e.direction.z(), 0.0);
        } else {
            ASSERT_LT(e.direction.z(), 0.0);
        }
    }
    // A mild tilt is kept: the shading normal sets the angle.
    const SurfaceNormals mild{Vec3d(0.1, 0.0, 1.0).normalized(), Vec3d(0.0, 0.0, 1.0)};
    const InterfaceEvent e = dielectric_event(incoming(30.0), mild, Complex(1.0), keratin, rng);
    EXPECT_FALSE(e.used_geometric_normal);
}

// specular_regimes_agree (the tracer's test for keeping a reflection shared across wavelengths)
// makes the same decisions as the events themselves: over random directions from both sides and
// shading normals up to ~30° off the facet, two indices agree exactly when dielectric_event keeps
// the same normal and reaches total internal reflection alike at both. The indices (1.45 and 1.65)
// are far apart so that both answers are common.
TEST(InterfaceEvents, RegimesAgreeExactlyWhenTheEventsDecideAlike) {
    const std::array<double, 2> outside = {1.0, 1.0}, inside = {1.45, 1.65};
    Rng rng(19, 0);
    int agreeing = 0, differing = 0;
    for (int i = 0; i < 200'000; ++i) {
        const double z = 2.0 * rng.uniform() - 1.0, phi = 2.0 * kPi * rng.uniform();
        if (std::abs(z) < 1e-6) continue;
        const double r = std::sqrt(1.0 - z * z);
        const Vec3d d(r * std::cos(phi), r * std::sin(phi), z);
        const SurfaceNormals normals{
            Vec3d(0.6 * (2.0 * rng.uniform() - 1.0), 0.6 * (2.0 * rng.uniform() - 1.0), 1.0)
                .normalized(),
            Vec3d::UnitZ()};
        Rng event_rng(1, 1);
        const InterfaceEvent a =
            dielectric_event(d, normals, Complex(outside[0]), Complex(inside[0]), event_rng);
        const InterfaceEvent b =
            dielectric_event(d, normals, Complex(outside[1]), Complex(inside[1]), event_rng);
        const bool alike = a.used_geometric_normal == b.used_geometric_normal &&
                           (a.kind == EventKind::total_internal_reflection) ==
                               (b.kind == EventKind::total_internal_reflection);
        ASSERT_EQ(specular_regimes_agree(d, normals, outside, inside), alike)
            << "direction " << d.transpose() << ", shading " << normals.shading.transpose();
        (alike ? agreeing : differing) += 1;
    }
    EXPECT_GT(differing, 1000);
    EXPECT_GT(agreeing, 100'000);
    RecordProperty("differing", std::to_string(differing));
}

TEST(InterfaceEvents, DiffuseIsCosineDistributedOnTheIncidenceSide) {
    constexpr int kDraws = 200'000;
    for (bool from_above : {true, false}) {
        Vec3d d = incoming(40.0);
        if (!from_above) d.z() = -d.z();
        Rng rng(17, from_above);
        double sum_cos = 0.0;
        for (int i = 0; i < kDraws; ++i) {
            const InterfaceEvent e = diffuse_event(d, kFlat, 0.3, rng);
            ASSERT_EQ(e.kind, EventKind::diffuse_reflect);
            ASSERT_EQ(e.throughput, 0.3);
            ASSERT_EQ(e.to_outside, from_above);
            const double c = from_above ? e.direction.z() : -e.direction.z();
            ASSERT_GT(c, 0.0);
            sum_cos += c;
        }
        // Cosine law: E[cos θ] = 2/3, Var[cos θ] = 1/2 − 4/9 = 1/18.
        EXPECT_NEAR(sum_cos / kDraws, 2.0 / 3.0, kSigmas * std::sqrt(1.0 / 18.0 / kDraws));
    }
    Rng rng(1, 1);
    EXPECT_EQ(diffuse_event(incoming(0.0), kFlat, 0.0, rng).kind, EventKind::absorb);
    EXPECT_EQ(absorber_event(incoming(0.0), kFlat).kind, EventKind::absorb);
    EXPECT_EQ(absorber_event(incoming(0.0), kFlat).throughput, 0.0);
}

TEST(InterfaceEvents, DirectionInThePlaneOfTheFacetIsABug) {
    Rng rng(1, 1);
    EXPECT_THROW(dielectric_event({1.0, 0.0, 0.0}, kFlat, Complex(1.0), Complex(1.5), rng),
                 InvariantError);
}

TEST(InterfaceFilmTable, MatchesDirectEvaluationWithinItsTolerance) {
    std::mt19937_64 engine(42);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    for (double lambda : {400.0, 550.0, 700.0}) {
        const Complex keratin = optics::keratin()->index(lambda);
        for (double d : {0.1, 0.59, 2.0}) {
            const FilmOptics film{Complex(1.0), keratin, Complex(1.0), d};
            for (bool outside : {true, false}) {
                const auto table = FilmTable::build(film, outside, lambda);
                ASSERT_TRUE(table.has_value()) << lambda << " nm, d = " << d;
                EXPECT_LE(table->nodes(), FilmTable::kMaxNodes);
                double worst = 0.0;
                for (int i = 0; i < 100'000 / 18; ++i) {
                    const double c =
                        FilmTable::kMinCos + (1.0 - FilmTable::kMinCos) * uniform(engine);
                    const FilmResponse t = (*table)(c);
                    const FilmResponse e = film_response(film, outside, lambda, c);
                    worst = std::max({worst, std::abs(t.reflectance - e.reflectance),
                                      std::abs(t.transmittance - e.transmittance)});
                }
                EXPECT_LE(worst, FilmTable::kDefaultTolerance) << lambda << " nm, d = " << d;
                // Below kMinCos the tracer's source evaluates directly: exact.
                const TabulatedFilmResponse source(film, lambda, outside ? &*table : nullptr,
                                                   outside ? nullptr : &*table);
                const FilmResponse grazing = source.response(outside, 0.01);
                EXPECT_EQ(grazing.reflectance,
                          film_response(film, outside, lambda, 0.01).reflectance);
                RecordProperty("worst_error_" + std::to_string(static_cast<int>(lambda)) + "_" +
                                   std::to_string(static_cast<int>(1000 * d)),
                               std::to_string(worst));
            }
        }
    }
}

TEST(InterfaceFilmTable, RefusesKinksAndDenseFringes) {
    const double lambda = 550.0;
    const Complex keratin = optics::keratin()->index(lambda);
    // From the dense substrate side, light can be totally reflected: a kink in cos θ.
    EXPECT_FALSE(FilmTable::build({Complex(1.0), keratin, Complex(1.6), 0.5}, false, lambda));
    EXPECT_TRUE(FilmTable::build({Complex(1.0), keratin, Complex(1.6), 0.5}, true, lambda));
    // A coherent 50 µm film has ~70 fringes across cos θ: too many for 8193 nodes.
    EXPECT_FALSE(FilmTable::build({Complex(1.0), keratin, Complex(1.0), 50.0}, true, lambda));
    // Flagged incoherent, it is smooth and tabulates.
    EXPECT_TRUE(FilmTable::build(
        {Complex(1.0), keratin, Complex(1.0), 50.0, optics::Coherence::incoherent}, true, lambda));
    EXPECT_THROW(FilmTable::build({Complex(1.0), keratin, Complex(1.0), 0.5}, true, lambda, 0.0),
                 InputError);
}

// The guide's test case: a tilted facet, four cones above it and one below (whose directions
// must carry nothing), and the three test functions g of the checks below: g = 1 (all of it),
// the indicator of one of the guide's cones (where it concentrates) and the indicator of a
// cone it does not aim at.
struct GuideCase {
    Vec3d normal = Vec3d(0.3, -0.2, 1.0).normalized();
    SurfaceNormals normals{normal, normal};
    double alpha = 5.0 * kDeg, cos_alpha = std::cos(alpha);
    std::vector<Vec3d> axes;
    Vec3d elsewhere = Vec3d(-0.5, 0.6, 0.62).normalized();

    GuideCase() {
        for (double theta : {0.0, 30.0, 60.0, 75.0})
            axes.push_back(Vec3d(std::sin(theta * kDeg), 0.0, std::cos(theta * kDeg)));
        axes.push_back(-normal);
    }
    std::array<double, 3> g(const Vec3d& d) const {
        return {1.0, d.dot(axes[2]) >= cos_alpha ? 1.0 : 0.0,
                d.dot(elsewhere) >= cos_alpha ? 1.0 : 0.0};
    }
    // ∫ g(d) cos θ/π dω for the three g; over a cone of half-angle α around a (wholly above the
    // facet) it is (a·n) sin²α (the cap's projected area over π).
    std::array<double, 3> expected() const {
        const double s2 = std::pow(std::sin(alpha), 2);
        return {1.0, axes[2].dot(normal) * s2, elsewhere.dot(normal) * s2};
    }
    // Each of the n estimates x (one per g) within 5 σ (its Monte Carlo error) of the closed form.
    static void check_means(const std::array<double, 3>& sum, const std::array<double, 3>& sum_sq,
                            int n, const std::array<double, 3>& expected) {
        for (int k = 0; k < 3; ++k) {
            const double mean = sum[k] / n;
            const double sigma = std::sqrt((sum_sq[k] / n - mean * mean) / (n - 1));
            EXPECT_NEAR(mean, expected[k], 5.0 * sigma) << "test function " << k;
        }
    }
};

// E[throughput · g(d)] = ∫ g(d) cos θ/π dω for the three g of GuideCase.
TEST(InterfaceEvents, GuidedDiffuseReflectionIsUnbiasedForEveryDirection) {
    const GuideCase c;
    Rng rng(11, 5);
    const int n = 400000;
    std::array<double, 3> sum{}, sum_sq{};
    for (int i = 0; i < n; ++i) {
        const InterfaceEvent e =
            guided_diffuse_event(-c.normal, c.normals, c.axes, c.cos_alpha, 0.8, rng);
        const std::array<double, 3> g = c.g(e.direction);
        for (int k = 0; k < 3; ++k) {
            const double x = e.throughput * g[k];
            sum[k] += x;
            sum_sq[k] += x * x;
        }
        if (e.kind == EventKind::diffuse_reflect) {
            ASSERT_GT(e.direction.dot(c.normal), 0.0);
            ASSERT_LE(e.throughput, 1.0 / (1.0 - 0.8) + 1e-12);
        }
    }
    GuideCase::check_means(sum, sum_sq, n, c.expected());
}

// The 1 + k directions of guided_diffuse_branches as one estimate, E[Σ_i throughput_i g(d_i)]
// = ∫ g(d) cos θ/π dω for the three g of GuideCase, for k = 1 and 3; every throughput at most 1,
// and exactly 1 outside every cone (a plain diffuse event's).
TEST(InterfaceEvents, GuidedDiffuseBranchesAreUnbiasedForEveryDirection) {
    const GuideCase c;
    for (std::size_t k : {std::size_t{1}, std::size_t{3}}) {
        SCOPED_TRACE(k);
        Rng rng(11, 6 + k);
        const int n = 200000;
        std::array<double, 3> sum{}, sum_sq{};
        std::array<InterfaceEvent, 4> events{};
        for (int i = 0; i < n; ++i) {
            ASSERT_EQ(
                guided_diffuse_branches(-c.normal, c.normals, c.axes, c.cos_alpha, k, rng, events),
                1 + k);
            std::array<double, 3> x{};
            for (std::size_t b = 0; b <= k; ++b) {
                const InterfaceEvent& e = events[b];
                const std::array<double, 3> g = c.g(e.direction);
                for (int t = 0; t < 3; ++t) x[t] += e.throughput * g[t];
                if (e.kind != EventKind::diffuse_reflect) continue;
                ASSERT_GT(e.direction.dot(c.normal), 0.0);
                ASSERT_LE(e.throughput, 1.0 + 1e-12);
                bool in_cone = false;
                for (const Vec3d& a : c.axes)
                    in_cone = in_cone || e.direction.dot(a) >= c.cos_alpha;
                if (!in_cone) {
                    ASSERT_NEAR(e.throughput, 1.0, 1e-12);
                }
            }
            for (int t = 0; t < 3; ++t) {
                sum[t] += x[t];
                sum_sq[t] += x[t] * x[t];
            }
        }
        GuideCase::check_means(sum, sum_sq, n, c.expected());
    }
}

}  // namespace
}  // namespace plumage::sim
