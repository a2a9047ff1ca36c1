// The goniometer's apertures (virtual_gonio/goniometer.h, "Aperture"): the both_cones cell is
// the cosine-weighted double-cone average of f, symmetric under light ↔ view, while the
// view_cone cell of a lobe narrower than the cone is not. Tested on a reciprocal scatterer
// built here: a Lambertian base plus a narrow Phong lobe about the mirror direction, which can
// be evaluated, sampled exactly, and integrated independently.
#include "virtual_gonio/goniometer.h"

#include <omp.h>

#include <cmath>

#include <gtest/gtest.h>

#include "analysis/metrics/statistics.h"
#include "common/constants.h"
#include "common/error.h"
#include "sim/interface_events.h"

namespace plumage::gonio {
namespace {

// f(ω_i, ω_o) = ρ/π + c · max(0, m(ω_i)·ω_o)^n, m the mirror about the normal. Reciprocal:
// m(ω_i)·ω_o = ω_i·m(ω_o). Sampled by one-sample MIS over the cosine hemisphere and the
// Phong lobe (density (n+1)/(2π) cos^n about m(ω_i)), so weights are exact: f cos θ_o / pdf.
//  | name | value | meaning                                        |
//  | ρ    | 0.5   | Lambertian albedo                              |
//  | n    | 3000  | Phong exponent: lobe width ~1/√n ≈ 1°          |
//  | c    | 0.4 (n+1)/(2π) | lobe albedo ≈ 0.4 cos θ_i           |
class LambertPlusPhong final : public Scatterer {
public:
    static constexpr double kRho = 0.5, kN = 3000.0;
    static constexpr double kC = 0.4 * (kN + 1.0) / (2.0 * kPi);

    std::string name() const override { return "lambert+phong"; }
    const std::vector<std::string>& lobe_names() const override { return names_; }
    bool can_evaluate() const override { return true; }

