// The barb/barbule masking term of Padrón-Griffe et al. 2024 ("A Surface-based Appearance Model
// for Pennaceous Feathers"): for a direction ω, the fractions of the patch that ω sees as barb,
// as distal or proximal barbule, and as nothing (light passing between barbs and barbules).
//
// The paper is a two-page poster without equations; the model is defined by the authors' public
// code (juanraul8/PennaceousFeathersRendering, masking/). We read it (we did not copy it) and
// derive the same quantities exactly, for the same geometry. What we took from their code:
//  - masking/barbs.h Barbs::masking: the barb cross-section is an ellipse with horizontal
//    semi-axis a and vertical semi-axis a × excentricity (so "excentricity" is the axis ratio,
//    our barb_axis_ratio), centred on the vane plane; a = 1/(2 (1 + L cos i)) of the period, so
//    the period is barb width × (1 + L cos i); the barbules are segments from the barb's
//    horizontal extreme points, each L a = L × width / 2 long, rising by the inclination i, the
//    distal one of a barb meeting the proximal one of the next at a corner.
//  - masking/barbules.h Barbules::masking: a barbule row is a row of ellipses (horizontal
//    semi-axis b, vertical b × excentricity: our barbule_axis_ratio) with pitch 2b (1 + s), s =
//    separation, the gap in barbule widths; its transmittance for a direction d is the open
//    part of the projected pitch, 0 when neighbouring fibres overlap in projection.
//  - masking/feather-base.h FeatherBase and masking/feather.h Feather::masking: each row's frame
//    from the 3D direction: barbule axis (cos i sin r, sin i, cos i cos r) in (across the barbs,
//    normal, barb axis) for the distal (right) row, with −r for the proximal (left) row (r =
//    barbule_rotation: the barbules' direction in the vane, from the barb axis); the transmittance
//    uses the direction's components across the row (normalise(normal × axis)) and along the
//    row's normal (axis × across). The barb-level term takes the direction projected on the
//    cross-section and the two rows' transmittances; light that passes a row goes on in a
//    straight line (Barbs::masking weights what lies behind by the transparencies).
//  - Direction: the authors' masking functions take the propagation direction d of the rays
//    (rays are cast along +d from the shapes to find shadows); our ω points towards the light or
//    viewer, so our G(ω) corresponds to theirs at d = −ω.
// Where we differ on purpose:
//  - Barbs::masking evaluates a fixed set of occlusion cases (one neighbour each side, at most
//    two rows in front of a barbule) and normalises the rates by their sum; we compute the first
//    hit exactly (below), through any number of rows and neighbours, and the fractions sum to 1
//    without normalisation. Barbs::masking also mirrors the geometry for light from below the
//    vane (the barbules then point down); ours keeps the geometry and sees it from below.
//  - barb_rotation (the ellipse turned about the barb axis) and barb_spacing (barbs further apart
//    than the authors' period, leaving a gap between barbule tips) are ours; their defaults (0)
//    are the authors' model.
//  - BarbuleStrips::kFibreThickness cuts the barbules as strips as thick as the fibre and as long
//    as the explicit geometry's fibres (geometry/barb.h: shortened by h |tan i| where the thick
//    tips of neighbouring barbs would overlap); kSegments (default) is the authors' segments.
//  - The barbule-level "hmin" (the part of a barbule fibre visible behind its neighbour) is not
//    returned: analysis/models/padrongriffe2024.h spreads hits uniformly across a fibre's width.
//
// Geometry (the y–z cross-section, one period P along y; lengths in µm; geometry/barb.h):
//  - the barb: an ellipse centred at the origin, vertical semi-axis a along u_a = (sin ρ, cos ρ)
//    (ρ = barb_rotation, from +z towards +y), horizontal semi-axis b = barb_width/2 along
//    u_b = (cos ρ, −sin ρ); the medulla lies inside it and counts as barb;
//  - the distal barbule: a strip of length L = barbule_length × barb_width / 2 along
//    d = (cos i, sin i) and half-thickness h (0, or the fibre's r w / 2), starting at the barb's
//    extreme point along +y, r₊ = (r_y, r_z), r_y = √(a² sin² ρ + b² cos² ρ), r_z =
//    (a² − b²) sin ρ cos ρ / r_y; its end faces are perpendicular to d;
//  - the proximal barbule: the distal strip turned by π about the barb's centre and then about
//    the vertical (start −r₊, direction (−cos i, sin i): it still rises);
//  - period P = 2 r_y + 2 L cos i (the authors' barb_width (1 + barbule_length cos i)), or
//    barb_spacing × barb_width.
//
// Derivation. Parallel rays arrive along −ω, ω = (sin θ, cos θ) in the y–z plane; each ray is
// labelled by u, where it would cross the patch plane z = 0, and a point p = (y, z) of the
// plane has depth t = p·ω towards the viewer. The map (y, z) ↦ (u, t) = (y − z tan θ,
// y sin θ + z cos θ) is affine and invertible (determinant 1/cos θ), so it takes every ellipse
// to an ellipse and every rectangle to a parallelogram. Along the ray at u, the shapes met are
// those whose image's u-interval holds u, in the order of their upper boundaries t_front(u)
// (disjoint convex shapes are met in the same order by every ray that meets both). A barb stops
// the ray; a barbule strip of row c stops the fraction 1 − T_c(ω) of what reaches it and lets
// T_c through, T_c the row's transmittance above (opaque rows: separation 0 gives T = 0). The
// fraction of the patch seen as component c is the integral over u ∈ [0, P) of what stops on c,
// divided by P. For an ellipse image with centre (u_c, t_c) and S = M Mᵀ (M the image of its
// semi-axis vectors) the upper boundary is the closed form t_front = t_c + (S₁₂ v + √(det S (S₁₁
// − v²))) / S₁₁, v = u − u_c, |v| ≤ √S₁₁; a parallelogram's upper boundary is the upper hull of its
// four corners. The set and the order of the shapes met change only where a shape starts or
// ends (interval ends) or where two upper boundaries cross: a line against a line, a line
// against an elliptic arc (a quadratic, roots in closed form). Two barb ellipses never cross (the
// period is at least the barb's extent along y). Between consecutive breakpoints the order is
// constant and is found by evaluating every boundary at the midpoint. The result is exact up to
// round-off: no sampling, no tessellation.
//
// The row transmittance is exact for an infinite row crossed from one face to the other. A row of
// fibres of thickness 2h is not a strip of thickness 2h, though: it is thinner between the fibre
// centres, and near a barbule's root and tip, or seen nearly edge-on, a ray crosses only part of
// it. First-hit ray casting on the explicit 3D patch (sim/patch_masking_mc.h,
// tests/sim/patch_masking_mc_test.cpp, the masking study) measures what that costs against
// kFibreThickness: the explicit patch shows more barb and gap and less barbule, by about 0.003
// for 0.4 µm thick fibres and up to 0.024 for 3.2 µm ones (0.05 for 20 µm) at 60–70° from the
// normal: a systematic of order h/P, which vanishes with the authors' segments (h → 0). The
// authors' barbule level is normalised to its own pitch, so their model is the limit of small
// barbules: shrinking width, thickness and pitch together, the explicit patch converges to this
// term (kSegments) at first order, 1.9e-2 → 4.9e-3 → 8.8e-4 for 2h = 3.2, 0.8, 0.2 µm, the last
// within the sampling bound of 4·10⁵ rays (tests/sim/patch_masking_mc_test.cpp). Two rows
// are taken as independent (the product of their transmittances): the explicit geometry places
// each row at its own phase along the barb for that reason (measured effect below 0.001).
//
// Validation (tests/analysis/padrongriffe2024_masking_test.cpp): against Monte Carlo ray casting
// on the polygons of build_patch_cross_section, and against exact first-hit ray casting of the
// authors' configurations (their figure programs' parameter sets), opaque and see-through.
//
// What is supported:
//  - in_plane(θ): view directions in the y–z plane, θ from +z towards +y, any θ with
//    |cos θ| >= kMinimumCosine (within 89.9° of ±z); the rows' transmittances at ω = (0, sin θ,
//    cos θ).
//  - operator()(ω): any 3D direction: the cross-section at the projected direction (ω_y, ω_z)
//    (translation invariance along x), the rows' transmittances at ω itself. Directions closer
//    than 0.1° to the patch plane are evaluated at 89.9°.
//
// clang-format off
// Parameters: geometry::BarbulePatchParams (the full table, with the authors' names, is in
// geometry/barb.h). The term reads:
//  | name                    | unit          | default | valid range                        |
//  |-------------------------|---------------|---------|------------------------------------|
//  | barb_width_um           | µm            | 30      | finite, > 0                        |
//  | barb_axis_ratio         | 1             | 1.5     | [0.05, 20] (vertical/horizontal)   |
//  | barb_rotation_rad       | rad           | 0       | finite                             |
//  | barbule_width_um        | µm            | 8       | finite, > 0 (kFibreThickness only) |
//  | barbule_axis_ratio      | 1             | 0.4     | [0.05, 20] (thickness/width)       |
//  | barbule_rotation_rad    | rad           | π/2     | [0, π]                             |
//  | barbule_inclination_rad | rad           | 0.35    | (−π/2, π/2)                        |
//  | barbule_length          | ½ barb widths | 3       | [0, 1000]; 0: none                 |
//  | barbule_separation      | barbule widths| 0.5     | >= 0 (0: opaque rows)              |
//  | barb_spacing            | barb widths   | 0 (auto)| 0, or >= the automatic period      |
// The medulla does not enter the term (it is inside the cortex).
// clang-format on
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "geometry/barb.h"
#include "sim/scatterer/scatterer.h"

