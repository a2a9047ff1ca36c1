// A measurement against a model, decided from the measurement's Monte Carlo noise alone: the
// verdict at the top of a study's report (agrees / differs / undecided), with its statistic and
// the size of the difference.
//
// Over the cells used (finite values, σ > 0, and the caller's mask: e.g. the cells with signal),
// z_c = (test_c − reference_c) / σ_c with σ the test's Monte Carlo standard error:
//  - χ² = Σ z_c², N cells, p = P(χ²_N ≥ χ²) (analysis/metrics/statistics.h);
//  - RMS z = sqrt(χ²/N), and the fraction of cells with |z| > 3 (0.27 % for pure noise);
//  - the power difference Σ test / Σ reference − 1 and its σ, sqrt(Σ σ²) / Σ reference (cells
//    taken as independent), and its two-sided normal p (a shift of every cell by a little is
//    seen here long before χ² sees it);
//  - p = min(1, 2 min(p_χ², p_power)): the two tests of one measurement, Bonferroni.
// Verdict: "differs" when p < 1e-3, "agrees" when p >= 0.01, "undecided" between: one
// measurement is one test, at the usual 1 % level, with a band below it where neither call is
// safe. A difference can be significant and small: the power difference and RMS z say how big.
//
// What the floor leaves out on purpose: the reference's own error (a model's cubature) is not
// noise. It is stated beside the verdict (its median relative value over the cells used,
// `reference_error`), and `reference_converged` is false when it exceeds `max_reference_error`
// (1 %): then a "differs" may be the model's numerics, not its physics, and the caller says so.
#pragma once

#include <cstdint>
#include <span>
#include <string>

namespace plumage::analysis {

struct AgreementVerdict {
    std::string verdict;  // "agrees", "differs", "undecided"; "no cells" when none is usable
    std::size_t cells = 0;
    double chi_square = 0.0, chi_square_p = 1.0, power_p = 1.0;
    double p_value = 1.0;  // the two tests together (header)
    double rms_z = 0.0, beyond_3_sigma = 0.0;
    double power_difference = 0.0, power_difference_sigma = 0.0;
    double reference_error = 0.0;  // median |error / value| of the reference over the cells used
    bool reference_converged = true;
};

// Spans of one length (InvariantError otherwise); `reference_error` and `use` may be empty (no
// reference error; every cell).
AgreementVerdict agreement(std::span<const double> test, std::span<const double> test_sigma,
                           std::span<const double> reference,
                           std::span<const double> reference_error = {},
                           std::span<const std::uint8_t> use = {},
                           double max_reference_error = 0.01);

}  // namespace plumage::analysis
