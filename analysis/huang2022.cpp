#include "analysis/huang2022.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <deque>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <string_view>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/require.h"
#include "sim/optics/material.h"
#include "sim/optics/thin_film.h"

namespace plumage::analysis {
namespace {

// The name that prefixes this file's input errors.
constexpr std::string_view kWhat = "huang2022";

// Gauss–Legendre nodes and weights on [−1, 1].
constexpr std::array<double, 8> kGl8Nodes = {
    -0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
    0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
constexpr std::array<double, 8> kGl8Weights = {
    0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
    0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};

// Gauss–Kronrod pairs on [−1, 1] (QUADPACK qk15 and the 7-point extension of Gauss 3):
// nodes x_k ≥ 0 in decreasing order, the last one 0; the embedded Gauss nodes are the odd
// entries x_1, x_3, ... with weights wg.
struct GaussKronrod {
    std::span<const double> xk, wk, wg;
};
constexpr std::array<double, 8> kK15Nodes = {
    0.991455371120812639, 0.949107912342758525, 0.864864423359769073, 0.741531185599394440,
    0.586087235467691130, 0.405845151377397167, 0.207784955007898468, 0.0};
constexpr std::array<double, 8> kK15Weights = {
    0.022935322010529225, 0.063092092629978553, 0.104790010322250184, 0.140653259715525919,
    0.169004726639267903, 0.190350578064785410, 0.204432940075298892, 0.209482141084727828};
constexpr std::array<double, 4> kG7Weights = {0.129484966168869693, 0.279705391489276668,
                                              0.381830050505118945, 0.417959183673469388};
constexpr std::array<double, 4> kK7Nodes = {0.960491268708020283, 0.774596669241483377,
                                            0.434243749346802558, 0.0};
constexpr std::array<double, 4> kK7Weights = {0.104656226026467265, 0.268488089868333441,
                                              0.401397414775962223, 0.450916538658474142};
constexpr std::array<double, 2> kG3Weights = {0.555555555555555556, 0.888888888888888889};
constexpr GaussKronrod kGk15{kK15Nodes, kK15Weights, kG7Weights};
constexpr std::size_t kPhiNodesPerPiece = 2 * kK15Nodes.size() - 1;  // TRT's base rule
constexpr GaussKronrod kGk7{kK7Nodes, kK7Weights, kG3Weights};

// ∫_a^b g by the Kronrod rule, bisecting until |Kronrod − Gauss| ≤ tol on every panel (the
// tolerance is shared between the halves in proportion to their length), or until depth
// runs out: then the panel's Kronrod value is kept as it is.
template <typename G>
double adaptive_gauss_kronrod(const G& g, const GaussKronrod& rule, double a, double b, double tol,
                              double rel, int depth) {
    const double centre = 0.5 * (a + b), half = 0.5 * (b - a);
    const std::size_t n = rule.xk.size();
    // Both rules have an even number of entries: the centre (index n − 1) is a Gauss node.
    const double g_centre = g(centre);
    double kronrod = rule.wk[n - 1] * g_centre;
    double gauss = rule.wg[rule.wg.size() - 1] * g_centre;
    for (std::size_t k = 0; k + 1 < n; ++k) {
        const double pair = g(centre - half * rule.xk[k]) + g(centre + half * rule.xk[k]);
        kronrod += rule.wk[k] * pair;
        if (k % 2 == 1) gauss += rule.wg[k / 2] * pair;
    }
    kronrod *= half;
    gauss *= half;
    if (std::abs(kronrod - gauss) <= std::max(tol, rel * std::abs(kronrod)) || depth <= 0)
        return kronrod;
    return adaptive_gauss_kronrod(g, rule, a, centre, 0.5 * tol, rel, depth - 1) +
           adaptive_gauss_kronrod(g, rule, centre, b, 0.5 * tol, rel, depth - 1);
}

// The keratin film's unpolarised transmittance T(c), c = cos θ, at one wavelength, for
// the TRT quadrature, which asks for it at a few hundred facet normals per eval() (the
// Airy sum was 80 % of eval's time). Uniform in c on [kMinCos, 1], cubic (4-point
// Lagrange) interpolation; the node count doubles from 129 until the largest
// |interpolated − exact| at the interval midpoints is ≤ kTolerance (the cubic's error
// peaks near the midpoints, and T's fourth derivative changes little within an interval
// once that holds). Below kMinCos the film's finesse grows without bound as c → 0
// (sim/film_table.h): those facets, seen nearly edge-on, are evaluated directly.
class FilmTransmittanceTable {
public:
    static constexpr double kMinCos = 0.125;
    static constexpr double kTolerance = 1e-9;  // absolute, T ∈ [0, 1]

    template <typename Exact>
    explicit FilmTransmittanceTable(const Exact& exact) {
        for (int nodes = 129;; nodes = 2 * nodes - 1) {
            scale_ = (nodes - 1) / (1.0 - kMinCos);
            values_.resize(static_cast<std::size_t>(nodes));
            for (int k = 0; k < nodes; ++k) values_[k] = exact(kMinCos + k / scale_);
            double worst = 0.0;
            for (int k = 0; k + 1 < nodes; ++k) {
                const double c = kMinCos + (k + 0.5) / scale_;
                worst = std::max(worst, std::abs((*this)(c)-exact(c)));
            }
            if (worst <= kTolerance || nodes >= 8193) break;
        }
    }
    // c in [kMinCos, 1].
    double operator()(double c) const {
        const int last = static_cast<int>(values_.size()) - 1;
        const double x = (c - kMinCos) * scale_;
        const int k = std::clamp(static_cast<int>(x), 1, last - 2);  // nodes k−1 … k+2
        const double t = x - k;
        const double* v = values_.data() + k - 1;
        // Lagrange weights at t for nodes −1, 0, 1, 2.
        const double w0 = -t * (t - 1.0) * (t - 2.0) / 6.0,
                     w1 = (t + 1.0) * (t - 1.0) * (t - 2.0) / 2.0,
                     w2 = -(t + 1.0) * t * (t - 2.0) / 2.0, w3 = (t + 1.0) * t * (t - 1.0) / 6.0;
        return w0 * v[0] + w1 * v[1] + w2 * v[2] + w3 * v[3];
    }

private:
    std::vector<double> values_;
    double scale_ = 0.0;
};

// The table for (model, wavelength), kept per thread: the instruments and fits ask for a
// handful of wavelengths, many times each. Always built on first use, never bypassed, so
// that a value does not depend on which thread asked first (records and fits are
// bit-identical across thread counts). A deque, so that a reference handed out stays
// valid while entries are added; up to kMaxTables wavelengths (a caller drawing
// wavelengths at random pays ~0.1 ms per new one).
template <typename Exact>
const FilmTransmittanceTable& transmittance_table(const void* owner, std::uint64_t generation,
                                                  double lambda_nm, const Exact& exact) {
    struct Entry {
        const void* owner;
        std::uint64_t generation;
        double lambda_nm;
        FilmTransmittanceTable table;
    };
    constexpr std::size_t kMaxTables = 1024;  // ~8 kB each for the rock-dove film
    thread_local std::deque<Entry> cache;
    for (const Entry& e : cache) {
        if (e.owner == owner && e.generation == generation && e.lambda_nm == lambda_nm)
            return e.table;
    }
    if (cache.size() >= kMaxTables) cache.clear();
    cache.push_back({owner, generation, lambda_nm, FilmTransmittanceTable(exact)});
    return cache.back().table;
}

}  // namespace

// Unit ellipse of the model (semi-major 1 along x, semi-minor b along z), written
// independently of geometry/ so that simulation against model is a real comparison.
struct Huang2022Bsdf::Frame {
    Vec3d wi;            // barbule frame
    double phi_i = 0.0;  // azimuth of ω_i's projection on the x–z plane
    double cos_theta_i = 0.0, sin_theta_i = 0.0;
    double period = 0.0;                           // Δh = H cos(φ_i + μ)
    std::vector<std::array<double, 2>> intervals;  // visible, front-facing φ_m ranges
    std::vector<double> h_cumulative;              // projected visible length up to interval k
    double visible_length = 0.0;                   // front-facing visible part of Δh'
    double t_mass = 1.0;                           // 1 − min(W, Δh)/Δh (Eq. 15)
    // Quadrature of the hit-normal density q (weights sum to 1), built once per ω_i.
    std::vector<std::pair<Vec3d, double>> nodes;
    // Per node, for the wavelength last asked: T(ω_i·ω_m) R_m and I_R(ω_i·ω_m).
    mutable double nodes_lambda = -1.0;
    mutable std::vector<double> node_trt_in, node_r;
    // TRT's base rule (eval), built once per ω_i: the visible arc in pieces of at most
    // 1 rad, 15 Kronrod φ_m nodes each (7 of them Gauss), and 7 Kronrod θ_m nodes (3 of
    // them Gauss) over each node's θ support. Weights include q's densities; T(ω_i·ω_m)
    // at the θ nodes is kept for the wavelength last asked.
    struct TrtPiece {
        double a, c, mass;  // φ range and its q-mass
        std::size_t first;  // first of its kGk15 φ nodes in trt_phi
    };
    struct TrtPhiNode {
        double phi, wk, wg;        // outer weights: Kronrod, Gauss (0 off the Gauss nodes)
        Vec3d m_lo, m_hi;          // the facet normals at the ends of its θ support
        std::size_t first, count;  // its θ nodes in trt_m (count 0: empty support)
    };
    std::vector<TrtPiece> trt_pieces;
    std::vector<TrtPhiNode> trt_phi;
    std::vector<Vec3d> trt_m;
    std::vector<double> trt_wk, trt_wg;
    mutable double trt_lambda = -1.0;
    mutable std::vector<double> trt_t_in;
    // Fraction of the incident light that hits the front (film side) of a barbule.
    double hit_fraction() const {
        return period > 0.0 ? std::min(1.0, visible_length / period) : 0.0;
    }
};

Huang2022Bsdf::Huang2022Bsdf(const Huang2022Params& p)
    : params_(p), keratin_(optics::keratin()), melanin_(optics::melanin()) {
    require(std::isfinite(p.b) && p.b >= 1e-3 && p.b <= 1.0, kWhat, "b", p.b,
            "a value in [1e-3, 1]");
    require(std::isfinite(p.phi0) && std::isfinite(p.phi1) && p.phi1 > p.phi0 &&
                p.phi1 - p.phi0 <= 2.0 * kPi,
            kWhat, "phi1 - phi0", p.phi1 - p.phi0, "an arc with phi0 < phi1 <= phi0 + 2 pi (rad)");
    require(std::isfinite(p.H) && p.H > 0.0, kWhat, "H", p.H, "a spacing > 0 (in semi-major axes)");
    require(std::isfinite(p.d_um) && p.d_um >= 0.0 && p.d_um <= 50.0, kWhat, "d", p.d_um,
            "a film thickness in [0, 50] um");
    require(std::isfinite(p.theta_d) && p.theta_d > 0.0 && p.theta_d <= 0.25 * kPi, kWhat,
            "theta_d", p.theta_d, "a half-opening in (0, pi/4] rad");
    require(std::isfinite(p.mu) && std::abs(p.mu) < 0.5 * kPi, kWhat, "mu", p.mu,
            "a tilt in (-pi/2, pi/2) rad");
    static std::atomic<std::uint64_t> counter{0};
    generation_ = ++counter;
}

const std::vector<std::string>& Huang2022Bsdf::lobe_names() const {
    static const std::vector<std::string> names = {"R", "TRT", "T"};
    return names;
}

namespace {

struct Ellipse {
    double b;
    double rho(double phi) const {
        const double s = std::sin(phi), c = std::cos(phi);
        return b * b / std::pow(s * s + b * b * c * c, 1.5);
    }
    std::array<double, 2> point(double phi) const {
        const double s = std::sin(phi), c = std::cos(phi);
        const double q = std::sqrt(s * s + b * b * c * c);
        return {s / q, b * b * c / q};
    }
};

Vec3d to_barbule(const Vec3d& w, double mu) {
    const double c = std::cos(mu), s = std::sin(mu);
    return {w.x() * c - w.z() * s, w.y(), w.x() * s + w.z() * c};
}

Vec3d to_patch(const Vec3d& w, double mu) {
    const double c = std::cos(mu), s = std::sin(mu);
    return {w.x() * c + w.z() * s, w.y(), -w.x() * s + w.z() * c};
}

double wrap_into(double phi, double phi0) {
    // φ shifted by whole turns into [phi0, phi0 + 2π).
    return phi - 2.0 * kPi * std::floor((phi - phi0) / (2.0 * kPi));
}

}  // namespace

namespace {

// Conditional density of θ_m given φ_m: ∝ max(0, a cos θ + b sin θ) on [−θ_d, θ_d], with
// a = cos θ_i cos(φ_m − φ_i), b = sin θ_i. Returns the support and normaliser.
struct ThetaDensity {
    double delta, amplitude, lo, hi, norm;
    bool empty() const { return !(norm > 0.0); }
    double density(double theta) const {
        if (theta < lo || theta > hi || empty()) return 0.0;
        return std::max(0.0, amplitude * std::cos(theta - delta)) / norm;
    }
    double sample(double u) const {
        const double s0 = std::sin(lo - delta), s1 = std::sin(hi - delta);
        return delta + std::asin(std::clamp(s0 + u * (s1 - s0), -1.0, 1.0));
    }
};

ThetaDensity theta_density(double a, double b, double theta_d) {
    ThetaDensity t{};
    t.amplitude = std::hypot(a, b);
    t.delta = std::atan2(b, a);
    t.lo = std::max(-theta_d, t.delta - 0.5 * kPi);
    t.hi = std::min(theta_d, t.delta + 0.5 * kPi);
    t.norm =
        t.hi > t.lo ? t.amplitude * (std::sin(t.hi - t.delta) - std::sin(t.lo - t.delta)) : 0.0;
    return t;
}

Vec3d normal_at(double phi, double theta) {
    return {std::sin(phi) * std::cos(theta), std::sin(theta), std::cos(phi) * std::cos(theta)};
}

}  // namespace

bool Huang2022Bsdf::visible(double phi_m, double dir_x, double dir_z) const {
    const double len = std::hypot(dir_x, dir_z);
    if (len < 1e-12) return true;  // looking along the barbules: nothing in the way
    const double dx = dir_x / len, dz = dir_z / len;
    const Ellipse e{params_.b};
    const auto p = e.point(phi_m);
    const double ux = std::cos(params_.mu), uz = std::sin(params_.mu);
    // Copies further than 1 (the semi-major axis) from the ray cannot be hit; their
    // distance to the ray line grows by H |sin α| per copy.
    const double sin_alpha = std::abs(ux * dz - uz * dx);
    // At most 1000 copies each way; the bound is taken in double before the cast, since for
    // nearly parallel rays the quotient exceeds the range of int (found by UBSan in the
    // extremes study: the cast was undefined and, on x86, left no copy checked at all).
    const int reach =
        sin_alpha * params_.H > 1e-9
            ? static_cast<int>(std::min(
                  1000.0, std::ceil((2.0 + 2.0 * params_.H) / (params_.H * sin_alpha)) + 1.0))
            : 1000;
    const double b2 = params_.b * params_.b;
    for (int k = -reach; k <= reach; ++k) {
        if (k == 0) continue;
        const double cx = k * params_.H * ux, cz = k * params_.H * uz;
        // Ray p + t d against the ellipse (x − cx)² + (z − cz)²/b² = 1.
        const double ox = p[0] - cx, oz = p[1] - cz;
        const double qa = dx * dx + dz * dz / b2;
        const double qb = 2.0 * (ox * dx + oz * dz / b2);
        const double qc = ox * ox + oz * oz / b2 - 1.0;
        const double disc = qb * qb - 4.0 * qa * qc;
        if (disc < 0.0) continue;
        const double sq = std::sqrt(disc);
        for (double t : {(-qb - sq) / (2.0 * qa), (-qb + sq) / (2.0 * qa)}) {
            if (t <= 1e-12) continue;
            const double hx = ox + t * dx, hz = oz + t * dz;
            const double phi_hit = wrap_into(std::atan2(hx, hz / b2), params_.phi0);
            if (phi_hit <= params_.phi1) return false;
        }
    }
    return true;
}

Huang2022Bsdf::Frame Huang2022Bsdf::compute_frame(const Vec3d& wi_patch) const {
    if (!(wi_patch.z() > 0.0) || std::abs(wi_patch.norm() - 1.0) > 1e-6) {
        throw InputError(fmt::format(
            "huang2022: incident direction ({}, {}, {}) must be a unit vector above the barb "
            "plane (z > 0): the barbule BSDF is lit from above",
            wi_patch.x(), wi_patch.y(), wi_patch.z()));
    }
    Frame f;
    f.wi = to_barbule(wi_patch, params_.mu);
    f.cos_theta_i = std::hypot(f.wi.x(), f.wi.z());
    f.sin_theta_i = f.wi.y();
    f.phi_i = std::atan2(f.wi.x(), f.wi.z());
    f.period = params_.H * std::cos(f.phi_i + params_.mu);
    if (f.cos_theta_i < 1e-12) return f;  // along the barbules: everything passes

    const Ellipse e{params_.b};
    // Front-facing part of the arc: cos(φ_m − φ_i) > 0, i.e. φ_m ∈ (φ_i − π/2, φ_i + π/2)
    // (mod 2π), intersected with [φ0, φ1]; then split where the neighbours occlude.
    std::vector<std::array<double, 2>> front;
    for (int k = -2; k <= 2; ++k) {
        const double lo = std::max(params_.phi0, f.phi_i - 0.5 * kPi + 2.0 * kPi * k);
        const double hi = std::min(params_.phi1, f.phi_i + 0.5 * kPi + 2.0 * kPi * k);
        if (hi > lo) front.push_back({lo, hi});
    }
    const double dx = f.wi.x(), dz = f.wi.z();
    for (const auto& [lo, hi] : front) {
        constexpr int kScan = 192;
        double start = lo;
        bool inside = visible(lo + 1e-12 * (hi - lo), dx, dz);
        double previous = lo;
        for (int s = 1; s <= kScan; ++s) {
            const double phi = lo + (hi - lo) * s / kScan;
            const bool v = visible(std::min(phi, hi - 1e-12 * (hi - lo)), dx, dz);
            if (v != inside) {
                double a = previous, c = phi;  // refine the transition by bisection
                for (int it = 0; it < 50; ++it) {
                    const double mid = 0.5 * (a + c);
                    (visible(mid, dx, dz) == inside ? a : c) = mid;
                }
                const double edge = 0.5 * (a + c);
                if (inside) f.intervals.push_back({start, edge});
                start = edge;
                inside = v;
            }
            previous = phi;
        }
        if (inside) f.intervals.push_back({start, hi});
    }
    // Projected (h) length of each visible interval: h(φ) = E(φ)·p, p = (cos φ_i, −sin φ_i),
    // monotone on the front-facing arc with dh/dφ = ρ(φ) cos(φ − φ_i).
    const double px = std::cos(f.phi_i), pz = -std::sin(f.phi_i);
    f.h_cumulative.push_back(0.0);
    for (const auto& [lo, hi] : f.intervals) {
        const auto a = e.point(lo), c = e.point(hi);
        f.visible_length += (c[0] - a[0]) * px + (c[1] - a[1]) * pz;
        f.h_cumulative.push_back(f.visible_length);
    }
    // Eq. 15: the width of the arc's shadow across the direction, W, is reached at the
    // ends or where the normal is perpendicular to the direction; translated copies
    // every Δh cover min(W, Δh) of each period. Rays in that cover but not on a
    // front-facing visible point reach the concave underside of an arc: the model has
    // no lobe for them (they are absorbed, see back_hit_fraction()).
    auto h = [&](double phi) {
        const auto q = e.point(phi);
        return q[0] * px + q[1] * pz;
    };
    double lo = std::min(h(params_.phi0), h(params_.phi1)),
           hi = std::max(h(params_.phi0), h(params_.phi1));
    for (int k = -3; k <= 3; ++k) {
        for (double c : {f.phi_i + 0.5 * kPi, f.phi_i - 0.5 * kPi}) {
            const double phi = c + 2.0 * kPi * k;
            if (phi > params_.phi0 && phi < params_.phi1)
                lo = std::min(lo, h(phi)), hi = std::max(hi, h(phi));
        }
    }
    f.t_mass = 1.0 - std::min(hi - lo, f.period) / f.period;
    build_nodes(f);
    build_trt_nodes(f);
    return f;
}

const Huang2022Bsdf::Frame& Huang2022Bsdf::frame_for(const Vec3d& wi_patch) const {
    // Instruments ask many questions for one incident direction: keep the last frame
    // per thread (the visibility intervals cost a few thousand ray–ellipse tests).
    struct Cache {
        const Huang2022Bsdf* owner = nullptr;
        std::uint64_t generation = 0;
        Vec3d wi = Vec3d::Zero();
        Frame frame;
    };
    thread_local Cache cache;
    if (cache.owner != this || cache.generation != generation_ || cache.wi != wi_patch) {
        cache.frame = compute_frame(wi_patch);
        cache.owner = this;
        cache.generation = generation_;
        cache.wi = wi_patch;
    }
    return cache.frame;
}

double Huang2022Bsdf::film_reflectance(double cos_theta, double lambda_nm) const {
    const optics::FilmMedia media{1.0, keratin_->index(lambda_nm), optics::Complex(1.0)};
    return optics::airy_film_intensities_unpolarised(media, params_.d_um, lambda_nm,
                                                     std::clamp(cos_theta, 0.0, 1.0))
        .reflectance;
}

double Huang2022Bsdf::film_transmittance(double cos_theta, double lambda_nm) const {
    const optics::FilmMedia media{1.0, keratin_->index(lambda_nm), optics::Complex(1.0)};
    return optics::airy_film_intensities_unpolarised(media, params_.d_um, lambda_nm,
                                                     std::clamp(cos_theta, 0.0, 1.0))
        .transmittance;
}

double Huang2022Bsdf::melanin_reflectance(double lambda_nm) const {
    return optics::fresnel_intensities_unpolarised(1.0, melanin_->index(lambda_nm), 1.0)
        .reflectance;
}

double Huang2022Bsdf::ndf(double phi_m, double theta_m) const {
    const double phi = wrap_into(phi_m, params_.phi0);
    if (phi > params_.phi1 || std::abs(theta_m) > params_.theta_d) return 0.0;
    const double b = params_.b, s = std::sin(phi), c = std::cos(phi);
    return b * b / (2.0 * params_.H * std::sin(params_.theta_d) * std::cos(theta_m)) *
           std::pow(s * s + b * b * c * c, -1.5);
}

double Huang2022Bsdf::t_lobe_mass(const Vec3d& wi) const { return frame_for(wi).t_mass; }

double Huang2022Bsdf::back_hit_fraction(const Vec3d& wi) const {
    const Frame& f = frame_for(wi);
    return std::max(0.0, 1.0 - f.t_mass - f.hit_fraction());
}

double Huang2022Bsdf::hit_fraction_closed_form(const Vec3d& wi) const {
    return 1.0 - frame_for(wi).t_mass;
}

std::vector<std::array<double, 2>> Huang2022Bsdf::visible_arc(const Vec3d& wi) const {
    return frame_for(wi).intervals;
}

double Huang2022Bsdf::hit_fraction_by_quadrature(const Vec3d& wi) const {
    // ∫ D ⟨ω_i, ω_m⟩ G_1 dω_m / ⟨ω_i, n⟩ with D of Eq. 7 and G_1 from frame_for's intervals.
    const Frame& f = frame_for(wi);
    double sum = 0.0;
    for (const auto& [lo, hi] : f.intervals) {
        constexpr int kPieces = 16;
        for (int piece = 0; piece < kPieces; ++piece) {
            const double a = lo + (hi - lo) * piece / kPieces,
                         c = lo + (hi - lo) * (piece + 1) / kPieces;
            for (std::size_t i = 0; i < kGl8Nodes.size(); ++i) {
                const double phi = 0.5 * (a + c) + 0.5 * (c - a) * kGl8Nodes[i];
                for (std::size_t j = 0; j < kGl8Nodes.size(); ++j) {
                    const double theta = params_.theta_d * kGl8Nodes[j];
                    const Vec3d m = normal_at(phi, theta);
                    // dω = cos θ dθ dφ
                    // Signed ⟨ω_i, ω_m⟩: over a front-facing φ_m strip the longitudinal
                    // terms cancel (the projection theorem). Clipping them at 0 would count
                    // light twice near the silhouette and exceed 1 by up to 3 % at grazing
                    // incidence: Eq. 7 with a 2D visibility is exactly normalised only so.
                    sum += 0.5 * (c - a) * kGl8Weights[i] * params_.theta_d * kGl8Weights[j] *
                           ndf(phi, theta) * f.wi.dot(m) * std::cos(theta);
                }
            }
        }
    }
    return sum / wi.z();
}

double Huang2022Bsdf::ndf_projected_integral() const {
    const Vec3d n(-std::sin(params_.mu), 0.0, std::cos(params_.mu));
    double sum = 0.0;
    constexpr int kPieces = 64;
    for (int piece = 0; piece < kPieces; ++piece) {
        const double a = params_.phi0 + (params_.phi1 - params_.phi0) * piece / kPieces;
        const double c = params_.phi0 + (params_.phi1 - params_.phi0) * (piece + 1) / kPieces;
        for (std::size_t i = 0; i < kGl8Nodes.size(); ++i) {
            const double phi = 0.5 * (a + c) + 0.5 * (c - a) * kGl8Nodes[i];
            for (std::size_t j = 0; j < kGl8Nodes.size(); ++j) {
                const double theta = params_.theta_d * kGl8Nodes[j];
                sum += 0.5 * (c - a) * kGl8Weights[i] * params_.theta_d * kGl8Weights[j] *
                       ndf(phi, theta) * normal_at(phi, theta).dot(n) * std::cos(theta);
            }
        }
    }
    return sum;
}

std::optional<ScatterEvent> Huang2022Bsdf::sample(const Vec3d& wi, double lambda_nm,
                                                  const Vec2& position_um, Rng& rng) const {
    const Frame& f = frame_for(wi);
    const double u_hit = rng.uniform();
    if (u_hit >= f.hit_fraction() || f.intervals.empty()) {
        // Passes between barbules (Eq. 15), or reaches an arc's underside, which the
        // model has no lobe for: absorbed.
        if (u_hit < f.hit_fraction() + f.t_mass) return ScatterEvent{-wi, 1.0, kT, position_um};
        return std::nullopt;
    }
    // φ_m: uniform in the projected visible length h, inverted interval by interval.
    const double target = rng.uniform() * f.visible_length;
    std::size_t k = 0;
    while (k + 1 < f.intervals.size() && f.h_cumulative[k + 1] < target) ++k;
    const Ellipse e{params_.b};
    const double px = std::cos(f.phi_i), pz = -std::sin(f.phi_i);
    auto h = [&](double phi) {
        const auto q = e.point(phi);
        return q[0] * px + q[1] * pz;
    };
    const auto [lo, hi] = f.intervals[k];
    const double goal = h(lo) + (target - f.h_cumulative[k]);
    double a = lo, c = hi;
    for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (a + c);
        (h(mid) < goal ? a : c) = mid;
    }
    const double phi_m = 0.5 * (a + c);
    const ThetaDensity td =
        theta_density(f.cos_theta_i * std::cos(phi_m - f.phi_i), f.sin_theta_i, params_.theta_d);
    if (td.empty()) return ScatterEvent{-wi, 0.0, kR, position_um};
    const double theta_m = td.sample(rng.uniform());
    const Vec3d m = normal_at(phi_m, theta_m);
    const double cos_i = f.wi.dot(m);

