// The virtual goniometer: measures the BRDF of any Scatterer on a list of
// (light, view) direction pairs, each cell with its standard error, progressively,
// with a convergence table of (wall time, samples, estimated error), resumable after
// an interruption. The record layout is documented in virtual_gonio/RECORD.md.
//
// Geometry: the patch frame of sim/scatterer.h (+z normal). The light is a collimated
// beam of radius beam_radius_um (its footprint on the patch is the beam's cross-section
// projected along ω_i); each view direction has a detector: a cone of half-angle α
// around it, solid angle Ω = 2π(1 − cos α), projected solid angle π sin²α cos θ_v.
//
// Estimators:
//  - photon: play quanta through sample() and count what enters each detector:
//    f̂ = mean(weight · 1[ω_o ∈ cone]) / (π sin²α cos θ_v). Unbiased for the cone-averaged
//    BRDF (cosine-weighted over the cone); works for every scatterer (the tracer too).
//    Standard errors from the per-quantum variance. Streams are seeded from (seed, light
//    direction, wavelength, quantum index), and partial sums are combined in a fixed
//    order: results do not depend on thread count, and a resumed run equals an
//    uninterrupted one bit for bit.
//  - eval: for scatterers that can evaluate f, the cone average by a product cubature
//    (cosine-weighted; `eval_rings` Gauss rings in projected area × 2·rings azimuths);
//    its error is estimated against the rule with half the rings. Deterministic. Narrow
//    lobes (Huang's R) need more rings than smooth ones.
//  automatic picks eval when available.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "common/interrupt.h"
#include "sim/scatterer.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/png_image.h"

namespace plumage::gonio {

enum class Estimator { automatic, photon, eval };

struct GoniometerConfig {
    std::string direction_set = "custom";
    std::vector<DirectionPair> pairs;
    std::vector<double> wavelengths_nm = {550.0};
    double detector_half_angle_rad = 0.0436;  // 2.5°
    double beam_radius_um = 50.0;
    std::uint64_t seed = kDefaultSeed;
    Estimator estimator = Estimator::automatic;
    std::uint64_t quanta_per_pass = 20000;  // per light direction and wavelength
    int max_passes = 100;
    double time_budget_s = std::numeric_limits<double>::infinity();
    double target_relative_error = 0.0;  // stop once the estimated relative RMS error is below
    int eval_rings = 4;                  // eval estimator: cubature rings (see above)
    std::string config_text;             // the study text, for provenance

    void validate() const;  // InputError naming the field
};

struct ConvergenceRow {
    int pass;
    double wall_time_s;
    std::uint64_t quanta;  // per (light direction, wavelength)
    double estimated_relative_rms_error;
};

struct BrdfRecord {
    GoniometerConfig config;
    std::string scatterer;
    std::vector<std::string> lobes;
    Estimator estimator_used = Estimator::photon;
    // Row-major [pair][wavelength]; lobe_values [lobe][pair][wavelength], 1/sr.
    std::vector<double> value, standard_error, lobe_values, lobe_standard_error;
    std::vector<ConvergenceRow> convergence;
    int passes = 0;
    std::uint64_t quanta = 0;
    double wall_time_s = 0.0;
    double cpu_time_s = 0.0;  // process CPU time (all threads), summed over resumed runs as wall
    int threads = 1;
    // Stopped by an interrupt with a checkpoint: the completed passes (the checkpoint holds
    // them). Without a checkpoint an interrupt throws Interrupted (common/interrupt.h) instead.
    bool interrupted = false;
    double detector_solid_angle_sr = 0.0;

    double at(std::size_t pair, std::size_t wavelength) const {
        return value[pair * config.wavelengths_nm.size() + wavelength];
    }
    double error_at(std::size_t pair, std::size_t wavelength) const {
        return standard_error[pair * config.wavelengths_nm.size() + wavelength];
    }
};

struct RunControl {
    // Polled between chunks of work; by default the process-wide flag that a
    // ScopedInterruptHandler sets on SIGINT/SIGTERM (never set while none is installed).
    const std::atomic<bool>* interrupt = &interrupt_flag();
    std::function<void(const ConvergenceRow&)> on_pass;     // after each completed pass
    std::function<void(const BrdfRecord&)> on_pass_record;  // the same moment, with the values
    std::filesystem::path checkpoint;  // empty: none; else resumed from and written after each pass
    bool progress = false;             // progress line on stderr
};

BrdfRecord measure_brdf(const Scatterer& scatterer, const GoniometerConfig& config,
                        const RunControl& control = {});

// Filip et al. 2024, Fig. 7: the "BRDF fingerprint" of a light-major pair list (pair =
// light × views + view): one block of `block` × `block` pixels per pair, rows the light
// directions, columns the view directions, each the pair's colour under D65 (a flat
// spectrum is neutral on any wavelength grid). exposure <= 0: brightest cell → Y = 1.
record::RgbImage brdf_fingerprint(const BrdfRecord& record, int lights, int views, int block = 4,
                                  double exposure = 0.0);

// Self-describing HDF5 (RECORD.md); written under a temporary name and renamed.
void write_brdf_record(const BrdfRecord& record, const std::filesystem::path& path);

}  // namespace plumage::gonio
