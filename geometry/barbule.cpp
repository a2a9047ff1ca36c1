#include "geometry/barbule.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string_view>
#include <utility>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/require.h"
#include "common/seed.h"

namespace plumage::geometry {
namespace {

// The name that prefixes this file's input errors.
constexpr std::string_view kWhat = "barbule";

// Smallest radius of curvature of the arc over [phi0, phi1]. With A >= B, ρ(φ) is
// smallest at the ends of the major axis, φ = π/2 + kπ (the barbule's sharp edges).
double min_radius(const EllipticalArc& arc) {
    double rho = std::min(arc.radius_of_curvature(arc.phi0()), arc.radius_of_curvature(arc.phi1()));
    for (int k = -3; k <= 3; ++k) {
        const double edge = 0.5 * kPi + k * kPi;
        if (edge > arc.phi0() && edge < arc.phi1())
            rho = std::min(rho, arc.radius_of_curvature(edge));
    }
    return rho;
}

EllipticalArc make_arc(const BarbuleCellParams& p) {
    require(std::isfinite(p.b) && p.b >= 1e-3 && p.b <= 1.0, kWhat, "b", p.b,
            "a value in [1e-3, 1]: b is the semi-minor axis relative to the semi-major one; "
            "b -> 0 is a flat strip whose edges have no defined normal");
    require(std::isfinite(p.semi_major_um) && p.semi_major_um > 0.0, kWhat, "semi_major_um",
            p.semi_major_um, "a finite length > 0 (um)");
    require(std::isfinite(p.phi0), kWhat, "phi0", p.phi0, "a finite angle (rad)");
    require(
        std::isfinite(p.phi1) && p.phi1 - p.phi0 >= 1e-6, kWhat, "phi1", p.phi1,
        fmt::format("phi1 - phi0 >= 1e-6 rad (phi0 = {}); an empty arc has no surface", p.phi0));
    require(p.phi1 - p.phi0 <= 2.0 * kPi, kWhat, "phi1", p.phi1,
            fmt::format("phi1 - phi0 <= 2 pi (phi0 = {}); a longer arc covers the ellipse twice",
                        p.phi0));
    return EllipticalArc(p.semi_major_um, p.b * p.semi_major_um, p.phi0, p.phi1);
}

double longitudinal_radius(const BarbuleCellParams& p) {
    require(std::isfinite(p.theta_d) && p.theta_d >= 0.0 && p.theta_d <= 0.25 * kPi, kWhat,
            "theta_d", p.theta_d, "a longitudinal half-opening in [0, pi/4] rad");
    require(std::isfinite(p.cell_length_um) && p.cell_length_um > 0.0, kWhat, "cell_length_um",
            p.cell_length_um, "a finite length > 0 (um)");
    return p.theta_d > 0.0 ? p.cell_length_um / (2.0 * std::sin(p.theta_d))
                           : std::numeric_limits<double>::infinity();
}

double profile_sign(LongitudinalProfile profile) {
    return profile == LongitudinalProfile::saddle ? 1.0 : -1.0;
}

}  // namespace

BarbuleCell::BarbuleCell(const BarbuleCellParams& params)
    : params_(params), arc_(make_arc(params)), r_theta_(longitudinal_radius(params)) {
    require(std::isfinite(params.film_thickness_um) && params.film_thickness_um >= 0.0, kWhat,
            "film_thickness_um", params.film_thickness_um, "a finite thickness >= 0 (um)");
    const double rho_min = min_radius(arc_);
    if (params.profile == LongitudinalProfile::convex && params.theta_d > 0.0) {
        const double sag = r_theta_ * (1.0 - std::cos(params.theta_d));
        require(
            sag < rho_min, kWhat, "cell_length_um", params.cell_length_um,
            fmt::format("a shorter cell: with a convex longitudinal arc the surface folds where "
                        "r_theta (1 - cos theta_d) = {:.4g} um exceeds the smallest transversal "
                        "radius of curvature {:.4g} um",
                        sag, rho_min));
    }
    require(std::isfinite(params.melanin_depth_um) && params.melanin_depth_um > 0.0 &&
                params.melanin_depth_um < rho_min,
            kWhat, "melanin_depth_um", params.melanin_depth_um,
            fmt::format("a depth in (0, {:.4g}) um: beyond the arc's smallest radius of curvature "
                        "(b^2 A at the edges) the offset surface folds over itself",
                        rho_min));
}

Eigen::Vector3d BarbuleCell::normal(double phi, double theta) const {
    const Eigen::Vector2d n = arc_.normal(phi);
    const double s = params_.theta_d > 0.0 ? -profile_sign(params_.profile) * std::sin(theta) : 0.0;
    const double c = params_.theta_d > 0.0 ? std::cos(theta) : 1.0;
    return {n.x() * c, s, n.y() * c};
}

Eigen::Vector3d BarbuleCell::point(double phi, double theta, double depth_um) const {
    const Eigen::Vector2d e = arc_.point(phi);
    const Eigen::Vector2d n = arc_.normal(phi);
    Eigen::Vector3d p(e.x(), 0.0, e.y());
    if (params_.theta_d > 0.0) {
        const double radial = profile_sign(params_.profile) * r_theta_ * (1.0 - std::cos(theta));
        p += Eigen::Vector3d(n.x() * radial, r_theta_ * std::sin(theta), n.y() * radial);
    } else {
        p.y() = theta * 0.5 * params_.cell_length_um;
    }
    return p - depth_um * normal(phi, theta);
}

double BarbuleCell::area_element(double phi, double theta) const {
    if (!(params_.theta_d > 0.0))
        return arc_.radius_of_curvature(phi) * 0.5 * params_.cell_length_um;
    return r_theta_ * (arc_.radius_of_curvature(phi) +
                       profile_sign(params_.profile) * r_theta_ * (1.0 - std::cos(theta)));
}

TriangleMesh BarbuleCell::tessellate(const TessellationTolerance& tolerance, bool melanin_surface,
                                     TessellationReport* report) const {
    tolerance.validate();
    const double depth = melanin_surface ? params_.melanin_depth_um : 0.0;
    const double sign = profile_sign(params_.profile);
    const double sag = params_.theta_d > 0.0 ? r_theta_ * (1.0 - std::cos(params_.theta_d)) : 0.0;
    // Smallest transversal radius along the φ-curves at this depth: the convex profile
    // tightens it towards the cell ends, the saddle widens it.
    auto transversal_radius = [&](double phi) {
        return arc_.radius_of_curvature(phi) + std::min(0.0, sign * sag) - depth;
    };

    double max_chord = 0.0;
    const std::vector<double> phis = sample_normal_azimuths(
        params_.phi0, params_.phi1, transversal_radius,
        [&](double rho) { return tolerance.max_angular_step(rho); }, &max_chord);

    // Longitudinal samples: uniform in θ (constant curvature r_θ ∓ depth).
    std::vector<double> thetas;
    if (params_.theta_d > 0.0) {
        const double radius = r_theta_ + sign * depth;  // saddle: centre outside, offset widens
        const double step = tolerance.max_angular_step(radius);
        const int segments = std::max(1, static_cast<int>(std::ceil(2.0 * params_.theta_d / step)));
        for (int k = 0; k <= segments; ++k)
            thetas.push_back(-params_.theta_d + 2.0 * params_.theta_d * k / segments);
        const double dtheta = 2.0 * params_.theta_d / segments;
        max_chord = std::max(max_chord, radius * (1.0 - std::cos(0.5 * dtheta)));
    } else {
        thetas = {-1.0, 1.0};
    }

    TriangleMesh mesh;
    const std::size_t nphi = phis.size(), ntheta = thetas.size();
    mesh.positions.reserve(nphi * ntheta);
    mesh.shading_normals.reserve(nphi * ntheta);
    for (double theta : thetas) {
        for (double phi : phis) {
            mesh.positions.push_back(point(phi, theta, depth));
            mesh.shading_normals.push_back(normal(phi, params_.theta_d > 0.0 ? theta : 0.0));
        }
    }
    auto index = [&](std::size_t i, std::size_t k) {
        return static_cast<std::uint32_t>(k * nphi + i);
    };
    for (std::size_t k = 0; k + 1 < ntheta; ++k) {
        for (std::size_t i = 0; i + 1 < nphi; ++i) {
            mesh.triangles.push_back({index(i, k), index(i + 1, k), index(i + 1, k + 1)});
            mesh.triangles.push_back({index(i, k), index(i + 1, k + 1), index(i, k + 1)});
        }
    }
    // Wind so that the geometric normal agrees with the analytic outward normal.
    if (mesh.face_normal(0).dot(mesh.shading_normals[mesh.triangles[0][0]]) < 0.0) {
        for (Triangle& t : mesh.triangles) std::swap(t[1], t[2]);
    }
    if (report != nullptr) {
        report->max_chord_um = max_chord;
        report->max_normal_error_rad = 0.0;
        for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
            const Vec3 n = mesh.face_normal(f);
            for (std::uint32_t v : mesh.triangles[f]) {
                const double c = std::clamp(n.dot(mesh.shading_normals[v]), -1.0, 1.0);
                report->max_normal_error_rad = std::max(report->max_normal_error_rad, std::acos(c));
            }
        }
        report->triangles = mesh.triangles.size();
    }
    return mesh;
}

