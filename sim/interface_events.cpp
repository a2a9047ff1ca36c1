#include "sim/interface_events.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <span>

#include <fmt/format.h>

#include "common/error.h"
#include "sim/scatterer/scatterer.h"

namespace plumage::sim {
namespace {

// The specular geometry of one event, with the normal that was accepted.
struct SpecularGeometry {
    Vec3d normal;  // unit, facing the incidence side
    double cos_i;  // in (0, 1]
    Vec3d reflected;
    Vec3d transmitted;
    bool can_transmit;
    bool geometric;
};

// refract() for a normal that faces the incidence side (cos_i = −direction · normal > 0).
inline bool refract_facing(const Vec3d& direction, const Vec3d& normal, double cos_i, double eta,
                           Vec3d* refracted) {
    if (eta == 1.0) {
        *refracted = direction;  // index-matched: exactly straight on
        return true;
    }
    const double sin2_t = eta * eta * std::max(0.0, 1.0 - cos_i * cos_i);
    if (sin2_t >= 1.0) return false;
    const double cos_t = std::sqrt(1.0 - sin2_t);
    *refracted = (eta * direction + (eta * cos_i - cos_t) * normal).normalized();
    return true;
}

bool specular_geometry_with(const Vec3d& direction, const Vec3d& normal, const Vec3d& facet,
                            double eta, bool geometric, SpecularGeometry* out) {
    const double cos_i = -direction.dot(normal);
    if (!(cos_i > 0.0)) return false;
    out->normal = normal;
    out->cos_i = std::min(cos_i, 1.0);
    out->geometric = geometric;
    out->reflected = reflect(direction, normal);
    if (!geometric && !(out->reflected.dot(facet) > 0.0)) return false;
    out->can_transmit = refract_facing(direction, normal, cos_i, eta, &out->transmitted);
    if (!geometric && out->can_transmit && !(out->transmitted.dot(facet) < 0.0)) return false;
    return true;
}

// `facet` is the geometric normal turned to face the incidence side.
SpecularGeometry specular_geometry(const Vec3d& direction, const Vec3d& shading, const Vec3d& facet,
                                   double eta) {
    SpecularGeometry g;
    if (specular_geometry_with(direction, shading, facet, eta, false, &g)) return g;
    const bool ok = specular_geometry_with(direction, facet, facet, eta, true, &g);
    PLUMAGE_CHECK(ok, "a hit whose direction is parallel to its facet");
    return g;
}

struct Incidence {
    bool from_outside;
    Vec3d facet;    // geometric normal facing the incidence side
    Vec3d shading;  // shading normal turned the same way
};

Incidence incidence(const Vec3d& direction, const SurfaceNormals& normals) {
    const double dg = direction.dot(normals.geometric);
    PLUMAGE_CHECK(
        dg != 0.0 && std::isfinite(dg),
        fmt::format("direction . geometric normal = {}: expected a nonzero finite value", dg));
    const bool from_outside = dg < 0.0;
    const double sign = from_outside ? 1.0 : -1.0;
    return {from_outside, sign * normals.geometric, sign * normals.shading};
}

InterfaceEvent choose(const SpecularGeometry& g, bool from_outside, FilmResponse r,
                      EventKind reflect_kind, EventKind transmit_kind, Rng& rng) {
    const double reflectance = std::max(0.0, r.reflectance);
    const double transmittance = g.can_transmit ? std::max(0.0, r.transmittance) : 0.0;
    const double total = reflectance + transmittance;
    if (!(total > 0.0)) {
        return {EventKind::absorb, Vec3d::Zero(), 0.0, from_outside, g.geometric};
    }
    const double throughput = std::min(total, 1.0);
    if (rng.uniform() * total < reflectance) {
        return {reflect_kind, g.reflected, throughput, from_outside, g.geometric};
    }
    return {transmit_kind, g.transmitted, throughput, !from_outside, g.geometric};
}

}  // namespace

const char* to_string(EventKind kind) {
    switch (kind) {
        case EventKind::film_reflect:
            return "film_reflect";
        case EventKind::film_transmit:
            return "film_transmit";
        case EventKind::specular_reflect:
            return "specular_reflect";
        case EventKind::refract:
            return "refract";
        case EventKind::total_internal_reflection:
            return "total_internal_reflection";
        case EventKind::diffuse_reflect:
            return "diffuse_reflect";
        case EventKind::absorb:
            return "absorb";
        case EventKind::medium_scatter:
            return "medium_scatter";
    }
    return "unknown";
}

Vec3d reflect(const Vec3d& direction, const Vec3d& normal) {
    return direction - 2.0 * direction.dot(normal) * normal;
}

bool refract(const Vec3d& direction, const Vec3d& normal, double eta, Vec3d* refracted) {
    // Orient the normal against the direction: cos_i > 0.
    const double cos_i = -direction.dot(normal);
    return cos_i >= 0.0 ? refract_facing(direction, normal, cos_i, eta, refracted)
                        : refract_facing(direction, -normal, -cos_i, eta, refracted);
}

Vec3d sample_cosine_hemisphere(const Vec3d& normal, Rng& rng) {
    const double u1 = rng.uniform(), u2 = rng.uniform();
    const double r = std::sqrt(u1), phi = 2.0 * std::numbers::pi * u2;
    const double x = r * std::cos(phi), y = r * std::sin(phi), z = std::sqrt(1.0 - u1);
    // Orthonormal basis about the normal without a branch on the tangent choice
    // (Duff et al. 2017, "Building an orthonormal basis, revisited").
    const double sign = std::copysign(1.0, normal.z());
    const double a = -1.0 / (sign + normal.z());
    const double b = normal.x() * normal.y() * a;
    const Vec3d t1(1.0 + sign * normal.x() * normal.x() * a, sign * b, -sign * normal.x());
    const Vec3d t2(b, sign + normal.y() * normal.y() * a, -normal.y());
    return (x * t1 + y * t2 + z * normal).normalized();
}

FilmResponse film_response(const FilmOptics& film, bool from_outside, double lambda_nm,
                           double cos_theta) {
    const double incident = (from_outside ? film.outside : film.inside).real();
    const optics::Complex exit = from_outside ? film.inside : film.outside;
    const double c = std::clamp(cos_theta, 0.0, 1.0);
    if (film.coherence == optics::Coherence::coherent) {
        const optics::FilmIntensities i = optics::airy_film_intensities_unpolarised(
            {incident, film.film, exit}, film.thickness_um, lambda_nm, c);
        return {i.reflectance, i.transmittance};
    }
    const optics::StackLayer layer{film.film, film.thickness_um, optics::Coherence::incoherent};
    const optics::StackIntensities i = optics::transfer_matrix_intensities_unpolarised(
        {incident, std::span(&layer, 1), exit}, lambda_nm, c);
    return {i.reflectance, i.transmittance};
}

InterfaceEvent thin_film_event(const Vec3d& direction, const SurfaceNormals& normals,
                               const FilmOptics& film, const FilmResponseSource& source, Rng& rng) {
    const Incidence in = incidence(direction, normals);
    const double n_in = (in.from_outside ? film.outside : film.inside).real();
    const double n_out = (in.from_outside ? film.inside : film.outside).real();
    const SpecularGeometry g = specular_geometry(direction, in.shading, in.facet, n_in / n_out);
    const FilmResponse r = source.response(in.from_outside, g.cos_i);
    return choose(g, in.from_outside, r, EventKind::film_reflect, EventKind::film_transmit, rng);
}

FilmIncidence film_incidence(const Vec3d& direction, const SurfaceNormals& normals, double eta) {
    const Incidence in = incidence(direction, normals);
    return {in.from_outside, specular_geometry(direction, in.shading, in.facet, eta).cos_i};
}

InterfaceEvent thin_film_event(const Vec3d& direction, const SurfaceNormals& normals,
                               const FilmOptics& film, double lambda_nm, Rng& rng) {
    return thin_film_event(direction, normals, film, DirectFilmResponse(film, lambda_nm), rng);
}

optics::FresnelIntensities lossless_fresnel_unpolarised(double n_in, double n_out, double cos_i) {
    // optics::fresnel_intensities_unpolarised's equations (sim/optics/fresnel.h) with real q:
    // q = n cos θ, the transmitted one as sqrt((n_out² − n_in²) + q_in²) for its precision
    // near grazing incidence, r_s = (q_in − q_out)/(q_in + q_out),
    // r_p = (n_out² q_in − n_in² q_out)/(n_out² q_in + n_in² q_out), and T = 1 − R (the
    // interface absorbs nothing).
    if (n_in == n_out) return {0.0, 1.0};
    const double q_in = n_in * std::clamp(cos_i, 0.0, 1.0);
    const double radicand = (n_out * n_out - n_in * n_in) + q_in * q_in;
    if (!(radicand > 0.0)) return {1.0, 0.0};  // beyond the critical angle
    const double q_out = std::sqrt(radicand);
    const double rs = (q_in - q_out) / (q_in + q_out);
    const double in2 = n_in * n_in, out2 = n_out * n_out;
    const double rp = (out2 * q_in - in2 * q_out) / (out2 * q_in + in2 * q_out);
    const double reflectance = 0.5 * (rs * rs + rp * rp);
    return {reflectance, 1.0 - reflectance};
}

InterfaceEvent dielectric_event(const Vec3d& direction, const SurfaceNormals& normals,
                                optics::Complex outside, optics::Complex inside, Rng& rng) {
    const Incidence in = incidence(direction, normals);
    const optics::Complex n_in = in.from_outside ? outside : inside;
    const optics::Complex n_out = in.from_outside ? inside : outside;
    const SpecularGeometry g =
        specular_geometry(direction, in.shading, in.facet, n_in.real() / n_out.real());
    if (!g.can_transmit) {
        return {EventKind::total_internal_reflection, g.reflected, 1.0, in.from_outside,
                g.geometric};
    }
    // Lossless on both sides (keratin, air, the spongy shell's n_eff): real arithmetic, about
    // 10× faster than the complex general case, which absorbing media (melanin) still take.
    const optics::FresnelIntensities f =
        n_out.imag() == 0.0 ? lossless_fresnel_unpolarised(n_in.real(), n_out.real(), g.cos_i)
                            : optics::fresnel_intensities_unpolarised(n_in.real(), n_out, g.cos_i);
    return choose(g, in.from_outside, {f.reflectance, f.transmittance}, EventKind::specular_reflect,
                  EventKind::refract, rng);
}

InterfaceEvent dielectric_event(const Vec3d& direction, const SurfaceNormals& normals,
                                double outside, double inside, const FilmResponseSource& source,
                                Rng& rng) {
    const Incidence in = incidence(direction, normals);
    const double n_in = in.from_outside ? outside : inside;
    const double n_out = in.from_outside ? inside : outside;
    const SpecularGeometry g = specular_geometry(direction, in.shading, in.facet, n_in / n_out);
    if (!g.can_transmit) {
        return {EventKind::total_internal_reflection, g.reflected, 1.0, in.from_outside,
                g.geometric};
    }
    return choose(g, in.from_outside, source.response(in.from_outside, g.cos_i),
                  EventKind::specular_reflect, EventKind::refract, rng);
}

bool specular_regimes_agree(const Vec3d& direction, const SurfaceNormals& normals,
                            std::span<const double> outside, std::span<const double> inside) {
    // specular_geometry()'s decisions, per index ratio η, without building the directions: the
    // shading normal is kept when its reflection leaves above the facet (η plays no part) and
    // its transmitted direction, where there is one, goes below it; the sign of
    // t·f = η (d·f) + (η cos θ_s − cos θ_t)(n_s·f) is that of the normalised direction's.
    const Incidence in = incidence(direction, normals);
    const double d_f = direction.dot(in.facet), cos_g = -d_f;
    const double cos_s = -direction.dot(in.shading), n_f = in.shading.dot(in.facet);
    const bool shading_reflects = cos_s > 0.0 && reflect(direction, in.shading).dot(in.facet) > 0.0;
    // Regime code: bit 0 the geometric normal, bit 1 transmission possible.
    auto regime = [&](double eta) {
        if (shading_reflects) {
            if (eta == 1.0) return 2;  // straight on: below the facet
            const double sin2_t = eta * eta * std::max(0.0, 1.0 - cos_s * cos_s);
            if (sin2_t >= 1.0) return 0;
            const double cos_t = std::sqrt(1.0 - sin2_t);
            if (eta * d_f + (eta * cos_s - cos_t) * n_f < 0.0) return 2;
        }
        const double sin2_g = eta * eta * std::max(0.0, 1.0 - cos_g * cos_g);
        return eta == 1.0 || sin2_g < 1.0 ? 3 : 1;
    };
    int first = -1;
    for (std::size_t k = 0; k < outside.size(); ++k) {
        const double eta = in.from_outside ? outside[k] / inside[k] : inside[k] / outside[k];
        const int r = regime(eta);
        if (first < 0) first = r;
        if (r != first) return false;
    }
    return true;
}

InterfaceEvent diffuse_event(const Vec3d& direction, const SurfaceNormals& normals, double albedo,
                             Rng& rng) {
    const Incidence in = incidence(direction, normals);
    if (!(albedo > 0.0)) return {EventKind::absorb, Vec3d::Zero(), 0.0, in.from_outside, true};
    return {EventKind::diffuse_reflect, sample_cosine_hemisphere(in.facet, rng),
            std::min(albedo, 1.0), in.from_outside, true};
}

namespace {

// A direction uniform in solid angle within one of the cones, picked with probability 1/m.
Vec3d sample_in_cones(std::span<const Vec3d> cone_axes, double cos_half_angle, Rng& rng) {
    const auto m = static_cast<double>(cone_axes.size());
    const std::size_t j =
        std::min(cone_axes.size() - 1, static_cast<std::size_t>(rng.uniform() * m));
    const double cos_t = 1.0 - rng.uniform() * (1.0 - cos_half_angle);
    const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos_t * cos_t));
    const double phi = 2.0 * std::numbers::pi * rng.uniform();
    const Vec3d& a = cone_axes[j];
    Vec3d e1, e2;
    orthonormal_frame(a, e1, e2);
    return (cos_t * a + sin_t * (std::cos(phi) * e1 + std::sin(phi) * e2)).normalized();
}

