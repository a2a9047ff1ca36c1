// The virtual BTF camera (Filip et al. 2024's capture): for each (light, view) pair, an
// image of the patch, rectified to the patch plane (x right along the barb axis, y up),
// each pixel the BRDF of that patch area: light exiting there towards the detector.
// It shows what a patch average hides: barbs occluding barbules, shadowed rows.
//
// Aperture (as the goniometer's, virtual_gonio/goniometer.h): the detector is a cone C_o of
// half-angle α around ω_o; the light is collimated along ω_i (view_cone) or comes from a cone
// C_i of the same half-angle (both_cones). A pixel p of pair (ω_i, ω_o) is the average of the
// pixel's BRDF f_p over the cone(s), weighted by projected solid angle (Π = π sin²α cos θ for a
// cone around an axis at θ, exactly, while the cone stays above the patch).
//
// Two estimators of the same pixels:
//  - forward (light side): quanta land uniformly over the whole (square) patch area A seen from
//    the light (under both_cones from a direction drawn in C_i by projected solid angle); a
//    quantum counts for pixel p and pair (ω_i, ω_o) when it leaves through the top plane inside
//    p's square and within C_o:
//        f̂_p = Σ weight / (N · (A_p / A) · Π_o),
//    N quanta per light direction and wavelength, each counted for every pair of that light
//    whose cone it enters (a set of L lights and V views costs L × N quanta, not L × V × N).
//    Quantum q of light l and wavelength k draws from Rng(derive_seed(seed, "btf/forward",
//    l · nλ + k), q) (common/seed.h).
//  - detector (adjoint, both_cones only): quanta start in pixel p (uniformly over its square on
//    the top plane) in a direction drawn in C_o by projected solid angle and are traced back into
//    the patch by the scatterer's detector-side walk (sim/scatterer/scatterer.h, sim/tracer.h); a
//    quantum counts for every light cone C_i of that view which its escape enters through the
//    patch:
//        f̂_p = Σ weight / (N_p · Π_i),
//    N_p quanta per view direction and pixel, all wavelengths on one shared path. Why it holds:
//    reciprocity of the radiance kernel S(x_i, ω_i; x_o, ω_o) = S(x_o, ω_o; x_i, ω_i) makes the
//    detector walk's E[w · 1{ω ∈ C_i, exit ∈ A}] equal to (A / A_p) · (1/Π_o) ∫∫ (the forward
//    walk's density) cos θ_i cos θ_o dω_i dω_o, which is Π_i f̂_p. Why it pays: every quantum
//    starts in the pixel it measures and all wavelengths share it, a view's quanta serve all of
//    its lights, and it splits at its first film and aims one branch of its first diffuse event
//    at the light cones (sim/tracer.h: "Splitting", "Guided diffuse branches"), the source-side
//    connection of a bidirectional estimator. A collimated light (view_cone) cannot be reached
//    by a walk from the detector through mirror-like events, so that aperture keeps the forward
//    estimator.
// Stratified groups (detector estimator, stratified_group = G > 1): a pixel's quanta come in
// groups of G whose start points on the pixel's square and directions in C_o are the points of
// one scrambled Sobol group (sim/scatterer/stratified.h: exactly uniform each, so unbiased, and
// spread evenly over the square and the cone together). A pixel's edge of a highlight, a
// barbule's rim and the light cone's rim then cost less noise than with independent starts; the
// walk beyond the start draws from the quantum's own stream as before. Group g of pixel item
// (as below) draws its scramble from Rng(derive_seed(seed, "btf/detector-strata", view),
// item × groups + g).
// Standard errors: forward, Σx² / per-pixel share (sparse hits); detector, the sample variance
// over each pixel's N_p quanta (a quantum's branches added before squaring), or with stratified
// groups over its N_p / G group means (the groups are independent; the quanta within one are
// not, and their spread would overstate the error).
// Analytic models have no spatial structure (they return the entry point): their images
// are flat, which is the comparison a BTF makes visible. They have no detector-side walk.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "sim/scatterer/scatterer.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/goniometer.h"  // ConvergenceRow
#include "virtual_gonio/record/png_image.h"