double projected_period(double H, double mu, double phi) { return H * std::cos(phi + mu); }

double projected_hit_length(const BarbuleCellParams& cell, double H, double mu, double phi) {
    const EllipticalArc unit(1.0, cell.b, cell.phi0, cell.phi1);
    return std::min(unit.projected_width(phi), projected_period(H, mu, phi));
}

namespace {

bool segments_intersect(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                        const Eigen::Vector2d& c, const Eigen::Vector2d& d) {
    auto cross = [](const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
        return u.x() * v.y() - u.y() * v.x();
    };
    const double d1 = cross(b - a, c - a), d2 = cross(b - a, d - a);
    const double d3 = cross(d - c, a - c), d4 = cross(d - c, b - c);
    return ((d1 > 0) != (d2 > 0)) && ((d3 > 0) != (d4 > 0));
}

// An axis-aligned box in the plane.
struct Box2 {
    double min_x = std::numeric_limits<double>::infinity();
    double max_x = -std::numeric_limits<double>::infinity();
    double min_y = std::numeric_limits<double>::infinity();
    double max_y = -std::numeric_limits<double>::infinity();

    void extend(const Eigen::Vector2d& p) {
        min_x = std::min(min_x, p.x());
        max_x = std::max(max_x, p.x());
        min_y = std::min(min_y, p.y());
        max_y = std::max(max_y, p.y());
    }
    // Whether this box and `other` shifted by `shift` are strictly apart. Exact, not a
    // tolerance: rounding is monotone, so min(a + s, b + s) is min(a, b) + s to the last bit.
    bool apart(const Box2& other, const Eigen::Vector2d& shift) const {
        return max_x < other.min_x + shift.x() || other.max_x + shift.x() < min_x ||
               max_y < other.min_y + shift.y() || other.max_y + shift.y() < min_y;
    }
};

// The arc's polyline in runs of consecutive segments, each run with its bounding box. An arc
// and its shifted copy meet, if at all, near a few points, so most pairs of runs are apart
// and their segments are never tested (a 240-segment arc: 225 box tests instead of 57 600
// segment tests per shift).
struct ArcRuns {
    static constexpr std::size_t kRun = 16;  // segments per run
    std::vector<Eigen::Vector2d> points;
    std::vector<Box2> segment_boxes;  // segment i joins points[i] and points[i + 1]
    std::vector<Box2> run_boxes;      // run r holds segments [r kRun, (r + 1) kRun)

