// Barbule microgeometry after Huang et al. 2022 (Figs. 7b and 8): unit cells, barbules
// made of cells, and rows of barbules forming a barb plane, instanced.
//
// Barbule frame (Huang Fig. 7b): y along the barbule; x–z the transversal plane; a
// direction is ω = (sin φ cos θ, sin θ, cos φ cos θ), φ from +z towards +x, θ from the
// x–z plane. The barb plane has normal n = (−sin μ, 0, cos μ) (so that ⟨ω, n⟩ =
// cos θ cos(φ + μ) as in Huang Eq. 13) and barbules repeat along u = (cos μ, 0, sin μ)
// with spacing H·A.
//
// Patch frame (sim/scatterer/scatterer.h): patch normal +z, barb axis +x, barbules along +y. It is
// the barbule frame rotated by μ about y: n ↦ +z, u ↦ +x.
//
// The unit cell's outer surface is a canal surface: the elliptical arc E(φ) (semi-axes
// A along x and b·A along z, normal azimuths [φ0, φ1]) with, at every φ, a circular
// longitudinal arc of radius r_θ and opening ±θ_d through E(φ):
//   saddle (default, Huang's "saddle-like" cell; the longitudinal arc is concave):
//     P(φ, θ) = E(φ) + r_θ [(1 − cos θ) n_E(φ) + sin θ ŷ],  N = n_E cos θ − ŷ sin θ
//   convex:
//     P(φ, θ) = E(φ) + r_θ [(cos θ − 1) n_E(φ) + sin θ ŷ],  N = n_E cos θ + ŷ sin θ
// Its normals are exactly Huang's (φ_m, θ_m) with θ_m ∈ [−θ_d, θ_d]. Its area element is
// r_θ (ρ(φ) ± r_θ (1 − cos θ)) dφ dθ, so its normal distribution is Huang's Eq. 7 times
// (1 ± r_θ(1 − cos θ_m)/ρ(φ_m)): Eq. 7 assumes the longitudinal arc short next to the
// transversal radius of curvature, r_θ θ_d² ≪ b² A. The cell length along y (chord) is
// L = 2 r_θ sin θ_d; θ_d = 0 gives a straight extrusion of length L.
//
// Layers: the outer surface carries the keratin cortex as a thin film (thickness d,
// not modelled as geometry); beneath, across an air gap, lies the melanin layer, an
// explicit offset surface P − g N at depth g (< the smallest radius of curvature, else
// the offset folds over itself).
//
// Parameter table (defaults: Huang 2022 rock dove; lengths in µm):
//  | name                 | unit | default | valid range                               |
//  |----------------------|------|---------|-------------------------------------------|
//  | b                    | 1    | 0.25    | [1e-3, 1]   (b → 0 is a strip: edges have no normal) |
//  | phi0, phi1           | rad  | −0.37, 2.64 | phi0 < phi1 <= phi0 + 2π              |
//  | theta_d              | rad  | 0.0785  | [0, π/4]                                  |
//  | semi_major_um (A)    | µm   | 10      | > 0                                       |
//  | cell_length_um (L)   | µm   | 20      | > 0                                       |
//  | H                    | 1    | 1.25    | > 0, barbules must not interpenetrate     |
//  | mu                   | rad  | −0.35   | (−π/2, π/2)                               |
//  | film_thickness_um (d)| µm   | 0.59    | >= 0                                      |
//  | melanin_depth_um (g) | µm   | 0.3     | (0, b² A)                                 |
//  | jitter_phi_rad, jitter_theta_rad | rad | 0 | [0, 0.5]: per-cell rotation, normal distribution,
//  seeded |
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/elliptical_arc.h"
#include "geometry/tessellation.h"
#include "geometry/triangle_mesh.h"

namespace plumage::geometry {

enum class LongitudinalProfile { saddle, convex };

struct BarbuleCellParams {
    double b = 0.25;
    double phi0 = -0.37;
    double phi1 = 2.64;
    double theta_d = 0.0785;
    double semi_major_um = 10.0;
    double cell_length_um = 20.0;
    LongitudinalProfile profile = LongitudinalProfile::saddle;
    double film_thickness_um = 0.59;
    double melanin_depth_um = 0.3;
};

class BarbuleCell {
public:
    explicit BarbuleCell(const BarbuleCellParams& params);  // validates; InputError says why

    const BarbuleCellParams& params() const { return params_; }
    const EllipticalArc& arc() const { return arc_; }           // in µm
    double longitudinal_radius_um() const { return r_theta_; }  // ∞ when θ_d = 0

    // Surface point and unit outward normal at normal azimuth φ and longitudinal angle θ
    // (θ is the longitudinal parameter, |θ| <= θ_d; for θ_d = 0, pass t ∈ [−1, 1] as the
    // fraction of the half-length instead). depth moves along −N (0: the film surface).
    Eigen::Vector3d point(double phi, double theta, double depth_um = 0.0) const;
    Eigen::Vector3d normal(double phi, double theta) const;
    // Exact area element dA/(dφ dθ) of the outer surface (µm² per rad²).
    double area_element(double phi, double theta) const;

    // Triangles of the outer (film) surface or the melanin surface, with analytic
    // shading normals, meeting the tolerance. The report states what was achieved.
    TriangleMesh tessellate(const TessellationTolerance& tolerance, bool melanin_surface = false,
                            TessellationReport* report = nullptr) const;

private:
    BarbuleCellParams params_;
    EllipticalArc arc_;
    double r_theta_;
};

struct BarbuleRowParams {
    BarbuleCellParams cell;
    double H = 1.25;
    double mu = -0.35;
    int barbules = 8;           // along the barb plane (patch +x)
    int cells_per_barbule = 8;  // along each barbule (patch +y)
    double jitter_phi_rad = 0.0;
    double jitter_theta_rad = 0.0;
    std::uint64_t seed = 1;
};

// A row (patch) of barbules: the cell mesh once, plus one transform per cell.
struct BarbuleRow {
    BarbuleRowParams params;
    TriangleMesh cell_film;     // cell-local coordinates (barbule frame, cell at origin)
    TriangleMesh cell_melanin;  // same frame
    std::vector<Eigen::Affine3d> instances;  // cell-local → patch frame
    TessellationReport tessellation;

    // Bytes held by the meshes and the transforms: instancing keeps this small.
    std::size_t memory_bytes() const;
    // Patch-frame extents of the cells' origins plus the cell size.
    Eigen::AlignedBox3d bounds() const;
    // All instances flattened into one mesh (for export and previews, not for tracing).
    TriangleMesh flatten(bool melanin_surface = false) const;
};

BarbuleRow build_barbule_row(const BarbuleRowParams& params,
                             const TessellationTolerance& tolerance);

// Huang's projected lengths in the transversal plane, in units of the semi-major axis A,
// for in-plane direction φ (Eq. 13 and the T lobe, Eq. 15):
//   Δh(φ)  = H cos(φ + μ)                       one period's projected length
//   Δh'(φ) = min(W(φ), Δh(φ))                   the part that hits a barbule
// where W(φ) is the arc's projected width. 1 − Δh'/Δh is the fraction of light that
// passes between barbules unhindered.
double projected_period(double H, double mu, double phi);
double projected_hit_length(const BarbuleCellParams& cell, double H, double mu, double phi);

// Smallest spacing H at which neighbouring arcs (translated by H A u) do not intersect.
double minimum_spacing(const BarbuleCellParams& cell, double mu);

}  // namespace plumage::geometry
