// Error against run time: how a Monte Carlo estimate converges, told from its passes.
//
//  - error_against_reference: one pass of an estimate with standard errors σ_k against a
//    reference with its own error ε_k (a cubature's |fine − coarse|, 0 for closed forms),
//    over the cells whose reference is positive:
//      estimated  = sqrt(mean (σ_k / ref_k)²)         what the instrument says
//      true       = sqrt(mean ((x_k − ref_k) / ref_k)²) what it is
//      floor      = sqrt(mean (ε_k / ref_k)²)          below this "true" cannot be told
//      χ²         = Σ (x_k − ref_k)² / (σ_k² + ε_k²), with its upper-tail p-value over the
//                   cell count: a small p means the estimate's errors are larger than its σ
//                   says (bias, or a reference worse than its ε).
//    With few cells the "true" RMS scatters by about 1/√(2n) of itself even when σ is right;
//    the χ² test is the verdict, the two RMS curves the picture.
//  - fit_power_law: e = c·t^a by least squares in log–log, with the standard error of a from
//    the residual scatter (a Monte Carlo error falls as t^(−1/2)).
#pragma once

#include <span>

namespace plumage::analysis {

struct ErrorAgainstReference {
    double estimated = 0.0, true_error = 0.0, reference_floor = 0.0;
    double chi_square = 0.0, p_value = 1.0;
    int cells = 0;
};

// All spans the same length. Cells with reference ≤ 0 or σ = ε = 0 are left out.
ErrorAgainstReference error_against_reference(std::span<const double> value,
                                              std::span<const double> standard_error,
                                              std::span<const double> reference,
                                              std::span<const double> reference_error);

struct PowerLawFit {
    double exponent = 0.0, exponent_standard_error = 0.0, prefactor = 0.0;
    int points = 0;
};

// Points with t ≤ 0 or e ≤ 0 are left out; fewer than two points give points < 2 and
// exponent NaN. The standard error is 0 for two points (no residual to tell it from).
PowerLawFit fit_power_law(std::span<const double> t, std::span<const double> e);

}  // namespace plumage::analysis
