// Barbs (elliptical keratin cortex with an optional off-centre medulla) and barb + barbule patches
// of a pennaceous vane, as explicit 2D cross-sections and 3D meshes, with the parameters of
// Padrón-Griffe et al. 2024 meaning what the authors' code means (their public code,
// juanraul8/PennaceousFeathersRendering: masking/feather-base.h FeatherBase, masking/barbs.h
// Barbs::masking, masking/barbules.h Barbules::masking; the poster has no equations). Every
// reading is listed in analysis/models/padrongriffe2024_masking.h; the mapping from this suite's
// earlier meanings is in studies/README.md ("Padrón-Griffe parameters").
//
// Patch frame (sim/scatterer/scatterer.h): patch normal +z, barb axis +x, barbs repeat along y. A
// barb's cross-section lies in the y–z plane: an ellipse with horizontal semi-axis w/2 (w = barb
// width, across the vane) and vertical semi-axis w/2 × barb_axis_ratio (the authors' barb
// "excentricity": Barbs::excentricity_, "excentricity of barb (vertical axis)", used as
// flatland::ellipse(c, 0, a, a·excentricity)), turned by barb_rotation (ours; 0 in the authors'
// model) from +z towards +y. Barbules leave the barb's extreme points along ±y (distal towards
// +y, proximal towards −y), rising out of the vane plane by the inclination i; each is
// barbule_length × w / 2 long, so that the barb period is w (1 + barbule_length cos i) and the
// distal barbule of one barb meets the proximal barbule of the next at its tip (Barbs::masking:
// factor = 1/(2 (1 + length cos i)) is the barb's half width in units of the period). A barbule is
// an elliptical fibre: width across the row of barbules (along the barb axis for rotation 90°),
// thickness width × barbule_axis_ratio (the authors' barbule "excentricity"); fibres repeat along
// the barb with a gap of barbule_separation barbule widths between neighbours (pitch = width ×
// (1 + separation); Barbules::masking: factor = 1/(2 + 2 separation)), so light passes between
// them. barbule_rotation is the direction of the barbules within the vane, measured from the barb
// axis (FeatherBase: the right barbule's axis is (cos i sin r, sin i, cos i cos r) in the frame
// (across, normal, barb axis)); the explicit geometry builds barbules perpendicular to the barb
// (rotation 90°) only, and refuses other rotations.
//
// clang-format off
// Parameter table (lengths in µm; the defaults are a generic pennaceous vane, not a species):
//  | name                    | unit           | default  | valid range                            | authors' name        |
//  |-------------------------|----------------|----------|----------------------------------------|----------------------|
//  | barb_width_um           | µm             | 30       | > 0 (horizontal diameter)              | (scale; period = 1)  |
//  | barb_axis_ratio         | 1              | 1.5      | [0.05, 20]: vertical / horizontal      | barb excentricity    |
//  | barb_rotation_rad       | rad            | 0        | finite (ours; authors: 0)              | —                    |
//  | medulla_scale           | 1              | 0 (none) | [0, 0.95]: medulla semi-axes / cortex's| —                    |
//  | medulla_offset_y/z_um   | µm             | 0, 0     | medulla strictly inside the cortex     | —                    |
//  | barbule_width_um        | µm             | 8        | > 0 (across the row of barbules)       | (scale)              |
//  | barbule_axis_ratio      | 1              | 0.4      | [0.05, 20]: thickness / width          | barbule excentricity |
//  | barbule_rotation_rad    | rad            | π/2      | [0, π]; explicit geometry: π/2 only    | barbule rotation     |
//  | barbule_inclination_rad | rad            | 0.35     | (−π/2, π/2)                            | barbule inclination  |
//  | barbule_length          | half barb widths | 3      | (0, 1000]: each barbule length × w / 2 | barbule length       |
//  | barbule_separation      | barbule widths | 0.5      | >= 0: the gap between fibres           | barbule separation   |
//  | barb_spacing            | barb widths    | 0 (auto) | 0: the authors' period; or >= it       | — (ours)             |
// clang-format on
#pragma once

#include <string_view>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/tessellation.h"
#include "geometry/triangle_mesh.h"

namespace plumage::geometry {

struct BarbParams {
    double barb_width_um = 30.0;
    double barb_axis_ratio = 1.5;
    double barb_rotation_rad = 0.0;
    double medulla_scale = 0.0;
    double medulla_offset_y_um = 0.0;
    double medulla_offset_z_um = 0.0;
};

struct BarbulePatchParams {
    BarbParams barb;
    double barbule_width_um = 8.0;
    double barbule_axis_ratio = 0.4;
    double barbule_rotation_rad = 1.5707963267948966;  // π/2: perpendicular to the barb
    double barbule_inclination_rad = 0.35;
    double barbule_length = 3.0;
    double barbule_separation = 0.5;
    double barb_spacing = 0.0;

