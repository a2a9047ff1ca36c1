// Avian colour vision beside CIE: cone spectral sensitivities of tetrachromatic birds, their
// quantum catches of a reflectance spectrum, and the receptor-noise-limited (RNL) model of
// Vorobyev & Osorio (1998) giving colour distances ΔS in just-noticeable differences (JND), with
// the achromatic (double-cone) contrast ΔL beside it — the numbers the R package pavo 2.9.0
// computes with vismodel and coldist (tests/reference/pavo/ holds pavo's own numbers).
//
// Conventions (all spectra per nanometre, wavelengths in nm, vacuum):
//  - The named birds are pavo 2.9.0's (pavo_visual_system): cone sensitivities tabulated on
//    300–700 nm at 1 nm, oil droplets and ocular media included as measured or modelled by the
//    sources (analysis/metrics/data/README.md), the double cone of a related species for ΔL.
//    Outside 300–700 nm a tabulated cone has no data and catches nothing (pavo's range too).
//  - A system without a table is built from templates: S_i(λ) = P(λ; λmax_i) · T_oil,i(λ),
//    quantal units, P the Govardovskii et al. (2000) A1 template (α and β bands, peak of the α
//    band 1 at λmax), T_oil the Hart & Vorobyev (2005) oil-droplet transmittance, no ocular media.
//  - Illuminant: photon flux I(λ) ∝ E(λ) · λ from the illuminant's relative spectral power E
//    (CIE D65: tabulated 300–830 nm).
//  - Quantum catch Q_i = Σ_λ R(λ) I(λ) S_i(λ) over whole nanometres λ (pavo's 1 nm sum), R
//    interpolated linearly between the caller's grid points and used only inside the grid's span
//    (nothing is extrapolated; captured_share() says what the span leaves out of each cone). von
//    Kries adaptation to the illuminant: q_i = Q_i(R) / Q_i(R ≡ 1) (a perfect white has q_i = 1).
//  - Receptor signal f_i = ln q_i (Fechner); receptor noise ω_i = ν / √η_i, η_i the cone's
//    share of the relative densities and ν fixed by the Weber fraction of the reference cone
//    (ω_ref = weber). ΔS from the closed form for four receptors (Vorobyev & Osorio 1998,
//    appendix; Vorobyev et al. 1998). ΔS = 1 is one JND at threshold (pavo: noise = "neural").
//  - Achromatic contrast ΔL = |ln(q_L,a / q_L,b)| / weber_achromatic, q_L the double cone's
//    adapted catch (pavo's coldist dL; the von Kries factor cancels in the ratio).
//  - Consequences of the model, tested: ΔS(a, a) = 0; ΔS is unchanged when either spectrum (or
//    both) is scaled by a constant (the achromatic direction carries no chromatic contrast).
#pragma once

#include <array>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "sim/optics/colour.h"
#include "sim/optics/spectrum.h"

