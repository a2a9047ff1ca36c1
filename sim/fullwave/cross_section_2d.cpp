#include "sim/fullwave/cross_section_2d.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "common/require.h"

namespace plumage::sim::fullwave {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

bool finite(const Eigen::Vector2d& v) { return std::isfinite(v.x()) && std::isfinite(v.y()); }

// Distance from (y0, y1), both >= 0, to the ellipse (x/e0)² + (z/e1)² = 1 with e0 >= e1
// (Eberly 2013, "Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid").
double distance_first_quadrant(double e0, double e1, double y0, double y1) {
    if (y1 > 0.0) {
        if (y0 > 0.0) {
            const double z0 = y0 / e0, z1 = y1 / e1, g = z0 * z0 + z1 * z1 - 1.0;
            if (g == 0.0) return 0.0;
            const double r0 = (e0 / e1) * (e0 / e1), n0 = r0 * z0;
            double s0 = z1 - 1.0, s1 = g < 0.0 ? 0.0 : std::hypot(n0, z1) - 1.0, s = 0.0;
            for (int i = 0; i < 200; ++i) {  // bisection of the root's bracket to rounding
                s = 0.5 * (s0 + s1);
                if (s == s0 || s == s1) break;
                const double a = n0 / (s + r0), b = z1 / (s + 1.0), gs = a * a + b * b - 1.0;
                if (gs > 0.0)
                    s0 = s;
                else if (gs < 0.0)
                    s1 = s;
                else
                    break;
            }
            const double x0 = r0 * y0 / (s + r0), x1 = y1 / (s + 1.0);
            return std::hypot(x0 - y0, x1 - y1);
        }
        return std::abs(y1 - e1);
    }
    const double numer0 = e0 * y0, denom0 = e0 * e0 - e1 * e1;
    if (numer0 < denom0) {
        const double xde0 = numer0 / denom0, x0 = e0 * xde0, x1 = e1 * std::sqrt(1.0 - xde0 * xde0);
        return std::hypot(x0 - y0, x1);
    }
    return std::abs(y0 - e0);
}

// A point in an ellipse's own frame (centre at the origin, axes along x and z).
Eigen::Vector2d to_local(const Eigen::Vector2d& p, const Eigen::Vector2d& centre, double c,
                         double s) {
    const Eigen::Vector2d d = p - centre;
    return {c * d.x() + s * d.y(), -s * d.x() + c * d.y()};
}

Box2d rotated_ellipse_box(const Eigen::Vector2d& centre, double a, double b, double c, double s) {
    const double hx = std::hypot(a * c, b * s), hz = std::hypot(a * s, b * c);
    return {centre - Eigen::Vector2d(hx, hz), centre + Eigen::Vector2d(hx, hz)};
}

class Ellipse final : public Shape2d {
public:
    Ellipse(Eigen::Vector2d centre, double a, double b, double angle)
        : centre_(centre), a_(a), b_(b), angle_(angle), c_(std::cos(angle)), s_(std::sin(angle)) {}
    bool contains(const Eigen::Vector2d& p) const override {
        const Eigen::Vector2d q = to_local(p, centre_, c_, s_);
        return (q.x() / a_) * (q.x() / a_) + (q.y() / b_) * (q.y() / b_) <= 1.0;
    }
    Box2d bounds() const override { return rotated_ellipse_box(centre_, a_, b_, c_, s_); }
    double thinnest_um() const override { return 2.0 * std::min(a_, b_); }
    std::string describe() const override {
        return fmt::format("ellipse ({}, {}) µm at ({}, {}) µm, turned {} rad", a_, b_, centre_.x(),
                           centre_.y(), angle_);
    }

private:
    Eigen::Vector2d centre_;
    double a_, b_, angle_, c_, s_;
};

class EllipseShell final : public Shape2d {
public:
    EllipseShell(Eigen::Vector2d centre, double a, double b, double d, double angle)
        : centre_(centre),
          a_(a),
          b_(b),
          d_(d),
          angle_(angle),
          c_(std::cos(angle)),
          s_(std::sin(angle)) {
        // Ellipses holding the shell E ⊕ disc(d): an ellipse (A, B) holds it when its support
        // function √(A²u_x² + B²u_z²) ≥ h_E(u) + d for every unit u, h_E = √(a²u_x² + b²u_z²)
        // = g(u_x²), g(t) = √(b² + (a² − b²) t) concave, so below its tangent α + β t at any t0:
        // A² = a² + 2d(α + β) + d², B² = b² + 2dα + d² suffice. Tangents at five t0 leave a thin
        // band around the offset curve to the bisection.
        for (const double t0 : {0.0, 0.25, 0.5, 0.75, 1.0}) {
            const double g0 = std::sqrt(b * b + (a * a - b * b) * t0);
            const double beta = (a * a - b * b) / (2.0 * g0), alpha = g0 - beta * t0;
            outer_.push_back({1.0 / (a * a + 2.0 * d * (alpha + beta) + d * d),
                              1.0 / (b * b + 2.0 * d * alpha + d * d)});
        }
    }
    bool contains(const Eigen::Vector2d& p) const override {
        const Eigen::Vector2d q = to_local(p, centre_, c_, s_);
        const double x = std::abs(q.x()), z = std::abs(q.y());
        if (x > a_ + d_ || z > b_ + d_) return false;  // the offset curve lies within a + d, b + d
        if ((x / a_) * (x / a_) + (z / b_) * (z / b_) <= 1.0) return true;
        // Exact bounds spare most points the bisection (a grid's set-up asks millions): the
        // ellipse (a + d, b + d) lies inside the shell (its point at parameter φ is d from the
        // ellipse's point at φ), and the shell inside every ellipse of outer_ (below).
        const double xo = x / (a_ + d_), zo = z / (b_ + d_);
        if (xo * xo + zo * zo <= 1.0) return true;
        for (const auto& [ia2, ib2] : outer_)
            if (x * x * ia2 + z * z * ib2 > 1.0) return false;
        const double dist = a_ >= b_ ? distance_first_quadrant(a_, b_, x, z)
                                     : distance_first_quadrant(b_, a_, z, x);
        return dist <= d_;
    }
    Box2d bounds() const override { return rotated_ellipse_box(centre_, a_ + d_, b_ + d_, c_, s_); }
    double thinnest_um() const override { return d_; }
    std::string describe() const override {
        return fmt::format("ellipse shell ({}, {}) µm + {} µm at ({}, {}) µm, turned {} rad", a_,
                           b_, d_, centre_.x(), centre_.y(), angle_);
    }

private:
    Eigen::Vector2d centre_;
    double a_, b_, d_, angle_, c_, s_;
    std::vector<std::pair<double, double>> outer_;  // (1/A², 1/B²) of the holding ellipses
};

double point_segment_distance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                              const Eigen::Vector2d& b) {
    const Eigen::Vector2d ab = b - a;
    const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    return (a + t * ab - p).norm();
}

