// Comparison of two BRDF records measured on the same instrument (same direction
// pairs and wavelengths): the numbers an appearance researcher asks of a model
// against ground truth.
//
//  rmse                  sqrt(mean (a − b)²) over cells, 1/sr
//  relative_l1           Σ|a − b| / Σ|b| (b is the reference)
//  cosine_weighted_rmse  as rmse with weights cos θ_i cos θ_o (what reaches a sensor)
//  ΔE00                  per pair, between the colours of π·f (the reflectance factor: 1
//                        for a white Lambertian) under D65, CIE 1931 2°; mean and max
//  per lobe              the same three numbers for every lobe name both records have
//  worst                 the cells with the largest |a − b|, with their directions
//
// Noise floors: what each number would be if a and b were the same function measured with
// the records' Monte Carlo standard errors (σ² = σ_a² + σ_b² per cell). A record made by the eval
// estimator (a cubature) adds nothing: its error estimate is the rule's, not noise, and a floor
// that carried it would hide the model's departures behind its own numerics (converge the rule
// instead: GoniometerConfig::eval_tolerance): rmse sqrt(mean σ²); relative L1 sqrt(2/π) Σσ / Σ|b|
// (the mean |N(0, σ)|); ΔE00 the mean over pairs of ΔE00(b, b + noise), noise drawn 16 times per
// pair from a fixed stream. A difference well above its floor is the models'; one at the floor is
// noise.
#pragma once

#include <string>
#include <vector>

#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::analysis {

struct CellDifference {
    std::size_t pair, wavelength;
    double test, reference, standard_error;  // standard error of the test (if Monte Carlo)
};

struct ErrorMeasures {
    double rmse = 0.0, relative_l1 = 0.0, cosine_weighted_rmse = 0.0;
    double rmse_noise_floor = 0.0, relative_l1_noise_floor = 0.0;
};

struct RecordComparison {
    ErrorMeasures total;
    std::vector<std::pair<std::string, ErrorMeasures>> lobes;
    double mean_delta_e00 = 0.0, max_delta_e00 = 0.0, delta_e00_noise_floor = 0.0;
    bool colour_available = false;  // optics::carries_colour (300–830 nm, UV weight 0)
    std::vector<CellDifference> worst;
};

// InputError if the records' pairs or wavelengths differ.
RecordComparison compare_records(const gonio::BrdfRecord& test, const gonio::BrdfRecord& reference,
                                 std::size_t worst_count = 10);

// Markdown: a summary table and the worst cells.
std::string comparison_markdown(const RecordComparison& c, const gonio::BrdfRecord& test,
                                const std::string& test_name, const std::string& reference_name);

// Scatterogram summaries, by lobe index of s.lobes (−1 or absent: 0). The mean over wavelengths
// of the fraction of the incident power a lobe takes below the patch; and the share of the
// reflected power Σ I Ω (pixels and wavelengths) that a lobe carries.
double mean_transmitted(const gonio::Scatterogram& s, int lobe);
double reflected_share(const gonio::Scatterogram& s, int lobe);

// Σ|a − b| Ω / Σ b Ω over pixels and wavelengths, for one lobe of each (or all: −1).
double image_relative_l1(const gonio::Scatterogram& a, const gonio::Scatterogram& b, int lobe_a,
                         int lobe_b);

// What image_relative_l1(a, b, −1, −1) would be if a and b were the same image measured with
// their standard errors: sqrt(2/π) Σ sqrt(σ_a² + σ_b²) Ω / Σ b Ω (the mean |N(0, σ)|). Totals
// only: the records carry no per-lobe standard errors.
double image_relative_l1_noise_floor(const gonio::Scatterogram& a, const gonio::Scatterogram& b);

// Index of a lobe name, or −1.
int lobe_index(const std::vector<std::string>& lobes, const std::string& name);

}  // namespace plumage::analysis
