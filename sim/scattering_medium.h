// A scattering participating medium (the wave-optical spongy keratin of level 2 of physics,
// docs/architecture.md): free flights with μ_t = μ_s + μ_a and scattering directions from a
// tabulated phase function, per wavelength, for the tracer's Medium seam (sim/medium.h).
//
// Where the numbers come from: sim/wave/volume/born_medium.h computes, per wavelength, the
// effective index, μ_s, μ_a and p(cos θ) of a spongy volume (first Born, or Mie × S(q)).
// This file takes them as plain MediumTables, so that plumage_sim needs neither FFTW nor
// plumage_wave_volume (and plumage_wave_volume stays free of the tracer and Embree); medium_table()
// below converts a wave::ScatteringTable (or any struct with the same fields) in code that
// links both (studies, tests, benchmarks).
//
// Conventions:
//  - Units: distances µm, μ_s and μ_a µm⁻¹, wavelengths nm (vacuum), p in sr⁻¹.
//  - Directions are PROPAGATION directions (where the light travels), unit vectors, as in
//    sim/interface_events.h. The phase function's θ is the angle between the incoming
//    propagation direction and the outgoing one: cos θ = 1 is forward (no deflection),
//    cos θ = −1 backscattering. p is normalised over the sphere, ∫ p dΩ = 1.
//  - The phase function between table nodes is the piecewise-LINEAR interpolant in
//    μ = cos θ, renormalised so that it integrates to 1 exactly (the tables of
//    born_medium.h are normalised by quadrature of the continuous function; their linear
//    interpolant integrates to 1 within about 1e-4 for 181 nodes; tables whose interpolant
//    is off by more than kPhaseNormalisationTolerance are refused, since they are too
//    coarse to sample faithfully). This interpolant is THE phase function of the medium:
//    scatter() samples it exactly (inverse CDF, a quadratic per segment, and a uniform
//    azimuth) and phase() evaluates it; scatter()'s weight is therefore 1.
//  - Between tables the medium is linear in λ: μ_s, μ_a and n_eff are interpolated linearly,
//    and so is the differential coefficient μ_s p (dσ/dΩ per volume), so the phase
//    function at λ is the μ_s-weighted mixture of the two neighbouring tables' phase
//    functions, sampled exactly by choosing the table first. Wavelengths outside the
//    tables' range are refused (InputError naming λ and the range). A single table serves
//    exactly its own wavelength.
//  - Absorption (AbsorptionSampling):
//      weighted (default): a collision is sampled with density μ_t e^{−μ_t s}; it always
//        scatters and multiplies the path weight by the single-scattering albedo
//        ω = μ_s / μ_t; surviving the segment has weight 1. E[weight] over a segment is
//        then e^{−μ_t s} (uncollided) + μ_s e^{−μ_t t} dt (scattered at t): unbiased. A
//        medium with μ_s = 0 at λ attenuates by e^{−μ_a s} (Beer–Lambert) instead.
//      analog: a collision is an absorption with probability μ_a / μ_t (fly() returns
//        weight 0, the tracer ends the path) and a scattering otherwise (weight 1).
//    Both are unbiased; weighted has the lower variance, analog keeps every weight 0 or 1
//    (used by tests as an independent estimate of the absorbed fraction).
//  - Random numbers only from the Rng passed in: fly() draws one uniform when μ_t > 0 (and
//    analog draws one more at a collision), scatter() three (table choice, μ, azimuth).
//
// Parameter ranges (InputError naming the table's index and wavelength): at least one
// table; wavelengths finite, positive and distinct (sorted here); n_eff finite and > 0;
// μ_s, μ_a finite and >= 0; phase tables of >= 2 nodes with cos θ strictly monotone from
// ±1 to ∓1 (either order), values finite and >= 0, not all zero when μ_s > 0.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "sim/medium.h"
#include "sim/optics/material.h"