// How many of the cones hold d.
int cones_holding(const Vec3d& d, std::span<const Vec3d> cone_axes, double cos_half_angle) {
    int inside = 0;
    for (const Vec3d& a : cone_axes) inside += d.dot(a) >= cos_half_angle ? 1 : 0;
    return inside;
}

}  // namespace

InterfaceEvent guided_diffuse_event(const Vec3d& direction, const SurfaceNormals& normals,
                                    std::span<const Vec3d> cone_axes, double cos_half_angle,
                                    double fraction, Rng& rng) {
    const Incidence in = incidence(direction, normals);
    const Vec3d out = cone_axes.empty() || rng.uniform() >= fraction
                          ? sample_cosine_hemisphere(in.facet, rng)
                          : sample_in_cones(cone_axes, cos_half_angle, rng);
    const double cos_n = out.dot(in.facet);
    if (!(cos_n > 0.0)) return {EventKind::absorb, Vec3d::Zero(), 0.0, in.from_outside, true};
    const int inside = cones_holding(out, cone_axes, cos_half_angle);
    const auto m = static_cast<double>(cone_axes.size());
    const double cone_solid_angle = 2.0 * std::numbers::pi * (1.0 - cos_half_angle);
    const double lambertian = cos_n / std::numbers::pi;
    const double density = (cone_axes.empty() ? 1.0 : 1.0 - fraction) * lambertian +
                           (cone_axes.empty() ? 0.0 : fraction * inside / (m * cone_solid_angle));
    return {EventKind::diffuse_reflect, out, lambertian / density, in.from_outside, true};
}

