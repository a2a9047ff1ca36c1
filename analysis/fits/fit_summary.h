// A fit's result in one model-independent form, and that form as the documented JSON file
// (docs/user_data.md, "Fitted parameters (JSON)"): model, parameter name → value, σ, unit, valid
// range, fixed or free; fit quality (χ², degrees of freedom, reduced χ², residual RMS); the
// covariance of the free parameters; the data's provenance.
//
// σ is what the fits state (analysis/fits/huang2022_fit.h, analysis/fits/filip2024_fit.h): the
// square root of the diagonal of s² (JᵀJ)⁻¹ at the optimum, s² the reduced χ² — so it already
// absorbs a misjudged noise level; NaN (JSON null) for fixed parameters, parameters on a bound's
// linearisation and when JᵀJ is singular.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "analysis/fits/filip2024_fit.h"
#include "analysis/fits/huang2022_fit.h"

namespace plumage::analysis {

struct FittedParameter {
    std::string name;
    std::string unit;
    double value = 0.0;
    double sigma = 0.0;  // NaN: none (fixed, or no covariance)
    double min = 0.0;    // valid range; ±infinity where unbounded (JSON null)
    double max = 0.0;
    bool fixed = false;
    bool at_bound = false;
};

struct FitProvenance {
    std::string data_file;         // as the user named it
    std::string data_format;       // "csv", "brdf_record", "scatterogram_record", "arrays"
    bool standard_errors = false;  // the data gave σ per observation
    std::size_t left_out = 0;      // observations the reader dropped (docs/user_data.md)
    std::vector<double> wavelengths_nm;
};

struct FitSummary {
    std::string model;                               // "huang2022" or "filip2024"
    std::string reference;                           // the paper and equations
    std::vector<FittedParameter> parameters;         // the model's table order
    std::vector<std::string> covariance_parameters;  // free parameters, covariance's order
    Eigen::MatrixXd covariance;                      // empty when not available
    double chi_square = 0.0;
    double reduced_chi_square = 0.0;
    int observations = 0;
    int degrees_of_freedom = 0;
    double residual_rms_per_sr = 0.0;
    bool converged = false;
    std::string termination;
    int local_fits = 0;  // Levenberg–Marquardt runs from different starts (global stage)
    // Parameters another run's optimum, as good (Δχ² ≤ 1), puts over 3σ away.
    std::vector<std::string> undetermined;
    FitProvenance provenance;
    // What a reader must know before trusting the fit (fit_warnings); empty: none.
    std::vector<std::string> warnings;

    // The documented JSON (format "plumage fit", format_version 1), UTF-8, 2-space indented.
    std::string to_json() const;
};

// χ²/dof above this, with σ given by the data, is "far above 1": at 100 degrees of freedom its
// p-value is below 1e-20, so the model does not describe the data within their σ, or the fit
// stopped in a local minimum (analysis/fits/huang2022_fit.h, filip2024_fit.h: their global stages).
inline constexpr double kFitWarningReducedChiSquare = 3.0;
// Nearer 1, χ² is still tested: a p-value below this (a 3.7σ excess) with σ given by the data is
// a warning too; a fit at the true parameters reaches it once in 10⁴.
inline constexpr double kFitWarningPValue = 1e-4;

// The fit's warnings, each a sentence naming what to check: not converged; χ²/dof above
// kFitWarningReducedChiSquare or its p-value below kFitWarningPValue (data with σ), or no σ given
// (then χ² cannot judge the fit); free parameters on a bound of their valid range (their σ is
// undefined and the data may want a value the model does not allow); parameters that an equally
// good minimum puts elsewhere; no covariance (JᵀJ singular: some combination of parameters is not
// determined). summarise_fit fills FitSummary::warnings with it.
std::vector<std::string> fit_warnings(const FitSummary& summary);

// Huang's parameter table (analysis/models/huang2022.h): the ranges the fit's maps keep it in.
FitSummary summarise_fit(const HuangFitResult& fit, const HuangFitOptions& options,
                         FitProvenance provenance);
FitSummary summarise_fit(const Filip2024FitResult& fit, const Filip2024FitOptions& options,
                         FitProvenance provenance);

}  // namespace plumage::analysis
