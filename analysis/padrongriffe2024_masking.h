// The barb/barbule masking term of Padrón-Griffe et al. 2024 ("A Surface-based Appearance
// Model for Pennaceous Feathers", ../shared/papers/padrongriffe2024_pennaceous_feathers.txt):
// for a direction ω, the fractions of the patch that ω sees first as barb, as barbule, and as
// nothing (light passing between the structures).
//
// The paper is a two-page poster without equations ("we derive a masking term for the
// differential projected areas of the different components ... validated against Monte Carlo
// simulations on explicit 2D geometry"). The derivation below is ours, for the geometry that
// geometry/barb.h builds (build_patch_cross_section), and it is exact for that geometry.
//
// Geometry (the y–z cross-section, one period P along y; lengths in µm):
//  - the barb: an ellipse centred at the origin, semi-axis a = barb_width/2 along
//    u_a = (sin ρ, cos ρ) (ρ = barb_rotation, from +z towards +y), b = a √(1 − e_b²) along
//    u_b = (cos ρ, −sin ρ); the medulla lies inside it and counts as barb;
//  - the distal barbule: a rectangle (strip) of length L = barbule_length × barb_width along
//    d = (cos i, sin i) (i = barbule_inclination) and half-thickness h (the fibre's cut through
//    its own axis: the radius of the barbule's ellipse at angle barbule_rotation from its major
//    axis, h = 1/√((cos r / A)² + (sin r / B)²)), starting at the barb's extreme point along +y,
//    r₊ = (r_y, r_z) with r_y = √(a² sin² ρ + b² cos² ρ), r_z = (a² − b²) sin ρ cos ρ / r_y;
//    its end faces are perpendicular to d;
//  - the proximal barbule: the distal strip turned by π about the barb's centre and then about
//    the vertical (start −r₊ = (−r_y, −r_z), the point reflection of the distal root, so it lies
//    on the cortex for any rotation; direction (−cos i, sin i): it still rises), as
//    build_patch_cross_section places it;
//  - period P = barb_spacing × barb_width, or (barb_spacing = 0) 2 (r_y + L cos i): the tips
//    of neighbouring barbules meet.
//
// Derivation. Parallel rays arrive along −ω, ω = (sin θ, cos θ) in the y–z plane; each ray is
// labelled by u, where it would cross the patch plane z = 0, and a point p = (y, z) of the
// plane has depth t = p·ω towards the viewer. The map (y, z) ↦ (u, t) = (y − z tan θ,
// y sin θ + z cos θ) is affine and invertible (determinant 1/cos θ), so it takes every ellipse
// to an ellipse and every rectangle to a parallelogram. The fraction of the patch's projected
// area seen as component c is the length of the set of u in one period on which c is the
// first thing a ray meets, divided by P; and the first thing met at u is the shape whose upper
// boundary t_front(u) is largest there. So the masking term is the upper envelope of the
// images of all shapes of all barbs (barb k translated by (kP, 0), i.e. by (kP, kP sin θ) in
// (u, t)), measured on u ∈ [0, P). For an ellipse image with centre (u_c, t_c) and
// S = M Mᵀ (M the image of its semi-axis vectors) the upper boundary is the closed form
// t_front = t_c + (S₁₂ v + √(det S (S₁₁ − v²))) / S₁₁, v = u − u_c, |v| ≤ √S₁₁ (the projected
// half-width); a parallelogram's upper boundary is the upper hull of its four corners, a
// concave polyline. The envelope changes owner only where a shape starts or ends (interval
// ends) or where two upper boundaries cross: a line against a line (linear), a line against an
// elliptic arc (a quadratic, roots in closed form). Two barb ellipses never cross: the period is
// at least the barb's extent along y (2 r_y), so neighbouring barbs are disjoint, and disjoint
// convex shapes are met in the same order by every ray that meets both; no quartic is needed.
// Between consecutive breakpoints the owner is constant and is found by evaluating every boundary
// at the midpoint. The result is exact up to round-off: no sampling, no tessellation. Mutual
// occlusion between a barb and its own barbules, between neighbouring barbs, and between barbules
// of the same and of neighbouring barbs all come out of the same envelope, at any angle; light from
// below the patch (cos θ < 0) works the same way.
//
// Validation (tests/analysis/padrongriffe2024_masking_test.cpp): against Monte Carlo ray casting
// on the polygons of build_patch_cross_section, 8 configurations × 90 angles in −89..89°, the
// largest difference is 5e-5 (40 000 stratified rays per angle).
//
// What is supported:
//  - in_plane(θ): view directions in the y–z plane (perpendicular to the barb axis), θ from +z
//    towards +y, any θ with |cos θ| >= kMinimumCosine (within 89.9° of ±z): exact.
//  - operator()(ω): any 3D direction, for the cross-section extruded along the barb axis
//    (barbules as continuous sheets, the "vane" picture of the paper): translation invariance
//    along x makes the fractions those of the projected direction (ω_y, ω_z), exactly. For the
//    instanced 3D patch of build_barbule_patch, whose barbules are separate fibres
//    (barbule_separation > 1), light can also pass between barbules along x; that is NOT
//    modelled (the 2D term over-estimates the barbule fraction by up to a factor
//    barbule_separation). Directions closer than 0.1° to the patch plane are evaluated at 89.9°.
//
// clang-format off
// Parameters: geometry::BarbulePatchParams (see geometry/barb.h for the full table). The term
// reads, and validates with the ranges of geometry/barb.h:
//  | name                    | unit         | default | valid range                        |
//  |-------------------------|--------------|---------|------------------------------------|
//  | barb_width_um           | µm           | 30      | finite, > 0                        |
//  | barb_eccentricity       | 1            | 0.6     | [0, 0.999]                         |
//  | barb_rotation_rad       | rad          | 0       | finite                             |
//  | barbule_width_um        | µm           | 8       | finite, > 0                        |
//  | barbule_eccentricity    | 1            | 0.9     | [0, 0.999]                         |
//  | barbule_rotation_rad    | rad          | 0       | finite                             |
//  | barbule_inclination_rad | rad          | 0.35    | (−π/2, π/2)                        |
//  | barbule_length          | barb widths  | 3       | [0, 1000]; 0: none (geometry/: > 0)|
//  | barb_spacing            | barb widths  | 0 (auto)| 0, or >= 1                         |
// The medulla and barbule_separation do not enter the 2D term (the medulla is inside the
// cortex; the separation is along x).
// clang-format on
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "geometry/barb.h"
#include "sim/scatterer.h"

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