namespace plumage::analysis {

enum class MaskingComponent : int { kBarb = 0, kDistalBarbule = 1, kProximalBarbule = 2, kGap = 3 };
inline constexpr std::size_t kMaskingComponentCount = 4;

struct MaskingFractions {
    double barb = 0.0;
    double distal_barbule = 0.0;
    double proximal_barbule = 0.0;
    double gap = 0.0;  // transmission: rays that meet nothing

    double barbule() const { return distal_barbule + proximal_barbule; }
    double sum() const { return barb + distal_barbule + proximal_barbule + gap; }
    double operator[](MaskingComponent c) const;
};

// One piece of the partition of a period: on u ∈ [u0_um, u1_um) a ray meets `component` first,
// and `share` (indexed by MaskingComponent, summing to 1) is where its light stops when barbule
// rows let part of it through.
struct MaskingSegment {
    double u0_um, u1_um;
    MaskingComponent component;
    std::array<double, kMaskingComponentCount> share{};
};

// The fraction of light a barbule row lets through between its fibres, for one direction.
struct RowTransmittance {
    double distal = 0.0;
    double proximal = 0.0;
};

// How the barb-level cross-section cuts the barbules: the authors' segments, or strips as thick
// as the fibre (the explicit geometry's).
enum class BarbuleStrips { kSegments, kFibreThickness };

class PadronGriffe2024Masking {
public:
    // |cos θ| below this (θ within 0.1° of the patch plane) is refused by in_plane() and clamped
    // by operator(): the number of barbs a ray crosses grows like tan θ.
    static constexpr double kMinimumCosine = 1.7453283658983088e-3;  // cos(89.9°)

