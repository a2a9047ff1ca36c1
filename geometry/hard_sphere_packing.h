// Equilibrium-like hard-sphere packings: N centres in a periodic cube at a prescribed
// hard-sphere volume fraction φ, up to φ = 0.55, for structure-factor work (the
// Percus–Yevick comparison of sim/wave/volume/structure_factor.h) where random sequential
// addition (geometry/spongy_volume.h) cannot go.
//
// Conventions and units. The box is the periodic cube [0, L)³ in µm; every centre lies in
// it. Spheres have one diameter σ (µm), fixed by the target fraction
//     φ = N π σ³ / (6 L³).
// Two spheres overlap when the distance between one centre and the nearest periodic image
// of the other is < σ (touching, = σ, is allowed). σ <= L/2 is required, so that the
// nearest image is the only one that can overlap.
//
// Why not random sequential addition: RSA places each sphere once and never moves it, so
// it jams near φ ≈ 0.38 (the RSA saturation limit): no gap is left that fits a whole new
// sphere. Here the spheres move, so the whole volume can be shared out.
//
// Algorithm (compression by Metropolis hard-core Monte Carlo, in the spirit of
// Lubachevsky–Stillinger, who grow the spheres during event-driven molecular dynamics):
//  1. Start: RSA of N spheres of diameter σ₀ < σ at φ₀ = min(φ, 0.25), far below the RSA
//     limit, so it never stalls (stream `initial`).
//  2. Compression: repeat
//       - one sweep = N trial moves: a sphere chosen uniformly, displaced uniformly in the
//         cube [−δ, δ]³ (and wrapped into the box), rejected if it would overlap any other
//         sphere or image (stream `moves`);
//       - if no pair overlaps, grow σ to min(σ_target, max((1 − 10⁻¹²) d_min, 1.004 σ)),
//         d_min the current minimum pair distance. Growing only to just below d_min (the
//         pure hard-core rule) is limited by the single closest of ~N near-contacts and
//         needs ~25 000 sweeps for N = 2000 at φ = 0.5; the relative step of 0.004 may
//         create a few shallow overlaps instead. While any remain, a sphere that overlaps
//         may move if its summed squared overlap Σ (σ − d)² does not increase, and σ does
//         not grow (the others keep the hard-core rule), so the overlaps are swept out in
//         a few sweeps (~1000 compression sweeps in all for N = 1000 at φ = 0.5);
//       - adapt δ by ×1.05 or ÷1.05 towards an acceptance of 0.35–0.45;
//     until σ = σ_target without any overlap. The moves open up the closest pairs, so σ
//     keeps growing: this is what reaches φ = 0.5 where RSA jams at 0.38.
//  3. Equilibration: `equilibration_sweeps` sweeps at σ_target with δ frozen (a proper
//     Metropolis chain of symmetric proposals, whose stationary distribution is the
//     uniform one over non-overlapping configurations: equilibrium hard spheres). The
//     fast compression leaves pairs nearly touching; a few hundred sweeps relax the local
//     structure (the first peak of S(q)) to that of the fluid.
// Neighbour checks use a cell list with cells of side >= σ_target (27 neighbour cells),
// so a sweep costs O(N); N = 1000 at φ = 0.5 with 300 equilibration sweeps takes
// 1.6–1.8 s (Release, on a loaded 2-core machine), N = 1000 at φ = 0.3 about 0.4 s.
//
// Range. Hard spheres freeze at φ = 0.494 and melt at 0.545; between them, and up to about
// 0.55, the compressed packing stays a metastable fluid over the sweeps run here. Above
// ~0.55 the compression crystallises (nucleation becomes fast) or jams (a random close
// packing is reached near 0.64 only with ever slower growth), so φ > 0.55 is refused.
//
// Determinism: all random numbers come from std::mt19937_64 seeded through std::seed_seq
// from (seed, item, stream), and uniform variates are taken from the raw 64-bit output
// (not from std::uniform_real_distribution, whose algorithm the standard leaves to the
// library); the arithmetic is sequential. The same parameters give bit-identical packings
// on any machine.
//
// clang-format off
// Parameter table:
//  | name                   | unit | default | valid range                                       |
//  |------------------------|------|---------|---------------------------------------------------|
//  | count (N)              | 1    | 1000    | [2, 10⁷], and σ <= L/2 (N >= 48 φ / π)            |
//  | box_um (L)             | µm   | 2.0     | finite, > 0                                       |
//  | volume_fraction (φ)    | 1    | 0.5     | (0, 0.55]                                         |
//  | equilibration_sweeps   | 1    | 300     | [0, 10⁹]                                          |
//  | max_compression_sweeps | 1    | 10⁶     | [1, 10⁹]: compression not done by then is an error|
//  | seed, item             | —    | 1, 0    | any                                               |
// clang-format on
// Bad input is an InputError naming the parameter, its value and the expected range. A
// compression that does not reach the target within max_compression_sweeps is an
// InputError that says which fraction was reached.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace plumage::geometry {

struct HardSpherePackingParams {
    std::int64_t count = 1000;
    double box_um = 2.0;
    double volume_fraction = 0.5;
    std::int64_t equilibration_sweeps = 300;
    std::int64_t max_compression_sweeps = 1'000'000;
    std::uint64_t seed = 1;
    std::uint64_t item = 0;
};

struct HardSpherePacking {
    std::vector<Eigen::Vector3d> centres_um;  // N centres in [0, L)³, µm
    double box_um = 0.0;                      // L, µm
    double diameter_um = 0.0;                 // σ, µm (the target's)
    double volume_fraction = 0.0;             // N π σ³ / (6 L³) reached
    double min_distance_um = 0.0;             // smallest periodic centre distance (>= σ)
    std::int64_t compression_sweeps = 0;      // sweeps until σ reached the target
    std::int64_t equilibration_sweeps = 0;    // sweeps at the target
    double step_um = 0.0;                     // δ of the equilibration moves, µm
    // Accepted / attempted moves over the equilibration sweeps (over the last compression
    // sweep if there were none).
    double acceptance_ratio = 0.0;
};

// Generates the packing described in the header comment. Throws InputError for bad
// parameters or a compression that does not finish.
HardSpherePacking make_hard_sphere_packing(const HardSpherePackingParams& params);

}  // namespace plumage::geometry