    const double i_r = film_reflectance(cos_i, lambda_nm);
    const double i_trt_in = film_transmittance(cos_i, lambda_nm) * melanin_reflectance(lambda_nm);
    const double total = i_r + i_trt_in;
    if (rng.uniform() * total < i_r) {
        const Vec3d wo_b = 2.0 * cos_i * m - f.wi;
        const bool seen = visible(phi_m, wo_b.x(), wo_b.z());
        return ScatterEvent{to_patch(wo_b, params_.mu).normalized(), seen ? total : 0.0, kR,
                            position_um};
    }
    // TRT: diffuse off the melanin, cosine-distributed about the barb-plane normal.
    const double r = std::sqrt(rng.uniform()), phi = 2.0 * kPi * rng.uniform();
    const Vec3d wo(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1.0 - r * r)));
    const double cos_o = to_barbule(wo, params_.mu).dot(m);
    const double weight = cos_o > 0.0 ? total * film_transmittance(cos_o, lambda_nm) : 0.0;
    return ScatterEvent{wo, weight, kTRT, position_um};
}

void Huang2022Bsdf::build_nodes(Frame& f) const {
    // q(ω_m) dω_m = [ρ cos(φ_m − φ_i) / Δh'] dφ_m · p_θ(θ_m | φ_m) dθ_m: Gauss–Legendre,
    // 8 nodes per 0.25 rad of φ_m and 2 over the θ support (±θ_d is a few degrees: the
    // film's response is nearly linear across it). Used by pdf() only, whose integrand is
    // smooth; eval()'s TRT term has a kink in θ_m and uses trt_efficiency() instead (two
    // nodes here were up to 30 % off for views along the barbule axis).
    static constexpr std::array<double, 2> n2 = {-0.5773502691896258, 0.5773502691896258};
    if (!(f.visible_length > 0.0)) return;
    const Ellipse e{params_.b};
    for (const auto& [lo, hi] : f.intervals) {
        const int pieces = std::max(1, static_cast<int>(std::ceil((hi - lo) / 0.25)));
        for (int piece = 0; piece < pieces; ++piece) {
            const double a = lo + (hi - lo) * piece / pieces,
                         c = lo + (hi - lo) * (piece + 1) / pieces;
            for (std::size_t i = 0; i < kGl8Nodes.size(); ++i) {
                const double phi = 0.5 * (a + c) + 0.5 * (c - a) * kGl8Nodes[i];
                const double w_phi = 0.5 * (c - a) * kGl8Weights[i] * e.rho(phi) *
                                     std::cos(phi - f.phi_i) / f.visible_length;
                const ThetaDensity td = theta_density(f.cos_theta_i * std::cos(phi - f.phi_i),
                                                      f.sin_theta_i, params_.theta_d);
                if (td.empty()) continue;
                for (std::size_t j = 0; j < n2.size(); ++j) {
                    const double theta = 0.5 * (td.lo + td.hi) + 0.5 * (td.hi - td.lo) * n2[j];
                    f.nodes.emplace_back(normal_at(phi, theta),
                                         w_phi * 0.5 * (td.hi - td.lo) * td.density(theta));
                }
            }
        }
    }
}

