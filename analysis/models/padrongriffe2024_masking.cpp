#include "analysis/models/padrongriffe2024_masking.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/require.h"

namespace plumage::analysis {
namespace {

// The name that prefixes this file's input errors.
constexpr std::string_view kWhat = "Padrón-Griffe 2024 masking";

struct Box {
    double y0, y1, z0, z1;
    bool overlaps(const Box& o, double dy, double margin) const {
        return y0 <= o.y1 + dy + margin && o.y0 + dy <= y1 + margin && z0 <= o.z1 + margin &&
               o.z0 <= z1 + margin;
    }
};

Box corners_box(const std::array<Eigen::Vector2d, 4>& c) {
    Box b{c[0].x(), c[0].x(), c[0].y(), c[0].y()};
    for (const auto& p : c) {
        b.y0 = std::min(b.y0, p.x());
        b.y1 = std::max(b.y1, p.x());
        b.z0 = std::min(b.z0, p.y());
        b.z1 = std::max(b.z1, p.y());
    }
    return b;
}

}  // namespace

double MaskingFractions::operator[](MaskingComponent c) const {
    switch (c) {
        case MaskingComponent::kBarb:
            return barb;
        case MaskingComponent::kDistalBarbule:
            return distal_barbule;
        case MaskingComponent::kProximalBarbule:
            return proximal_barbule;
        case MaskingComponent::kGap:
            return gap;
    }
    throw InvariantError("MaskingFractions: unknown component");
}

// A shape's image in (u, t) for one direction: its interval of u and its upper boundary, either
// the closed-form elliptic arc or the upper hull of a parallelogram (u increasing).
struct PadronGriffe2024Masking::ShapeImage {
    MaskingComponent component;
    double lo, hi;
    bool elliptic;
    double uc = 0.0, tc = 0.0, s11 = 0.0, s12 = 0.0, det = 0.0;  // ellipse
    std::vector<Eigen::Vector2d> hull;                           // parallelogram

