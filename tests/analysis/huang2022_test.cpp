// The Huang 2022 barbule BSDF: hit fractions (closed form against quadrature), the
// NDF normalisation trap, energy, reciprocity (R yes, TRT no), eval against an
// independent brute-force computation of Eq. 14, eval/pdf consistency.
#include "analysis/models/huang2022.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <Eigen/LU>

#include "common/constants.h"
#include "sim/optics/material.h"
#include "sim/optics/thin_film.h"
#include "tests/analysis/chi_square.h"
#include "tests/test_util.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/goniometer.h"

namespace plumage::analysis {
namespace {

Vec3d direction(double theta_deg, double phi_deg) {
    const double t = theta_deg * kPi / 180.0, p = phi_deg * kPi / 180.0;
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

std::vector<Vec3d> incident_grid() {
    std::vector<Vec3d> dirs;
    for (double theta : {0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0}) {
        for (double phi : {0.0, 45.0, 90.0, 135.0, 180.0, 250.0, 300.0})
            dirs.push_back(direction(theta, phi));
    }
    return dirs;
}

// Unit-ellipse arc as a fine polyline (independent of the model's analytic geometry).
std::vector<Eigen::Vector2d> arc_polyline(const Huang2022Params& p, int segments) {
    std::vector<Eigen::Vector2d> arc;
    for (int i = 0; i <= segments; ++i) {
        const double phi = p.phi0 + (p.phi1 - p.phi0) * i / segments;
        const double s = std::sin(phi), c = std::cos(phi), q = std::sqrt(s * s + p.b * p.b * c * c);
        arc.emplace_back(s / q, p.b * p.b * c / q);
    }
    return arc;
}

// Casts parallel 2D rays from direction ω_i across one period of the row: the fraction
// that hits any arc, and the fraction whose first hit is on the film side (the side
// the arc's outward normal faces).
std::pair<double, double> ray_cast_hit_fractions(const Huang2022Params& p, const Vec3d& wi_patch) {
    const Vec3d wi(wi_patch.x() * std::cos(p.mu) - wi_patch.z() * std::sin(p.mu), wi_patch.y(),
                   wi_patch.x() * std::sin(p.mu) + wi_patch.z() * std::cos(p.mu));
    const Eigen::Vector2d to_light = Eigen::Vector2d(wi.x(), wi.z()).normalized();
    const Eigen::Vector2d across(to_light.y(), -to_light.x());
    const Eigen::Vector2d u(std::cos(p.mu), std::sin(p.mu));
    const double period = p.H * u.dot(across);
    const auto arc = arc_polyline(p, 4000);
    constexpr int kRays = 2000;
    int hits = 0, front = 0;
    for (int r = 0; r < kRays; ++r) {
        const Eigen::Vector2d origin = 1e4 * to_light + ((r + 0.5) / kRays) * period * across;
        double best = 1e300;
        bool best_front = false;
        for (int k = -400; k <= 400; ++k) {
            const Eigen::Vector2d shift = k * p.H * u;
            if (std::abs((shift - origin).dot(across)) > 1.5) continue;  // out of reach
            for (std::size_t i = 0; i + 1 < arc.size(); ++i) {
                const Eigen::Vector2d a = arc[i] + shift, b = arc[i + 1] + shift;
                Eigen::Matrix2d mat;
                mat << -to_light.x(), a.x() - b.x(), -to_light.y(), a.y() - b.y();
                const double det = mat.determinant();
                if (std::abs(det) < 1e-15) continue;
                const Eigen::Vector2d tu = mat.inverse() * (a - origin);
                if (tu.x() > 0.0 && tu.y() >= 0.0 && tu.y() <= 1.0 && tu.x() < best) {
                    best = tu.x();
                    const Eigen::Vector2d edge = b - a;
                    // The arc runs with increasing φ (clockwise in x–z): its outward normal is
                    // the edge turned left, (−e_z, e_x); (0, 1) at the top for e = (1, 0).
                    const Eigen::Vector2d outward(-edge.y(), edge.x());
                    best_front = outward.dot(to_light) > 0.0;
                }
            }
        }
        hits += best < 1e299;
        front += best < 1e299 && best_front;
    }
    return {static_cast<double>(hits) / kRays, static_cast<double>(front) / kRays};
}

TEST(Huang2022, HitFractionsAgreeWithRayCastingAndNdfQuadrature) {
    // Three routes to what the light from ω_i meets: (1) Eq. 15's closed form
    // min(W, Δh)/Δh, (2) ∫ D ⟨ω_i, ω_m⟩ G_1 dω_m / ⟨ω_i, n⟩ with Eq. 7, (3) brute-force
    // 2D ray casting against polyline arcs. Front-facing hits (the R/TRT domain) and all
    // hits differ once the barbules leave gaps (H = 2.5): those rays reach an underside.
    double largest_back = 0.0;
    for (double h : {0.6, 1.25, 2.5}) {
        Huang2022Params p;
        p.H = h;
        const Huang2022Bsdf model(p);
        for (const Vec3d& wi :
             {direction(0.0, 0.0), direction(30.0, 45.0), direction(60.0, 180.0),
              direction(75.0, 0.0), direction(85.0, 45.0), direction(85.0, 300.0)}) {
            const auto [all, front] = ray_cast_hit_fractions(p, wi);
            // Ray spacing 1/2000 of a period and 4000-segment arcs: ±2e-3.
            EXPECT_NEAR(model.hit_fraction_closed_form(wi), all, 2e-3)
                << "H " << h << " wi " << wi.transpose();
            EXPECT_NEAR(model.hit_fraction_by_quadrature(wi), front, 2e-3)
                << "H " << h << " wi " << wi.transpose();
            EXPECT_NEAR(model.hit_fraction_by_quadrature(wi) + model.back_hit_fraction(wi),
                        model.hit_fraction_closed_form(wi), 2e-5);
            EXPECT_NEAR(model.t_lobe_mass(wi), 1.0 - all, 2e-3);
            largest_back = std::max(largest_back, model.back_hit_fraction(wi));
            if (h <= 1.25) {
                EXPECT_LT(model.back_hit_fraction(wi), 2e-5)
                    << "overlapping barbules hide the undersides";
            }
        }
    }
    RecordProperty("largest_back_hit_fraction_H2.5", std::to_string(largest_back));
    EXPECT_GT(largest_back, 0.05);
}

TEST(Huang2022, NdfExceedsOneOverTheWholeArcButNotWhenMasked) {
    // The trap the issue names: at the rock-dove parameters ∫ D ⟨ω_m, n⟩ dω_m over the
    // whole arc is the arc's net run along the barb plane divided by H, and exceeds 1;
    // the arc's projected width on the barb plane is larger still.
    const Huang2022Bsdf model({});
    const Huang2022Params p;
    const auto arc = arc_polyline(p, 100000);
    const Eigen::Vector2d u(std::cos(p.mu), std::sin(p.mu));
    double lo = 1e9, hi = -1e9;
    for (const auto& q : arc) lo = std::min(lo, q.dot(u)), hi = std::max(hi, q.dot(u));
    const double net = (arc.back() - arc.front()).dot(u);
    EXPECT_NEAR(model.ndf_projected_integral(), net / p.H, 1e-6);
    EXPECT_GT(model.ndf_projected_integral(), 1.0);
    EXPECT_GT((hi - lo) / p.H, 1.0);
    // Masked by visibility it is what the light meets: at most 1.
    for (const Vec3d& wi : incident_grid())
        EXPECT_LE(model.hit_fraction_by_quadrature(wi), 1.0 + 2e-5);
}

// Eq. 14 written out directly: D (Eq. 7), I_R (Airy, unpolarised), and G by casting
// 2D rays against a 20000-segment polyline of the neighbouring arcs (not the model's
// analytic ray–ellipse code).
double brute_force_f_r(const Huang2022Params& p, const Vec3d& wi_patch, const Vec3d& wo_patch,
                       double lambda) {
    auto to_barbule = [&](const Vec3d& w) {
        return Vec3d(w.x() * std::cos(p.mu) - w.z() * std::sin(p.mu), w.y(),
                     w.x() * std::sin(p.mu) + w.z() * std::cos(p.mu));
    };
    const Vec3d wi = to_barbule(wi_patch), wo = to_barbule(wo_patch);
    const Vec3d m = (wi + wo).normalized();
    double phi_m = std::atan2(m.x(), m.z());
    if (phi_m < p.phi0) phi_m += 2.0 * kPi;
    const double theta_m = std::asin(m.y());
    if (phi_m > p.phi1 || std::abs(theta_m) > p.theta_d) return 0.0;
    const double s = std::sin(phi_m), c = std::cos(phi_m);
    const double d = p.b * p.b / (2.0 * p.H * std::sin(p.theta_d) * std::cos(theta_m)) *
                     std::pow(s * s + p.b * p.b * c * c, -1.5);
    const double q = std::sqrt(s * s + p.b * p.b * c * c);
    const Eigen::Vector2d point(s / q, p.b * p.b * c / q);
    constexpr int kSegments = 20000;
    std::vector<Eigen::Vector2d> arc;
    for (int i = 0; i <= kSegments; ++i) {
        const double phi = p.phi0 + (p.phi1 - p.phi0) * i / kSegments;
        const double si = std::sin(phi), ci = std::cos(phi),
                     qi = std::sqrt(si * si + p.b * p.b * ci * ci);
        arc.emplace_back(si / qi, p.b * p.b * ci / qi);
    }
    auto blocked = [&](const Vec3d& w) {
        Eigen::Vector2d dir(w.x(), w.z());
        if (dir.norm() < 1e-12) return false;
        dir.normalize();
        for (int k = -60; k <= 60; ++k) {
            if (k == 0) continue;
            const Eigen::Vector2d shift = k * p.H * Eigen::Vector2d(std::cos(p.mu), std::sin(p.mu));
            for (int i = 0; i < kSegments; ++i) {
                const Eigen::Vector2d a = arc[i] + shift, b = arc[i + 1] + shift;
                // Solve point + t dir = a + u (b − a), t > 0, u ∈ [0, 1].
                Eigen::Matrix2d mat;
                mat << dir.x(), a.x() - b.x(), dir.y(), a.y() - b.y();
                if (std::abs(mat.determinant()) < 1e-15) continue;
                const Eigen::Vector2d tu = mat.inverse() * (a - point);
                if (tu.x() > 1e-9 && tu.y() >= 0.0 && tu.y() <= 1.0) return true;
            }
        }
        return false;
    };
    if (blocked(wi) || blocked(wo)) return 0.0;
    const optics::FilmMedia film{1.0, optics::keratin()->index(lambda), optics::Complex(1.0)};
    const double i_r =
        optics::airy_film_intensities_unpolarised(film, p.d_um, lambda, wi.dot(m)).reflectance;
    return i_r * d / (4.0 * wi_patch.z() * std::abs(wo_patch.z()));
}

TEST(Huang2022, RLobeMatchesAnIndependentEq14) {
    const Huang2022Params p;
    const Huang2022Bsdf model(p);
    int compared = 0, nonzero = 0;
    for (double ti : {10.0, 35.0, 60.0}) {
        for (double pi : {0.0, 90.0, 200.0}) {
            for (double to : {5.0, 30.0, 55.0, 80.0}) {
                for (double po : {10.0, 100.0, 170.0, 280.0}) {
                    const Vec3d wi = direction(ti, pi), wo = direction(to, po);
                    std::array<double, 3> lobes{};
                    model.eval(wi, wo, 550.0, lobes);
                    const double expected = brute_force_f_r(p, wi, wo, 550.0);
                    // Polyline visibility can differ from the exact arc within 1e-8 of an
                    // occlusion edge; none of these pairs sit that close.
                    EXPECT_NEAR(lobes[0], expected, 1e-9 * std::max(1.0, expected))
                        << wi.transpose() << " | " << wo.transpose();
                    ++compared;
                    nonzero += expected > 0.0;
                }
            }
        }
    }
    EXPECT_EQ(compared, 144);
    EXPECT_GT(nonzero, 20);  // the comparison is not vacuous
}

TEST(Huang2022, RLobeIsReciprocalAndTrtIsNot) {
    const Huang2022Bsdf model({});
    double worst_r = 0.0, largest_trt_asymmetry = 0.0;
    for (const Vec3d& wi : incident_grid()) {
        for (const Vec3d& wo : incident_grid()) {
            std::array<double, 3> forward{}, backward{};
            model.eval(wi, wo, 600.0, forward);
            model.eval(wo, wi, 600.0, backward);
            worst_r =
                std::max(worst_r, std::abs(forward[0] - backward[0]) / std::max(1e-3, forward[0]));
            largest_trt_asymmetry =
                std::max(largest_trt_asymmetry,
                         std::abs(forward[1] - backward[1]) / std::max(1e-6, forward[1]));
        }
    }
    EXPECT_LT(worst_r, 1e-9);
    // TRT averages over what ω_i illuminates only: swapping the directions changes it.
    EXPECT_GT(largest_trt_asymmetry, 0.05);
    RecordProperty("trt_max_relative_asymmetry", std::to_string(largest_trt_asymmetry));
}

TEST(Huang2022, EnergyNeverExceedsOne) {
    // Albedo + T mass <= 1 by quadrature of eval over the sphere (R lobes are narrow:
    // use the sample weights' mean instead, which is the albedo exactly, plus quadrature
    // of the smooth TRT lobe as a cross-check of its size).
    const Huang2022Bsdf model({});
    for (const Vec3d& wi : incident_grid()) {
        for (double lambda : {400.0, 550.0, 700.0}) {
            Rng rng(7, static_cast<std::uint64_t>(lambda));
            constexpr int kSamples = 4000;
            double total = 0.0, total_sq = 0.0;
            for (int s = 0; s < kSamples; ++s) {
                const auto e = model.sample(wi, lambda, {0.0, 0.0}, rng);
                const double w = e ? e->weight : 0.0;
                ASSERT_TRUE(std::isfinite(w));
                ASSERT_LE(w, 1.0 + 1e-12);
                total += w;
                total_sq += w * w;
            }
            const double mean = total / kSamples;
            EXPECT_LE(mean, 1.0 + 1e-12);
        }
    }
}

TEST(Huang2022, SampleWeightsAgreeWithEvalQuadrature) {
    // E[weight · 1(ω_o ∈ upper hemisphere, not T)] = ∫ f cos θ_o dω_o: Monte Carlo from
    // sample() against a fine quadrature of eval() (TRT and R; R is narrow in θ, so the
    // quadrature is adaptive in the half-vector instead: integrate over ω_m).
    const Huang2022Bsdf model({});
    for (const Vec3d& wi : {direction(10.0, 0.0), direction(50.0, 200.0)}) {
        const double lambda = 530.0;
        Rng rng(11, 3);
        constexpr int kSamples = 100000;
        double sum_trt = 0.0, sq_trt = 0.0, sum_r = 0.0, sq_r = 0.0;
        for (int s = 0; s < kSamples; ++s) {
            const auto e = model.sample(wi, lambda, {0.0, 0.0}, rng);
            if (!e || e->lobe == Huang2022Bsdf::kT) continue;
            if (e->lobe == Huang2022Bsdf::kTRT)
                sum_trt += e->weight, sq_trt += e->weight * e->weight;
            if (e->lobe == Huang2022Bsdf::kR && e->wo.z() > 0.0)
                sum_r += e->weight, sq_r += e->weight * e->weight;
        }
        const double mc_trt = sum_trt / kSamples, mc_r = sum_r / kSamples;
        const double se_trt =
            std::sqrt(std::max(0.0, sq_trt / kSamples - mc_trt * mc_trt) / kSamples);
        const double se_r = std::sqrt(std::max(0.0, sq_r / kSamples - mc_r * mc_r) / kSamples);
        // Quadrature of the TRT lobe over the upper hemisphere (smooth): 48 × 96 midpoints.
        double quad_trt = 0.0;
        constexpr int kT = 24, kP = 48;
        for (int i = 0; i < kT; ++i) {
            const double t = (i + 0.5) * 0.5 * kPi / kT;
            for (int j = 0; j < kP; ++j) {
                const double ph = (j + 0.5) * 2.0 * kPi / kP;
                const Vec3d wo(std::sin(t) * std::cos(ph), std::sin(t) * std::sin(ph), std::cos(t));
                std::array<double, 3> lobes{};
                model.eval(wi, wo, lambda, lobes);
                quad_trt +=
                    lobes[1] * std::cos(t) * std::sin(t) * (0.5 * kPi / kT) * (2.0 * kPi / kP);
            }
        }
        // 24 × 48 midpoints resolve the smooth TRT lobe to better than 1 %.
        EXPECT_NEAR(mc_trt, quad_trt, 4.0 * se_trt + 1e-2 * quad_trt) << wi.transpose();
        // R: ∫ f_R cos θ_o dω_o = P_hit E_q[I_R G_o] — evaluate f_R on a fine grid of the
        // reflected directions is costly; check instead that the R weights' mean matches
        // the R eval integrated over a 192 × 384 grid.
        double quad_r = 0.0;
        constexpr int kTr = 160, kPr = 320;
        for (int i = 0; i < kTr; ++i) {
            const double t = (i + 0.5) * 0.5 * kPi / kTr;
            for (int j = 0; j < kPr; ++j) {
                const double ph = (j + 0.5) * 2.0 * kPi / kPr;
                const Vec3d wo(std::sin(t) * std::cos(ph), std::sin(t) * std::sin(ph), std::cos(t));
                std::array<double, 3> lobes{};
                model.eval(wi, wo, lambda, lobes);
                quad_r +=
                    lobes[0] * std::cos(t) * std::sin(t) * (0.5 * kPi / kTr) * (2.0 * kPi / kPr);
            }
        }
        // The R lobe spans only ±2θ_d longitudinally: the grid resolves it to ~2 %.
        EXPECT_NEAR(mc_r, quad_r, 4.0 * se_r + 0.03 * quad_r) << wi.transpose();
        RecordProperty("r_mc_vs_quadrature",
                       std::to_string(mc_r) + " vs " + std::to_string(quad_r));
    }
}

// The goniometer's adaptive cone cubature (GoniometerConfig::eval_tolerance) converges the
// model: on the in-plane set at 450 and 650 nm (the specular R lobe is narrow beside a 5° cone),
// every cell it calls converged (stated error <= 0.5 %: it converges to half the tolerance) is
// within 1 % of a rule four times finer than its largest (16 → 64 rings), and it calls most of
// them converged. A cell's stated error
// is the difference to the rule with half its rings, so the test checks that this estimate is
// honest against a much finer rule, not only that it is small.
TEST(Huang2022, AdaptiveConeCubatureIsWithinOnePercentOfAFourTimesFinerRule) {
    const Huang2022Bsdf model(Huang2022Params{});
    gonio::GoniometerConfig c;
    c.pairs = gonio::filip2024_in_plane_pairs();
    c.wavelengths_nm = {450.0, 650.0};
    c.detector_half_angle_rad = 5.0 * kDeg;
    c.estimator = gonio::Estimator::eval;
    c.eval_tolerance = 0.01;
    c.eval_max_rings = 16;
    const gonio::BrdfRecord adaptive = gonio::measure_brdf(model, c);
    c.eval_tolerance = 0.0;
    c.eval_rings = 64;
    const gonio::BrdfRecord fine = gonio::measure_brdf(model, c);
    double peak = 0.0;
    for (double v : fine.value) peak = std::max(peak, v);
    int converged = 0, cells = 0;
    double worst = 0.0;
    for (std::size_t i = 0; i < fine.value.size(); ++i) {
        if (fine.value[i] < 1e-6 * peak) continue;  // nothing to compare
        ++cells;
        if (adaptive.standard_error[i] > 0.005 * std::abs(adaptive.value[i])) continue;
        ++converged;
        worst = std::max(worst, std::abs(adaptive.value[i] / fine.value[i] - 1.0));
    }
    std::printf("adaptive cubature: %d of %d cells converged, worst %.2e against 64 rings\n",
                converged, cells, worst);
    EXPECT_LE(worst, 0.01);
    // 98 of 110 at 16 rings (the studies allow 64); the rest state their larger error.
    EXPECT_GE(converged, (17 * cells) / 20);
}

// eval_lobes() asked for one lobe gives that lobe of eval() to the bit, and 0 for the other.
TEST(Huang2022, EvalLobesGivesEachLobeOfEval) {
    const Huang2022Bsdf model(Huang2022Params{});
    Rng rng(7, 0);
    const auto upper = [&rng] {
        const double u = rng.uniform(), phi = 2.0 * kPi * rng.uniform();
        return Vec3d(std::sqrt(u) * std::cos(phi), std::sqrt(u) * std::sin(phi),
                     std::sqrt(1.0 - u));
    };
    int both = 0;
    for (int n = 0; n < 2000; ++n) {
        const Vec3d wi = upper(), wo = upper();
        const double lambda = 400.0 + 300.0 * rng.uniform();
        std::array<double, 3> all{}, one{};
        const double total = model.eval(wi, wo, lambda, all);
        for (const int lobe : {Huang2022Bsdf::kR, Huang2022Bsdf::kTRT}) {
            one.fill(-1.0);
            const double value = model.eval_lobes(wi, wo, lambda, 1u << lobe, one);
            EXPECT_EQ(value, all[static_cast<std::size_t>(lobe)]);
            EXPECT_EQ(one[static_cast<std::size_t>(lobe)], all[static_cast<std::size_t>(lobe)]);
            EXPECT_EQ(one[static_cast<std::size_t>(1 - lobe)], 0.0);
        }
        EXPECT_EQ(total, all[0] + all[1]);
        both += all[0] > 0.0 && all[1] > 0.0;
    }
    EXPECT_GT(both, 20);  // pairs where both lobes are lit were among them
}

// The same model behind a scatterer that does not evaluate its lobes apart, counting the
// directions the cubature asks for: what the goniometer did before it refined lobe by lobe.
class CountingModel final : public Scatterer {
public:
    explicit CountingModel(const Scatterer& model, bool apart) : model_(model), apart_(apart) {}
    std::string name() const override { return model_.name(); }
    const std::vector<std::string>& lobe_names() const override { return model_.lobe_names(); }
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm, const Vec2& position,
                                       Rng& rng) const override {
        return model_.sample(wi, lambda_nm, position, rng);
    }
    bool can_evaluate() const override { return true; }
    double eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                std::span<double> per_lobe) const override {
        ++trt_evaluations_;
        return model_.eval(wi, wo, lambda_nm, per_lobe);
    }
    bool evaluates_lobes_apart() const override { return apart_; }
    double eval_lobes(const Vec3d& wi, const Vec3d& wo, double lambda_nm, std::uint32_t wanted,
                      std::span<double> per_lobe) const override {
        if ((wanted >> Huang2022Bsdf::kTRT) & 1u) ++trt_evaluations_;
        return model_.eval_lobes(wi, wo, lambda_nm, wanted, per_lobe);
    }
    long trt_evaluations() const { return trt_evaluations_.load(); }

private:
    const Scatterer& model_;
    bool apart_;
    mutable std::atomic<long> trt_evaluations_{0};
};

// Lobe by lobe (Scatterer::evaluates_lobes_apart), the adaptive cubature keeps its guarantee on
// the Filip set (every 15th pair, 450 and 650 nm): each cell it calls converged is within 1 % of
// a rule four times finer than its largest (16 → 64 rings), and it calls as many converged as
// the cell-by-cell rule does. Up to the studies' 64 rings it asks for TRT, the costly lobe, less
// than a third as often: R's edges take R alone to the finer rules.
TEST(Huang2022, LobeByLobeCubatureKeepsItsGuaranteeAndSparesTrt) {
    const Huang2022Bsdf model(Huang2022Params{});
    gonio::GoniometerConfig c;
    const std::vector<gonio::DirectionPair> all = gonio::filip2024_btf_pairs();
    for (std::size_t p = 0; p < all.size(); p += 15) c.pairs.push_back(all[p]);
    c.wavelengths_nm = {450.0, 650.0};
    c.detector_half_angle_rad = 5.0 * kDeg;
    c.estimator = gonio::Estimator::eval;
    c.eval_tolerance = 0.01;
    c.eval_max_rings = 16;
    const CountingModel by_lobe(model, true), by_cell(model, false);
    const gonio::BrdfRecord lobes = gonio::measure_brdf(by_lobe, c);
    const gonio::BrdfRecord cells = gonio::measure_brdf(by_cell, c);
    c.eval_tolerance = 0.0;
    c.eval_rings = 64;
    const gonio::BrdfRecord fine = gonio::measure_brdf(model, c);
    double peak = 0.0;
    for (double v : fine.value) peak = std::max(peak, v);
    int converged[2] = {0, 0}, compared = 0;
    double worst = 0.0;
    for (std::size_t i = 0; i < fine.value.size(); ++i) {
        if (fine.value[i] < 1e-6 * peak) continue;
        ++compared;
        converged[1] += cells.standard_error[i] <= 0.005 * std::abs(cells.value[i]);
        if (lobes.standard_error[i] > 0.005 * std::abs(lobes.value[i])) continue;
        ++converged[0];
        worst = std::max(worst, std::abs(lobes.value[i] / fine.value[i] - 1.0));
    }
    std::printf(
        "lobe by lobe: %d of %d cells converged (cell by cell %d), worst %.2e against 64 "
        "rings\n",
        converged[0], compared, converged[1], worst);
    EXPECT_LE(worst, 0.01);
    EXPECT_GE(converged[0], converged[1]);
    // Up to the studies' 64 rings, where R's edges go (eval_max_rings' default).
    c.eval_tolerance = 0.01;
    c.eval_rings = 4;
    c.eval_max_rings = 64;
    const CountingModel deep_lobe(model, true), deep_cell(model, false);
    gonio::measure_brdf(deep_lobe, c);
    gonio::measure_brdf(deep_cell, c);
    std::printf("to 64 rings: TRT evaluated %ld times lobe by lobe, %ld cell by cell\n",
                deep_lobe.trt_evaluations(), deep_cell.trt_evaluations());
    EXPECT_LT(3 * deep_lobe.trt_evaluations(), deep_cell.trt_evaluations());
}

TEST(Huang2022, RejectsOutOfRangeParameters) {
    using plumage::testing::input_error_message;
    Huang2022Params p;
    p.b = 0.0;
    EXPECT_NE(input_error_message([&] { Huang2022Bsdf{p}; }).find("b = 0"), std::string::npos);
    p = {};
    p.H = -1.0;
    EXPECT_NE(input_error_message([&] { Huang2022Bsdf{p}; }).find("H = -1"), std::string::npos);
    p = {};
    p.theta_d = 0.0;
    EXPECT_NE(input_error_message([&] { Huang2022Bsdf{p}; }).find("theta_d = 0"),
              std::string::npos);
    const Huang2022Bsdf model({});
    EXPECT_NE(input_error_message([&] {
                  model.t_lobe_mass({0.0, 0.0, -1.0});
              }).find("above the barb plane"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::analysis

namespace plumage::analysis {
namespace {

TEST(Huang2022, SamplingMatchesPdfChiSquare) {
    // pbrt-style: directions drawn by sample() against pdf() integrated over sphere bins;
    // the T lobe (a Dirac) and quanta absorbed at undersides fill the extra cell.
    const Huang2022Bsdf model({});
    const std::vector<Vec3d> incident = {direction(0.0, 0.0), direction(35.0, 60.0),
                                         direction(70.0, 180.0)};
    for (std::size_t i = 0; i < incident.size(); ++i) {
        plumage::testing::ChiSquareOptions options;
        options.samples = 100000;
        options.quadrature_cells = 8;  // the R lobe is only 2θ_d ≈ 9° wide longitudinally
        options.tests_in_family = static_cast<int>(incident.size());
        options.stream = i;
        options.name = "huang2022";
        options.outside_density = [](const ScatterEvent& e) { return e.lobe == Huang2022Bsdf::kT; };
        const auto result = plumage::testing::chi_square_test(model, incident[i], 550.0, options);
        EXPECT_GT(result.p_value, result.threshold)
            << "wi " << incident[i].transpose() << ": " << result.summary();
    }
}

}  // namespace
}  // namespace plumage::analysis

namespace plumage::analysis {
namespace {

// The TRT lobe as the header defines it, written out without the model's quadrature:
// f_TRT = P_hit/π · R_m · E_q[T(ω_i·ω_m) T(ω_o·ω_m) 1(ω_o·ω_m > 0)], q(ω_m) ∝ ρ(φ_m)
// cos(φ_m − φ_i) over the visible arc times max(0, ω_i·ω_m) uniform in θ_m ∈ [−θ_d, θ_d].
// A composite midpoint rule with kPhi × kTheta = 10⁴ nodes; q's two factors are normalised
// by their own midpoint sums (q is a probability density, so the reference is a weighted
// mean). Also returns the efficiency E_q[T_i T_o 1] ∈ [0, 1].
struct TrtReference {
    double f_trt = 0.0;
    double efficiency = 0.0;
    double scale = 0.0;  // P_hit R_m / π: the lobe's value if every facet transmitted fully
};

TrtReference reference_trt(const Huang2022Bsdf& model, const Vec3d& wi_patch, const Vec3d& wo_patch,
                           double lambda, int k_phi = 200, int k_theta = 50) {
    const Huang2022Params& p = model.params();
    auto to_barbule = [&](const Vec3d& w) {
        return Vec3d(w.x() * std::cos(p.mu) - w.z() * std::sin(p.mu), w.y(),
                     w.x() * std::sin(p.mu) + w.z() * std::cos(p.mu));
    };
    const Vec3d wi = to_barbule(wi_patch), wo = to_barbule(wo_patch);
    const double phi_i = std::atan2(wi.x(), wi.z());
    auto point = [&](double phi) {
        const double s = std::sin(phi), c = std::cos(phi), q = std::sqrt(s * s + p.b * p.b * c * c);
        return Eigen::Vector2d(s / q, p.b * p.b * c / q);
    };
    const auto arc = model.visible_arc(wi_patch);
    double total_length = 0.0, visible = 0.0;
    const Eigen::Vector2d across(std::cos(phi_i), -std::sin(phi_i));
    for (const auto& [lo, hi] : arc) {
        total_length += hi - lo;
        visible += (point(hi) - point(lo)).dot(across);
    }
    TrtReference out;
    if (arc.empty() || !(visible > 0.0)) return out;
    const optics::FilmMedia film{1.0, optics::keratin()->index(lambda), optics::Complex(1.0)};
    auto transmittance = [&](double c) {
        return optics::airy_film_intensities_unpolarised(film, p.d_um, lambda, c).transmittance;
    };
    double sum = 0.0, weight_sum = 0.0;
    for (const auto& [lo, hi] : arc) {
        const int n = std::max(1, static_cast<int>(std::lround(k_phi * (hi - lo) / total_length)));
        for (int a = 0; a < n; ++a) {
            const double phi = lo + (a + 0.5) * (hi - lo) / n;
            const double s = std::sin(phi), c = std::cos(phi);
            const double rho = p.b * p.b / std::pow(s * s + p.b * p.b * c * c, 1.5);
            const double w_phi = rho * std::cos(phi - phi_i) * (hi - lo) / n;
            double inner = 0.0, inner_weight = 0.0;
            for (int t = 0; t < k_theta; ++t) {
                const double theta = -p.theta_d + (t + 0.5) * 2.0 * p.theta_d / k_theta;
                const Vec3d m(s * std::cos(theta), std::sin(theta), c * std::cos(theta));
                const double cos_i = wi.dot(m), cos_o = wo.dot(m);
                if (cos_i <= 0.0) continue;
                inner_weight += cos_i;
                if (cos_o > 0.0) inner += cos_i * transmittance(cos_i) * transmittance(cos_o);
            }
            if (inner_weight > 0.0) {
                sum += w_phi * inner / inner_weight;
                weight_sum += w_phi;
            }
        }
    }
    const double period = p.H * std::cos(phi_i + p.mu);
    const double p_hit = std::min(1.0, visible / period);
    const double r_m =
        optics::fresnel_intensities_unpolarised(1.0, optics::melanin()->index(lambda), 1.0)
            .reflectance;
    out.efficiency = sum / weight_sum;
    out.scale = p_hit * r_m / kPi;
    out.f_trt = out.scale * out.efficiency;
    return out;
}

// Views for the TRT checks: a coarse hemisphere grid, and views along the barbule axis (patch
// ±y, where every facet is seen nearly edge-on and 1(ω_o·ω_m > 0) cuts the θ_m support in two)
// and near grazing.
std::vector<Vec3d> trt_views() {
    std::vector<Vec3d> views;
    for (double theta : {0.0, 30.0, 60.0, 80.0, 88.0}) {
        for (double phi : {0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0})
            views.push_back(direction(theta, phi));
    }
    for (double theta : {70.0, 84.0, 87.0, 89.5}) {
        for (double phi : {88.0, 90.0, 92.0, 268.0, 270.0, 272.0})
            views.push_back(direction(theta, phi));
    }
    return views;
}

TEST(Huang2022, TrtLobeMatchesADenseReference) {
    const Huang2022Bsdf model({});
    const std::vector<Vec3d> views = trt_views();
    double worst = 0.0, worst_below_cut = 0.0;
    int compared = 0;
    for (const Vec3d& wi : {direction(10.0, 0.0), direction(40.0, 90.0), direction(60.0, 200.0),
                            direction(80.0, 270.0), direction(75.0, 30.0)}) {
        for (double lambda : {430.0, 550.0, 680.0}) {
            for (const Vec3d& wo : views) {
                std::array<double, 3> lobes{};
                model.eval(wi, wo, lambda, lobes);
                const TrtReference ref = reference_trt(model, wi, wo, lambda);
                const double error = std::abs(lobes[1] - ref.f_trt);
                // The cut: TRT at least 1 % of the lobe's scale P_hit R_m / π (every hit
                // facet transmitting fully in and out). Below it the lobe is a few tenths of
                // a percent of the BRDF at most; there the absolute error is held to the
                // quadrature's bound instead.
                if (ref.efficiency >= 0.01) {
                    worst = std::max(worst, error / ref.f_trt);
                    EXPECT_LE(error, 1e-3 * ref.f_trt)
                        << "wi " << wi.transpose() << " wo " << wo.transpose() << " lambda "
                        << lambda << ": model " << lobes[1] << " reference " << ref.f_trt;
                    ++compared;
                } else {
                    worst_below_cut = std::max(worst_below_cut, error / ref.scale);
                    EXPECT_LE(error, 1e-4 * ref.scale)
                        << "wi " << wi.transpose() << " wo " << wo.transpose();
                }
            }
        }
    }
    // The reference's own error, largest at grazing views along the barbule axis where the
    // TRT is smallest (the midpoint rule across the kink of T_o): refined 8×, it moves by
    // 5.5e-4 at most, inside the 1e-3 tolerance, and the model agrees with the refined one
    // to 1e-4 (measured: ≤ 4e-5, against up to 4e-4 for the 10⁴-node reference).
    double reference_change = 0.0;
    for (const Vec3d& wo : {direction(89.5, 90.0), direction(89.5, 92.0), direction(87.0, 270.0)}) {
        for (const Vec3d& wi : {direction(75.0, 30.0), direction(10.0, 0.0)}) {
            const TrtReference coarse = reference_trt(model, wi, wo, 430.0);
            const TrtReference fine = reference_trt(model, wi, wo, 430.0, 400, 200);
            reference_change =
                std::max(reference_change, std::abs(fine.f_trt - coarse.f_trt) / fine.f_trt);
            std::array<double, 3> lobes{};
            model.eval(wi, wo, 430.0, lobes);
            EXPECT_LE(std::abs(lobes[1] - fine.f_trt), 1e-4 * fine.f_trt);
        }
    }
    EXPECT_LT(reference_change, 7e-4);
    RecordProperty("reference_change_when_refined", std::to_string(reference_change));
    RecordProperty("trt_max_relative_error", std::to_string(worst));
    RecordProperty("trt_max_error_below_cut_over_scale", std::to_string(worst_below_cut));
    std::printf(
        "TRT max relative error %.3g over %d pairs; below the cut %.3g of the scale; the "
        "reference moves by %.3g when refined\n",
        worst, compared, worst_below_cut, reference_change);
    EXPECT_GT(compared, 500);
}

// The wavelengths (nm) near 400–700 nm at which the rock-dove film's resonance sits at grazing
// incidence, sin(k₀ d q(0)) = 0 with q(0) = √(n² − 1): there T → 1 as cos θ → 0 instead of
// → 0, the hardest case for a table. By bisection on k₀ d q(0) = mπ.
std::vector<double> grazing_resonance_wavelengths(const Huang2022Params& p) {
    auto phase = [&](double lambda) {
        const double n = optics::keratin()->index(lambda).real();
        return 2.0 * kPi * p.d_um * 1000.0 / lambda * std::sqrt(n * n - 1.0);
    };
    std::vector<double> out;
    for (int m = 1; m <= 8; ++m) {
        double a = 380.0, b = 780.0;  // phase decreases with λ
        if ((phase(a) - m * kPi) * (phase(b) - m * kPi) > 0.0) continue;
        for (int it = 0; it < 100; ++it) {
            const double mid = 0.5 * (a + b);
            (phase(mid) > m * kPi ? a : b) = mid;
        }
        out.push_back(0.5 * (a + b));
    }
    return out;
}

TEST(Huang2022, FilmTableMatchesDirectAiry) {
    // The table eval()'s TRT quadrature reads T(cos θ) from, against the Airy sum at 10⁵ random
    // cos θ and down to cos θ = 1e-12 (log-spaced), at 400–700 nm and at the wavelengths whose
    // resonance sits at grazing. The table meets a relative 2.5e-7 at its own check points
    // (interval midpoints); the bound claimed anywhere is twice that (FilmTransmittanceTable in
    // huang2022.cpp).
    const Huang2022Bsdf model({});
    std::vector<double> wavelengths = {400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0};
    const std::vector<double> resonances = grazing_resonance_wavelengths(model.params());
    ASSERT_GE(resonances.size(), 2U);
    wavelengths.insert(wavelengths.end(), resonances.begin(), resonances.end());
    Rng rng(derive_seed(kDefaultSeed, "huang film table"), 0);
    double worst = 0.0, worst_grazing = 0.0;
    for (double lambda : wavelengths) {
        const optics::FilmMedia film{1.0, optics::keratin()->index(lambda), optics::Complex(1.0)};
        auto check = [&](double c, double& into) {
            const double exact =
                optics::airy_film_intensities_unpolarised(film, model.params().d_um, lambda, c)
                    .transmittance;
            const double table = model.tabulated_film_transmittance(c, lambda);
            const double error = std::abs(table - exact) / exact;
            into = std::max(into, error);
            EXPECT_LE(error, 5e-7)
                << "lambda " << lambda << " cos " << c << ": table " << table << " Airy " << exact;
        };
        for (int k = 0; k < 10000; ++k) check(rng.uniform(), worst);
        for (int k = 0; k <= 1100; ++k)
            check(std::pow(10.0, -12.0 + 11.1 * k / 1100.0), worst_grazing);
    }
    RecordProperty("film_table_max_relative_error", std::to_string(worst));
    RecordProperty("film_table_max_relative_error_grazing", std::to_string(worst_grazing));
    std::printf("film table: max relative error %.3g (random c), %.3g (c from 1e-12 to 0.125)\n",
                worst, worst_grazing);
}

TEST(Huang2022, EvalMatchesTheDirectFilmReference) {
    // eval() (film tables, per-ω_i and per-λ caches) against the same quadrature with every
    // film factor by direct Airy evaluation and no cache (eval_reference, refine 1: the model
    // as it was before the tables reached grazing facets), on a grid of directions including
    // grazing views along the barbule axis, at 400–700 nm and the grazing resonances. Bound:
    // TRT within 1e-6 relative (two film factors per node, each ≤ 5e-7), R identical.
    const Huang2022Bsdf model({});
    const std::vector<Vec3d> views = trt_views();
    std::vector<double> wavelengths = {400.0, 550.0, 700.0};
    for (double r : grazing_resonance_wavelengths(model.params())) wavelengths.push_back(r);
    double worst = 0.0;
    int compared = 0;
    for (const Vec3d& wi : {direction(10.0, 0.0), direction(40.0, 90.0), direction(80.0, 270.0),
                            direction(75.0, 30.0), direction(89.0, 180.0)}) {
        for (double lambda : wavelengths) {
            for (const Vec3d& wo : views) {
                std::array<double, 3> lobes{}, ref{};
                model.eval(wi, wo, lambda, lobes);
                model.eval_reference(wi, wo, lambda, 1, ref);
                EXPECT_EQ(lobes[0], ref[0]) << "R lobe, wi " << wi.transpose();
                const double error = std::abs(lobes[1] - ref[1]);
                if (ref[1] > 0.0) worst = std::max(worst, error / ref[1]);
                EXPECT_LE(error, 1e-6 * ref[1])
                    << "wi " << wi.transpose() << " wo " << wo.transpose() << " lambda " << lambda;
                compared += ref[1] > 0.0;
            }
        }
    }
    RecordProperty("trt_max_relative_change", std::to_string(worst));
    std::printf("eval against direct film: TRT max relative difference %.3g over %d values\n",
                worst, compared);
    EXPECT_GT(compared, 500);
}

TEST(Huang2022, OnceAskedAndStoredTrtNodesGiveTheSameBits) {
    // A frame evaluated once builds TRT's nodes only on the pieces that ω_o lights, and never
    // stores them; a frame asked again stores them all (eval()). Both must give the same values
    // to the bit, or results would depend on the order of the calls (and on the thread count
    // that splits a sweep). Random pairs over the hemisphere at 400–700 nm and the grazing
    // resonances (where the terminator's piece is graded).
    const Huang2022Bsdf model({});
    std::vector<double> wavelengths = {400.0, 550.0, 700.0};
    for (double r : grazing_resonance_wavelengths(model.params())) wavelengths.push_back(r);
    Rng rng(derive_seed(kDefaultSeed, "huang fresh and stored nodes"), 0);
    auto hemisphere = [&] {
        const double z = rng.uniform(), phi = 2.0 * kPi * rng.uniform();
        const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
        return Vec3d(s * std::cos(phi), s * std::sin(phi), z);
    };
    int nonzero = 0;
    for (int i = 0; i < 3000; ++i) {
        const Vec3d wi = hemisphere(), wo = hemisphere();
        if (!(wi.z() > 1e-9)) continue;
        const double lambda = wavelengths[static_cast<std::size_t>(i) % wavelengths.size()];
        std::array<double, 3> once{}, stored{};
        model.eval(wi, wo, lambda, once);    // a new ω_i: fresh nodes
        model.eval(wi, wo, lambda, stored);  // asked again: stored nodes
        EXPECT_EQ(once[0], stored[0]) << "R, wi " << wi.transpose() << " wo " << wo.transpose();
        EXPECT_EQ(once[1], stored[1]) << "TRT, wi " << wi.transpose() << " wo " << wo.transpose();
        nonzero += once[1] > 0.0;
    }
    EXPECT_GT(nonzero, 1000);
}

TEST(Huang2022, PointTableOnTheFilipSetIsConvergedTo1e4) {
    // Issue 15's "Huang model tabulated on the 3660-pair set, exact to 1e-4": the table's cells
    // are the model's values f(ω_i, ω_o, λ) at the pairs (eval(), as plumage.models and the fits
    // use it; the goniometer's eval estimator averages them over its detector cone by its own
    // cubature, whose error the record carries). Against a converged reference: the same model
    // with every film factor by direct Airy evaluation and TRT's φ_m pieces and θ_m panels 4×
    // finer (eval_reference, refine 4; composite Gauss–Legendre of an integrand that is C¹ at
    // worst, so its error falls ≥ 64×), on every 15th pair at the default study's 7
    // wavelengths. The reference's own change from refine 4 to 8 is checked on a few pairs.
    //
    // Near a wavelength whose film resonance sits at grazing (grazing_resonance_wavelengths:
    // ≈ 471 and 694 nm) T(c) steps from 0 to ≈ 1 over a small c and the model grades its rule
    // (steep_at_grazing in huang2022.cpp; without it the error there reached 1.2e-2): checked
    // at the resonances and 2 nm either side on every 61st pair, bound 3e-4. A 2 nm scan of
    // 440–720 nm on those pairs: ≤ 7.6e-5 but at 694 nm, 2.1e-4.
    const Huang2022Bsdf model({});
    std::vector<double> near_resonance;
    for (double r : grazing_resonance_wavelengths(model.params())) {
        if (r > 400.0 && r < 700.0)
            near_resonance.insert(near_resonance.end(), {r - 2.0, r, r + 2.0});
    }
    ASSERT_EQ(near_resonance.size(), 6U);
    const std::vector<gonio::DirectionPair> pairs = gonio::filip2024_btf_pairs();
    ASSERT_EQ(pairs.size(), 3660U);
    const std::array<double, 7> wavelengths = {400, 450, 500, 550, 600, 650, 700};
    double worst = 0.0, worst_near = 0.0, worst_trt = 0.0, reference_change = 0.0;
    int compared = 0;
    auto compare = [&](std::size_t p, double lambda, double bound, double& into) {
        std::array<double, 3> lobes{}, ref{};
        const double value = model.eval(pairs[p].wi, pairs[p].wo, lambda, lobes);
        const double reference = model.eval_reference(pairs[p].wi, pairs[p].wo, lambda, 4, ref);
        if (!(reference > 0.0)) {
            EXPECT_EQ(value, 0.0);
            return;
        }
        const double error = std::abs(value - reference) / reference;
        into = std::max(into, error);
        if (ref[1] > 0.0) worst_trt = std::max(worst_trt, std::abs(lobes[1] - ref[1]) / ref[1]);
        EXPECT_LE(error, bound) << "pair " << p << " lambda " << lambda << ": " << value
                                << " against " << reference;
        ++compared;
        if (p % 600 == 0 && (lambda == 400.0 || lambda == near_resonance[4])) {
            const double finer = model.eval_reference(pairs[p].wi, pairs[p].wo, lambda, 8);
            reference_change = std::max(reference_change, std::abs(finer - reference) / finer);
        }
    };
    for (std::size_t p = 0; p < pairs.size(); p += 15) {
        for (double lambda : wavelengths) compare(p, lambda, 1e-4, worst);
    }
    for (std::size_t p = 0; p < pairs.size(); p += 61) {
        for (double lambda : near_resonance) compare(p, lambda, 3e-4, worst_near);
    }
    EXPECT_LT(reference_change, 1e-5);
    RecordProperty("point_table_max_relative_error", std::to_string(worst));
    RecordProperty("point_table_max_relative_error_near_resonance", std::to_string(worst_near));
    std::printf(
        "point table: max relative error %.3g over the set's cells, %.3g within 2 nm of a "
        "grazing resonance (%d cells in all; TRT lobe alone %.3g); the reference moves by %.3g "
        "from refine 4 to 8\n",
        worst, worst_near, compared, worst_trt, reference_change);
    EXPECT_GT(compared, 1000);
}

}  // namespace
}  // namespace plumage::analysis
