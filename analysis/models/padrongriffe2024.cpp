#include "analysis/models/padrongriffe2024.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <string_view>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/require.h"
#include "sim/optics/fresnel.h"
#include "sim/optics/material.h"

namespace plumage::analysis {
namespace {

using Vec2d = Eigen::Vector2d;

constexpr double kMinimumCosTheta = 1e-6;  // as in fibre_baseline.cpp: edge-on cross-sections

// The name that prefixes this file's input errors.
constexpr std::string_view kWhat = "Padrón-Griffe 2024 BSDF";

void validate(const PadronGriffe2024Params& p) {
    auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
    require(in(p.barb_absorption_per_um, 0.0, 10.0), kWhat, "barb_absorption_per_um",
            p.barb_absorption_per_um, "a value in [0, 10] (1/um)");
    require(in(p.barbule_absorption_per_um, 0.0, 10.0), kWhat, "barbule_absorption_per_um",
            p.barbule_absorption_per_um, "a value in [0, 10] (1/um)");
    require(in(p.medulla_albedo, 0.0, 1.0), kWhat, "medulla_albedo", p.medulla_albedo,
            "a value in [0, 1]");
    require(in(p.barb_alpha_r_rad, -0.35, 0.35), kWhat, "barb_alpha_r_rad", p.barb_alpha_r_rad,
            "a value in [-0.35, 0.35] (rad)");
    require(in(p.barb_beta_r_rad, 0.01, 0.5), kWhat, "barb_beta_r_rad", p.barb_beta_r_rad,
            "a value in [0.01, 0.5] (rad)");
    require(in(p.barbule_alpha_r_rad, -0.35, 0.35), kWhat, "barbule_alpha_r_rad",
            p.barbule_alpha_r_rad, "a value in [-0.35, 0.35] (rad)");
    require(in(p.barbule_beta_r_rad, 0.01, 0.5), kWhat, "barbule_beta_r_rad", p.barbule_beta_r_rad,
            "a value in [0.01, 0.5] (rad)");
    require(in(p.azimuthal_roughness_rad, 0.03, 1.5), kWhat, "azimuthal_roughness_rad",
            p.azimuthal_roughness_rad, "a value in [0.03, 1.5] (rad)");
    require(p.fibre_offsets >= 16 && p.fibre_offsets <= 65536, kWhat, "fibre_offsets",
            p.fibre_offsets, "an integer in [16, 65536]");
    // The medulla (the masking term ignores it; the barb's trace needs it inside the cortex).
    const geometry::BarbParams& b = p.geometry.barb;
    require(in(b.medulla_scale, 0.0, 0.95), kWhat, "medulla_scale", b.medulla_scale,
            "a value in [0, 0.95] (0: no medulla)");
    require(std::isfinite(b.medulla_offset_y_um) && std::isfinite(b.medulla_offset_z_um), kWhat,
            "medulla_offset", std::hypot(b.medulla_offset_y_um, b.medulla_offset_z_um),
            "finite offsets (um)");
}

// An ellipse of the cross-section: centre, unit axes e1 (semi-axis a) and e2 (semi-axis b).
struct Ellipse {
    Vec2d centre, e1, e2;
    double a, b;

    Ellipse(const Vec2d& c, double major, double minor, double rotation)
        : centre(c),
          e1(std::sin(rotation), std::cos(rotation)),
          e2(std::cos(rotation), -std::sin(rotation)),
          a(major),
          b(minor) {}