// One piece of the partition of a period: u ∈ [u0_um, u1_um) is seen as `component`.
struct MaskingSegment {
    double u0_um, u1_um;
    MaskingComponent component;
};

class PadronGriffe2024Masking {
public:
    // |cos θ| below this (θ within 0.1° of the patch plane) is refused by in_plane() and clamped
    // by operator(): the number of barbs a ray crosses grows like tan θ.
    static constexpr double kMinimumCosine = 1.7453283658983088e-3;  // cos(89.9°)

    explicit PadronGriffe2024Masking(const geometry::BarbulePatchParams& params);  // InputError

    // View direction (sin θ, cos θ) in the (y, z) plane; InputError when |cos θ| < kMinimumCosine.
    MaskingFractions in_plane(double theta_rad) const;
    // The partition of u ∈ [0, P) behind in_plane(), merged where the component does not change.
    std::vector<MaskingSegment> segments(double theta_rad) const;
    // Any 3D direction (either hemisphere), for the cross-section extruded along x (see above).
    MaskingFractions operator()(const Vec3d& direction) const;
    // The in-plane angle operator() uses for a 3D direction: atan2(ω_y, ω_z), clamped to
    // within 89.9° of ±z; 0 when ω is (anti)parallel to the barb axis.
    static double projected_angle(const Vec3d& direction);

    // Each component's shadow on the patch plane without any occlusion, per period (the
    // barbule entries count the strips' full shadows; the sum can exceed 1). gap is unused (0).
    MaskingFractions unoccluded(double theta_rad) const;

    const geometry::BarbulePatchParams& params() const { return params_; }
    double period_um() const { return period_um_; }
    double barb_semi_major_um() const { return semi_major_; }
    double barb_semi_minor_um() const { return semi_minor_; }
    Eigen::Vector2d distal_root_um() const { return root_; }
    double strip_half_thickness_um() const { return half_thickness_; }
    double barbule_length_um() const { return length_; }
    bool has_barbules() const { return length_ > 0.0; }

private:
    struct ShapeImage;
    std::vector<ShapeImage> images(double theta_rad) const;
    std::vector<MaskingSegment> partition(double theta_rad) const;

    geometry::BarbulePatchParams params_;
    double semi_major_, semi_minor_;
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
