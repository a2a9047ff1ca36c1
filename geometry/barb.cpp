#include "geometry/barb.h"

#include <algorithm>
#include <cmath>
#include <string_view>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/require.h"
#include "geometry/elliptical_arc.h"
#include "geometry/random_stream.h"

namespace plumage::geometry {
namespace {

// The name that prefixes this file's input errors.
constexpr std::string_view kWhat = "barb patch";

struct Outline {
    std::vector<Eigen::Vector2d> points;   // counter-clockwise in (y, z)
    std::vector<Eigen::Vector2d> normals;  // outward unit normals
};

// Rotated ellipse: semi-axis `along` in the direction at angle rotation from +z towards
// +y, semi-axis `across` perpendicular to it, centred at centre.
Outline ellipse_outline(double along, double across, double rotation, const Eigen::Vector2d& centre,
                        const TessellationTolerance& tolerance) {
    const EllipticalArc arc(across, along, -kPi, kPi);  // arc x ↦ across (y), arc z ↦ along (z)
    const std::vector<double> phis = sample_normal_azimuths(
        -kPi, kPi, [&](double phi) { return arc.radius_of_curvature(phi); },
        [&](double rho) { return tolerance.max_angular_step(rho); }, nullptr);
    const double c = std::cos(rotation), s = std::sin(rotation);
    auto rotate = [&](const Eigen::Vector2d& v) {
        return Eigen::Vector2d(v.x() * c + v.y() * s, -v.x() * s + v.y() * c);
    };
    Outline out;
    // The arc runs clockwise in (y, z) (top, then +y side); walk it backwards for
    // counter-clockwise, without the duplicated closing point.
    for (std::size_t i = phis.size() - 1; i-- > 0;) {
        out.points.push_back(centre + rotate(arc.point(phis[i])));
        out.normals.push_back(rotate(arc.normal(phis[i])));
    }
    return out;
}

}  // namespace

Barb::Barb(const BarbParams& p) : params_(p) {
    require(std::isfinite(p.barb_width_um) && p.barb_width_um > 0.0, kWhat, "barb_width_um",
            p.barb_width_um, "a finite width > 0 (um)");
    require(
        std::isfinite(p.barb_axis_ratio) && p.barb_axis_ratio >= 0.05 && p.barb_axis_ratio <= 20.0,
        kWhat, "barb_axis_ratio", p.barb_axis_ratio,
        "a vertical/horizontal axis ratio in [0.05, 20] (Padrón-Griffe's barb excentricity)");
    require(std::isfinite(p.barb_rotation_rad), kWhat, "barb_rotation_rad", p.barb_rotation_rad,
            "a finite angle");
    require(std::isfinite(p.medulla_scale) && p.medulla_scale >= 0.0 && p.medulla_scale <= 0.95,
            kWhat, "medulla_scale", p.medulla_scale, "a value in [0, 0.95] (0: no medulla)");
    require(std::isfinite(p.medulla_offset_y_um) && std::isfinite(p.medulla_offset_z_um), kWhat,
            "medulla_offset", p.medulla_offset_y_um, "finite offsets (um)");
    if (has_medulla()) {
        // Every medulla point must lie inside the cortex ellipse, with a wall of at least
        // 0.1 % of the barb width (zero wall leaves coincident surfaces).
        const Outline medulla = ellipse_outline(
            p.medulla_scale * vertical_semi_axis_um(), p.medulla_scale * horizontal_semi_axis_um(),
            p.barb_rotation_rad, {p.medulla_offset_y_um, p.medulla_offset_z_um},
            {1e-3 * std::min(vertical_semi_axis_um(), horizontal_semi_axis_um()), 0.05});
        const double c = std::cos(p.barb_rotation_rad), s = std::sin(p.barb_rotation_rad);
        for (const Eigen::Vector2d& q : medulla.points) {
            // Back into the cortex's axis frame: along (vertical) and across (horizontal).
            const double along = q.x() * s + q.y() * c, across = q.x() * c - q.y() * s;
            const double level =
                std::hypot(along / vertical_semi_axis_um(), across / horizontal_semi_axis_um());
            require(level < 1.0 - 2e-3, kWhat, "medulla_offset",
                    std::hypot(p.medulla_offset_y_um, p.medulla_offset_z_um),
                    fmt::format(
                        "a medulla strictly inside the cortex (scale {} with this offset reaches "
                        "{:.3f} of the cortex radius)",
                        p.medulla_scale, level));
        }
    }
}

Eigen::Vector2d Barb::distal_root_um() const {
    // The support point in direction +y of the ellipse with semi-axis a_v along u_v = (sin ρ,
    // cos ρ) and a_h along u_h = (cos ρ, −sin ρ): ∇h(ŷ) with h(n) = √(a_v² (n·u_v)² + a_h²
    // (n·u_h)²).
    const double av = vertical_semi_axis_um(), ah = horizontal_semi_axis_um();
    const double s = std::sin(params_.barb_rotation_rad), c = std::cos(params_.barb_rotation_rad);
    const double ry = std::sqrt(av * av * s * s + ah * ah * c * c);
    return {ry, (av * av - ah * ah) * s * c / ry};
}

std::vector<Eigen::Vector2d> Barb::cortex_outline(const TessellationTolerance& tolerance) const {
    return ellipse_outline(vertical_semi_axis_um(), horizontal_semi_axis_um(),
                           params_.barb_rotation_rad, {0.0, 0.0}, tolerance)
        .points;
}

std::vector<Eigen::Vector2d> Barb::medulla_outline(const TessellationTolerance& tolerance) const {
    if (!has_medulla()) return {};
    return ellipse_outline(params_.medulla_scale * vertical_semi_axis_um(),
                           params_.medulla_scale * horizontal_semi_axis_um(),
                           params_.barb_rotation_rad,
                           {params_.medulla_offset_y_um, params_.medulla_offset_z_um}, tolerance)
        .points;
}

namespace {

// The barb's axis: straight along x over length_um, or bent in the x–z plane about a centre
// axis_radius_um below it. A ring of the sweep sits at alpha: the bend angle, or the axial
// fraction in [-0.5, 0.5] when straight.
struct SweepAxis {
    double length_um, radius_um;
    bool bent() const { return radius_um > 0.0; }
    Vec3 place(double alpha, const Eigen::Vector2d& yz) const {
        if (!bent()) return {alpha * length_um, yz.x(), yz.y()};
        const double r = radius_um + yz.y();
        return {r * std::sin(alpha), yz.x(), r * std::cos(alpha) - radius_um};
    }
    Vec3 place_normal(double alpha, const Eigen::Vector2d& n) const {
        if (!bent()) return {0.0, n.x(), n.y()};
        return {n.y() * std::sin(alpha), n.x(), n.y() * std::cos(alpha)};
    }
    Vec3 tangent(double alpha) const {
        return bent() ? Vec3(std::cos(alpha), 0.0, -std::sin(alpha)) : Vec3(1.0, 0.0, 0.0);
    }
    // The rings: both ends when straight; bent, as many as keep each segment's chord within
    // the tolerance at the outline's innermost reach.
    std::vector<double> rings(const Outline& outline,
                              const TessellationTolerance& tolerance) const {
        require(std::isfinite(length_um) && length_um > 0.0, kWhat, "length_um", length_um,
                "a finite length > 0");
        require(std::isfinite(radius_um) && radius_um >= 0.0, kWhat, "axis_radius_um", radius_um,
                "0 (straight) or a bend radius > 0 (um)");
        if (!bent()) return {-0.5, 0.5};
        double extent = 0.0;
        for (const auto& p : outline.points) extent = std::max(extent, std::abs(p.y()));
        require(radius_um > extent, kWhat, "axis_radius_um", radius_um,
                fmt::format(
                    "a bend radius larger than the cross-section's reach {:.4g} um (else the tube "
                    "folds on its inner side)",
                    extent));
        const double half = 0.5 * length_um / radius_um;
        require(half < kPi, kWhat, "length_um", length_um, "a bent barb shorter than a full turn");
        const double step = tolerance.max_angular_step(radius_um - extent);
        const int segments = std::max(1, static_cast<int>(std::ceil(2.0 * half / step)));
        std::vector<double> alphas;
        for (int k = 0; k <= segments; ++k) alphas.push_back(-half + 2.0 * half * k / segments);
        return alphas;
    }
};

// End caps: fans around the outline's centroid, with their own flat-normal vertices.
void add_end_caps(TriangleMesh& mesh, const Outline& outline, const SweepAxis& axis,
                  const std::vector<double>& alphas) {
    const auto m = static_cast<std::uint32_t>(outline.points.size());
    Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
    for (const auto& p : outline.points) centroid += p;
    centroid /= static_cast<double>(m);
    for (int end = 0; end < 2; ++end) {
        const double alpha = end == 0 ? alphas.front() : alphas.back();
        const Vec3 normal = (end == 0 ? -1.0 : 1.0) * axis.tangent(alpha);
        const auto base = static_cast<std::uint32_t>(mesh.positions.size());
        mesh.positions.push_back(axis.place(alpha, centroid));
        mesh.shading_normals.push_back(normal);
        for (std::uint32_t i = 0; i < m; ++i) {
            mesh.positions.push_back(axis.place(alpha, outline.points[i]));
            mesh.shading_normals.push_back(normal);
        }
        for (std::uint32_t i = 0; i < m; ++i) {
            const std::uint32_t a = base + 1 + i, b = base + 1 + (i + 1) % m;
            mesh.triangles.push_back(end == 0 ? Triangle{base, a, b} : Triangle{base, b, a});
        }
    }
}

TriangleMesh sweep(const Outline& outline, double length_um, double axis_radius_um,
                   const TessellationTolerance& tolerance) {
    const SweepAxis axis{length_um, axis_radius_um};
    const std::vector<double> alphas = axis.rings(outline, tolerance);
    TriangleMesh mesh;
    const auto m = static_cast<std::uint32_t>(outline.points.size());
    for (double alpha : alphas) {
        for (std::uint32_t i = 0; i < m; ++i) {
            mesh.positions.push_back(axis.place(alpha, outline.points[i]));
            mesh.shading_normals.push_back(axis.place_normal(alpha, outline.normals[i]));
        }
    }
    for (std::uint32_t k = 0; k + 1 < alphas.size(); ++k) {
        for (std::uint32_t i = 0; i < m; ++i) {
            const std::uint32_t j = (i + 1) % m;
            const std::uint32_t a = k * m + i, b = k * m + j, c = (k + 1) * m + j,
                                d = (k + 1) * m + i;
            mesh.triangles.push_back({a, c, b});
            mesh.triangles.push_back({a, d, c});
        }
    }
    add_end_caps(mesh, outline, axis, alphas);
    // Make the winding outward: positive enclosed volume (divergence theorem).
    double volume = 0.0;
    for (const Triangle& t : mesh.triangles) {
        volume += mesh.positions[t[0]].dot(mesh.positions[t[1]].cross(mesh.positions[t[2]])) / 6.0;
    }
    if (volume < 0.0) {
        for (Triangle& t : mesh.triangles) std::swap(t[1], t[2]);
    }
    return mesh;
}

}  // namespace

TriangleMesh Barb::cortex_mesh(double length_um, double axis_radius_um,
                               const TessellationTolerance& tolerance) const {
    tolerance.validate();
    return sweep(ellipse_outline(vertical_semi_axis_um(), horizontal_semi_axis_um(),
                                 params_.barb_rotation_rad, {0.0, 0.0}, tolerance),
                 length_um, axis_radius_um, tolerance);
}

TriangleMesh Barb::medulla_mesh(double length_um, double axis_radius_um,
                                const TessellationTolerance& tolerance) const {
    tolerance.validate();
    if (!has_medulla()) return {};
    return sweep(ellipse_outline(
                     params_.medulla_scale * vertical_semi_axis_um(),
                     params_.medulla_scale * horizontal_semi_axis_um(), params_.barb_rotation_rad,
                     {params_.medulla_offset_y_um, params_.medulla_offset_z_um}, tolerance),
                 length_um, axis_radius_um, tolerance);
}

TriangleMesh sweep_closed_outline(const std::vector<Eigen::Vector2d>& outline, double length_um,
                                  double axis_radius_um, const TessellationTolerance& tolerance) {
    require(outline.size() >= 3, kWhat, "outline points", static_cast<double>(outline.size()),
            "at least 3");
    Outline o{outline, {}};
    const std::size_t m = outline.size();
    for (std::size_t i = 0; i < m; ++i) {
        const Eigen::Vector2d edge = outline[(i + 1) % m] - outline[(i + m - 1) % m];
        o.normals.emplace_back(
            Eigen::Vector2d(edge.y(), -edge.x()).normalized());  // CCW: right of the edge is out
    }
    return sweep(o, length_um, axis_radius_um, tolerance);
}

void validate_patch_params(const BarbulePatchParams& p, std::string_view what,
                           bool allow_no_barbules) {
    const Barb barb(p.barb);  // the barb's own checks
    require(std::isfinite(p.barbule_width_um) && p.barbule_width_um > 0.0, what, "barbule_width_um",
            p.barbule_width_um, "a finite width > 0 (um)");
    require(std::isfinite(p.barbule_axis_ratio) && p.barbule_axis_ratio >= 0.05 &&
                p.barbule_axis_ratio <= 20.0,
            what, "barbule_axis_ratio", p.barbule_axis_ratio,
            "a thickness/width ratio in [0.05, 20] (Padrón-Griffe's barbule excentricity)");
    require(std::isfinite(p.barbule_rotation_rad) && p.barbule_rotation_rad >= 0.0 &&
                p.barbule_rotation_rad <= kPi,
            what, "barbule_rotation_rad", p.barbule_rotation_rad,
            "the barbules' direction in the vane from the barb axis, in [0, pi]");
    require(
        std::isfinite(p.barbule_inclination_rad) && std::abs(p.barbule_inclination_rad) < 0.5 * kPi,
        what, "barbule_inclination_rad", p.barbule_inclination_rad, "an angle in (-pi/2, pi/2)");
    require(std::isfinite(p.barbule_length) &&
                (allow_no_barbules ? p.barbule_length >= 0.0 : p.barbule_length > 0.0) &&
                p.barbule_length <= 1000.0,
            what, "barbule_length", p.barbule_length,
            allow_no_barbules
                ? "a length in [0, 1000] (each barbule length x barb width / 2; 0: no barbules)"
                : "a length in (0, 1000] (each barbule is length x barb width / 2)");
    require(std::isfinite(p.barbule_separation) && p.barbule_separation >= 0.0 &&
                p.barbule_separation <= 1e6,
            what, "barbule_separation", p.barbule_separation,
            "a gap >= 0 between barbule fibres, in barbule widths");
    const double automatic = p.automatic_period_um() / p.barb.barb_width_um;
    require(std::isfinite(p.barb_spacing) &&
                (p.barb_spacing == 0.0 || p.barb_spacing >= automatic * (1.0 - 1e-12)),
            what, "barb_spacing", p.barb_spacing,
            fmt::format("0 (automatic: neighbouring barbules meet) or at least {:.6g} barb widths "
                        "(closer barbs would cross their barbules)",
                        automatic));
}

double BarbulePatchParams::automatic_period_um() const {
    const Barb b(barb);
    return 2.0 * b.distal_root_um().x() +
           2.0 * barbule_length_um() * std::cos(barbule_inclination_rad);
}

double BarbulePatchParams::barbule_fibre_length_um() const {
    const double ci = std::cos(barbule_inclination_rad), si = std::sin(barbule_inclination_rad);
    const double h = 0.5 * barbule_axis_ratio * barbule_width_um;
    // The tip face's outer corner reaches y = r_y + ℓ cos i + h |sin i|; it must stay within
    // half a period of its barb.
    const double room = 0.5 * period_um() - Barb(barb).distal_root_um().x() - h * std::abs(si);
    return std::max(0.0, std::min(barbule_length_um(), room / ci));
}

double BarbulePatchParams::period_um() const {
    return barb_spacing > 0.0 ? barb_spacing * barb.barb_width_um : automatic_period_um();
}

PatchCrossSection build_patch_cross_section(const BarbulePatchParams& params,
                                            const TessellationTolerance& tolerance) {
    tolerance.validate();
    validate_patch_params(params, kWhat);
    const Barb barb(params.barb);
    PatchCrossSection section;
    const auto cortex = barb.cortex_outline(tolerance);
    section.shapes.push_back({SurfaceRole::barb_cortex, cortex});
    if (barb.has_medulla())
        section.shapes.push_back({SurfaceRole::barb_medulla, barb.medulla_outline(tolerance)});
    // The cut of a barbule fibre through its axis: a strip as thick as the fibre (the barb-level
    // model of the authors' masking/barbs.h uses segments: thickness 0).
    const double half = 0.5 * params.barbule_axis_ratio * params.barbule_width_um;
    const double length = params.barbule_fibre_length_um();
    const Eigen::Vector2d root = barb.distal_root_um();
    for (double side : {1.0, -1.0}) {
        // The proximal root is the cortex point furthest along −y: the distal one
        // reflected through the centre (an ellipse is point-symmetric), which differs
        // from its mirror image in y when the barb is rotated.
        const Eigen::Vector2d start = side * root;
        const Eigen::Vector2d d(side * std::cos(params.barbule_inclination_rad),
                                std::sin(params.barbule_inclination_rad));
        const Eigen::Vector2d m(-d.y(), d.x());
        std::vector<Eigen::Vector2d> strip = {start - half * m, start + length * d - half * m,
                                              start + length * d + half * m, start + half * m};
        // Right edge out, left edge back: counter-clockwise for either direction of d.
        section.shapes.push_back({SurfaceRole::barbule, strip});
    }
    section.period_um = params.period_um();
    return section;
}

std::size_t BarbulePatch::memory_bytes() const {
    return sizeof(*this) + barb_cortex.memory_bytes() + barb_medulla.memory_bytes() +
           barbule.memory_bytes() +
           (barb_instances.capacity() + barbule_instances.capacity()) * sizeof(Eigen::Affine3d);
}

namespace {

bool inside_polygon(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p) {
    bool inside = false;
    for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
        const Eigen::Vector2d& a = polygon[i];
        const Eigen::Vector2d& b = polygon[j];
        if ((a.y() > p.y()) != (b.y() > p.y()) &&
            p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) {
            inside = !inside;
        }
    }
    return inside;
}

}  // namespace

