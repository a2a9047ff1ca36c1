#include "sim/patch_masking_mc.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "sim/scatterer/random.h"
#include "sim/scene.h"

namespace plumage::sim {
namespace {

constexpr double kStartClearanceUm = 1.0;  // rays start this far beyond the patch's bounds
constexpr std::int64_t kMaxRays = 10'000'000'000;
constexpr std::size_t kMaxInstances = 2'000'000;

void require_option(bool ok, const char* name, double value, const char* expected) {
    if (!ok) {
        throw InputError(
            fmt::format("patch masking Monte Carlo: {} = {}: expected {}", name, value, expected));
    }
}

// A bound on |z| of every point of the patch, from the parameters alone (before building it):
// the barb's largest semi-axis, the barbule's rise along its length and the fibre's larger
// half-extent, plus 1 µm.
double height_bound_um(const geometry::BarbulePatchParams& q) {
    const double barb = 0.5 * q.barb.barb_width_um * std::max(1.0, q.barb.barb_axis_ratio);
    const double rise = q.barbule_length_um() * std::abs(std::sin(q.barbule_inclination_rad));
    const double fibre = 0.5 * q.barbule_width_um * std::max(1.0, q.barbule_axis_ratio);
    return barb + rise + fibre + 1.0;
}

}  // namespace

PatchMaskingMonteCarlo::PatchMaskingMonteCarlo(const geometry::BarbulePatchParams& params,
                                               const PatchMaskingOptions& options)
    : options_(options) {
    require_option(options.window_periods >= 1 && options.window_periods <= 1000, "window_periods",
                   options.window_periods, "an integer in [1, 1000]");
    require_option(options.window_pitches >= 1 && options.window_pitches <= 10000, "window_pitches",
                   options.window_pitches, "an integer in [1, 10000]");
    require_option(std::isfinite(options.max_polar_deg) && options.max_polar_deg >= 0.0 &&
                       options.max_polar_deg <= 85.0,
                   "max_polar_deg", options.max_polar_deg, "a number of degrees in [0, 85]");
    options.tolerance.validate();

    // Size the patch: a ray line at the largest slant moves by at most `drift` horizontally
    // between z = 0 and the patch's top or bottom.
    const double drift = height_bound_um(params) * std::tan(options.max_polar_deg * kDeg);
    const double period = params.period_um();
    const double pitch = params.barbule_pitch_um();
    require_option(std::isfinite(period) && period > 0.0, "period_um", period, "a period > 0");
    require_option(std::isfinite(pitch) && pitch > 0.0, "barbule pitch (um)", pitch, "a pitch > 0");
    const double barbs = options.window_periods + 2.0 * std::ceil(drift / period) + 2.0;
    const double fibres = options.window_pitches + 2.0 * std::ceil(drift / pitch) + 6.0;
    require_option(barbs * fibres * 2.0 <= static_cast<double>(kMaxInstances), "barbule instances",
                   barbs * fibres * 2.0,
                   "at most 2e6 (fewer window periods or pitches, or wider barbules)");
    barbs_ = static_cast<int>(barbs);
    // (fibres + 1/2) pitches: build_barbule_patch places floor(length / pitch) fibres per row.
    patch_ =
        geometry::build_barbule_patch(params, (fibres + 0.5) * pitch, barbs_, options.tolerance);
    const std::size_t rows = 2 * static_cast<std::size_t>(barbs_);
    PLUMAGE_CHECK(!patch_.barbule_instances.empty() && patch_.barbule_instances.size() % rows == 0,
                  "build_barbule_patch: expected the same number of fibres in every row");
    fibres_per_row_ = static_cast<int>(patch_.barbule_instances.size() / rows);
    scene_ = std::make_unique<Scene>(barbule_patch_scene(patch_));
    const Eigen::AlignedBox3d bounds = scene_->bounds();
    z_min_um_ = bounds.min().z();
    z_max_um_ = bounds.max().z();

    window_x_um_ = options.window_pitches * pitch;
    window_y_um_ = options.window_periods * patch_.period_um;
    // The periodic interior: the rows' fibres sit at (j − (n − 1)/2) p + phase, |phase| <= p/2,
    // so |x| <= (n/2 − 1) p is covered by whole fibres on both sides; two pitches of margin
    // inside it (and inside the barbs' length). Along y, one barb period inside the patch.
    interior_x_um_ =
        std::min((0.5 * fibres_per_row_ - 1.0) * pitch, 0.5 * (fibres + 0.5) * pitch) - 2.0 * pitch;
    interior_y_um_ = 0.5 * barbs_ * patch_.period_um - patch_.period_um;
}

PatchMaskingMonteCarlo::~PatchMaskingMonteCarlo() = default;

double PatchMaskingMonteCarlo::strip_picture_allowance(const Vec3d& direction) const {
    const geometry::BarbulePatchParams& q = patch_.params;
    const double thickness = q.barbule_axis_ratio * q.barbule_width_um;
    const double tan_projected = direction.z() != 0.0 ? std::abs(direction.y() / direction.z())
                                                      : std::numeric_limits<double>::infinity();
    // Where tips meet, the explicit fibres end short of the authors' tips (so that the bodies
    // stay disjoint): a gap like the roots' clearance.
    const double tip_cut = q.barbule_length_um() - q.barbule_fibre_length_um();
    return (thickness * (0.25 + 0.4 * tan_projected) + 0.5 * (patch_.root_clearance_um + tip_cut)) /
           patch_.period_um;
}

PatchFirstHit PatchMaskingMonteCarlo::first_hit(double x_um, double y_um,
                                                const Vec3d& direction) const {
    const double z_start =
        direction.z() > 0.0 ? z_max_um_ + kStartClearanceUm : z_min_um_ - kStartClearanceUm;
    const Vec3d origin = Vec3d(x_um, y_um, 0.0) + (z_start / direction.z()) * direction;
    const std::optional<SurfaceHit> hit = scene_->intersect(origin, -direction);
    if (!hit) return PatchFirstHit::kNothing;
    const auto instance = static_cast<int>(hit->primitive.instance);
    if (instance < barbs_) return PatchFirstHit::kBarb;
    const int row = (instance - barbs_) / fibres_per_row_;  // 2k: barb k's distal row, 2k + 1
    return row % 2 == 0 ? PatchFirstHit::kDistalBarbule : PatchFirstHit::kProximalBarbule;
}

PatchMaskingEstimate PatchMaskingMonteCarlo::estimate(const Vec3d& direction, std::int64_t rays,
                                                      std::uint64_t seed) const {
    require_option(rays >= 1 && rays <= kMaxRays, "rays", static_cast<double>(rays),
                   "an integer in [1, 1e10]");
    const double norm = direction.norm();
    if (!direction.allFinite() || !(norm > 0.0)) {
        throw InputError(fmt::format(
            "patch masking Monte Carlo: direction ({}, {}, {}): expected a finite, non-zero vector",
            direction.x(), direction.y(), direction.z()));
    }
    const Vec3d w = direction / norm;
    const double polar_from_axis = std::acos(std::min(1.0, std::abs(w.z()))) / kDeg;
    if (polar_from_axis > options_.max_polar_deg * (1.0 + 1e-12)) {
        throw InputError(fmt::format(
            "patch masking Monte Carlo: direction ({:.6g}, {:.6g}, {:.6g}) is {:.4g} deg from ±z: "
            "expected at most max_polar_deg = {} (the patch was built for that slant)",
            w.x(), w.y(), w.z(), polar_from_axis, options_.max_polar_deg));
    }
    // Every ray line stays in the periodic interior over the patch's height (see the header).
    const double z_extent = std::max(std::abs(z_min_um_), std::abs(z_max_um_));
    const double drift_x = z_extent * std::abs(w.x() / w.z());
    const double drift_y = z_extent * std::abs(w.y() / w.z());
    PLUMAGE_CHECK(0.5 * window_x_um_ + drift_x <= interior_x_um_ &&
                      0.5 * window_y_um_ + drift_y <= interior_y_um_,
                  "patch masking Monte Carlo: the window leaves the patch's interior");

    PatchMaskingEstimate out;
    const auto n = static_cast<double>(rays);
    out.cells_y =
        std::clamp<std::int64_t>(std::llround(std::sqrt(n * window_y_um_ / window_x_um_)), 1, rays);
    out.cells_x = std::max<std::int64_t>(1, rays / out.cells_y);
    out.rays = out.cells_x * out.cells_y;
    const std::int64_t cells_x = out.cells_x, cells_y = out.cells_y, total = out.rays;
    const double step_x = window_x_um_ / static_cast<double>(cells_x);
    const double step_y = window_y_um_ / static_cast<double>(cells_y);
    std::array<std::int64_t, kPatchFirstHitCount> counts{};
#pragma omp parallel
    {
        std::array<std::int64_t, kPatchFirstHitCount> local{};
#pragma omp for schedule(dynamic, 4096) nowait
        for (std::int64_t q = 0; q < total; ++q) {
            Rng rng(seed, static_cast<std::uint64_t>(q));
            const std::int64_t iy = q / cells_x, ix = q % cells_x;
            const double x =
                -0.5 * window_x_um_ + (static_cast<double>(ix) + rng.uniform()) * step_x;
            const double y =
                -0.5 * window_y_um_ + (static_cast<double>(iy) + rng.uniform()) * step_y;
            ++local[static_cast<std::size_t>(first_hit(x, y, w))];
        }
#pragma omp critical(plumage_patch_masking_mc)
        for (std::size_t c = 0; c < kPatchFirstHitCount; ++c) counts[c] += local[c];
    }
    const auto N = static_cast<double>(total);
    for (std::size_t c = 0; c < kPatchFirstHitCount; ++c) {
        const double p = static_cast<double>(counts[c]) / N;
        out.fraction[c] = p;
        out.standard_error[c] = std::sqrt(std::max(p * (1.0 - p), 1.0 / N) / N);
    }
    return out;
}

}  // namespace plumage::sim
