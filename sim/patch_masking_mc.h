// Monte Carlo masking fractions of the explicit 3D barb + barbule patch
// (geometry::build_barbule_patch: barbs as tubes, barbules as separate instanced fibres with real
// gaps between them), by exact first-hit ray casting with Embree (sim/scene.h Scene::intersect
// on barbule_patch_scene). It is the reference for the analytic masking term of Padrón-Griffe et
// al. 2024 (analysis/models/padrongriffe2024_masking.h, BarbuleStrips::kFibreThickness) in 3D: the
// term treats each barbule row as a strip of the cross-section with a transmittance computed from
// the 3D direction; here light passes (or not) between the actual fibres. Used by
// tests/sim/patch_masking_mc_test.cpp and the masking study (studies/masking_study.h).
//
// Frame (the patch frame, sim/scatterer/scatterer.h and geometry/barb.h): patch normal +z, barb
// axis +x, barbs repeat along y with period P; barbule fibres repeat along x with pitch p = barbule
// width × (1 + separation). The direction ω points towards the viewer (or the light), either
// hemisphere; rays travel along −ω.
//
// Estimator. A window of the patch interior, W_y = window_periods × P along y (so that every
// barb period counts alike) by W_x = window_pitches × p along x (so that, for every ray line, each
// barbule row's comb is sampled uniformly along x whatever its phase), centred on the patch. The
// window is cut into n_x × n_y equal cells (n_x n_y <= rays, cells about square) and one ray is
// placed uniformly in each (jittered stratification); the ray is labelled by the point (x, y, 0)
// where its line crosses the patch plane z = 0 and starts on the plane 1 µm beyond the patch's
// bounding box on the viewer's side. Its first hit is classified by the instance it lands on:
// a barb (cortex or medulla: both are in the barb unit), a distal barbule (the fibres of a
// barb's +y row) or a proximal barbule (−y row), in build_barbule_patch's instance order (for
// each barb, its distal row's fibres, then its proximal row's); no hit is "nothing". The patch
// is built large enough that every ray line, over the whole height of the patch, stays at least
// one barb period and two pitches inside the patch's edges for directions up to max_polar_deg
// from ±z (checked for each direction against the built patch's bounding box).
//
// Errors: the binomial standard error sqrt(max(p̂ (1 − p̂), 1/N) / N) of N independent rays, an
// upper bound for the stratified estimator (only cells holding a boundary vary), as
// analysis/models/cross_section_masking_mc.h. It does not cover what is fixed by the built patch:
// the barbule rows' phases along x (build_barbule_patch draws one per row from a fixed stream) — a
// ray crossing two rows passes both with a probability that depends on their relative phase,
// which the analytic term takes as independent — and the tessellation of barbs and fibres
// (chord error, about 10⁻³ µm by default: relative effect ~10⁻⁵).
//
// Random streams: ray q (cell order, y-major) draws from Rng(seed, q); the caller derives `seed`
// from the study's seed with derive_seed(seed, purpose, index) (common/seed.h). Rays run in
// parallel (OpenMP) and are counted in integers: the result is the same for any thread count.
//
// Parameters (InputError naming the parameter and value):
//  | name            | unit | default | valid range                                        |
//  |-----------------|------|---------|----------------------------------------------------|
//  | window_periods  | 1    | 16      | [1, 1000] barb periods along y                     |
//  | window_pitches  | 1    | 16      | [1, 10000] barbule pitches along x                 |
//  | max_polar_deg   | deg  | 75      | [0, 85]: directions further from ±z are refused    |
//  | tolerance       |      | default | geometry::TessellationTolerance                    |
//  | rays            | 1    | —       | [1, 10¹⁰] per estimate                             |
// The patch parameters are geometry::BarbulePatchParams (geometry/barb.h), which the explicit
// patch accepts (barbule_rotation π/2 only, barbule_length > 0).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "geometry/barb.h"
#include "geometry/tessellation.h"
#include "sim/scatterer/scatterer.h"

