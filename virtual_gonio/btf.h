// The virtual BTF camera (Filip et al. 2024's capture): for each (light, view) pair, an
// image of the patch, rectified to the patch plane (x right along the barb axis, y up),
// each pixel the BRDF of that patch area: light exiting there towards the detector.
// It shows what a patch average hides: barbs occluding barbules, shadowed rows.
//
// Estimator: quanta land uniformly over the whole (square) patch area seen from the
// light; a quantum counts for pixel p and pair (ω_i, ω_o) when it leaves through the top
// plane inside p's square and within the detector cone around ω_o:
//   f̂_p = Σ weight / (N · (A_p / A) · π sin²α cos θ_o),
// so a uniform patch images as its BRDF in every pixel (a Lambertian plate as ρ/π). N quanta
// are played per light direction and wavelength and each counts for every pair of that light
// whose detector cone it enters (as the goniometer's photon estimator): a set of L light and
// V view directions costs L × N quanta, not L × V × N; cells of one light are correlated.
// Analytic models have no spatial structure (they return the entry point): their images
// are flat, which is the comparison a BTF makes visible.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "sim/scatterer.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/goniometer.h"  // ConvergenceRow
#include "virtual_gonio/png_image.h"

namespace plumage::gonio {

struct BtfConfig {
    std::vector<DirectionPair> pairs;
    std::vector<double> wavelengths_nm = {450.0, 550.0, 650.0};
    double patch_size_um = 3000.0;            // square, centred on the origin
    int pixels = 32;                          // per side
    double detector_half_angle_rad = 0.1745;  // 10°: a BTF trades angular for spatial resolution
    // Per light direction and wavelength; pairs sharing a light direction share its quanta.
    std::uint64_t quanta_per_light = 2000000;
    std::uint64_t seed = kDefaultSeed;
    std::string config_text;  // the study text, for provenance
    void validate() const;
};

struct BtfRecord {
    BtfConfig config;
    std::string scatterer;
    // [pair][row][column][wavelength], row 0 at the top (largest y).
    std::vector<double> value, standard_error;
    double wall_time_s = 0.0;
    double cpu_time_s = 0.0;  // process CPU time (all threads) over the same span
    // One row (the BTF is one pass): wall time, quanta per light direction and wavelength, and
    // the power-weighted relative error Σσ / Σf over every pixel of every pair and wavelength
    // (bright pixels dominate; a relative RMS would be ruled by the pixels one quantum reached).
    std::vector<ConvergenceRow> convergence;
    std::size_t index(std::size_t pair, int row, int column, std::size_t wavelength) const {
        const std::size_t n = static_cast<std::size_t>(config.pixels);
        return ((pair * n + static_cast<std::size_t>(row)) * n + static_cast<std::size_t>(column)) *
                   config.wavelengths_nm.size() +
               wavelength;
    }
};

// Throws Interrupted (common/interrupt.h) on Ctrl-C/SIGTERM (interrupt_requested()).
BtfRecord measure_btf(const Scatterer& scatterer, const BtfConfig& config);
// One pair's image in sRGB (D65; exposure <= 0: the brightest pixel of that pair → Y = 1).
record::RgbImage btf_image(const BtfRecord& record, std::size_t pair, double exposure = 0.0);
void write_btf_record(const BtfRecord& record, const std::filesystem::path& path);

}  // namespace plumage::gonio