    explicit ArcRuns(std::vector<Eigen::Vector2d> polyline) : points(std::move(polyline)) {
        for (std::size_t i = 0; i + 1 < points.size(); ++i) {
            Box2 box;
            box.extend(points[i]);
            box.extend(points[i + 1]);
            segment_boxes.push_back(box);
            if (i % kRun == 0) run_boxes.emplace_back();
            run_boxes.back().extend(points[i]);
            run_boxes.back().extend(points[i + 1]);
        }
    }
    std::size_t run_end(std::size_t r) const {
        return std::min((r + 1) * kRun, segment_boxes.size());
    }
};

// Whether the arc meets its copy shifted by `shift`. Segments whose boxes are strictly apart
// cannot cross (segments_intersect asks for a crossing, not a near miss), so the box tests
// change no answer.
bool arcs_intersect(const ArcRuns& arc, const Eigen::Vector2d& shift) {
    for (std::size_t r = 0; r < arc.run_boxes.size(); ++r) {
        for (std::size_t t = 0; t < arc.run_boxes.size(); ++t) {
            if (arc.run_boxes[r].apart(arc.run_boxes[t], shift)) continue;
            for (std::size_t i = r * ArcRuns::kRun; i < arc.run_end(r); ++i) {
                for (std::size_t j = t * ArcRuns::kRun; j < arc.run_end(t); ++j) {
                    if (arc.segment_boxes[i].apart(arc.segment_boxes[j], shift)) continue;
                    if (segments_intersect(arc.points[i], arc.points[i + 1], arc.points[j] + shift,
                                           arc.points[j + 1] + shift))
                        return true;
                }
            }
        }
    }
    return false;
}

}  // namespace

