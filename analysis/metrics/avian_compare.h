// Two BRDF records (same instrument, pairs and wavelengths) as a bird sees them: the RNL colour
// distance ΔS (analysis/metrics/avian_vision.h) per direction pair between the spectra of π·f (the
// reflectance factor: 1 for a white Lambertian) under D65, beside the ΔS that the records'
// standard errors alone would give (first order, σ² = σ_test² + σ_reference² per cell).
//
// Pairs "carrying signal": the reference's mean π·f over the grid is at least signal_fraction
// of its largest over all pairs, and both records give every cone a positive catch (ΔS is a
// log ratio: a dark pair's colour is its noise). The summary is over those pairs.
//
// And the layout the R package pavo reads (as.rspec / getspec): a CSV with a header row, first
// column `wl` (nm), one column per sample, reflectance in percent.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "analysis/metrics/avian_vision.h"
#include "virtual_gonio/goniometer.h"

namespace plumage::analysis {

struct AvianRecordComparison {
    std::string system;
    std::string source;  // the system's citation and densities
    std::array<std::string, kAvianCones> cone_names;
    std::size_t pairs = 0, pairs_with_signal = 0;
    double signal_fraction = 0.0;               // the threshold used (see above)
    double median = 0.0, p95 = 0.0, max = 0.0;  // ΔS (JND) over pairs carrying signal
    double rms = 0.0;                           // √(mean ΔS²) over the same pairs
    // The noise floor per pair is √E[ΔS²] of the noise alone (first order); its median over
    // the pairs, and its RMS (to set beside `rms`: like against like).
    double median_noise_floor = 0.0, rms_noise_floor = 0.0;
    double share_above_one_jnd = 0.0;  // of the pairs carrying signal
    // Achromatic (double-cone) contrast ΔL (JND) over the same pairs, its RMS noise floor and
    // largest value; has_double_cone false (and these 0) for a system without one.
    bool has_double_cone = false;
    double rms_delta_l = 0.0, rms_delta_l_noise_floor = 0.0, max_delta_l = 0.0;
    std::size_t max_pair = 0;     // where ΔS is largest
    ConeVector captured_share{};  // ConeCatches::captured_share on the grid
};

// InputError if the records' pairs or wavelengths differ or the grid cannot feed the cones.
AvianRecordComparison compare_records_avian(const gonio::BrdfRecord& test,
                                            const gonio::BrdfRecord& reference,
                                            const AvianVisualSystem& system,
                                            double signal_fraction = 0.01);

// Markdown: one row per visual system (pairs carrying signal, ΔS median / 95th percentile / max
// beside the noise floor, ΔL RMS beside its floor and max) and what the grid leaves out of each
// cone's light.
std::string avian_comparison_markdown(const std::vector<AvianRecordComparison>& rows,
                                      const gonio::BrdfRecord& reference,
                                      const std::string& test_name,
                                      const std::string& reference_name);

// What a wavelength grid costs a bird: ΔS and ΔL between each spectrum sampled on the grid (the
// catches interpolate it linearly to 1 nm) and the same spectrum evaluated at every whole
// nanometre of the grid's span. An analytic model is the natural source (exact at any λ, so the
// difference is the grid's alone). Spectra whose catches are not all positive are skipped.
struct AvianQuadratureError {
    std::size_t spectra = 0;  // compared (positive catches on both grids)
    double rms_delta_s = 0.0, max_delta_s = 0.0, rms_delta_l = 0.0, max_delta_l = 0.0;
};
// `reflectance(i, λ)` must be safe to call from several threads at once.
AvianQuadratureError avian_quadrature_error(
    std::size_t spectra, const optics::WavelengthGrid& grid, const AvianVisualSystem& system,
    const std::function<double(std::size_t, double)>& reflectance);

// The direction pairs worth exporting as spectra: the reference's brightest pair (by mean π·f),
// each comparison's largest-ΔS pair and the reference's median-brightness pair, without repeats.
std::vector<std::size_t> pavo_export_pairs(const gonio::BrdfRecord& reference,
                                           const std::vector<AvianRecordComparison>& rows);

// Markdown: the RNL ΔS (JND) between every two of `spectra` (reflectance on `wavelengths_nm`,
// with standard errors `errors`), a symmetric matrix, each entry beside its noise floor
// √(floor_i² + floor_j²); "–" where a spectrum gives a cone no catch. Then the achromatic
// contrast ΔL as a matrix alike, and each spectrum's von Kries-adapted quantum catches (cones
// and double cone), if the system has a double cone.
std::string rnl_matrix_markdown(const std::vector<std::string>& names,
                                const std::vector<std::vector<double>>& spectra,
                                const std::vector<std::vector<double>>& errors,
                                const std::vector<double>& wavelengths_nm,
                                const AvianVisualSystem& system);

// pavo's spectra layout; `columns[j]` has one value per wavelength (already in percent).
std::string pavo_csv_text(const std::vector<double>& wavelengths_nm,
                          const std::vector<std::string>& names,
                          const std::vector<std::vector<double>>& columns);

// The von Kries-adapted quantum catches of the same columns (per cent, as for pavo_csv_text) for
// each of pavo's four birds (bluetit, pfowl, avg.uv, avg.v): a CSV with a header row and one row
// per bird and sample, `bird,sample,q_short,q_sws,q_mws,q_lws,q_double_cone` (q_short: the UVS
// or VS cone); NA where the grid gives a cone no light.
std::string avian_catches_csv(const std::vector<double>& wavelengths_nm,
                              const std::vector<std::string>& names,
                              const std::vector<std::vector<double>>& columns);

// A column name for a direction pair that R keeps as is: letters, digits and '_' only, e.g.
// "simulation_i30a0_o30a180" (θ_i 30°, azimuth 0°; θ_o 30°, azimuth 180°; azimuths in 0–359).
std::string pavo_pair_name(const std::string& prefix, const gonio::DirectionPair& pair);

}  // namespace plumage::analysis
