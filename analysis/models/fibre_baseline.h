// A Marschner-style fibre BSDF (Marschner et al. 2003, "Light scattering from human hair
// fibers": R, TT, TRT with longitudinal Gaussian lobes and azimuthal terms of a circular
// dielectric cross-section with Fresnel and absorption), as a baseline against which the
// feather models are compared; and the lobe machinery the Padrón-Griffe 2024 fibres share.
//
// Frames. The patch frame of sim/scatterer/scatterer.h (+z patch normal, +x barb axis, directions
// pointing away from the patch). The fibre runs along +x; a direction ω has longitudinal angle θ =
// asin(ω·axis) ∈ [−π/2, π/2] and azimuth ψ = atan2(ω·side, ω·up) around the fibre, measured from
// `up` (+z) towards `side` (+y); ω = sin θ axis + cos θ (cos ψ up + sin ψ side).
//
// What the patch is. A layer of parallel fibres dense enough that every quantum meets one, at an
// offset uniformly distributed across the fibre's projected width (what a surface renderer using
// a hair BCSDF assumes, Fig. 1 centre of Padrón-Griffe 2024). Light that the fibre scatters
// leaves the patch without meeting another fibre (single scattering). Then
//   f(ωi, ωo) = Σ_p M_p(θo | θi) N_p(ψo − ψi | θi) / (cos θo |ωo·z|),   p ∈ {R, TT, TRT},
// where M_p is a density in θo and N_p a (sub-)density in ψo: the fibre sends the fraction
// M_p dθo N_p dψ of the incident quanta into dω = cos θo dθo dψ, and |ωo·z| turns radiant
// intensity per unit patch area into the BSDF of sim/scatterer/scatterer.h. The directional albedo
// is exactly Σ_p ∫ N_p = Σ_p Ā_p ≤ 1: energy is conserved by construction (paths with more than two
// internal reflections are dropped, as in Marschner's model).
//
// Longitudinal lobes. Marschner's M_p is a Gaussian in θh = (θi + θo)/2 with mean α_p and
// standard deviation β_p: as a density of θo that is a Gaussian of mean 2α_p − θi and standard
// deviation 2β_p. We normalise it over θo ∈ [−π/2, π/2] (a truncated Gaussian; Marschner's is not
// normalised, which is why his model gains or loses energy) and sample it exactly (inversion, or
// Robert's exponential rejection in far tails). Shifts and widths of TT and TRT follow Marschner:
// α_TT = −α_R/2, α_TRT = −3α_R/2, β_TT = β_R/2, β_TRT = 2β_R.
//
// Azimuthal lobes. For a quantum entering at offset h = sin γ (γ the angle of incidence in the
// cross-section) the exit azimuth relative to ψi is Φ_p(h) = 2p γt − 2γ + pπ and the attenuation
//   A_R = F,  A_TT = (1 − F)² T,  A_TRT = (1 − F)² F T²,
// with sin γt = h/η' (Bravais' index η' = √(η² − sin² θi)/cos θi: the cross-section's projected
// refraction), F the unpolarised Fresnel reflectance at the true 3D angle of incidence
// (cos = cos θi cos γ; sim/optics), the same F inside by reciprocity of the interface, and
// T = exp(−σ_a D cos γt / cos θt) the absorption along the chord (3D path length).
// N_p(φ) = ½ ∫ A_p(h) K(φ − Φ_p(h)) dh, K a wrapped Gaussian of standard deviation
// azimuthal_roughness (Marschner's N_p is the K → δ limit, whose TRT caustics are infinite; the
// roughness is pbrt-v3's remedy). The integral over h is a deterministic quadrature in γ
// (`offsets` nodes, weight cos γ, which resolves the edges where Φ changes fastest), deposited
// into 360 one-degree bins and convolved with K: N_p is piecewise constant, and sample() draws
// from exactly that table, so pdf() and sample() agree to round-off. The table depends on θi
// only (not on θo: Marschner's θd-based symmetrisation is not used), and is rebuilt when θi
// changes (per thread, the last θi is kept: instruments ask many questions per incident
// direction).
//
// Reciprocity. This BSDF is NOT reciprocal: each θi has its own normalisation of M and its own
// N (through η' and cos θt), and the density is per outgoing solid angle, divided by |ωo·z|.
// Marschner's own form M(θh) N(θd, φ)/cos²θd is reciprocal but neither normalised nor bounded
// in energy. Where θo = θi the asymmetry is exactly the projection: f(ωi, ωo) |ωo·z| =
// f(ωo, ωi) |ωi·z| (tests/analysis/fibre_baseline_test.cpp shows both).
//
// Wavelength: η and σ_a are constants; λ is only checked (finite, > 0).
//
// clang-format off
// Parameter table:
//  | name                    | unit | default          | valid range                        |
//  |-------------------------|------|------------------|------------------------------------|
//  | eta                     | 1    | 1.55             | [1.01, 3]                          |
//  | absorption_per_um       | 1/µm | 0.01             | [0, 10] (σ_a of the fibre interior)|
//  | diameter_um             | µm   | 30               | (0, 10000]                         |
//  | alpha_r_rad             | rad  | −0.0873 (−5°)    | [−0.35, 0.35] (R lobe shift α_R)   |
//  | beta_r_rad              | rad  | 0.1309 (7.5°)    | [0.01, 0.5]  (R lobe width β_R)    |
//  | azimuthal_roughness_rad | rad  | 0.15             | [0.03, 1.5]  (std of K)            |
//  | offsets                 | 1    | 512              | [16, 65536] (quadrature nodes in h)|
// clang-format on
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "analysis/metrics/statistics.h"  // normal_quantile, which the lobes sample with
#include "common/constants.h"
#include "sim/scatterer/scatterer.h"