namespace plumage::gonio {

// See "Two estimators" above. Study files: estimator = "forward" | "detector".
enum class BtfEstimator { forward, detector };
const char* to_string(BtfEstimator estimator);
BtfEstimator parse_btf_estimator(const std::string& text);  // InputError naming the choices

struct BtfConfig {
    std::vector<DirectionPair> pairs;
    std::vector<double> wavelengths_nm = {450.0, 550.0, 650.0};
    double patch_size_um = 3000.0;            // square, centred on the origin
    int pixels = 32;                          // per side
    double detector_half_angle_rad = 0.1745;  // 10°: a BTF trades angular for spatial resolution
    // Per light direction and wavelength; pairs sharing a light direction share its quanta.
    std::uint64_t quanta_per_light = 2000000;
    Aperture aperture = Aperture::view_cone;
    BtfEstimator estimator = BtfEstimator::forward;
    // Detector estimator: per view direction, pixel and pass (all wavelengths on one shared
    // path).
    std::uint64_t quanta_per_pixel = 1000;
    // Detector estimator: quanta per stratified group (see "Stratified groups" above), a power of
    // two 1 … 4096 that divides quanta_per_pixel; 1: independent quanta.
    std::uint64_t stratified_group = 1;
    // Detector estimator: each walk's reflected branch splits again at its next event if that
    // is a film (BranchOptions::split_reflections, sim/tracer.h): the chains of two film
    // reflections between barbules then come from every walk whose first reflection meets a film.
    bool split_reflections = false;
    // Detector estimator: at a bare dielectric interface whose mirror direction lies within a
    // light's cone, each walk takes both sides, the reflection as a branch of its own
    // (BranchOptions::split_aimed_reflections, sim/tracer.h): the partial reflections that head
    // for a light (R ≈ 0.04 on keratin) come from every walk that meets one.
    bool split_aimed_reflections = false;
    // The detector estimator's stop rule: passes of quanta_per_pixel each, every pass on its own
    // streams, until the median per-pixel error over the lit pixels (median_lit_pixel_error) is
    // at most target_pixel_error, or max_passes are done, or another pass would end after
    // max_time_s (from the passes so far). 0 switches a target or the time limit off. The
    // forward estimator is one pass.
    int max_passes = 1;               // 1 … 100000
    double target_pixel_error = 0.0;  // [0, 1); e.g. 0.05
    double max_time_s = 0.0;          // s, >= 0
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
    // One row per pass (the forward estimator has one): pass, wall time, quanta so far (per
    // light direction and wavelength, or per view direction and pixel for the detector
    // estimator), and the power-weighted relative error Σσ / Σf over every pixel of every pair
    // and wavelength (bright pixels dominate; a relative RMS would be ruled by the pixels one
    // quantum reached). The detector estimator stops on the median rule (BtfConfig), and the
    // species report prints that median.
    std::vector<ConvergenceRow> convergence;
    std::size_t index(std::size_t pair, int row, int column, std::size_t wavelength) const {
        const std::size_t n = static_cast<std::size_t>(config.pixels);
        return ((pair * n + static_cast<std::size_t>(row)) * n + static_cast<std::size_t>(column)) *
                   config.wavelengths_nm.size() +
               wavelength;
    }
};

// Throws Interrupted (common/interrupt.h) on Ctrl-C/SIGTERM (interrupt_requested()), InputError
// for a bad configuration or a detector estimator on a scatterer without a detector-side walk.
// With progress, the detector estimator prints a line per pass on stderr (pass, quanta, median
// per-pixel error, time; each overwriting the last).
BtfRecord measure_btf(const Scatterer& scatterer, const BtfConfig& config, bool progress = false);
// The same with a run control: Ctrl-C flag, progress and, for the detector estimator, a
// checkpoint after every pass that a rerun of the same study resumes (pass_checkpoint.h; its
// parts: the build, config_text, the camera's configuration, control.checkpoint_inputs).
// Interrupted, it throws Interrupted; the checkpoint keeps the completed passes.
BtfRecord measure_btf(const Scatterer& scatterer, const BtfConfig& config,
                      const RunControl& control);
// The per-pixel error rule: the median of σ/f over the lit pixels of the given pairs (all when
// empty), every wavelength; a pixel is lit when its value exceeds lit_fraction of the brightest
// pixel of its tile at that wavelength (shadowed and unseen pixels are not ground truth of
// anything). Infinity when no pixel is lit.
double median_lit_pixel_error(const BtfRecord& record, std::span<const std::size_t> pairs = {},
                              double lit_fraction = 0.01);
// One pair's image in sRGB (D65; exposure <= 0: the brightest pixel of that pair → Y = 1).
record::RgbImage btf_image(const BtfRecord& record, std::size_t pair, double exposure = 0.0);
void write_btf_record(const BtfRecord& record, const std::filesystem::path& path);

}  // namespace plumage::gonio