std::size_t guided_diffuse_branches(const Vec3d& direction, const SurfaceNormals& normals,
                                    std::span<const Vec3d> cone_axes, double cos_half_angle,
                                    std::size_t guided, Rng& rng,
                                    std::span<InterfaceEvent> events) {
    PLUMAGE_CHECK(!cone_axes.empty() && events.size() >= 1 + guided,
                  "guided_diffuse_branches: cones, and room for 1 + k directions");
    const Incidence in = incidence(direction, normals);
    const auto k = static_cast<double>(guided), m = static_cast<double>(cone_axes.size());
    const double cone_solid_angle = 2.0 * std::numbers::pi * (1.0 - cos_half_angle);
    for (std::size_t i = 0; i <= guided; ++i) {
        const Vec3d out = i == 0 ? sample_cosine_hemisphere(in.facet, rng)
                                 : sample_in_cones(cone_axes, cos_half_angle, rng);
        const double cos_n = out.dot(in.facet);
        if (!(cos_n > 0.0)) {
            events[i] = {EventKind::absorb, Vec3d::Zero(), 0.0, in.from_outside, true};
            continue;
        }
        const double lambertian = cos_n / std::numbers::pi;
        const double density =
            lambertian + k * cones_holding(out, cone_axes, cos_half_angle) / (m * cone_solid_angle);
        events[i] = {EventKind::diffuse_reflect, out, lambertian / density, in.from_outside, true};
    }
    return 1 + guided;
}

