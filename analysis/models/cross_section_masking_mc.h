// Monte Carlo ray casting on the explicit 2D cross-section of a barb + barbule patch
// (geometry::build_patch_cross_section, tiled with its period): which structure parallel rays
// meet first. It is the reference the analytic masking term of Padrón-Griffe et al. 2024
// (analysis/models/padrongriffe2024_masking.h) is validated against, in
// tests/analysis/padrongriffe2024_masking_test.cpp and in the masking study
// (studies/masking_study.h): one implementation, so the test and the study measure the same thing.
//
// Frame and angle: as in padrongriffe2024_masking.h. The section lies in the (y, z) plane, one
// period P along y; the view direction is ω = (sin θ, cos θ), θ from +z towards +y, any θ with
// cos θ ≠ 0 (light from below the patch, cos θ < 0, works the same way). Rays arrive along −ω;
// a ray is labelled by u, where its line crosses z = 0, and the first thing it meets is the
// polygon boundary point of largest depth t = p·ω on that line. Every polygon edge the line
// crosses is tested (no convexity is assumed), through a per-polygon bucket grid over u so that
// finely tessellated ellipses (15 000 edges) stay cheap.
//
// Sampling: jittered stratification, one ray uniformly inside each of N equal slices of the
// period. Only a slice that holds a boundary of the true partition can be misclassified, so the
// estimator's error is at most (boundaries + 2) / N plus the polygons' own offset from the
// analytic shapes (see cross_section_offset_um) — far below the binomial error.
#pragma once

#include <array>
#include <cstdint>

#include "geometry/barb.h"
#include "sim/scatterer/random.h"

namespace plumage::analysis {

class PadronGriffe2024Masking;

// What a ray meets first. The section's polygons do not tell distal from proximal barbules
// (both carry SurfaceRole::barbule); the cortex and the medulla are both barb.
enum class SeenFirst : int { kBarb = 0, kBarbule = 1, kNothing = 2 };
inline constexpr std::size_t kSeenFirstCount = 3;

struct CrossSectionMaskingEstimate {
    std::int64_t rays = 0;
    // Indexed by SeenFirst: the fraction of the period's rays that meet that first.
    std::array<double, kSeenFirstCount> fraction{};
    // sqrt(max(p̂ (1 − p̂), 1/N) / N): the binomial standard error of N independent rays, an UPPER
    // bound for the stratified estimator (whose variance comes only from the few slices that hold
    // a boundary). Floored at 1/N, the estimator's resolution, so that p̂ = 0 or 1 still has an
    // error to divide by.
    std::array<double, kSeenFirstCount> standard_error{};

    double operator[](SeenFirst c) const { return fraction[static_cast<std::size_t>(c)]; }
};

// `rays` (>= 1) stratified rays over one period at in-plane angle theta_rad, drawn from `rng`
// (one uniform number per ray, in slice order). InputError when rays < 1, |cos θ| is below
// 1e-6 or the section has no period.
CrossSectionMaskingEstimate estimate_cross_section_masking(
    const geometry::PatchCrossSection& section, double theta_rad, std::int64_t rays, Rng& rng);

// How far the explicit polygons sit from the analytic shapes (µm): the tessellation's chord
// bound `max_chord_um` plus the offset of the barbule roots (the tessellated cortex's furthest
// vertex along ±y, not the ellipse's extreme point). A boundary of the partition moves by at most
// this across the rays, i.e. offset / |cos θ| along u.
double cross_section_offset_um(const geometry::PatchCrossSection& section,
                               const PadronGriffe2024Masking& masking, double max_chord_um);

}  // namespace plumage::analysis