double Huang2022Bsdf::trt_efficiency(const Frame& f, const Vec3d& wo_b, double lambda_nm) const {
    // E_q[T(ω_i·ω_m) T(ω_o·ω_m) 1(ω_o·ω_m > 0)] = ∫ w(φ) I(φ) dφ, w = ρ cos(φ − φ_i) / Δh'
    // on the visible arc, I(φ) = ∫ p_θ(θ | φ) T_i T_o 1(ω_o·ω_m > 0) dθ. The integrand is
    // bounded by 1 and both densities integrate to 1, so an absolute error is a fraction of
    // the lobe's scale P_hit R_m / π.
    //
    // Error bound (estimated): |error| ≤ 8e-6 + 5e-4 E_q, so the TRT value is within
    // (8e-6 + 5e-4 E_q) P_hit R_m / π: a relative error ≤ 1e-3 wherever E_q ≥ 1.6e-2, plus
    // the film table's ≤ 2e-9 (FilmTransmittanceTable: two factors of T, each ≤ 1e-9 off).
    // Enforced by adaptive Gauss–Kronrod on both axes, each panel bisected until
    // |Kronrod − Gauss| ≤ max(its share of the absolute tolerance, kRelative · |Kronrod|)
    // (the Kronrod value is kept, so the estimate is pessimistic for smooth panels):
    //  - θ_m (7-point Kronrod / 3-point Gauss): the support of p_θ is cut at the one point
    //    where ω_o·ω_m = A cos θ + B sin θ changes sign (T_o has a kink there, and it falls
    //    inside the support whenever the view is near the barbule axis or grazes the
    //    facet), and only the positive part is integrated: the panels are smooth. Share:
    //    kInnerTolerance + kRelative I(φ) on each I(φ) (I ≤ 1), so 1.6e-6 + 2.5e-4 E_q.
    //  - φ_m (15-point Kronrod / 7-point Gauss) over pieces of at most 1 rad of the visible
    //    arc; each piece gets the absolute tolerance in proportion to its q-mass, known in
    //    closed form ((h(c) − h(a)) / Δh'): 6.4e-6 + 2.5e-4 E_q in all. I(φ) needs no cut
    //    where the kink enters or leaves the θ support: the integrand vanishes there
    //    (T(0) = 0, grazing light does not enter the film), so I is continuously
    //    differentiable across it, and the Kronrod–Gauss estimate sees what remains.
    //    (Cutting there as well sent most pieces to the adaptive path at no gain.)
    constexpr double kTrtTolerance = 8e-6, kRelative = 2.5e-4;
    constexpr double kInnerTolerance = 0.2 * kTrtTolerance;
    constexpr double kOuterTolerance = kTrtTolerance - kInnerTolerance;
    constexpr int kPhiDepth = 8, kThetaDepth = 8;
    if (!(f.visible_length > 0.0)) return 0.0;
    const FilmTransmittanceTable& table = transmittance_table(
        this, generation_, lambda_nm, [&](double c) { return film_transmittance(c, lambda_nm); });
    auto transmittance = [&](double c) {
        return c >= FilmTransmittanceTable::kMinCos ? table(c) : film_transmittance(c, lambda_nm);
    };
    const double theta_d = params_.theta_d;
    const Ellipse e{params_.b};
    auto inner = [&](double phi) {
        const double sp = std::sin(phi), cp = std::cos(phi);
        const ThetaDensity td =
            theta_density(f.cos_theta_i * std::cos(phi - f.phi_i), f.sin_theta_i, theta_d);
        if (td.empty()) return 0.0;
        // ω_o·ω_m = A cos θ + B sin θ > 0 on (γ − π/2, γ + π/2) mod 2π; the support is
        // at most π/2 wide, so it meets that set in one interval.
        const double gamma = std::atan2(wo_b.y(), wo_b.x() * sp + wo_b.z() * cp);
        double a = 0.0, b = 0.0;
        for (int k = -1; k <= 1; ++k) {
            const double lo = std::max(td.lo, gamma - 0.5 * kPi + 2.0 * kPi * k);
            const double hi = std::min(td.hi, gamma + 0.5 * kPi + 2.0 * kPi * k);
            if (hi > lo) a = lo, b = hi;
        }
        if (!(b > a)) return 0.0;
        auto g = [&](double theta) {
            const Vec3d m = normal_at(phi, theta);
            return td.density(theta) * transmittance(f.wi.dot(m)) * transmittance(wo_b.dot(m));
        };
        return adaptive_gauss_kronrod(g, kGk7, a, b, kInnerTolerance, kRelative, kThetaDepth);
    };
    auto outer = [&](double phi) {
        return e.rho(phi) * std::cos(phi - f.phi_i) / f.visible_length * inner(phi);
    };
    // T(ω_i·ω_m) at the base rule's θ nodes, for this wavelength.
    // Filled on first use (NaN until then): a view from the other side skips many nodes.
    if (f.trt_lambda != lambda_nm) {
        f.trt_t_in.assign(f.trt_m.size(), std::numeric_limits<double>::quiet_NaN());
        f.trt_lambda = lambda_nm;
    }
    // I(φ) at a base node: the cached rule when T_o has no kink on the support and the
    // Kronrod–Gauss estimate meets kInnerTolerance; the adaptive cut rule otherwise.
    auto base_inner = [&](const Frame::TrtPhiNode& node) {
        if (node.count == 0) return 0.0;
        const double x_lo = wo_b.dot(node.m_lo), x_hi = wo_b.dot(node.m_hi);
        if (x_lo <= 0.0 && x_hi <= 0.0) return 0.0;  // one sign change at most: none > 0
        if (x_lo > 0.0 && x_hi > 0.0) {
            double k_sum = 0.0, g_sum = 0.0;
            for (std::size_t k = node.first; k < node.first + node.count; ++k) {
                if (std::isnan(f.trt_t_in[k])) f.trt_t_in[k] = transmittance(f.wi.dot(f.trt_m[k]));
                const double v = f.trt_t_in[k] * transmittance(wo_b.dot(f.trt_m[k]));
                k_sum += f.trt_wk[k] * v;
                g_sum += f.trt_wg[k] * v;
            }
            if (std::abs(k_sum - g_sum) <= std::max(kInnerTolerance, kRelative * k_sum))
                return k_sum;
        }
        return inner(node.phi);
    };
    double sum = 0.0;
    for (const Frame::TrtPiece& piece : f.trt_pieces) {
        double k_sum = 0.0, g_sum = 0.0;
        for (std::size_t j = piece.first; j < piece.first + kPhiNodesPerPiece; ++j) {
            const Frame::TrtPhiNode& node = f.trt_phi[j];
            const double v = base_inner(node);
            k_sum += node.wk * v;
            g_sum += node.wg * v;
        }
        if (std::abs(k_sum - g_sum) <= std::max(kOuterTolerance * piece.mass, kRelative * k_sum))
            sum += k_sum;
        else  // the estimate too large: bisect adaptively
            sum += adaptive_gauss_kronrod(outer, kGk15, piece.a, piece.c,
                                          kOuterTolerance * piece.mass, kRelative, kPhiDepth);
    }
    return sum;
}