namespace plumage::sim {

// One wavelength of a medium.
struct MediumTable {
    double lambda_nm = 0.0;
    double n_eff = 1.0;  // real effective index (the boundary's index; Fresnel and TIR)
    double mu_s_per_um = 0.0;
    double mu_a_per_um = 0.0;
    std::vector<double> cos_theta;     // nodes, from 1 to −1 or from −1 to 1
    std::vector<double> phase_per_sr;  // p at the nodes
};

// From sim::wave::ScatteringTable (born_medium.h) or any struct with its fields: the real
// part of n_eff is the boundary index; μ_a already holds Im n_eff's absorption.
template <typename Table>
MediumTable medium_table(const Table& t) {
    return {t.lambda_nm, t.n_eff.real(), t.mu_s_per_um, t.mu_a_per_um, t.cos_theta, t.phase_per_sr};
}

// The piecewise-linear phase function of one table (conventions above).
class TabulatedPhaseFunction {
public:
    // `where` names the table in error messages.
    TabulatedPhaseFunction(const std::vector<double>& cos_theta,
                           const std::vector<double>& phase_per_sr, const std::string& where);
    double eval(double cos_theta) const;       // sr⁻¹, cos θ clamped to [−1, 1]
    double sample_cos_theta(double u) const;   // u in [0, 1): inverse CDF
    double cdf(double cos_theta) const;        // P(cos Θ <= cos θ)
    double mean_cosine() const { return g_; }  // g of the interpolant
    // 2π ∫ p dμ of the table as given (before renormalisation).
    double table_integral() const { return table_integral_; }

private:
    std::vector<double> mu_;   // ascending, −1 … 1
    std::vector<double> p_;    // normalised
    std::vector<double> cdf_;  // at the nodes, 0 … 1
    double g_ = 0.0;
    double table_integral_ = 0.0;
};

enum class AbsorptionSampling { weighted, analog };

class ScatteringMedium final : public Medium {
public:
    // Tables whose linear phase interpolant integrates to 1 ± this are accepted.
    static constexpr double kPhaseNormalisationTolerance = 0.02;

    explicit ScatteringMedium(std::vector<MediumTable> tables,
                              AbsorptionSampling absorption = AbsorptionSampling::weighted,
                              std::string name = "scattering medium");

    std::string name() const override { return name_; }
    // μ_s + μ_a > 0 at λ; InputError outside the tables' range (the tracer asks this once
    // per wavelength, so a study at a wavelength the medium was not computed for stops there).
    bool active(double lambda_nm) const override;
    MediumFlight fly(double segment_um, double lambda_nm, Rng& rng) const override;
    MediumScatter scatter(const Vec3d& direction, double lambda_nm, Rng& rng) const override;

    double scattering_coefficient_per_um(double lambda_nm) const;
    double absorption_coefficient_per_um(double lambda_nm) const;
    double effective_index(double lambda_nm) const;
    // p(cos θ) at λ (the μ_s-weighted mixture between tables), sr⁻¹.
    double phase(double cos_theta, double lambda_nm) const;
    double mean_cosine(double lambda_nm) const;  // g
    AbsorptionSampling absorption_sampling() const { return absorption_; }
    double min_lambda_nm() const { return lambda_.front(); }
    double max_lambda_nm() const { return lambda_.back(); }
    // A material with index n_eff(λ) (real), for the medium's boundary (sim/scene.h).
    std::shared_ptr<const optics::Material> effective_material() const { return material_; }

private:
    struct Bracket {
        std::size_t lo, hi;  // table indices (equal for an exact node)
        double t;            // weight of hi, in [0, 1]
    };
    Bracket bracket(double lambda_nm) const;  // InputError outside the range

    std::string name_;
    AbsorptionSampling absorption_;
    std::vector<double> lambda_, n_eff_, mu_s_, mu_a_;
    std::vector<TabulatedPhaseFunction> phase_;
    std::shared_ptr<const optics::Material> material_;
};

}  // namespace plumage::sim