// A polygon's thinnest feature (header): the smallest distance from a vertex to a point of an edge
// not touching it, over the pairs that the boundary joins only the long way round — more than
// kDetour times the straight distance along the shorter way. Why: a smooth curve sampled every h
// has each vertex within h of its neighbours' edge (the boundary joins them in about h), which
// is no feature at all; across a body or a gap the boundary must go round (a disc's opposite
// points: π/2 ≈ 1.57 times; a sliver's two sides: its length twice), and a corner's sides count
// where it is sharper than 2·atan(1/kDetour) ≈ 67° (the boundary runs 1/tan(α/2) times the
// distance there). A triangle keeps its heights, as a wedge of any angle.
constexpr double kDetour = 1.5;

double thinnest_feature(const std::vector<Eigen::Vector2d>& v) {
    const std::size_t n = v.size();
    std::vector<double> arc(n + 1, 0.0);  // boundary length from vertex 0 to vertex k
    for (std::size_t k = 0; k < n; ++k) arc[k + 1] = arc[k] + (v[(k + 1) % n] - v[k]).norm();
    const double perimeter = arc[n];
    double thinnest = kInf;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j) {
            const std::size_t k = (j + 1) % n;
            if (j == i || k == i) continue;  // edges touching vertex i
            const Eigen::Vector2d ab = v[k] - v[j];
            const double t = std::clamp((v[i] - v[j]).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
            const double d = (v[j] + t * ab - v[i]).norm();
            const double along = std::abs(arc[j] + t * ab.norm() - arc[i]);
            if (std::min(along, perimeter - along) > kDetour * d) thinnest = std::min(thinnest, d);
        }
    if (n == 3)  // a triangle's heights, whatever its angles
        for (std::size_t i = 0; i < 3; ++i)
            thinnest =
                std::min(thinnest, point_segment_distance(v[i], v[(i + 1) % 3], v[(i + 2) % 3]));
    return thinnest;
}

class Polygon final : public Shape2d {
public:
    explicit Polygon(std::vector<Eigen::Vector2d> v) : v_(std::move(v)) {
        box_ = {v_.front(), v_.front()};
        for (const auto& p : v_) {
            box_.min = box_.min.cwiseMin(p);
            box_.max = box_.max.cwiseMax(p);
        }
        thinnest_ = thinnest_feature(v_);
    }
    bool contains(const Eigen::Vector2d& p) const override {
        if (p.x() < box_.min.x() || p.x() > box_.max.x() || p.y() < box_.min.y() ||
            p.y() > box_.max.y())
            return false;
        bool inside = false;
        for (std::size_t i = 0, j = v_.size() - 1; i < v_.size(); j = i++) {
            const Eigen::Vector2d &a = v_[i], &b = v_[j];
            if ((a.y() > p.y()) != (b.y() > p.y()) &&
                p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
                inside = !inside;
        }
        return inside;
    }
    Box2d bounds() const override { return box_; }
    double thinnest_um() const override { return thinnest_; }
    std::string describe() const override {
        return fmt::format("polygon of {} vertices in x [{}, {}], z [{}, {}] µm", v_.size(),
                           box_.min.x(), box_.max.x(), box_.min.y(), box_.max.y());
    }

private:
    std::vector<Eigen::Vector2d> v_;
    Box2d box_;
    double thinnest_ = 0.0;
};

class Layer final : public Shape2d {
public:
    Layer(double z0, double z1) : z0_(z0), z1_(z1) {}
    bool contains(const Eigen::Vector2d& p) const override { return p.y() >= z0_ && p.y() <= z1_; }
    Box2d bounds() const override { return {{-kInf, z0_}, {kInf, z1_}}; }
    double thinnest_um() const override { return z1_ - z0_; }
    bool is_layer() const override { return true; }
    std::string describe() const override { return fmt::format("layer z [{}, {}] µm", z0_, z1_); }

private:
    double z0_, z1_;
};

void require_positive(double v, std::string_view shape, std::string_view key) {
    require(std::isfinite(v) && v > 0.0, shape, key, v, "a finite length > 0 (µm)");
}

}  // namespace