double minimum_spacing(const BarbuleCellParams& cell, double mu) {
    const EllipticalArc unit(1.0, cell.b, cell.phi0, cell.phi1);
    constexpr int kPoints = 240;
    std::vector<Eigen::Vector2d> points;
    for (int i = 0; i <= kPoints; ++i)
        points.push_back(unit.point(cell.phi0 + (cell.phi1 - cell.phi0) * i / kPoints));
    const ArcRuns arc(std::move(points));
    const Eigen::Vector2d u(std::cos(mu), std::sin(mu));
    // Copies further apart than the ellipse's diameter cannot meet. Scan down from
    // there for the first spacing that intersects, then bisect.
    double free_h = 2.0 + 1e-9, hit_h = 0.0;
    for (double h = 2.0; h > 1e-3; h -= 0.02) {
        if (arcs_intersect(arc, h * u)) {
            hit_h = h;
            break;
        }
        free_h = h;
    }
    if (hit_h == 0.0) return 0.0;
    for (int i = 0; i < 30; ++i) {
        const double mid = 0.5 * (free_h + hit_h);
        (arcs_intersect(arc, mid * u) ? hit_h : free_h) = mid;
    }
    return free_h;
}

std::size_t BarbuleRow::memory_bytes() const {
    return sizeof(*this) + cell_film.memory_bytes() + cell_melanin.memory_bytes() +
           instances.capacity() * sizeof(Eigen::Affine3d);
}

Eigen::AlignedBox3d BarbuleRow::bounds() const {
    const auto local = cell_film.bounds();
    const auto melanin = cell_melanin.bounds();
    Eigen::AlignedBox3d cell_box(local[0].cwiseMin(melanin[0]), local[1].cwiseMax(melanin[1]));
    Eigen::AlignedBox3d box;
    for (const Eigen::Affine3d& t : instances) {
        for (int corner = 0; corner < 8; ++corner) {
            box.extend(t * cell_box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(corner)));
        }
    }
    return box;
}