double barbule_root_clearance_um(const PatchCrossSection& section) {
    const std::vector<Eigen::Vector2d>* cortex = nullptr;
    for (const auto& shape : section.shapes) {
        if (shape.role == SurfaceRole::barb_cortex) cortex = &shape.polygon;
    }
    PLUMAGE_CHECK(cortex != nullptr, "a patch cross-section has a cortex");
    double clearance = 0.0;
    for (const auto& shape : section.shapes) {  // distal and proximal strips
        if (shape.role != SurfaceRole::barbule) continue;
        const auto& strip = shape.polygon;
        PLUMAGE_CHECK(strip.size() == 4, "a barbule strip has four corners");
        const Eigen::Vector2d d = (strip[1] - strip[0]).normalized();
        // The whole root face, not only its corners: a chord between two outside points can
        // still cut a convex outline.
        auto clear = [&](double shift) {
            for (int k = 0; k <= 32; ++k) {
                const Eigen::Vector2d p = strip[0] + (k / 32.0) * (strip[3] - strip[0]) + shift * d;
                if (inside_polygon(*cortex, p)) return false;
            }
            return true;
        };
        if (clear(0.0)) continue;
        double lo = 0.0, hi = 1.0;
        while (!clear(hi)) hi *= 2.0;
        for (int k = 0; k < 60; ++k) (clear(0.5 * (lo + hi)) ? hi : lo) = 0.5 * (lo + hi);
        clearance = std::max(clearance, 1.01 * hi + 0.01);
    }
    return clearance;
}