Vec3d refracted_cone_axis(const Vec3d& a, const Vec3d& out, double n) {
    const double cos_a = a.dot(out);
    if (!(n > 1.0) || !(cos_a > 0.0)) return a;
    const Vec3d tangential = (a - cos_a * out) / n;
    return (tangential + std::sqrt(std::max(0.0, 1.0 - tangential.squaredNorm())) * out)
        .normalized();
}

InterfaceEvent absorber_event(const Vec3d& direction, const SurfaceNormals& normals) {
    const Incidence in = incidence(direction, normals);
    return {EventKind::absorb, Vec3d::Zero(), 0.0, in.from_outside, true};
}

double adjoint_shading_factor(const Vec3d& arriving, const InterfaceEvent& event,
                              const SurfaceNormals& normals) {
    switch (event.kind) {
        case EventKind::film_reflect:
        case EventKind::film_transmit:
        case EventKind::specular_reflect:
        case EventKind::refract:
        case EventKind::total_internal_reflection:
            break;
        default:
            return 1.0;
    }
    if (event.used_geometric_normal) return 1.0;
    const double in_g = std::abs(arriving.dot(normals.geometric));
    const double out_s = std::abs(event.direction.dot(normals.shading));
    // Neither is 0 for an event the shading normal passed (interface_events.h: it is rejected
    // when a direction would graze or cross the facet).
    if (!(in_g > 0.0) || !(out_s > 0.0)) return 1.0;
    return std::abs(event.direction.dot(normals.geometric)) *
           std::abs(arriving.dot(normals.shading)) / (in_g * out_s);
}

}  // namespace plumage::sim