void Huang2022Bsdf::build_trt_nodes(Frame& f) const {
    constexpr double kMaxPiece = 1.0;  // rad: pieces of 0.5 rad were no more accurate
    if (!(f.visible_length > 0.0)) return;
    const Ellipse e{params_.b};
    const double px = std::cos(f.phi_i), pz = -std::sin(f.phi_i);
    auto h = [&](double phi) {
        const auto q = e.point(phi);
        return q[0] * px + q[1] * pz;
    };
    // Nodes of a rule on [centre − half, centre + half] in the order of its entries: each
    // non-centre entry gives −x then +x, the centre comes last.
    auto for_each_node = [](const GaussKronrod& rule, double centre, double half, auto&& emit) {
        const std::size_t n = rule.xk.size();
        for (std::size_t k = 0; k < n; ++k) {
            const double wg = k % 2 == 1 ? rule.wg[k / 2] : 0.0;
            if (k + 1 == n) {
                emit(centre, half * rule.wk[k], half * wg);
            } else {
                emit(centre - half * rule.xk[k], half * rule.wk[k], half * wg);
                emit(centre + half * rule.xk[k], half * rule.wk[k], half * wg);
            }
        }
    };
    for (const auto& [lo, hi] : f.intervals) {
        const int pieces = std::max(1, static_cast<int>(std::ceil((hi - lo) / kMaxPiece)));
        for (int piece = 0; piece < pieces; ++piece) {
            const double a = lo + (hi - lo) * piece / pieces,
                         c = lo + (hi - lo) * (piece + 1) / pieces;
            f.trt_pieces.push_back(
                {a, c, std::max(0.0, h(c) - h(a)) / f.visible_length, f.trt_phi.size()});
            for_each_node(
                kGk15, 0.5 * (a + c), 0.5 * (c - a), [&](double phi, double wk, double wg) {
                    const double w = e.rho(phi) * std::cos(phi - f.phi_i) / f.visible_length;
                    const ThetaDensity td = theta_density(f.cos_theta_i * std::cos(phi - f.phi_i),
                                                          f.sin_theta_i, params_.theta_d);
                    Frame::TrtPhiNode node{phi,
                                           wk * w,
                                           wg * w,
                                           normal_at(phi, td.lo),
                                           normal_at(phi, td.hi),
                                           f.trt_m.size(),
                                           0};
                    if (!td.empty()) {
                        for_each_node(kGk7, 0.5 * (td.lo + td.hi), 0.5 * (td.hi - td.lo),
                                      [&](double theta, double vk, double vg) {
                                          f.trt_m.push_back(normal_at(phi, theta));
                                          f.trt_wk.push_back(vk * td.density(theta));
                                          f.trt_wg.push_back(vg * td.density(theta));
                                          ++node.count;
                                      });
                    }
                    f.trt_phi.push_back(node);
                });
        }
    }
}