    explicit PadronGriffe2024Masking(
        const geometry::BarbulePatchParams& params,
        BarbuleStrips strips = BarbuleStrips::kSegments);  // InputError

    // View direction (sin θ, cos θ) in the (y, z) plane; InputError when |cos θ| < kMinimumCosine.
    MaskingFractions in_plane(double theta_rad) const;
    // The cross-section at in-plane angle θ with the given row transmittances (both 0: opaque).
    MaskingFractions fractions(double theta_rad, const RowTransmittance& rows) const;
    // The partition of u ∈ [0, P) behind in_plane(), merged where nothing changes.
    std::vector<MaskingSegment> segments(double theta_rad) const;
    // The distal and proximal rows' transmittances for a 3D direction (either sign).
    RowTransmittance row_transmittance(const Vec3d& direction) const;
    static Vec3d in_plane_direction(double theta_rad);  // (0, sin θ, cos θ)
    // Row frames (side 0 distal, 1 proximal): the barbules' axis, across the row, the row's normal.
    const Vec3d& row_axis(int side) const { return row_axis_[side]; }
    const Vec3d& row_across(int side) const { return row_across_[side]; }
    const Vec3d& row_normal(int side) const { return row_normal_[side]; }
    // Any 3D direction (either hemisphere), for the cross-section extruded along x (see above).
    MaskingFractions operator()(const Vec3d& direction) const;
    // The in-plane angle operator() uses for a 3D direction: atan2(ω_y, ω_z), clamped to
    // within 89.9° of ±z; 0 when ω is (anti)parallel to the barb axis.
    static double projected_angle(const Vec3d& direction);

    // Each component's shadow on the patch plane without any occlusion, per period (the
    // barbule entries count the strips' full shadows; the sum can exceed 1). gap is unused (0).
    MaskingFractions unoccluded(double theta_rad) const;

    const geometry::BarbulePatchParams& params() const { return params_; }
    BarbuleStrips strips() const { return strips_; }
    double period_um() const { return period_um_; }
    double barb_vertical_semi_axis_um() const { return vertical_semi_axis_; }
    double barb_horizontal_semi_axis_um() const { return horizontal_semi_axis_; }
    Eigen::Vector2d distal_root_um() const { return root_; }
    double strip_half_thickness_um() const { return half_thickness_; }
    double barbule_length_um() const { return length_; }
    bool has_barbules() const { return length_ > 0.0; }

private:
    struct ShapeImage;
    std::vector<ShapeImage> images(double theta_rad) const;
    std::vector<MaskingSegment> partition(double theta_rad, const RowTransmittance& rows) const;

    geometry::BarbulePatchParams params_;
    BarbuleStrips strips_;
    std::array<Vec3d, 2> row_axis_, row_across_, row_normal_;  // distal, proximal
    double vertical_semi_axis_, horizontal_semi_axis_;
    Eigen::Vector2d root_;
    double half_thickness_, length_, period_um_;
    // The base shapes in (y, z): 0 barb ellipse (centre, semi-axis vectors), 1 and 2 the
    // distal and proximal strips (corners).
    std::array<Eigen::Vector2d, 4> distal_corners_, proximal_corners_;
    // Pairs of base shapes (i, j) and barb offsets Δk whose bounding boxes overlap: the only
    // pairs whose upper boundaries can cross (found once, independent of direction).
    struct OverlappingPair {
        int first, second, barb_offset;
    };
    std::vector<OverlappingPair> overlapping_;
};

}  // namespace plumage::analysis