namespace plumage::analysis {

inline constexpr std::size_t kAvianCones = 4;
using ConeVector = std::array<double, kAvianCones>;

// Govardovskii et al. (2000) A1 visual-pigment template: α band (with the λmax-dependent
// constant a) plus, if beta_band, the Gaussian β band. λmax in 300–700 nm, λ > 0.
double govardovskii_a1(double lambda_max_nm, double lambda_nm, bool beta_band = true);

// Hart & Vorobyev (2005) coloured oil droplets: types and their regressions λmid = a λcut + b
// (per droplet type) giving B_mid = 1 / (2 (λmid − λcut)) where only λcut was measured.
enum class OilDroplet { transparent, clear_c, yellow_y, red_r, pale_p };
double oil_droplet_b_mid(OilDroplet type, double lambda_cut_nm);
// T(λ) = exp(−exp(−2.89 B_mid (λ − λcut) + 1.08)) (Hart & Vorobyev 2005); 1 for
// transparent droplets. T(λmid) = 1/2 and dT/dλ(λmid) = B_mid (to 0.3 %) by construction.
double oil_droplet_transmittance(OilDroplet type, double lambda_cut_nm, double lambda_nm);

struct ConeClass {
    std::string name;         // "UVS", "VS", "SWS", "MWS", "LWS"
    double lambda_max_nm;     // template peak; for a tabulated cone, the table's (informative)
    OilDroplet droplet;       // templates only
    double lambda_cut_nm;     // templates only; ignored for transparent droplets
    double relative_density;  // η before normalisation
};

// Sensitivities sampled at first_nm, first_nm + 1, ... (1 nm), any common scale per column
// (von Kries adaptation removes it); zero outside the table.
struct ConeTable {
    double first_nm = 300.0;
    std::array<std::vector<double>, kAvianCones> cones;
    std::vector<double> double_cone;  // the achromatic channel; empty: none
    double last_nm() const;
};

struct AvianVisualSystem {
    std::string name;    // "UVS (blue tit)"
    std::string source;  // citation, one line
    std::array<ConeClass, kAvianCones> cones;
    double weber_fraction = 0.1;
    std::size_t weber_reference = 3;         // the cone whose Weber fraction is given (LWS)
    bool beta_band = true;                   // templates only
    std::shared_ptr<const ConeTable> table;  // when set, the cones (and double cone) from it
    std::string double_cone;                 // its name, e.g. "blue tit double cone"
    double weber_achromatic = 0.1;           // ω of the double cone (pavo's weber.achro)
};

// pavo 2.9.0's birds by pavo's name: "bluetit", "pfowl", "avg.uv", "avg.v" (sources and
// densities: analysis/metrics/data/README.md). InputError for any other name, listing these.
const AvianVisualSystem& pavo_visual_system(std::string_view pavo_name);
// The two birds of the studies: pavo's blue tit and peafowl.
const AvianVisualSystem& ultraviolet_sensitive_system();  // pavo "bluetit"
const AvianVisualSystem& violet_sensitive_system();       // pavo "pfowl"

// S_i(λ) as defined above (templates: the α band of the pigment peaks at 1; tables: as
// tabulated, linear between whole nanometres).
double cone_sensitivity(const AvianVisualSystem& system, std::size_t cone, double lambda_nm);
// The double cone's sensitivity; InputError if the system has none.
double double_cone_sensitivity(const AvianVisualSystem& system, double lambda_nm);
// Where the system's sensitivities are defined: [300, 700] for pavo's tables, [300, 800] for
// templates (the suite's spectral range).
std::array<double, 2> sensitivity_range_nm(const AvianVisualSystem& system);

// Receptor noise ω_i (Weber fractions of each channel).
ConeVector receptor_noise(const AvianVisualSystem& system);

// Quantum catches on a fixed wavelength grid, summed over whole nanometres of the grid's span
// (linear interpolation between grid points). Throws InputError if the grid leaves the
// illuminant's table (D65: 300–830 nm) or gives a cone no light at all.
class ConeCatches final {
public:
    ConeCatches(const AvianVisualSystem& system, const optics::WavelengthGrid& grid,
                optics::Illuminant illuminant = optics::Illuminant::d65);
    // von Kries-adapted catches q_i of a reflectance spectrum sampled on the grid.
    ConeVector operator()(std::span<const double> reflectance) const;
    // The double cone's von Kries-adapted catch q_L (InputError if the system has none).
    double double_cone(std::span<const double> reflectance) const;
    bool has_double_cone() const { return !double_cone_weights_.empty(); }
    // Var(ln q_L) for independent per-wavelength standard errors σ_k, to first order.
    double log_double_cone_variance(std::span<const double> reflectance,
                                    std::span<const double> standard_error) const;
    // Var(f_i)-style propagation: the covariance of f = ln q for independent per-wavelength
    // standard errors σ_k of the reflectance, to first order (C_ij = Σ_k w_ik w_jk σ_k² / q_i q_j).
    std::array<ConeVector, kAvianCones> log_catch_covariance(
        std::span<const double> reflectance, std::span<const double> standard_error) const;
    // The share of each cone's white-light catch over sensitivity_range_nm (1 nm) that the
    // grid's span [first, last] holds: what a cone misses when the grid does not cover it.
    const ConeVector& captured_share() const { return captured_share_; }
    const AvianVisualSystem& system() const { return system_; }

private:
    AvianVisualSystem system_;
    std::array<std::vector<double>, kAvianCones> weights_;  // Σ_k w_ik = 1
    std::vector<double> double_cone_weights_;               // Σ_k w_k = 1; empty: none
    ConeVector captured_share_{};
};

// ΔS in JND between two sets of von Kries-adapted catches (each q_i > 0).
double rnl_delta_s(const ConeVector& q_a, const ConeVector& q_b, const AvianVisualSystem& system);
// ΔL in JND between two adapted double-cone catches (each > 0): |ln(a / b)| / weber_achromatic.
double achromatic_contrast(double q_a, double q_b, const AvianVisualSystem& system);
// Δf^T W Δf = ΔS² as a quadratic form: W, for noise propagation (E[ΔS²] = tr(W C)).
std::array<ConeVector, kAvianCones> rnl_metric(const AvianVisualSystem& system);
// √tr(W C): the RMS ΔS that the standard errors alone put between a measured spectrum and its
// expectation (first order in σ / R).
double rnl_noise_floor(const std::array<ConeVector, kAvianCones>& log_catch_covariance,
                       const AvianVisualSystem& system);

}  // namespace plumage::analysis
