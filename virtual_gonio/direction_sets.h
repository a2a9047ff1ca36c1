// Direction sets of Filip, Maile and Vávra 2024 (filip2024_feathers_brdf.md, Sects. 4 and 5.2),
// as unit vectors in the patch frame (sim/scatterer/scatterer.h: +z normal, +x barb axis, azimuth φ
// from +x towards +y, directions pointing away from the patch).
//
// BTF / BRDF set (Sect. 5.2, Fig. 7): polar angles in 15° steps, 12 azimuths per polar angle in
// 30° steps (0°, 30°, ..., 330°):
//   light: θ = 0°, 15°, ..., 75° → 1 + 5 × 12 = 61 directions (one at the pole, φ = 0)
//   view:  θ = 15°, 30°, ..., 75° → 5 × 12 = 60 directions
//   → 61 × 60 = 3660 pairs, light-major (pair index = light index × 60 + view index), each list
//   ordered by polar angle, then azimuth ("moving circularly from the pole ... to its bottom").
// The paper gives the counts (61, 60, 3660), the polar angles and "12 azimuthal angles"; the
// count 61 forces a single light direction at the pole. It does not give the azimuth origin:
// we start at φ = 0 (the barb axis).
//
// In-plane set (Sect. 4): view fixed at θ = 45°, light from −81° to 81° in 3° steps → 55 pairs,
// all in one plane of incidence through the normal. The paper chose "the plane perpendicular
// horizontally to the captured barb structure": by default the plane perpendicular to the barb
// axis, i.e. the y–z plane (plane azimuth π/2). A signed light angle t puts the light at polar
// |t| on the view's side of the normal for t > 0 (t = +45° is retro-reflection) and on the
// opposite side for t < 0 (t = −45° is the mirror direction); t = 0 is the normal.
#pragma once

#include <numbers>
#include <vector>

#include "sim/scatterer/scatterer.h"

namespace plumage::gonio {

struct DirectionPair {
    Vec3d wi;  // towards the light
    Vec3d wo;  // towards the detector
};

// (sin θ cos φ, sin θ sin φ, cos θ).
Vec3d direction_from_angles(double theta_rad, double phi_rad);

inline constexpr int kFilip2024LightDirections = 61;
inline constexpr int kFilip2024ViewDirections = 60;
inline constexpr int kFilip2024InPlanePairs = 55;

std::vector<Vec3d> filip2024_light_directions();
std::vector<Vec3d> filip2024_view_directions();
std::vector<DirectionPair> filip2024_btf_pairs();

// The signed light angles of the in-plane set, −81° ... 81° (radians).
std::vector<double> filip2024_in_plane_light_angles();
// The plane perpendicular to the barb axis: the y–z plane.
inline constexpr double kPlaneAcrossBarbsRad = std::numbers::pi / 2;
std::vector<DirectionPair> filip2024_in_plane_pairs(
    double plane_azimuth_rad = kPlaneAcrossBarbsRad);

}  // namespace plumage::gonio