TriangleMesh BarbuleRow::flatten(bool melanin_surface) const {
    const TriangleMesh& cell = melanin_surface ? cell_melanin : cell_film;
    TriangleMesh out;
    out.positions.reserve(cell.positions.size() * instances.size());
    out.shading_normals.reserve(cell.positions.size() * instances.size());
    out.triangles.reserve(cell.triangles.size() * instances.size());
    for (const Eigen::Affine3d& t : instances) {
        TriangleMesh copy = cell;
        for (Vec3& p : copy.positions) p = t * p;
        for (Vec3& n : copy.shading_normals) n = (t.linear() * n).normalized();
        out.append(copy);
    }
    return out;
}

BarbuleRow build_barbule_row(const BarbuleRowParams& params,
                             const TessellationTolerance& tolerance) {
    const BarbuleCell cell(params.cell);
    require(std::isfinite(params.mu) && std::abs(params.mu) < 0.5 * kPi, kWhat, "mu", params.mu,
            "a barb-plane tilt in (-pi/2, pi/2) rad");
    require(std::isfinite(params.H) && params.H > 0.0, kWhat, "H", params.H,
            "a spacing > 0 (in units of the semi-major axis)");
    require(params.barbules >= 1 && params.barbules <= 100000, kWhat, "barbules", params.barbules,
            "1..100000");
    require(params.cells_per_barbule >= 1 && params.cells_per_barbule <= 100000, kWhat,
            "cells_per_barbule", params.cells_per_barbule, "1..100000");
    require(std::isfinite(params.jitter_phi_rad) && params.jitter_phi_rad >= 0.0 &&
                params.jitter_phi_rad <= 0.5,
            kWhat, "jitter_phi_rad", params.jitter_phi_rad, "a standard deviation in [0, 0.5] rad");
    require(std::isfinite(params.jitter_theta_rad) && params.jitter_theta_rad >= 0.0 &&
                params.jitter_theta_rad <= 0.5,
            kWhat, "jitter_theta_rad", params.jitter_theta_rad,
            "a standard deviation in [0, 0.5] rad");
    if (params.barbules > 1) {
        const double h_min = minimum_spacing(params.cell, params.mu);
        require(params.H >= h_min, kWhat, "H", params.H,
                fmt::format("H >= {:.4f}: closer barbules interpenetrate (their arcs intersect)",
                            h_min));
    }

    BarbuleRow row;
    row.params = params;
    row.cell_film = cell.tessellate(tolerance, false, &row.tessellation);
    row.cell_melanin = cell.tessellate(tolerance, true);

    const double a = params.cell.semi_major_um;
    const Eigen::Vector3d u(std::cos(params.mu), 0.0, std::sin(params.mu));
    const Eigen::Affine3d to_patch(Eigen::AngleAxisd(params.mu, Eigen::Vector3d::UnitY()));
    const Eigen::Vector3d centre =
        0.5 *
        ((params.barbules - 1) * params.H * a * u +
         (params.cells_per_barbule - 1) * params.cell.cell_length_um * Eigen::Vector3d::UnitY());
    row.instances.reserve(static_cast<std::size_t>(params.barbules) * params.cells_per_barbule);
    for (int i = 0; i < params.barbules; ++i) {
        for (int j = 0; j < params.cells_per_barbule; ++j) {
            const std::uint64_t item = static_cast<std::uint64_t>(i) * params.cells_per_barbule + j;
            // One stream per cell from (seed, index): independent of build order.
            std::mt19937_64 rng(derive_seed(params.seed, "barbule_row/jitter", item));
            std::normal_distribution<double> gauss(0.0, 1.0);
            const double dphi = params.jitter_phi_rad * gauss(rng);
            const double dtheta = params.jitter_theta_rad * gauss(rng);
            Eigen::Affine3d t = to_patch;
            t.translate(i * params.H * a * u +
                        j * params.cell.cell_length_um * Eigen::Vector3d::UnitY() - centre);
            t.rotate(Eigen::AngleAxisd(dphi, Eigen::Vector3d::UnitY()));
            t.rotate(Eigen::AngleAxisd(dtheta, Eigen::Vector3d::UnitX()));
            row.instances.push_back(t);
        }
    }
    return row;
}

}  // namespace plumage::geometry