    static Vec3d mirror(const Vec3d& w) { return Vec3d(-w.x(), -w.y(), w.z()); }
    static double lobe_density(const Vec3d& axis, const Vec3d& w) {
        const double c = axis.dot(w);
        return c > 0.0 ? (kN + 1.0) / (2.0 * kPi) * std::exp(kN * std::log(c)) : 0.0;
    }
    double eval(const Vec3d& wi, const Vec3d& wo, double,
                std::span<double> per_lobe) const override {
        const double f = wo.z() > 0.0 ? kRho / kPi + kC * lobe_density(mirror(wi), wo) /
                                                         ((kN + 1.0) / (2.0 * kPi))
                                      : 0.0;
        if (!per_lobe.empty()) per_lobe[0] = f;
        return f;
    }
    std::optional<ScatterEvent> sample(const Vec3d& wi, double, const Vec2& position,
                                       Rng& rng) const override {
        Vec3d wo;
        if (rng.uniform() < 0.5) {
            wo = sim::sample_cosine_hemisphere(Vec3d::UnitZ(), rng);
        } else {
            // cos^n about the mirror direction: cos β = u^(1/(n+1)).
            const Vec3d axis = mirror(wi);
            const double cb = std::pow(rng.uniform(), 1.0 / (kN + 1.0));
            const double sb = std::sqrt(std::max(0.0, 1.0 - cb * cb)),
                         g = 2.0 * kPi * rng.uniform();
            Vec3d e1, e2;
            orthonormal_frame(axis, e1, e2);
            wo = cb * axis + sb * (std::cos(g) * e1 + std::sin(g) * e2);
        }
        if (!(wo.z() > 0.0)) return std::nullopt;
        const double pdf = 0.5 * wo.z() / kPi + 0.5 * lobe_density(mirror(wi), wo);
        return ScatterEvent{wo, eval(wi, wo, 0.0, {}) * wo.z() / pdf, 0, position};
    }

private:
    std::vector<std::string> names_{"all"};
};

Vec3d direction(double theta_deg, double phi_deg) {
    const double t = theta_deg * kDeg, p = phi_deg * kDeg;
    return Vec3d(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
}

// All ordered pairs of ten directions: each couple (a, b), (b, a) is held both ways, and the
// near-specular couples differ in θ by 3°, inside the 5° cones.
std::vector<DirectionPair> symmetric_pairs() {
    std::vector<Vec3d> dirs;
    for (double phi : {0.0, 180.0})
        for (double theta : {20.0, 40.0, 43.0, 60.0, 63.0}) dirs.push_back(direction(theta, phi));
    std::vector<DirectionPair> pairs;
    for (const Vec3d& a : dirs)
        for (const Vec3d& b : dirs) pairs.push_back({a, b});
    return pairs;
}

GoniometerConfig photon_config(Aperture aperture) {
    GoniometerConfig c;
    c.pairs = symmetric_pairs();
    c.detector_half_angle_rad = 5.0 * kDeg;
    c.estimator = Estimator::photon;
    c.aperture = aperture;
    c.seed = 77;
    c.quanta_per_pass = 200000;
    c.max_passes = 1;
    return c;
}

struct Reciprocity {
    double chi_square = 0.0, max_z = 0.0;
    int dof = 0;
};

Reciprocity reciprocity(const BrdfRecord& r) {
    Reciprocity out;
    const auto& pairs = r.config.pairs;
    for (std::size_t a = 0; a < pairs.size(); ++a) {
        for (std::size_t b = a + 1; b < pairs.size(); ++b) {
            if ((pairs[a].wi - pairs[b].wo).norm() > 1e-12 ||
                (pairs[a].wo - pairs[b].wi).norm() > 1e-12)
                continue;
            const double z =
                (r.at(a, 0) - r.at(b, 0)) / std::hypot(r.error_at(a, 0), r.error_at(b, 0));
            out.chi_square += z * z;
            out.max_z = std::max(out.max_z, std::abs(z));
            ++out.dof;
        }
    }
    return out;
}

TEST(GoniometerAperture, ConeDirectionsCoverTheConeByProjectedSolidAngle) {
    const double alpha = 5.0 * kDeg;
    for (const Vec3d& axis : {direction(0.0, 0.0), direction(63.0, 180.0), direction(40.0, 33.0)}) {
        // The disc's rim maps onto the cone's rim, its centre inside.
        for (int k = 0; k < 16; ++k) {
            const double g = 2.0 * kPi * k / 16.0;
            const Vec3d w = cone_direction_by_projected_area(axis, alpha, std::cos(g), std::sin(g));
            EXPECT_NEAR(w.norm(), 1.0, 1e-12);
            EXPECT_NEAR(w.dot(axis), std::cos(alpha), 1e-12);
        }
        EXPECT_GT(cone_direction_by_projected_area(axis, alpha, 0.0, 0.0).dot(axis),
                  std::cos(alpha));
        // Mean of cos β over the cone under the density cos θ / P (β from the axis), against
        // a polar midpoint integral with the density written out.
        double num = 0.0, den = 0.0;
        Vec3d e1, e2;
        orthonormal_frame(axis, e1, e2);
        for (int i = 0; i < 400; ++i) {
            const double b = alpha * (i + 0.5) / 400.0;
            for (int j = 0; j < 64; ++j) {
                const double g = 2.0 * kPi * (j + 0.5) / 64.0;
                const Vec3d w =
                    std::cos(b) * axis + std::sin(b) * (std::cos(g) * e1 + std::sin(g) * e2);
                num += std::sin(b) * w.z() * std::cos(b);
                den += std::sin(b) * w.z();
            }
        }
        // The same mean with directions from the disc, over a grid uniform in area (u = r²).
        double mean = 0.0;
        const int m = 400, azimuths = 64;
        for (int i = 0; i < m; ++i) {
            const double r = std::sqrt((i + 0.5) / m);
            for (int j = 0; j < azimuths; ++j) {
                const double g = 2.0 * kPi * (j + 0.5) / azimuths;
                mean +=
                    cone_direction_by_projected_area(axis, alpha, r * std::cos(g), r * std::sin(g))
                        .dot(axis);
            }
        }
        mean /= m * azimuths;
        // Both are 1 − O(α²) ≈ 0.9981; midpoint errors O(α²/m²) ≈ 1e-8.
        EXPECT_NEAR(mean, num / den, 1e-7);
    }
}

TEST(GoniometerAperture, BothConesMakeAReciprocalScattererReadReciprocal) {
    // χ² over the couples held both ways: the both_cones cells must be consistent with
    // f̄(a, b) = f̄(b, a) at p > 0.001 and their largest |z| below the Šidák bound for a 1 %
    // family-wise error; the view_cone cells of the same scatterer must fail (p < 1e-6): the
    // test can tell a non-reciprocal instrument.
    const LambertPlusPhong scatterer;
    const BrdfRecord both = measure_brdf(scatterer, photon_config(Aperture::both_cones));
    const Reciprocity rb = reciprocity(both);
    ASSERT_EQ(rb.dof, 45);
    const double p_both = analysis::chi_square_p_value(rb.chi_square, rb.dof);
    const double sidak =
        analysis::two_sided_normal_quantile(analysis::sidak_significance(0.01, rb.dof));
    RecordProperty("both_cones_chi2_per_dof", std::to_string(rb.chi_square / rb.dof));
    RecordProperty("both_cones_max_z", std::to_string(rb.max_z));
    EXPECT_GT(p_both, 1e-3) << "chi2/dof " << rb.chi_square / rb.dof;
    EXPECT_LT(rb.max_z, sidak);

    const BrdfRecord view = measure_brdf(scatterer, photon_config(Aperture::view_cone));
    const Reciprocity rv = reciprocity(view);
    const double p_view = analysis::chi_square_p_value(rv.chi_square, rv.dof);
    RecordProperty("view_cone_chi2_per_dof", std::to_string(rv.chi_square / rv.dof));
    RecordProperty("view_cone_max_z", std::to_string(rv.max_z));
    EXPECT_LT(p_view, 1e-6) << "chi2/dof " << rv.chi_square / rv.dof;
    EXPECT_GT(rv.max_z, sidak);
}

// The double-cone average by a polar midpoint rule about each cone's axis, the projected
// solid angle written out (sin β cos θ dβ dγ): independent of the goniometer's disc mapping.
double reference_double_cone(const Scatterer& s, const DirectionPair& p, double alpha, int nb,
                             int ng) {
    auto nodes = [&](const Vec3d& axis) {
        std::vector<std::pair<Vec3d, double>> out;
        Vec3d e1, e2;
        orthonormal_frame(axis, e1, e2);
        for (int i = 0; i < nb; ++i) {
            const double b = alpha * (i + 0.5) / nb;
            for (int j = 0; j < ng; ++j) {
                const double g = 2.0 * kPi * (j + 0.5) / ng;
                const Vec3d w =
                    std::cos(b) * axis + std::sin(b) * (std::cos(g) * e1 + std::sin(g) * e2);
                out.emplace_back(w, std::sin(b) * w.z());
            }
        }
        return out;
    };
    const auto li = nodes(p.wi), vo = nodes(p.wo);
    double num = 0.0, den = 0.0;
    for (const auto& [wi, a] : li)
        for (const auto& [wo, b] : vo) {
            num += a * b * s.eval(wi, wo, 550.0);
            den += a * b;
        }
    return num / den;
}

TEST(GoniometerAperture, BothConesMatchAnIndependentDoubleConeIntegral) {
    const LambertPlusPhong scatterer;
    const double alpha = 5.0 * kDeg;
    // The specular pair, a near-specular one 3° off (both ways) and an off-specular one.
    const std::vector<DirectionPair> pairs = {{direction(40.0, 0.0), direction(40.0, 180.0)},
                                              {direction(40.0, 0.0), direction(43.0, 180.0)},
                                              {direction(43.0, 180.0), direction(40.0, 0.0)},
                                              {direction(20.0, 0.0), direction(60.0, 0.0)}};
    GoniometerConfig c;
    c.pairs = pairs;
    c.detector_half_angle_rad = alpha;
    c.aperture = Aperture::both_cones;
    c.estimator = Estimator::photon;
    c.seed = 5;
    c.quanta_per_pass = 400000;
    c.max_passes = 1;
    const BrdfRecord photon = measure_brdf(scatterer, c);
    c.estimator = Estimator::eval;
    c.eval_rings = 24;
    const BrdfRecord eval = measure_brdf(scatterer, c);
    for (std::size_t p = 0; p < pairs.size(); ++p) {
        const double fine = reference_double_cone(scatterer, pairs[p], alpha, 48, 96);
        const double coarse = reference_double_cone(scatterer, pairs[p], alpha, 24, 48);
        const double ref_error = std::abs(fine - coarse);  // the reference's own error, bounded
        // Photon: within 4 standard errors (4 cells: family-wise ~2.5e-4).
        EXPECT_LT(std::abs(photon.at(p, 0) - fine), 4.0 * photon.error_at(p, 0) + ref_error)
            << "pair " << p << ": photon " << photon.at(p, 0) << " ± " << photon.error_at(p, 0)
            << ", reference " << fine << " (±" << ref_error << ")";
        // Eval: within its own error estimate (rule against half the rings) and the
        // reference's.
        EXPECT_LT(std::abs(eval.at(p, 0) - fine), eval.error_at(p, 0) + ref_error + 1e-9 * fine)
            << "pair " << p << ": eval " << eval.at(p, 0) << " (±" << eval.error_at(p, 0)
            << "), reference " << fine;
        RecordProperty("pair" + std::to_string(p) + "_reference", std::to_string(fine));
    }
    // The pair and its swap read the same (eval is deterministic: to the rule's round-off).
    EXPECT_NEAR(eval.at(1, 0), eval.at(2, 0), 1e-12 * eval.at(1, 0));
}

TEST(GoniometerAperture, LambertianPlateStillReadsAlbedoOverPiAndThreadsDoNotMatter) {
    // A constant f: the both_cones average is ρ/π exactly; photon cells within the Šidák
    // bound, and the same bits on 1 and 2 threads.
    struct Plate final : Scatterer {
        std::string name() const override { return "plate"; }
        const std::vector<std::string>& lobe_names() const override { return names; }
        std::optional<ScatterEvent> sample(const Vec3d&, double, const Vec2& p,
                                           Rng& rng) const override {
            return ScatterEvent{sim::sample_cosine_hemisphere(Vec3d::UnitZ(), rng), 0.6, 0, p};
        }
        std::vector<std::string> names{"all"};
    } plate;
    GoniometerConfig c = photon_config(Aperture::both_cones);
    c.quanta_per_pass = 30000;
    const int before = omp_get_max_threads();
    omp_set_num_threads(1);
    const BrdfRecord one = measure_brdf(plate, c);
    omp_set_num_threads(2);
    const BrdfRecord two = measure_brdf(plate, c);
    omp_set_num_threads(before);
    EXPECT_EQ(one.value, two.value);
    EXPECT_EQ(one.standard_error, two.standard_error);
    const double bound = analysis::two_sided_normal_quantile(
        analysis::sidak_significance(0.01, static_cast<int>(c.pairs.size())));
    for (std::size_t p = 0; p < c.pairs.size(); ++p)
        EXPECT_LT(std::abs(one.at(p, 0) - 0.6 / kPi), bound * one.error_at(p, 0)) << p;
}

TEST(GoniometerAperture, RefusesBadInput) {
    EXPECT_THROW(parse_aperture("both", "[goniometer] aperture"), InputError);
    try {
        parse_aperture("cones", "[goniometer] aperture");
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("[goniometer] aperture"), std::string::npos);
    }
    EXPECT_EQ(parse_aperture("both_cones", "k"), Aperture::both_cones);
    // A light direction whose source cone would dip below the patch plane.
    GoniometerConfig c = photon_config(Aperture::both_cones);
    c.pairs = {{direction(87.0, 0.0), direction(30.0, 0.0)}};
    EXPECT_THROW(c.validate(), InputError);
    c.aperture = Aperture::view_cone;
    EXPECT_NO_THROW(c.validate());
}

}  // namespace
}  // namespace plumage::gonio