namespace plumage::sim {

class Scene;

// What a ray meets first; the order of analysis::MaskingComponent.
enum class PatchFirstHit : int {
    kBarb = 0,
    kDistalBarbule = 1,
    kProximalBarbule = 2,
    kNothing = 3
};
inline constexpr std::size_t kPatchFirstHitCount = 4;

struct PatchMaskingOptions {
    int window_periods = 16;
    int window_pitches = 16;
    double max_polar_deg = 75.0;
    geometry::TessellationTolerance tolerance{};
};

struct PatchMaskingEstimate {
    std::int64_t rays = 0;  // n_x × n_y
    std::int64_t cells_x = 0, cells_y = 0;
    // Indexed by PatchFirstHit: the fraction of the window's rays that meet that first, and its
    // binomial standard error (an upper bound, see above; floored at 1/N).
    std::array<double, kPatchFirstHitCount> fraction{};
    std::array<double, kPatchFirstHitCount> standard_error{};

    double operator[](PatchFirstHit c) const { return fraction[static_cast<std::size_t>(c)]; }
};

class PatchMaskingMonteCarlo {
public:
    // Builds the patch and its Embree scene; InputError for bad options or patch parameters.
    explicit PatchMaskingMonteCarlo(const geometry::BarbulePatchParams& params,
                                    const PatchMaskingOptions& options = {});
    ~PatchMaskingMonteCarlo();
    PatchMaskingMonteCarlo(const PatchMaskingMonteCarlo&) = delete;
    PatchMaskingMonteCarlo& operator=(const PatchMaskingMonteCarlo&) = delete;

    // `rays` stratified rays along −direction (normalised here; InputError when it is not finite,
    // is zero, or lies more than max_polar_deg from ±z; or rays outside [1, 10¹⁰]).
    PatchMaskingEstimate estimate(const Vec3d& direction, std::int64_t rays,
                                  std::uint64_t seed) const;
    // The first hit of the ray whose line crosses z = 0 at (x, y) (patch frame, µm), travelling
    // along −direction (unit, ω_z ≠ 0).
    PatchFirstHit first_hit(double x_um, double y_um, const Vec3d& direction) const;

    // What the analytic term's strip picture (analysis/models/padrongriffe2024_masking.h,
    // BarbuleStrips::kFibreThickness) may differ from this patch by, per component, beyond
    // sampling: [2h (0.25 + 0.4 |tan θ_p|) + (c + t) / 2] / P, 2h = barbule_axis_ratio ×
    // barbule_width (the fibre thickness), c = the roots' clearance from the cortex, t = how much
    // shorter the fibres are than the authors' barbules where tips meet (barbule_length_um −
    // barbule_fibre_length_um), P the barb period, θ_p = atan2(ω_y, ω_z). Measured in
    // tests/sim/patch_masking_mc_test.cpp (which says where the differences come from): an envelope
    // of every difference seen with 10⁶ rays, with margin.
    double strip_picture_allowance(const Vec3d& direction) const;

    const geometry::BarbulePatch& patch() const { return patch_; }
    int barbs() const { return barbs_; }
    int fibres_per_row() const { return fibres_per_row_; }
    double window_x_um() const { return window_x_um_; }  // window_pitches × pitch
    double window_y_um() const { return window_y_um_; }  // window_periods × period

private:
    PatchMaskingOptions options_;
    geometry::BarbulePatch patch_;
    std::unique_ptr<Scene> scene_;
    int barbs_ = 0;
    int fibres_per_row_ = 0;
    double window_x_um_ = 0.0, window_y_um_ = 0.0;
    double interior_x_um_ = 0.0, interior_y_um_ = 0.0;  // half-widths of the periodic interior
    double z_min_um_ = 0.0, z_max_um_ = 0.0;            // the scene's bounding box
};

}  // namespace plumage::sim