std::shared_ptr<const Shape2d> ellipse(Eigen::Vector2d centre, double semi_x, double semi_z,
                                       double angle_rad) {
    require(finite(centre), "ellipse", "the centre must be finite");
    require_positive(semi_x, "ellipse", "semi_x");
    require_positive(semi_z, "ellipse", "semi_z");
    require(std::isfinite(angle_rad), "ellipse", "angle", angle_rad, "a finite angle (rad)");
    return std::make_shared<Ellipse>(centre, semi_x, semi_z, angle_rad);
}

std::shared_ptr<const Shape2d> ellipse_shell(Eigen::Vector2d centre, double semi_x, double semi_z,
                                             double thickness, double angle_rad) {
    require(finite(centre), "ellipse shell", "the centre must be finite");
    require_positive(semi_x, "ellipse shell", "semi_x");
    require_positive(semi_z, "ellipse shell", "semi_z");
    require_positive(thickness, "ellipse shell", "thickness");
    require(std::isfinite(angle_rad), "ellipse shell", "angle", angle_rad, "a finite angle (rad)");
    return std::make_shared<EllipseShell>(centre, semi_x, semi_z, thickness, angle_rad);
}

std::shared_ptr<const Shape2d> polygon(std::vector<Eigen::Vector2d> vertices) {
    require(vertices.size() >= 3, "polygon", "at least 3 vertices are needed");
    for (const auto& v : vertices) require(finite(v), "polygon", "every vertex must be finite");
    return std::make_shared<Polygon>(std::move(vertices));
}

std::shared_ptr<const Shape2d> layer(double z_bottom, double z_top) {
    require(std::isfinite(z_top), "layer", "z_top", z_top, "a finite height (µm)");
    require(!std::isnan(z_bottom) && z_bottom < z_top, "layer", "z_bottom", z_bottom,
            fmt::format("a height below z_top = {} µm (or −∞)", z_top));
    return std::make_shared<Layer>(z_bottom, z_top);
}

CrossSection2d barbule_row(double semi_major_um, double b, double film_um, double gap_um,
                           double spacing_um, double tilt_rad, int count) {
    require_positive(semi_major_um, "barbule row", "semi_major_um");
    require(std::isfinite(b) && b > 0.0 && b <= 1.0, "barbule row", "b", b, "an aspect in (0, 1]");
    require_positive(film_um, "barbule row", "film_um");
    require(std::isfinite(gap_um) && gap_um >= 0.0, "barbule row", "gap_um", gap_um,
            "a finite gap >= 0 (µm)");
    require(b * semi_major_um > film_um + gap_um, "barbule row", "b", b,
            fmt::format("a semi-minor axis b·A above film + gap = {:.4g} µm", film_um + gap_um));
    require(std::isfinite(spacing_um) && spacing_um >= 0.0, "barbule row", "spacing_um", spacing_um,
            "a finite spacing >= 0 (µm)");
    require(std::isfinite(tilt_rad), "barbule row", "tilt", tilt_rad, "a finite angle (rad)");
    require(count >= 1 && count <= 1000, "barbule row", "count", count, "1 … 1000 barbules");
    const double core_a = semi_major_um - film_um - gap_um,
                 core_b = b * semi_major_um - film_um - gap_um;
    CrossSection2d row;
    for (int m = 0; m < count; ++m) {
        const Eigen::Vector2d centre((m - 0.5 * (count - 1)) * spacing_um, 0.0);
        row.bodies.push_back({ellipse_shell(centre, core_a, core_b, film_um + gap_um, -tilt_rad),
                              optics::keratin()});
        if (gap_um > 0.0)
            row.bodies.push_back(
                {ellipse_shell(centre, core_a, core_b, gap_um, -tilt_rad), optics::air()});
        row.bodies.push_back({ellipse(centre, core_a, core_b, -tilt_rad), optics::melanin()});
    }
    return row;
}

int CrossSection2d::body_at(const Eigen::Vector2d& p) const {
    for (int i = static_cast<int>(bodies.size()) - 1; i >= 0; --i)
        if (bodies[static_cast<std::size_t>(i)].shape->contains(p)) return i;
    return -1;
}

}  // namespace plumage::sim::fullwave