void Huang2022Bsdf::prepare_nodes(const Frame& f, double lambda_nm) const {
    if (f.nodes_lambda == lambda_nm) return;
    const double r_m = melanin_reflectance(lambda_nm);
    f.node_trt_in.resize(f.nodes.size());
    f.node_r.resize(f.nodes.size());
    for (std::size_t k = 0; k < f.nodes.size(); ++k) {
        const double cos_i = f.wi.dot(f.nodes[k].first);
        f.node_r[k] = film_reflectance(cos_i, lambda_nm);
        f.node_trt_in[k] = film_transmittance(cos_i, lambda_nm) * r_m;
    }
    f.nodes_lambda = lambda_nm;
}

double Huang2022Bsdf::eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                           std::span<double> per_lobe) const {
    const Frame& f = frame_for(wi);
    const Vec3d wo_b = to_barbule(wo, params_.mu);
    const Ellipse e{params_.b};
    double f_r = 0.0, f_trt = 0.0;
    const double cos_o_patch = std::abs(wo.z());
    if (f.visible_length > 0.0 && cos_o_patch > 1e-12) {
        // R: the half vector must be a hit normal the sampler can produce.
        const Vec3d h = f.wi + wo_b;
        if (h.norm() > 1e-12) {
            const Vec3d m = h.normalized();
            const double phi_m = wrap_into(std::atan2(m.x(), m.z()), params_.phi0);
            const double theta_m = std::asin(std::clamp(m.y(), -1.0, 1.0));
            const double cos_i = f.wi.dot(m);
            bool in_support =
                phi_m <= params_.phi1 && std::abs(theta_m) <= params_.theta_d && cos_i > 0.0;
            if (in_support) {
                in_support = false;
                for (const auto& [lo, hi] : f.intervals) in_support |= phi_m >= lo && phi_m <= hi;
            }
            if (in_support && visible(phi_m, wo_b.x(), wo_b.z())) {
                // P_hit q(ω_m) = ρ cos(φ_m − φ_i) p_θ(θ_m | φ_m) / (Δh cos θ_m); f_R cos θ_o =
                // P_hit q I_R / (4 ⟨ω_o, ω_m⟩). Equal to Eq. 14 wherever p_θ is unclipped.
                const ThetaDensity td = theta_density(f.cos_theta_i * std::cos(phi_m - f.phi_i),
                                                      f.sin_theta_i, params_.theta_d);
                const double q_hit = e.rho(phi_m) * std::cos(phi_m - f.phi_i) *
                                     td.density(theta_m) / (f.period * std::cos(theta_m));
                f_r = q_hit * film_reflectance(cos_i, lambda_nm) / (4.0 * cos_i * cos_o_patch);
            }
        }
        // TRT: P_hit/π · R_m · E_q[T_i T_o 1(ω_o·ω_m > 0)], only above the barb plane.
        if (wo.z() > 0.0) {
            f_trt = f.hit_fraction() * melanin_reflectance(lambda_nm) *
                    trt_efficiency(f, wo_b, lambda_nm) / kPi;
        }
    }
    if (!per_lobe.empty()) {
        PLUMAGE_CHECK(per_lobe.size() == 3, "huang2022 has 3 lobes");
        per_lobe[kR] = f_r;
        per_lobe[kTRT] = f_trt;
        per_lobe[kT] = 0.0;  // Dirac: see t_lobe_mass()
    }
    return f_r + f_trt;
}

