#include "analysis/models/cross_section_masking_mc.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <fmt/format.h>

#include "analysis/models/padrongriffe2024_masking.h"
#include "common/error.h"

namespace plumage::analysis {
namespace {

using geometry::PatchCrossSection;
using geometry::SurfaceRole;

// One polygon seen along −ω: its vertices in (u, t), its u-range, and its edges sorted into
// equal u buckets so that a ray tests only the few edges near it.
struct PolygonInView {
    SurfaceRole role;
    double lo, hi;
    std::vector<Eigen::Vector2d> uv;
    std::vector<std::vector<int>> bins;
    double bin_width;
};

constexpr int kBuckets = 256;

std::vector<PolygonInView> view_polygons(const PatchCrossSection& section, double theta) {
    const double sn = std::sin(theta), cs = std::cos(theta), tn = sn / cs;
    std::vector<PolygonInView> out;
    for (const auto& shape : section.shapes) {
        PolygonInView v{shape.role,
                        std::numeric_limits<double>::infinity(),
                        -std::numeric_limits<double>::infinity(),
                        {},
                        std::vector<std::vector<int>>(kBuckets),
                        0.0};
        for (const auto& p : shape.polygon) {
            v.uv.emplace_back(p.x() - p.y() * tn, p.x() * sn + p.y() * cs);
            v.lo = std::min(v.lo, v.uv.back().x());
            v.hi = std::max(v.hi, v.uv.back().x());
        }
        if (v.uv.empty()) continue;
        v.bin_width = std::max((v.hi - v.lo) / kBuckets, std::numeric_limits<double>::min());
        const int n = static_cast<int>(v.uv.size());
        for (int e = 0; e < n; ++e) {
            const double a = v.uv[e].x(), b = v.uv[(e + 1) % n].x();
            const int b0 = std::clamp(static_cast<int>((std::min(a, b) - v.lo) / v.bin_width), 0,
                                      kBuckets - 1);
            const int b1 = std::clamp(static_cast<int>((std::max(a, b) - v.lo) / v.bin_width), 0,
                                      kBuckets - 1);
            for (int k = b0; k <= b1; ++k) v.bins[k].push_back(e);
        }
        out.push_back(std::move(v));
    }
    return out;
}

// Largest depth at which the line u = const crosses the polygon's boundary (false: it misses).
bool polygon_front(const PolygonInView& v, double u, double& t) {
    if (u < v.lo || u > v.hi) return false;
    const int bin = std::clamp(static_cast<int>((u - v.lo) / v.bin_width), 0, kBuckets - 1);
    const int n = static_cast<int>(v.uv.size());
    bool hit = false;
    for (int e : v.bins[bin]) {
        const Eigen::Vector2d& a = v.uv[e];
        const Eigen::Vector2d& b = v.uv[(e + 1) % n];
        if ((u < a.x() && u < b.x()) || (u > a.x() && u > b.x())) continue;
        const double w = b.x() != a.x() ? (u - a.x()) / (b.x() - a.x()) : 0.0;
        const double depth = b.x() != a.x() ? a.y() + w * (b.y() - a.y()) : std::max(a.y(), b.y());
        if (!hit || depth > t) t = depth;
        hit = true;
    }
    return hit;
}

}  // namespace

CrossSectionMaskingEstimate estimate_cross_section_masking(const PatchCrossSection& section,
                                                           double theta_rad, std::int64_t rays,
                                                           Rng& rng) {
    if (rays < 1) {
        throw InputError(
            fmt::format("cross-section masking Monte Carlo: rays = {}: expected >= 1", rays));
    }
    // Below this the number of periods a ray crosses (tan θ) and the depth coordinates blow up.
    constexpr double kMinimumCosine = 1e-6;
    if (!std::isfinite(theta_rad) || std::abs(std::cos(theta_rad)) < kMinimumCosine) {
        throw InputError(fmt::format(
            "cross-section masking Monte Carlo: view angle = {} rad: expected a finite angle not "
            "parallel to the patch plane (|cos| >= {})",
            theta_rad, kMinimumCosine));
    }
    if (!(section.period_um > 0.0) || !std::isfinite(section.period_um)) {
        throw InputError(fmt::format(
            "cross-section masking Monte Carlo: period = {} um: expected a finite period > 0",
            section.period_um));
    }
    const auto polygons = view_polygons(section, theta_rad);
    const double p = section.period_um;
    // Barb k of the tiling is the base shapes translated by (kP, 0): (kP, kP sin θ) in (u, t).
    const double shift_t = p * std::sin(theta_rad);
    std::array<std::int64_t, kSeenFirstCount> count{};
    for (std::int64_t r = 0; r < rays; ++r) {
        const double u = p * (static_cast<double>(r) + rng.uniform()) / static_cast<double>(rays);
        double best = -std::numeric_limits<double>::infinity();
        SeenFirst owner = SeenFirst::kNothing;
        for (const auto& poly : polygons) {
            const auto ka = static_cast<std::int64_t>(std::ceil((u - poly.hi) / p));
            const auto kb = static_cast<std::int64_t>(std::floor((u - poly.lo) / p));
            for (std::int64_t k = ka; k <= kb; ++k) {
                double t = 0.0;
                const double kd = static_cast<double>(k);
                if (polygon_front(poly, u - kd * p, t) && t + kd * shift_t > best) {
                    best = t + kd * shift_t;
                    owner =
                        poly.role == SurfaceRole::barbule ? SeenFirst::kBarbule : SeenFirst::kBarb;
                }
            }
        }
        ++count[static_cast<std::size_t>(owner)];
    }
    CrossSectionMaskingEstimate estimate;
    estimate.rays = rays;
    const auto n = static_cast<double>(rays);
    for (std::size_t c = 0; c < kSeenFirstCount; ++c) {
        const double f = static_cast<double>(count[c]) / n;
        estimate.fraction[c] = f;
        estimate.standard_error[c] = std::sqrt(std::max(f * (1.0 - f), 1.0 / n) / n);
    }
    return estimate;
}

double cross_section_offset_um(const PatchCrossSection& section,
                               const PadronGriffe2024Masking& masking, double max_chord_um) {
    double root_offset = 0.0;
    for (const auto& shape : section.shapes) {
        if (shape.role != SurfaceRole::barbule || shape.polygon.size() < 4) continue;
        // The strip's root: the middle of its first and last corners (build_patch_cross_section
        // starts each strip at the root, corners 0 and 3 on either side of it). The proximal root
        // is the distal one reflected through the barb's centre (geometry/barb.cpp), which for a
        // rotated barb is not its mirror image in y.
        const Eigen::Vector2d start = 0.5 * (shape.polygon[0] + shape.polygon[3]);
        const Eigen::Vector2d root = masking.distal_root_um();
        const Eigen::Vector2d analytic = start.x() > 0.0 ? root : Eigen::Vector2d(-root);
        root_offset = std::max(root_offset, (start - analytic).norm());
    }
    return max_chord_um + root_offset;
}

}  // namespace plumage::analysis