BarbulePatch build_barbule_patch(const BarbulePatchParams& params, double length_x_um, int barbs,
                                 const TessellationTolerance& tolerance) {
    tolerance.validate();
    validate_patch_params(params, kWhat);
    require(barbs >= 1 && barbs <= 10000, kWhat, "barbs", barbs, "1..10000");
    require(std::abs(params.barbule_rotation_rad - 0.5 * kPi) <= 1e-9, kWhat,
            "barbule_rotation_rad", params.barbule_rotation_rad,
            "pi/2 (90 deg) for the explicit patch: it builds barbules perpendicular to the barb; "
            "other directions exist in the analytic model only");
    const Barb barb(params.barb);
    BarbulePatch patch;
    patch.params = params;
    patch.barb_cortex = barb.cortex_mesh(length_x_um, 0.0, tolerance);
    patch.barb_medulla = barb.medulla_mesh(length_x_um, 0.0, tolerance);

    const PatchCrossSection section = build_patch_cross_section(params, tolerance);
    patch.root_clearance_um = barbule_root_clearance_um(section);
    const double length = params.barbule_fibre_length_um() - patch.root_clearance_um;
    require(length > 0.0, kWhat, "barbule_length", params.barbule_length,
            fmt::format("barbules longer than the {:.4g} um they must start away from the cortex "
                        "(their roots would lie inside it)",
                        patch.root_clearance_um));

    // One barbule: its elliptical fibre (thickness along the outline's z, width along its y)
    // swept along local +x, then turned to run along +y (the outline's y becomes −x, the barb
    // axis) and tilted up by the inclination. It starts root_clearance_um out along its axis and
    // ends where the authors' barbule ends (less the tip overlap, barbule_fibre_length_um), so
    // the period is the authors'.
    const Outline fibre =
        ellipse_outline(0.5 * params.barbule_axis_ratio * params.barbule_width_um,
                        0.5 * params.barbule_width_um, 0.0, {0.0, 0.0}, tolerance);
    TriangleMesh barbule = sweep(fibre, length, 0.0, tolerance);
    const Eigen::Affine3d orient =
        Eigen::AngleAxisd(params.barbule_inclination_rad, Vec3::UnitX()) *
        Eigen::AngleAxisd(0.5 * kPi, Vec3::UnitZ()) * Eigen::Translation3d(0.5 * length, 0.0, 0.0);
    for (Vec3& p : barbule.positions) p = orient * p;
    for (Vec3& n : barbule.shading_normals) n = orient.linear() * n;
    patch.barbule = std::move(barbule);

    const Eigen::Vector2d root = barb.distal_root_um();
    const double ci = std::cos(params.barbule_inclination_rad);
    const double si = std::sin(params.barbule_inclination_rad);
    patch.period_um = params.period_um();
    // Each barbule moved out along its own axis, (0, cos i, sin i) in the unit mesh.
    const Eigen::Translation3d clearance(0.0, patch.root_clearance_um * ci,
                                         patch.root_clearance_um * si);
    // Rows of fibres along x with the authors' pitch; each row (a barb's distal or proximal side)
    // starts at its own random phase (a fixed stream per row index), so that across the barbs of
    // a patch a ray crossing two rows meets independent positions in them, as the analytic term
    // assumes when it multiplies the rows' transmittances. A regular sequence of phases would give
    // every pair of neighbouring rows the same relative phase.
    const double pitch = params.barbule_pitch_um();
    const int per_side = std::max(1, static_cast<int>(std::floor(length_x_um / pitch)));
    auto row_phase = [](int row) {
        constexpr std::uint64_t kRowPhaseSeed = 0x5047'3230'3234ull;  // "PG2024", fixed
        auto rng = detail::seeded_stream(kRowPhaseSeed, static_cast<std::uint64_t>(row), 0);
        return detail::uniform01(rng) - 0.5;  // in [−1/2, 1/2) pitches
    };
    for (int k = 0; k < barbs; ++k) {
        const double y = (k - 0.5 * (barbs - 1)) * patch.period_um;
        patch.barb_instances.emplace_back(Eigen::Translation3d(0.0, y, 0.0));
        for (int side = 0; side < 2; ++side) {
            const double phase = row_phase(2 * k + side) * pitch;
            for (int j = 0; j < per_side; ++j) {
                const double x = (j - 0.5 * (per_side - 1)) * pitch + phase;
                if (side == 0) {
                    patch.barbule_instances.emplace_back(
                        Eigen::Translation3d(x, y + root.x(), root.y()) * clearance);
                } else {
                    // Proximal: the distal barbule turned by π about z (runs towards −y, still
                    // rising), rooted at the point reflection of the distal root.
                    patch.barbule_instances.emplace_back(
                        Eigen::Translation3d(x, y - root.x(), -root.y()) *
                        Eigen::AngleAxisd(kPi, Vec3::UnitZ()) * clearance);
                }
            }
        }
    }
    return patch;
}

}  // namespace plumage::geometry