double Huang2022Bsdf::pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const {
    const Frame& f = frame_for(wi);
    if (f.visible_length <= 0.0) return 0.0;
    const Vec3d wo_b = to_barbule(wo, params_.mu);
    const Ellipse e{params_.b};
    const double r_m = melanin_reflectance(lambda_nm);
    const double p_hit = f.hit_fraction();
    double pdf_r = 0.0;
    const Vec3d h = f.wi + wo_b;
    if (h.norm() > 1e-12) {
        const Vec3d m = h.normalized();
        const double phi_m = wrap_into(std::atan2(m.x(), m.z()), params_.phi0);
        const double theta_m = std::asin(std::clamp(m.y(), -1.0, 1.0));
        const double cos_i = f.wi.dot(m);
        bool in_support = false;
        for (const auto& [lo, hi] : f.intervals) in_support |= phi_m >= lo && phi_m <= hi;
        if (in_support && cos_i > 0.0 && std::abs(theta_m) <= params_.theta_d) {
            const ThetaDensity td = theta_density(f.cos_theta_i * std::cos(phi_m - f.phi_i),
                                                  f.sin_theta_i, params_.theta_d);
            const double q = e.rho(phi_m) * std::cos(phi_m - f.phi_i) / f.visible_length *
                             td.density(theta_m) / std::cos(theta_m);
            const double i_r = film_reflectance(cos_i, lambda_nm);
            const double i_trt = film_transmittance(cos_i, lambda_nm) * r_m;
            pdf_r = p_hit * q * i_r / (i_r + i_trt) / (4.0 * cos_i);
        }
    }
    double pdf_trt = 0.0;
    if (wo.z() > 0.0) {
        // P(TRT | hit) = E_q[I_TRT_in / (I_R + I_TRT_in)], by the same quadrature as eval.
        double p_trt = 0.0;
        prepare_nodes(f, lambda_nm);
        for (std::size_t k = 0; k < f.nodes.size(); ++k) {
            p_trt += f.nodes[k].second * f.node_trt_in[k] / (f.node_r[k] + f.node_trt_in[k]);
        }
        pdf_trt = p_hit * p_trt * wo.z() / kPi;
    }
    return pdf_r + pdf_trt;
}

}  // namespace plumage::analysis