    // The barb period along y with automatic spacing: 2 r_y + barbule_length w cos i, r_y the
    // barb's half extent along y (w / 2 unless the barb is rotated): the authors' w (1 + L cos i).
    double automatic_period_um() const;
    double period_um() const;  // barb_spacing × w, or the automatic period
    // One barbule's length along its axis (barbule_length × w / 2), and the fibre pitch.
    double barbule_length_um() const { return 0.5 * barbule_length * barb.barb_width_um; }
    // The explicit fibre's length: the authors' barbules are segments, ours have a thickness h =
    // axis ratio × width / 2, and where two tips meet the thick ends would overlap (by h |tan i|
    // with automatic spacing); the explicit patch shortens its barbules by that much, because the
    // tracer needs disjoint bodies. Equal to barbule_length_um() where the tips do not meet.
    double barbule_fibre_length_um() const;
    double barbule_pitch_um() const { return barbule_width_um * (1.0 + barbule_separation); }
};

enum class SurfaceRole { barb_cortex, barb_medulla, barbule };

// A closed polygon of the 2D cross-section (counter-clockwise, (y, z) coordinates).
struct CrossSectionShape {
    SurfaceRole role;
    std::vector<Eigen::Vector2d> polygon;
};

// One period (along y) of the patch cut perpendicular to the barb axis (x = 0 lies
// on a barbule's mid-plane, so barbules appear as inclined strips).
struct PatchCrossSection {
    std::vector<CrossSectionShape> shapes;
    double period_um;  // barb spacing along y
};

class Barb {
public:
    explicit Barb(const BarbParams& params);  // InputError says why
    const BarbParams& params() const { return params_; }
    // Semi-axes of the cortex ellipse: across the vane (w/2) and vertical (w/2 × axis ratio),
    // before the barb's rotation.
    double horizontal_semi_axis_um() const { return 0.5 * params_.barb_width_um; }
    double vertical_semi_axis_um() const {
        return 0.5 * params_.barb_width_um * params_.barb_axis_ratio;
    }
    // The cortex point furthest along +y (where the distal barbule leaves), exact.
    Eigen::Vector2d distal_root_um() const;
    // Cross-section outlines (counter-clockwise) meeting the tolerance's chord bound.
    std::vector<Eigen::Vector2d> cortex_outline(const TessellationTolerance& tolerance) const;
    std::vector<Eigen::Vector2d> medulla_outline(const TessellationTolerance& tolerance) const;
    // Closed tube of the cortex (and of the medulla, when present) along +x, of the given
    // length, straight or bent with radius axis_radius_um in the x–z plane (0: straight).
    TriangleMesh cortex_mesh(double length_um, double axis_radius_um,
                             const TessellationTolerance& tolerance) const;
    TriangleMesh medulla_mesh(double length_um, double axis_radius_um,
                              const TessellationTolerance& tolerance) const;
    bool has_medulla() const { return params_.medulla_scale > 0.0; }

private:
    BarbParams params_;
};

// InputError, prefixed by `what`, naming the first parameter outside the table's range
// (barbule_length 0, no barbules, only when allow_no_barbules: the analytic terms accept it).
void validate_patch_params(const BarbulePatchParams& params, std::string_view what,
                           bool allow_no_barbules = false);

PatchCrossSection build_patch_cross_section(const BarbulePatchParams& params,
                                            const TessellationTolerance& tolerance);

// The patch in 3D: barbs along x (spaced along y), barbules as instanced fibres.
struct BarbulePatch {
    BarbulePatchParams params;
    TriangleMesh barb_cortex;   // one barb, in its own frame (axis along x through 0)
    TriangleMesh barb_medulla;  // empty without a medulla
    TriangleMesh barbule;       // one distal barbule (axis from the origin outwards)
    std::vector<Eigen::Affine3d> barb_instances;
    std::vector<Eigen::Affine3d> barbule_instances;
    // Barbules start this far out along their own axis from the cortex point the
    // cross-section roots them at (barbule_root_clearance_um), so that no barbule surface lies
    // inside the cortex: a tracer without nested media needs disjoint closed bodies (light in
    // the cortex meeting a barbule surface would refract as if it came from air). Sub-micron
    // for the usual barbules; the 2D cross-section (and the masking term built on it) keeps the
    // root on the cortex.
    double root_clearance_um = 0.0;
    // Barb spacing along y of this 3D patch: the cross-section's, or with automatic spacing
    // 2 (r_y + (clearance + ℓ) cos i), so the moved tips still just meet.
    double period_um = 0.0;
    std::size_t memory_bytes() const;
};

// How far barbules must move out along their axes so that the root faces of both strips of
// the cross-section (33 points across each) clear the cortex polygon (0 when they already do):
// bisection on the shift,
// then 1 % + 0.01 µm of margin. The cut through the barbule's axis is where the fibre is
// thickest, so clearing it clears the 3D fibre.
double barbule_root_clearance_um(const PatchCrossSection& section);

// InputError also when an explicit barb_spacing leaves the moved barbule tips of neighbouring
// barbs overlapping.
BarbulePatch build_barbule_patch(const BarbulePatchParams& params, double length_x_um, int barbs,
                                 const TessellationTolerance& tolerance);

// Sweep a closed cross-section (y, z) polygon along +x into a closed tube with end
// caps, straight or bent (radius in the x–z plane); outward normals.
TriangleMesh sweep_closed_outline(const std::vector<Eigen::Vector2d>& outline, double length_um,
                                  double axis_radius_um, const TessellationTolerance& tolerance);

}  // namespace plumage::geometry
