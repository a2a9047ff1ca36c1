// Barbs (elliptical keratin cortex with an optional off-centre medulla, Padrón-Griffe et
// al. 2024) and barb + barbule patches, as explicit 2D cross-sections and 3D meshes.
//
// Patch frame (DESIGN.md): patch normal +z, barb axis +x. A barb's cross-section lies in
// the y–z plane; its ellipse has semi-major axis a along the direction at angle
// `rotation` from +z towards +y, semi-minor b = a sqrt(1 − e²) (eccentricity e).
// Barbules leave both sides of the barb (distal towards +y, proximal towards −y), rising
// out of the vane plane by `inclination`; each barbule is an elliptical fibre (width =
// its major diameter, eccentricity, rotation about its own axis) and barbules repeat
// along the barb every `separation` barbule widths.
//
// Parameter table (lengths in µm; defaults are a generic pennaceous vane, not a species):
//  | name                    | unit         | default | valid range                        |
//  |-------------------------|--------------|---------|------------------------------------|
//  | barb_width_um           | µm           | 30      | > 0 (major diameter 2a)            |
//  | barb_eccentricity       | 1            | 0.6     | [0, 0.999]                         |
//  | barb_rotation_rad       | rad          | 0       | finite                             |
//  | medulla_scale           | 1            | 0 (none)| [0, 0.95]: medulla semi-axes / cortex's |
//  | medulla_offset_y/z_um   | µm           | 0, 0    | medulla strictly inside the cortex |
//  | barbule_width_um        | µm           | 8       | > 0                                |
//  | barbule_eccentricity    | 1            | 0.9     | [0, 0.999]                         |
//  | barbule_rotation_rad    | rad          | 0       | finite                             |
//  | barbule_inclination_rad | rad          | 0.35    | (−π/2, π/2)                        |
//  | barbule_length          | barb widths  | 3       | > 0                                |
//  | barbule_separation      | barbule widths | 1.5   | >= 1 (barbules may not overlap)    |
//  | barb_spacing            | barb widths  | 0 (auto)| >= 1; 0: barbules of neighbours meet |
#pragma once

#include <vector>

#include <Eigen/Geometry>

#include "geometry/tessellation.h"
#include "geometry/triangle_mesh.h"

namespace plumage::geometry {

struct BarbParams {
    double barb_width_um = 30.0;
    double barb_eccentricity = 0.6;
    double barb_rotation_rad = 0.0;
    double medulla_scale = 0.0;
    double medulla_offset_y_um = 0.0;
    double medulla_offset_z_um = 0.0;
};

struct BarbulePatchParams {
    BarbParams barb;
    double barbule_width_um = 8.0;
    double barbule_eccentricity = 0.9;
    double barbule_rotation_rad = 0.0;
    double barbule_inclination_rad = 0.35;
    double barbule_length = 3.0;
    double barbule_separation = 1.5;
    double barb_spacing = 0.0;
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
    double semi_major_um() const { return 0.5 * params_.barb_width_um; }
    double semi_minor_um() const;
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