namespace plumage::analysis {

// ---------------------------------------------------------------------------------------------
// Shared fibre machinery.

// An orthonormal fibre frame; axis × side = up, so (axis, side, up) is right-handed like x, y, z.
struct FibreFrame {
    Vec3d axis, up, side;
    double sin_theta(const Vec3d& w) const { return w.dot(axis); }
    double azimuth(const Vec3d& w) const;
    Vec3d direction(double theta, double psi) const;
};

// Marschner's longitudinal lobe as a density of θo: Gaussian of mean 2α − θi and standard
// deviation 2β, truncated to [−π/2, π/2] and normalised there.
class LongitudinalLobe {
public:
    LongitudinalLobe() = default;
    LongitudinalLobe(double theta_i, double alpha, double beta);
    double density(double theta_o) const;  // per radian of θo; 0 outside [−π/2, π/2]
    double sample(Rng& rng) const;         // exact
    double mean() const { return mean_; }
    double sigma() const { return sigma_; }

private:
    double mean_ = 0.0, sigma_ = 1.0;
    double a_ = -1.0, b_ = 1.0;  // standardised bounds
    double log_norm_ = 0.0;      // log(σ √(2π) (Φ(b) − Φ(a)))
};

// Marschner's (α, β) of R, TT, TRT from those of R.
struct LobeShape {
    double alpha, beta;
};
std::array<LobeShape, 3> marschner_lobe_shapes(double alpha_r, double beta_r);

// A (sub-)density over the azimuth ψ ∈ [−π, π), piecewise constant over kBins bins: built by
// depositing point masses (split linearly between neighbouring bin centres) and convolving with
// a wrapped Gaussian; sampled exactly.
class AzimuthalTable {
public:
    static constexpr int kBins = 360;
    void reset();
    void deposit(double psi, double mass);
    void smooth(double roughness_rad);  // convolve, then build the sampling CDF
    double mass() const { return mass_; }
    double density(double psi) const;  // per radian; integrates to mass()
    double sample(double u) const;     // u ∈ [0, 1): ψ with density / mass()
    double bin_mass(int bin) const { return value_[bin]; }
    static double bin_width() { return kTwoPi / kBins; }

private:
    std::array<double, kBins> value_{};
    std::array<double, kBins> cdf_{};
    double mass_ = 0.0;
};

enum FibreLobe : int { kFibreR = 0, kFibreTT = 1, kFibreTRT = 2 };

// The azimuthal side of one fibre for one incident direction: the R, TT, TRT tables and the
// fraction of the quanta that a medulla absorbs for diffuse re-emission (0 without one).
struct FibreAzimuthalScattering {
    std::array<AzimuthalTable, 3> lobes;
    double medulla = 0.0;
};

// The circular cross-section in closed form (above), tables over the relative azimuth
// φ = ψo − ψi. Throws InputError for offsets < 16.
void circular_fibre_azimuthal(double eta, double absorption_per_um, double diameter_um,
                              double sin_theta_i, double azimuthal_roughness_rad, int offsets,
                              FibreAzimuthalScattering& out);

// ---------------------------------------------------------------------------------------------
// The baseline model.

struct FibreBaselineParams {
    double eta = 1.55;
    double absorption_per_um = 0.01;
    double diameter_um = 30.0;
    double alpha_r_rad = -0.08726646259971647;  // −5°
    double beta_r_rad = 0.1308996938995747;     // 7.5°
    double azimuthal_roughness_rad = 0.15;
    int offsets = 512;
};

class FibreBaselineBsdf final : public Scatterer {
public:
    explicit FibreBaselineBsdf(
        const FibreBaselineParams& params);  // InputError names the parameter

    std::string name() const override { return "fibre_baseline"; }
    const std::vector<std::string>& lobe_names() const override;  // R, TT, TRT
    // Analog: returns weight 1 (pdf() is f |cos θo| itself) or nothing (absorbed, or lost to
    // paths beyond TRT).
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm, const Vec2& position_um,
                                       Rng& rng) const override;
    bool can_evaluate() const override { return true; }
    double eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                std::span<double> per_lobe = {}) const override;
    // f |cos θo|: a sub-density whose mass is the albedo.
    double pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const override;

    // The lobes' albedos Ā_R, Ā_TT, Ā_TRT for light from wi (their sum is the directional albedo).
    std::array<double, 3> lobe_albedos(const Vec3d& wi) const;
    const FibreBaselineParams& params() const { return params_; }
    static const FibreFrame& frame();

private:
    struct State;
    const State& state_for(const Vec3d& wi) const;
    double density(const State& s, const Vec3d& wo, std::span<double> per_lobe) const;

    FibreBaselineParams params_;
    std::uint64_t generation_;
};

}  // namespace plumage::analysis