    // Upper boundary at u for the copy shifted by (du, dt); false when u is outside.
    bool front(double u, double du, double dt, double& t) const {
        const double x = u - du;
        if (x < lo || x > hi) return false;
        if (elliptic) {
            const double v = x - uc;
            t = dt + tc + (s12 * v + std::sqrt(std::max(0.0, det * (s11 - v * v)))) / s11;
            return true;
        }
        for (std::size_t j = 0; j + 1 < hull.size(); ++j) {
            const double ua = hull[j].x(), ub = hull[j + 1].x();
            if (x <= ub || j + 2 == hull.size()) {
                const double w = ub > ua ? std::clamp((x - ua) / (ub - ua), 0.0, 1.0) : 1.0;
                t = dt + hull[j].y() + w * (hull[j + 1].y() - hull[j].y());
                return true;
            }
        }
        t = dt + hull.front().y();  // a single point
        return true;
    }
};

PadronGriffe2024Masking::PadronGriffe2024Masking(const geometry::BarbulePatchParams& params,
                                                 BarbuleStrips strips)
    : params_(params), strips_(strips) {
    geometry::validate_patch_params(params_, kWhat, /*allow_no_barbules=*/true);
    const geometry::Barb barb(params_.barb);
    vertical_semi_axis_ = barb.vertical_semi_axis_um();      // along u_a = (sin ρ, cos ρ)
    horizontal_semi_axis_ = barb.horizontal_semi_axis_um();  // along u_b = (cos ρ, −sin ρ)
    const double s = std::sin(params_.barb.barb_rotation_rad);
    const double c = std::cos(params_.barb.barb_rotation_rad);
    const double a2 = vertical_semi_axis_ * vertical_semi_axis_,
                 b2 = horizontal_semi_axis_ * horizontal_semi_axis_;
    root_ = barb.distal_root_um();
    const double ry = root_.x();

    // The authors' barb-level model cuts barbules as segments (masking/barbs.h); the explicit
    // geometry's fibres are as thick as the fibre (geometry/barb.cpp).
    half_thickness_ = strips_ == BarbuleStrips::kSegments
                          ? 0.0
                          : 0.5 * params_.barbule_axis_ratio * params_.barbule_width_um;
    length_ = strips_ == BarbuleStrips::kSegments ? params_.barbule_length_um()
                                                  : params_.barbule_fibre_length_um();
    const double ci = std::cos(params_.barbule_inclination_rad);
    const double si = std::sin(params_.barbule_inclination_rad);
    period_um_ = params_.period_um();

    // The barbules' frames (masking/feather-base.h FeatherBase, in our patch frame): the distal
    // (right) barbule's axis (cos i cos r, cos i sin r, sin i), the proximal (left) one's
    // (cos i cos r, −cos i sin r, sin i); across = normalise(z × axis), layer normal = axis ×
    // across.
    const double r = params_.barbule_rotation_rad;
    for (int side = 0; side < 2; ++side) {
        const double sign = side == 0 ? 1.0 : -1.0;
        const Vec3d axis(ci * std::cos(r), sign * ci * std::sin(r), si);
        const Vec3d across = Vec3d::UnitZ().cross(axis).normalized();
        row_axis_[side] = axis;
        row_across_[side] = across;
        row_normal_[side] = axis.cross(across);
    }

    for (double side : {1.0, -1.0}) {
        const Eigen::Vector2d start =
            side * root_;  // proximal root: point reflection (geometry/barb.cpp)
        const Eigen::Vector2d d(side * ci, si);
        const Eigen::Vector2d m(-d.y(), d.x());
        const std::array<Eigen::Vector2d, 4> corners = {
            start - half_thickness_ * m, start + length_ * d - half_thickness_ * m,
            start + length_ * d + half_thickness_ * m, start + half_thickness_ * m};
        (side > 0.0 ? distal_corners_ : proximal_corners_) = corners;
    }

    // Pairs of base shapes whose upper boundaries may cross: bounding boxes that overlap.
    if (has_barbules()) {
        const double z_extent = std::sqrt(a2 * c * c + b2 * s * s);
        const std::array<Box, 3> boxes = {Box{-ry, ry, -z_extent, z_extent},
                                          corners_box(distal_corners_),
                                          corners_box(proximal_corners_)};
        double reach = 0.0;
        for (const Box& b : boxes) reach = std::max({reach, std::abs(b.y0), std::abs(b.y1)});
        const int max_offset = static_cast<int>(std::ceil(2.0 * reach / period_um_)) + 1;
        const double margin = 1e-9 * (period_um_ + length_ + vertical_semi_axis_);
        for (int i = 0; i < 3; ++i) {
            for (int j = i; j < 3; ++j) {
                for (int dk = -max_offset; dk <= max_offset; ++dk) {
                    if (i == j && dk <= 0) continue;  // a shape against itself, or counted twice
                    if (i == 0 && j == 0)
                        continue;  // barb ellipses never overlap (spacing >= width)
                    if (boxes[i].overlaps(boxes[j], dk * period_um_, margin))
                        overlapping_.push_back({i, j, dk});
                }
            }
        }
    }
}

std::vector<PadronGriffe2024Masking::ShapeImage> PadronGriffe2024Masking::images(
    double theta) const {
    const double sn = std::sin(theta), cs = std::cos(theta), tn = sn / cs;
    auto map = [&](const Eigen::Vector2d& p) {
        return Eigen::Vector2d(p.x() - p.y() * tn, p.x() * sn + p.y() * cs);
    };
    std::vector<ShapeImage> out;

    // The barb: image of the semi-axis vectors a u_a and b u_b (the map's linear part).
    const double rs = std::sin(params_.barb.barb_rotation_rad),
                 rc = std::cos(params_.barb.barb_rotation_rad);
    const Eigen::Vector2d col1 =
        map(Eigen::Vector2d(vertical_semi_axis_ * rs, vertical_semi_axis_ * rc));
    const Eigen::Vector2d col2 =
        map(Eigen::Vector2d(horizontal_semi_axis_ * rc, -horizontal_semi_axis_ * rs));
    ShapeImage barb{MaskingComponent::kBarb, 0.0, 0.0, true, 0.0, 0.0, 0.0, 0.0, 0.0, {}};
    barb.s11 = col1.x() * col1.x() + col2.x() * col2.x();
    barb.s12 = col1.x() * col1.y() + col2.x() * col2.y();
    const double det_m = col1.x() * col2.y() - col2.x() * col1.y();
    barb.det = det_m * det_m;
    const double half_width = std::sqrt(barb.s11);
    barb.lo = -half_width;
    barb.hi = half_width;
    out.push_back(barb);

    if (!has_barbules()) return out;
    for (int side = 0; side < 2; ++side) {
        const auto& corners = side == 0 ? distal_corners_ : proximal_corners_;
        std::vector<Eigen::Vector2d> pts;
        for (const auto& p : corners) pts.push_back(map(p));
        // Upper hull (monotone chain) in (u, t): among equal u keep the highest t.
        std::sort(pts.begin(), pts.end(), [](const auto& p, const auto& q) {
            return p.x() < q.x() || (p.x() == q.x() && p.y() > q.y());
        });
        std::vector<Eigen::Vector2d> hull;
        for (const auto& p : pts) {
            if (!hull.empty() && p.x() == hull.back().x()) continue;
            while (hull.size() >= 2) {
                const Eigen::Vector2d& o = hull[hull.size() - 2];
                const Eigen::Vector2d& a = hull.back();
                const double cross =
                    (a.x() - o.x()) * (p.y() - o.y()) - (a.y() - o.y()) * (p.x() - o.x());
                if (cross >= 0.0)
                    hull.pop_back();  // a lies on or below o→p
                else
                    break;
            }
            hull.push_back(p);
        }
        ShapeImage strip{
            side == 0 ? MaskingComponent::kDistalBarbule : MaskingComponent::kProximalBarbule,
            hull.front().x(),
            hull.back().x(),
            false,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            std::move(hull)};
        out.push_back(std::move(strip));
    }
    return out;
}

namespace {

// Where two upper boundaries are equal, within [lo, hi]: each piece is a line or an elliptic arc.
struct Line {
    double u0, u1, alpha, beta;  // t = alpha + beta u on [u0, u1]
};

void line_line(const Line& a, const Line& b, double lo, double hi, std::vector<double>& out) {
    const double db = a.beta - b.beta;
    if (std::abs(db) < 1e-14 * (1.0 + std::abs(a.beta) + std::abs(b.beta))) return;  // parallel
    const double u = (b.alpha - a.alpha) / db;
    if (u >= std::max({a.u0, b.u0, lo}) && u <= std::min({a.u1, b.u1, hi})) out.push_back(u);
}

// Line t = alpha + beta u against the upper arc t = tc + (s12 v + √(det (s11 − v²)))/s11, v = u −
// uc. Squaring s11 g + q v = √(det (s11 − v²)) (g = alpha + beta uc − tc, q = s11 beta − s12) gives
// (q² + det) v² + 2 s11 g q v + s11² g² − det s11 = 0; roots on the lower branch are harmless
// extra breakpoints.
void line_arc(const Line& a, double uc, double tc, double s11, double s12, double det, double lo,
              double hi, std::vector<double>& out) {
    const double g = a.alpha + a.beta * uc - tc;
    const double q = s11 * a.beta - s12;
    const double r = s11 * g;
    const double qa = q * q + det;
    const double disc = det * (q * q * s11 - r * r + det * s11);
    if (disc < 0.0) return;
    const double root = std::sqrt(disc);
    const double w = std::sqrt(s11);
    for (double v : {(-r * q + root) / qa, (-r * q - root) / qa}) {
        const double u = uc + v;
        if (std::abs(v) <= w && u >= std::max(a.u0, lo) && u <= std::min(a.u1, hi))
            out.push_back(u);
    }
}

// A shape image's upper hull as lines, for the copy moved by (du, dt) in (u, t).
template <class Shape>
std::vector<Line> upper_lines(const Shape& shape, double du, double dt) {
    std::vector<Line> lines;
    for (std::size_t j = 0; j + 1 < shape.hull.size(); ++j) {
        const Eigen::Vector2d& a = shape.hull[j];
        const Eigen::Vector2d& b = shape.hull[j + 1];
        if (!(b.x() > a.x())) continue;
        const double beta = (b.y() - a.y()) / (b.x() - a.x());
        lines.push_back({a.x() + du, b.x() + du, a.y() + dt - beta * (a.x() + du), beta});
    }
    return lines;
}

// What a ray meeting `met` (front first) shares out: a barb stops the ray; a barbule row stops
// the fraction 1 − T of what reaches it and lets T through (the authors' Barbs::masking with
// the rows' transparencies); what passes everything is the gap's.
std::array<double, kMaskingComponentCount> shares_along(
    const std::vector<std::pair<double, MaskingComponent>>& met, const RowTransmittance& rows) {
    std::array<double, kMaskingComponentCount> share{};
    double remaining = 1.0;
    for (const auto& [t, component] : met) {
        if (component == MaskingComponent::kBarb) {
            share[0] += remaining;
            remaining = 0.0;
            break;
        }
        const double through =
            component == MaskingComponent::kDistalBarbule ? rows.distal : rows.proximal;
        share[static_cast<int>(component)] += remaining * (1.0 - through);
        remaining *= through;
    }
    share[static_cast<int>(MaskingComponent::kGap)] += remaining;
    return share;
}

// The segment, or the last one extended to its end when it continues it (same owner, shares).
void append_segment(std::vector<MaskingSegment>& segments, const MaskingSegment& next) {
    if (!segments.empty() && segments.back().component == next.component &&
        segments.back().share == next.share && segments.back().u1_um == next.u0_um) {
        segments.back().u1_um = next.u1_um;
    } else {
        segments.push_back(next);
    }
}

void check_view_angle(double theta) {
    const double cs = std::cos(theta);
    if (!std::isfinite(theta) ||
        std::abs(cs) < PadronGriffe2024Masking::kMinimumCosine * (1.0 - 1e-9)) {
        throw InputError(
            fmt::format("Padrón-Griffe 2024 masking: view angle = {} rad: expected a finite angle "
                        "at least 0.1 deg "
                        "away from the patch plane (|cos| >= {:.6g})",
                        theta, PadronGriffe2024Masking::kMinimumCosine));
    }
}

}  // namespace

std::vector<MaskingSegment> PadronGriffe2024Masking::partition(double theta,
                                                               const RowTransmittance& rows) const {
    check_view_angle(theta);
    const double p = period_um_;
    const double shift_t = p * std::sin(theta);  // a barb further along +y, seen in (u, t)
    const std::vector<ShapeImage> shapes = images(theta);

    // Copies that reach u ∈ [0, P]: barb k of shape s for k in [k_lo[s], k_hi[s]].
    std::vector<int> k_lo(shapes.size()), k_hi(shapes.size());
    for (std::size_t s = 0; s < shapes.size(); ++s) {
        k_lo[s] = static_cast<int>(std::ceil(-shapes[s].hi / p));
        k_hi[s] = static_cast<int>(std::floor((p - shapes[s].lo) / p));
    }

    std::vector<double> breaks = {0.0, p};
    auto add_break = [&](double u) {
        if (u > 0.0 && u < p) breaks.push_back(u);
    };
    for (std::size_t s = 0; s < shapes.size(); ++s) {
        for (int k = k_lo[s]; k <= k_hi[s]; ++k) {
            add_break(shapes[s].lo + k * p);
            add_break(shapes[s].hi + k * p);
        }
    }
    // Crossings of upper boundaries, for pairs that can overlap.
    auto lines_of = [&](const ShapeImage& shape, int k) {
        return upper_lines(shape, k * p, k * shift_t);
    };
    for (const OverlappingPair& pair : overlapping_) {
        const ShapeImage& first = shapes[pair.first];
        const ShapeImage& second = shapes[pair.second];
        for (int k = k_lo[pair.first]; k <= k_hi[pair.first]; ++k) {
            const int k2 = k + pair.barb_offset;
            if (k2 < k_lo[pair.second] || k2 > k_hi[pair.second]) continue;
            const double lo = std::max({first.lo + k * p, second.lo + k2 * p, 0.0});
            const double hi = std::min({first.hi + k * p, second.hi + k2 * p, p});
            if (lo >= hi) continue;
            const std::vector<Line> b_lines = lines_of(second, k2);  // second is always a strip
            if (first.elliptic) {
                for (const Line& line : b_lines) {
                    line_arc(line, first.uc + k * p, first.tc + k * shift_t, first.s11, first.s12,
                             first.det, lo, hi, breaks);
                }
            } else {
                for (const Line& a : lines_of(first, k)) {
                    for (const Line& b : b_lines) line_line(a, b, lo, hi, breaks);
                }
            }
        }
    }
    std::sort(breaks.begin(), breaks.end());

    std::vector<MaskingSegment> segments;
    std::vector<std::pair<double, MaskingComponent>> met;
    for (std::size_t j = 0; j + 1 < breaks.size(); ++j) {
        const double u0 = std::max(0.0, breaks[j]), u1 = std::min(p, breaks[j + 1]);
        if (!(u1 > u0)) continue;
        const double mid = 0.5 * (u0 + u1);
        // Every copy the ray at mid meets, front first (disjoint convex shapes are met in the
        // order of their front boundaries; the order cannot change inside the interval).
        met.clear();
        for (std::size_t s = 0; s < shapes.size(); ++s) {
            // Only copies whose interval holds mid: k with lo + kP <= mid <= hi + kP.
            const int ka = std::max(k_lo[s], static_cast<int>(std::ceil((mid - shapes[s].hi) / p)));
            const int kb =
                std::min(k_hi[s], static_cast<int>(std::floor((mid - shapes[s].lo) / p)));
            for (int k = ka; k <= kb; ++k) {
                double t;
                if (shapes[s].front(mid, k * p, k * shift_t, t))
                    met.push_back({t, shapes[s].component});
            }
        }
        std::sort(met.begin(), met.end(),
                  [](const auto& a, const auto& b) { return a.first > b.first; });
        const std::array<double, kMaskingComponentCount> share = shares_along(met, rows);
        append_segment(segments,
                       {u0, u1, met.empty() ? MaskingComponent::kGap : met.front().second, share});
    }
    return segments;
}

RowTransmittance PadronGriffe2024Masking::row_transmittance(const Vec3d& direction) const {
    RowTransmittance out;
    if (!has_barbules()) return out;
    // Barbules::masking: a row of elliptical fibres (width along `across`, thickness × axis
    // ratio along the row's normal), pitch width × (1 + separation); seen along ω, each fibre
    // shadows 2 √((w/2)² n² + (r w/2)² a²) of the row's projected pitch w (1 + s) |n|, with
    // (a, n) = (ω·across, ω·normal); the rest of the pitch is open. 0 where the shadows overlap.
    const double ratio = params_.barbule_axis_ratio, gap = 1.0 + params_.barbule_separation;
    for (int side = 0; side < 2; ++side) {
        const double a = direction.dot(row_across_[side]);
        const double n = direction.dot(row_normal_[side]);
        const double open =
            std::abs(n) > 0.0 ? 1.0 - std::sqrt(n * n + ratio * ratio * a * a) / (gap * std::abs(n))
                              : 0.0;
        (side == 0 ? out.distal : out.proximal) = std::max(0.0, open);
    }
    return out;
}

std::vector<MaskingSegment> PadronGriffe2024Masking::segments(double theta_rad) const {
    return partition(theta_rad, row_transmittance(in_plane_direction(theta_rad)));
}

Vec3d PadronGriffe2024Masking::in_plane_direction(double theta_rad) {
    return {0.0, std::sin(theta_rad), std::cos(theta_rad)};
}

MaskingFractions PadronGriffe2024Masking::fractions(double theta_rad,
                                                    const RowTransmittance& rows) const {
    std::array<double, kMaskingComponentCount> length{};
    double total = 0.0;
    for (const MaskingSegment& s : partition(theta_rad, rows)) {
        for (std::size_t c = 0; c < kMaskingComponentCount; ++c)
            length[c] += (s.u1_um - s.u0_um) * s.share[c];
        total += s.u1_um - s.u0_um;  // P up to round-off
    }
    return {length[0] / total, length[1] / total, length[2] / total, length[3] / total};
}

MaskingFractions PadronGriffe2024Masking::in_plane(double theta_rad) const {
    return fractions(theta_rad, row_transmittance(in_plane_direction(theta_rad)));
}

double PadronGriffe2024Masking::projected_angle(const Vec3d& w) {
    if (std::hypot(w.y(), w.z()) < 1e-300) return 0.0;
    double psi = std::atan2(w.y(), w.z());
    const double limit = std::acos(kMinimumCosine);
    if (std::abs(std::cos(psi)) < kMinimumCosine) {
        const double sign = psi < 0.0 ? -1.0 : 1.0;
        psi = std::cos(psi) >= 0.0 ? sign * limit : sign * (kPi - limit);
    }
    return psi;
}

MaskingFractions PadronGriffe2024Masking::operator()(const Vec3d& direction) const {
    return fractions(projected_angle(direction), row_transmittance(direction));
}

MaskingFractions PadronGriffe2024Masking::unoccluded(double theta_rad) const {
    if (!std::isfinite(theta_rad) ||
        std::abs(std::cos(theta_rad)) < kMinimumCosine * (1.0 - 1e-9)) {
        throw InputError(fmt::format(
            "Padrón-Griffe 2024 masking: view angle = {} rad: expected a finite angle at "
            "least 0.1 deg away from the patch plane",
            theta_rad));
    }
    const auto shapes = images(theta_rad);
    MaskingFractions f;
    f.barb = (shapes[0].hi - shapes[0].lo) / period_um_;
    if (shapes.size() == 3) {
        f.distal_barbule = (shapes[1].hi - shapes[1].lo) / period_um_;
        f.proximal_barbule = (shapes[2].hi - shapes[2].lo) / period_um_;
    }
    return f;
}

}  // namespace plumage::analysis