    Vec2d local(const Vec2d& p) const {  // into the unit circle
        const Vec2d q = p - centre;
        return {q.dot(e1) / a, q.dot(e2) / b};
    }
    Vec2d scaled(const Vec2d& d) const { return {d.dot(e1) / a, d.dot(e2) / b}; }
    double level(const Vec2d& p) const { return local(p).norm(); }  // < 1 inside
    // Roots s of |local(o + s d)| = 1 (false: the line misses).
    bool roots(const Vec2d& o, const Vec2d& d, double& s0, double& s1) const {
        const Vec2d p = local(o), v = scaled(d);
        const double qa = v.squaredNorm(), qb = p.dot(v), qc = p.squaredNorm() - 1.0;
        const double disc = qb * qb - qa * qc;
        if (disc < 0.0) return false;
        const double root = std::sqrt(disc);
        // Stable pair: the root of larger magnitude first, the other from the product qc/qa.
        const double big = qb >= 0.0 ? -(qb + root) : -(qb - root);
        if (big == 0.0) {
            s0 = s1 = 0.0;
            return true;
        }
        s0 = big / qa;
        s1 = qc / big;
        if (s0 > s1) std::swap(s0, s1);
        return true;
    }
    Vec2d outward_normal(const Vec2d& p) const {
        const Vec2d q = p - centre;
        return (e1 * (q.dot(e1) / (a * a)) + e2 * (q.dot(e2) / (b * b))).normalized();
    }
    double support(const Vec2d& n) const { return std::hypot(a * n.dot(e1), b * n.dot(e2)); }
};

// Refraction of unit d through a surface with unit normal `facing` on the side d comes from
// (d·facing < 0), index ratio r = n_from / n_to; false on total internal reflection.
bool refract(const Vec2d& d, const Vec2d& facing, double r, Vec2d& out) {
    const double cos_i = -d.dot(facing);
    const double sin2_t = r * r * std::max(0.0, 1.0 - cos_i * cos_i);
    if (sin2_t >= 1.0) return false;
    const double cos_t = std::sqrt(1.0 - sin2_t);
    out = (r * d + (r * cos_i - cos_t) * facing).normalized();
    return true;
}

Vec2d reflect(const Vec2d& d, const Vec2d& n) { return d - 2.0 * d.dot(n) * n; }

double azimuth_of(const Vec2d& d) {
    return std::atan2(d.x(), d.y());
}  // (side, up): from up towards side

double reflectance(double n_from, double n_to, double cos_3d) {
    return optics::fresnel_intensities_unpolarised(n_from, n_to, std::clamp(cos_3d, 0.0, 1.0))
        .reflectance;
}

}  // namespace

void elliptical_fibre_azimuthal(const EllipticalCrossSection& section, double eta,
                                double absorption_per_um, double medulla_albedo, double sin_theta_i,
                                double psi_i, double azimuthal_roughness_rad, int offsets,
                                FibreAzimuthalScattering& out) {
    if (offsets < 16)
        throw InputError(fmt::format("elliptical fibre: offsets = {}: expected >= 16", offsets));
    for (auto& lobe : out.lobes) lobe.reset();
    out.medulla = 0.0;
    const Ellipse cortex(Vec2d::Zero(), section.up_semi_axis_um, section.side_semi_axis_um,
                         section.rotation_rad);
    const bool has_medulla = section.medulla_scale > 0.0;
    const Ellipse medulla(Vec2d(section.medulla_side_um, section.medulla_up_um),
                          section.medulla_scale * section.up_semi_axis_um,
                          section.medulla_scale * section.side_semi_axis_um, section.rotation_rad);

    const double s = std::clamp(sin_theta_i, -1.0, 1.0);
    const double cos_theta = std::max(kMinimumCosTheta, std::sqrt(1.0 - s * s));
    const double eta_projected = std::sqrt(eta * eta - s * s) / cos_theta;  // Bravais
    const double sin_theta_t = s / eta;
    const double cos_theta_t = std::sqrt(1.0 - sin_theta_t * sin_theta_t);

    // Light travels along −l, l the in-plane direction towards it; offsets along `across`.
    const Vec2d towards_light(std::sin(psi_i), std::cos(psi_i));
    const Vec2d travel = -towards_light;
    const Vec2d across(std::cos(psi_i), -std::sin(psi_i));
    const double half_width = cortex.support(across);
    const double far = 4.0 * (cortex.a + cortex.b);

    // Offsets half_width · sin ξ, ξ at midpoints of (−π/2, π/2), weight cos ξ: for a circle this is
    // uniform h = sin γ with the angle of incidence γ = ξ, the baseline's quadrature.
    const double step = kPi / offsets;
    double weight_sum = 0.0;
    for (int k = 0; k < offsets; ++k) weight_sum += std::cos(-0.5 * kPi + (k + 0.5) * step);
    for (int k = 0; k < offsets; ++k) {
        const double xi = -0.5 * kPi + (k + 0.5) * step;
        double carried = std::cos(xi) / weight_sum;
        const Vec2d origin = half_width * std::sin(xi) * across + far * towards_light;
        double s0, s1;
        if (!cortex.roots(origin, travel, s0, s1))
            continue;  // grazing round-off: no energy to speak of
        Vec2d point = origin + s0 * travel;
        Vec2d normal = cortex.outward_normal(point);
        const double cos_in = std::max(0.0, -travel.dot(normal));
        const double fresnel = reflectance(1.0, eta, cos_theta * cos_in);
        out.lobes[kFibreR].deposit(azimuth_of(reflect(travel, normal)), carried * fresnel);
        Vec2d inside;
        if (!refract(travel, normal, 1.0 / eta_projected, inside))
            continue;  // cannot happen from outside
        carried *= 1.0 - fresnel;
        for (int bounce = 1; bounce <= 2; ++bounce) {
            // Across the cortex to the far wall: the larger root from a point on the boundary.
            double t0, t1;
            if (!cortex.roots(point, inside, t0, t1)) break;
            const double exit_length = std::max(t0, t1);
            if (has_medulla) {
                double m0, m1;
                if (medulla.roots(point, inside, m0, m1) && m0 > 0.0 && m0 < exit_length) {
                    out.medulla +=
                        carried * std::exp(-absorption_per_um * m0 / cos_theta_t) * medulla_albedo;
                    carried = 0.0;
                    break;
                }
            }
            carried *= std::exp(-absorption_per_um * exit_length / cos_theta_t);
            point += exit_length * inside;
            normal = cortex.outward_normal(point);
            const double cos_wall = std::clamp(inside.dot(normal), 0.0, 1.0);
            const double internal =
                reflectance(eta, 1.0, cos_theta_t * cos_wall);  // 1 beyond the critical angle
            Vec2d leaving;
            if (internal < 1.0 && refract(inside, -normal, eta_projected, leaving)) {
                out.lobes[bounce].deposit(azimuth_of(leaving), carried * (1.0 - internal));
            }
            carried *= internal;
            inside = reflect(inside, normal);
        }
    }
    for (auto& lobe : out.lobes) lobe.smooth(azimuthal_roughness_rad);
}

// ---------------------------------------------------------------------------------------------

struct PadronGriffe2024Bsdf::State {
    const PadronGriffe2024Bsdf* owner = nullptr;
    std::uint64_t generation = 0;
    Vec3d wi = Vec3d::Zero();
    double lambda_nm = -1.0;
    MaskingFractions g;
    std::array<double, 3> weight{};  // G of barb, distal, proximal
    std::array<std::array<LongitudinalLobe, 3>, 3> longitudinal;
    std::array<FibreAzimuthalScattering, 3> azimuthal;
};

namespace {
std::shared_ptr<const optics::Material> keratin_material() {
    static const std::shared_ptr<const optics::Material> k = optics::keratin();
    return k;
}
}  // namespace

PadronGriffe2024Bsdf::PadronGriffe2024Bsdf(const PadronGriffe2024Params& params)
    : params_(params), masking_((validate(params), params.geometry)) {
    const geometry::BarbulePatchParams& g = params_.geometry;
    frames_[kBarb] = {Vec3d::UnitX(), Vec3d::UnitZ(), Vec3d::UnitY()};
    // The rows' frames of the masking term (the authors' FeatherBase): for barbules perpendicular
    // to the barb, distal (0, cos i, sin i) up (0, −sin i, cos i) side −x, as geometry/barb.h's
    // instanced meshes.
    for (int side = 0; side < 2; ++side) {
        frames_[side == 0 ? kDistalBarbule : kProximalBarbule] = {
            masking_.row_axis(side), masking_.row_normal(side), masking_.row_across(side)};
    }

    EllipticalCrossSection barb;
    barb.up_semi_axis_um = masking_.barb_vertical_semi_axis_um();
    barb.side_semi_axis_um = masking_.barb_horizontal_semi_axis_um();
    barb.rotation_rad = g.barb.barb_rotation_rad;
    barb.medulla_scale = g.barb.medulla_scale;
    barb.medulla_side_um = g.barb.medulla_offset_y_um;
    barb.medulla_up_um = g.barb.medulla_offset_z_um;
    if (barb.medulla_scale > 0.0) {
        // Strictly inside the cortex, with a wall of at least 0.2 % (geometry/barb.h's rule).
        const Ellipse cortex(Vec2d::Zero(), barb.up_semi_axis_um, barb.side_semi_axis_um,
                             barb.rotation_rad);
        const Ellipse core(Vec2d(barb.medulla_side_um, barb.medulla_up_um),
                           barb.medulla_scale * barb.up_semi_axis_um,
                           barb.medulla_scale * barb.side_semi_axis_um, barb.rotation_rad);
        double reach = 0.0;
        for (int k = 0; k < 720; ++k) {
            const double t = 2.0 * kPi * k / 720;
            reach = std::max(reach, cortex.level(core.centre + core.a * std::cos(t) * core.e1 +
                                                 core.b * std::sin(t) * core.e2));
        }
        require(reach < 1.0 - 2e-3, kWhat, "medulla_offset",
                std::hypot(barb.medulla_side_um, barb.medulla_up_um),
                fmt::format("a medulla strictly inside the cortex (scale {} with this offset "
                            "reaches {:.3f} of the "
                            "cortex radius)",
                            barb.medulla_scale, reach));
    }
    sections_[kBarb] = barb;
    EllipticalCrossSection barbule;
    // Thickness (axis ratio × width) along the row's normal ("up"), width across the row.
    barbule.up_semi_axis_um = 0.5 * g.barbule_axis_ratio * g.barbule_width_um;
    barbule.side_semi_axis_um = 0.5 * g.barbule_width_um;
    barbule.rotation_rad = 0.0;
    sections_[kDistalBarbule] = barbule;
    sections_[kProximalBarbule] = barbule;

    static std::atomic<std::uint64_t> counter{0};
    generation_ = ++counter;
}

const std::vector<std::string>& PadronGriffe2024Bsdf::lobe_names() const {
    static const std::vector<std::string> names = {"barb R",       "barb TT",   "barb TRT",
                                                   "barb medulla", "barbule R", "barbule TT",
                                                   "barbule TRT",  "T"};
    return names;
}

const PadronGriffe2024Bsdf::State& PadronGriffe2024Bsdf::state_for(const Vec3d& wi,
                                                                   double lambda_nm) const {
    if (!(std::isfinite(lambda_nm) && lambda_nm > 0.0)) {
        throw InputError(fmt::format(
            "Padrón-Griffe 2024 BSDF: wavelength = {} nm: expected a finite value > 0", lambda_nm));
    }
    // Instruments ask many questions per incident direction: keep the last one per thread (three
    // cross-section traces and the masking partition cost about a millisecond).
    thread_local State state;
    if (state.owner == this && state.generation == generation_ && state.wi == wi &&
        state.lambda_nm == lambda_nm) {
        return state;
    }
    const double eta = keratin_material()->index(lambda_nm).real();
    state.g = masking_(wi);
    state.weight = {state.g.barb, state.g.distal_barbule, state.g.proximal_barbule};
    for (int c = 0; c < 3; ++c) {
        const bool barb = c == kBarb;
        const FibreFrame& f = frames_[c];
        const double sin_theta = std::clamp(f.sin_theta(wi), -1.0, 1.0);
        const auto shapes =
            barb ? marschner_lobe_shapes(params_.barb_alpha_r_rad, params_.barb_beta_r_rad)
                 : marschner_lobe_shapes(params_.barbule_alpha_r_rad, params_.barbule_beta_r_rad);
        for (int p = 0; p < 3; ++p) {
            state.longitudinal[c][p] =
                LongitudinalLobe(std::asin(sin_theta), shapes[p].alpha, shapes[p].beta);
        }
        elliptical_fibre_azimuthal(
            sections_[c], eta,
            barb ? params_.barb_absorption_per_um : params_.barbule_absorption_per_um,
            params_.medulla_albedo, sin_theta, f.azimuth(wi), params_.azimuthal_roughness_rad,
            params_.fibre_offsets, state.azimuthal[c]);
    }
    state.owner = this;
    state.generation = generation_;
    state.wi = wi;
    state.lambda_nm = lambda_nm;
    return state;
}

// f |cos θo| (the analog sampling density), and per lobe when asked.
double PadronGriffe2024Bsdf::density(const State& s, const Vec3d& wo,
                                     std::span<double> per_lobe) const {
    std::array<double, kLobeCount> lobes{};
    for (int c = 0; c < 3; ++c) {
        const double g = s.weight[c];
        if (!(g > 0.0)) continue;
        const FibreFrame& f = frames_[c];
        const double sin_o = std::clamp(f.sin_theta(wo), -1.0, 1.0);
        const double cos_o = std::sqrt(1.0 - sin_o * sin_o);
        const int first = c == kBarb ? kBarbR : kBarbuleR;
        if (cos_o > 0.0) {
            const double theta_o = std::asin(sin_o), psi_o = f.azimuth(wo);
            for (int p = 0; p < 3; ++p) {
                lobes[first + p] += g * s.longitudinal[c][p].density(theta_o) *
                                    s.azimuthal[c].lobes[p].density(psi_o) / cos_o;
            }
        }
        if (c == kBarb) lobes[kBarbMedulla] += g * s.azimuthal[c].medulla / (4.0 * kPi);
    }
    double total = 0.0;
    for (double v : lobes) total += v;
    if (!per_lobe.empty()) std::copy(lobes.begin(), lobes.end(), per_lobe.begin());
    return total;
}

double PadronGriffe2024Bsdf::eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                                  std::span<double> per_lobe) const {
    PLUMAGE_CHECK(per_lobe.empty() || per_lobe.size() == kLobeCount,
                  fmt::format("per_lobe has {} entries; Padrón-Griffe 2024 has {} lobes",
                              per_lobe.size(), static_cast<int>(kLobeCount)));
    const State& s = state_for(wi, lambda_nm);
    const double cos_o = std::abs(wo.z());
    if (!(cos_o > 0.0)) {
        std::fill(per_lobe.begin(), per_lobe.end(), 0.0);
        return 0.0;
    }
    const double f = density(s, wo, per_lobe) / cos_o;
    for (double& v : per_lobe) v /= cos_o;
    return f;
}

