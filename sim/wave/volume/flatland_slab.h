// Radiative transfer in flatland: a Monte Carlo of a laterally infinite slab of a 2D
// scattering medium (born_2d.h's tables), lit at normal incidence from air. The transport
// counterpart of a 2D full-wave slab (tests/reference/spongy_2d): it adds the incoherent
// sum over scattering orders to the single-scattering kernel, and the Fresnel faces.
//
// Geometry and conventions. The slab fills 0 <= z <= d (z downward, into the slab) and all
// x; the medium has the real index n_eff and scattering coefficient μ_s (no absorption), air
// (n = 1) on both sides. Directions lie in the (x, z) plane: a unit vector (s_x, s_z). Light
// arrives along +z. Both faces are flat Fresnel interfaces; in flatland the TE field (E
// along y, out of the plane) is perpendicular to every plane of incidence, so TE uses the
// s-polarised Fresnel coefficients and TM (E in the plane) the p-polarised ones
// (sim/optics/fresnel.h). Scattering keeps the polarisation (born_2d.h), so one
// polarisation is followed throughout.
//
// The walk (analog, unit weight, no absorption). The front face's specular reflection
// R_0 = ((n_eff − 1)/(n_eff + 1))² is added exactly, not sampled: it is the coherent
// reflection of the effective slab's front face, part of R. The remaining 1 − R_0 enters
// along +z at z = 0 and each path then repeats: a free flight s = −ln(1 − ξ)/μ_s (∞ for
// μ_s = 0); if the flight reaches a face first, the light meets it at cos θ_i = |s_z| and
// is reflected with the Fresnel reflectance R_F(cos θ_i) (total internal reflection beyond
// the critical angle: R_F = 1), else leaves (R if through z = 0, T if through z = d);
// otherwise it scatters: the direction turns by ±θ, θ from the tabulated p(θ) (piecewise
// linear in θ between the table's points, sampled exactly by inversion), the sign with
// probability ½ each. So
//     R = R_0 + (1 − R_0) N_R / N,   T = (1 − R_0) N_T / N,
// N_R, N_T the counts of paths leaving through each face; every path leaves through one
// (a path still inside after `max_events` interactions is counted as lost and reported; none
// is lost in any regime used here), so R + T = 1 exactly when nothing is lost. Standard
// errors are the binomial ones, (1 − R_0) √(p(1 − p)/N), p = N_R/N.
//
// Coherent effects are outside the model by construction: no Fabry–Pérot fringes of the
// ballistic beam (the faces add in intensity), no coherent backscattering, no near-field
// or dependent scattering beyond what the power spectrum carries.
//
// Randomness and threads: path i draws from Rng(derive_seed(seed, "wave/flatland_slab"), i)
// (sim/scatterer/random.h, common/seed.h), and the tallies are integer counts, so the result is
// bit-identical for any thread count and any scheduling.
//
// Closed forms for the tests (and for the thin and clear limits):
//  - incoherent_slab: the two-interface slab at normal incidence whose ballistic beam is
//    attenuated by e^{−τ} per crossing (scattered light discarded):
//        R = R_0 + (1 − R_0)² R_0 e^{−2τ} / (1 − R_0² e^{−2τ}),
//        T = (1 − R_0)² e^{−τ} / (1 − R_0² e^{−2τ});
//    at τ = 0, R = 2 R_0 / (1 + R_0), the μ_s → 0 limit of the Monte Carlo.
//  - single_scattering_reflectance_matched: an index-matched slab (n_eff = 1: no faces),
//    light scattered exactly once and leaving through z = 0. Scattering at depth z (density
//    μ_s e^{−μ_s z}) into θ, |θ| > π/2, escapes with e^{−μ_s z/|cos θ|}; integrating over z
//    from 0 to d:
//        R_1 = 2 ∫_{π/2}^{π} p(θ) [1 − e^{−τ (1 + 1/|cos θ|)}] / (1 + 1/|cos θ|) dθ,  τ = μ_s d,
//    → τ · 2 ∫_{π/2}^{π} p dθ (the backscattered fraction times τ) for τ → 0. The Monte
//    Carlo tallies the once-scattered part of R separately, which is compared with R_1.
//
// Parameter table:
//  | name            | unit | range                                                     |
//  |-----------------|------|-----------------------------------------------------------|
//  | thickness_um    | µm   | finite, > 0                                               |
//  | n_eff           | 1    | finite, in [1, 10] (real: lossless)                       |
//  | mu_s_per_um     | µm⁻¹ | finite, >= 0, μ_s d <= 1000                               |
//  | theta_rad       | rad  | >= 2 points, strictly increasing from 0 to π              |
//  | phase_per_rad   | rad⁻¹| finite, >= 0, same length, not all 0 (normalised here)    |
//  | paths           | 1    | [1, 10⁹]                                                  |
//  | threads         | 1    | [1, 256]                                                  |
//  | max_events      | 1    | >= 1 (interactions per path: scatterings + reflections)   |
//  | tau (closed forms) | 1 | finite, >= 0                                             |
#pragma once

#include <cstdint>
#include <vector>

#include "sim/wave/volume/born_2d.h"

namespace plumage::sim::wave {

struct FlatlandSlab {
    double thickness_um = 0.0;
    double n_eff = 1.0;
    double mu_s_per_um = 0.0;
    Polarisation2d polarisation = Polarisation2d::te;
    std::vector<double> theta_rad;      // [0, π], increasing
    std::vector<double> phase_per_rad;  // p(θ) at theta_rad (any positive scale: renormalised)

    // The slab of a born_2d.h table: its n_eff, μ_s, polarisation and p(θ).
    static FlatlandSlab from_table(const FlatlandTable& table, double thickness_um);
};

struct FlatlandSlabOptions {
    std::uint64_t seed = 1;
    std::uint64_t paths = 10000;
    int threads = 1;
    std::uint64_t max_events = 10000000;
};

struct FlatlandSlabResult {
    double reflectance = 0.0;     // R = R_0 + diffuse, total
    double transmittance = 0.0;   // T (ballistic + diffuse)
    double reflectance_se = 0.0;  // binomial standard errors (header)
    double transmittance_se = 0.0;
    double specular = 0.0;            // R_0, the front face's coherent reflection (in R)
    double reflectance_single = 0.0;  // the part of R from paths scattered exactly once
    double mean_events = 0.0;         // interactions per path (scatterings + face hits)
    std::uint64_t paths = 0;
    std::uint64_t lost = 0;  // paths cut at max_events (not in R or T)
};

FlatlandSlabResult simulate_flatland_slab(const FlatlandSlab& slab,
                                          const FlatlandSlabOptions& options);

struct SlabIntensities {
    double reflectance = 0.0;
    double transmittance = 0.0;
};

// The two-interface incoherent slab at normal incidence (header), optical thickness τ of
// the ballistic beam per crossing.
SlabIntensities incoherent_slab(double n_eff, double tau);

// R_1 of the index-matched slab (header), for the phase function of `slab` as the Monte Carlo
// samples it (piecewise linear in θ) and τ = μ_s d of `slab`.
double single_scattering_reflectance_matched(const FlatlandSlab& slab);

}  // namespace plumage::sim::wave