double PadronGriffe2024Bsdf::pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const {
    const State& s = state_for(wi, lambda_nm);
    if (!(std::abs(wo.z()) > 0.0)) return 0.0;
    return density(s, wo, {});
}

MaskingFractions PadronGriffe2024Bsdf::fractions(const Vec3d& wi) const { return masking_(wi); }

std::array<double, 4> PadronGriffe2024Bsdf::fibre_albedos(Fibre fibre, const Vec3d& wi,
                                                          double lambda_nm) const {
    const State& s = state_for(wi, lambda_nm);
    const auto& a = s.azimuthal[fibre];
    return {a.lobes[0].mass(), a.lobes[1].mass(), a.lobes[2].mass(), a.medulla};
}

double PadronGriffe2024Bsdf::albedo(const Vec3d& wi, double lambda_nm) const {
    const State& s = state_for(wi, lambda_nm);
    double sum = 0.0;
    for (int c = 0; c < 3; ++c) {
        const auto& a = s.azimuthal[c];
        sum +=
            s.weight[c] * (a.lobes[0].mass() + a.lobes[1].mass() + a.lobes[2].mass() + a.medulla);
    }
    return sum;
}

std::optional<ScatterEvent> PadronGriffe2024Bsdf::sample(const Vec3d& wi, double lambda_nm,
                                                         const Vec2& position_um, Rng& rng) const {
    const State& s = state_for(wi, lambda_nm);
    // Which component the quantum meets first (the masking fractions), then what that fibre does
    // with it (its lobe albedos; the rest is absorbed or lost beyond TRT).
    double u = rng.uniform();
    int fibre = -1;
    for (int c = 0; c < 3; ++c) {
        if (u < s.weight[c]) {
            fibre = c;
            break;
        }
        u -= s.weight[c];
    }
    if (fibre < 0) return ScatterEvent{-wi, 1.0, kT, position_um};  // between the structures
    const auto& az = s.azimuthal[fibre];
    double v = rng.uniform();
    int lobe = -1;
    for (int p = 0; p < 3; ++p) {
        if (v < az.lobes[p].mass()) {
            lobe = p;
            break;
        }
        v -= az.lobes[p].mass();
    }
    Vec3d wo;
    int reported;
    if (lobe >= 0) {
        const double theta_o = s.longitudinal[fibre][lobe].sample(rng);
        const double psi_o = az.lobes[lobe].sample(rng.uniform());
        wo = frames_[fibre].direction(theta_o, psi_o).normalized();
        reported = (fibre == kBarb ? kBarbR : kBarbuleR) + lobe;
    } else if (fibre == kBarb && v < az.medulla) {
        const double z = 1.0 - 2.0 * rng.uniform();
        const double phi = 2.0 * kPi * rng.uniform();
        const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
        wo = Vec3d(r * std::cos(phi), r * std::sin(phi), z);
        reported = kBarbMedulla;
    } else {
        return std::nullopt;
    }
    if (!(std::abs(wo.z()) > 0.0)) return std::nullopt;  // in the patch plane: measure zero
    return ScatterEvent{wo, 1.0, reported, position_um};
}

}  // namespace plumage::analysis
