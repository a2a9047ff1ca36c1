// The integrating sphere: the directional–hemispherical reflectance R(λ) and transmittance T(λ)
// of a Scatterer lit by a collimated beam, i.e. all the light that leaves the patch above it
// (+z, the patch frame of sim/scatterer/scatterer.h) and below it, whatever its direction; the
// absorbed part is 1 − R − T. What a lab's integrating sphere with a specular port closed measures,
// and the simplest instrument on the pass loop (virtual_gonio/pass_loop.h): this file and its .cpp
// are the whole instrument, its registry entry included: a study file's [integrating_sphere]
// table (virtual_gonio/instrument_registry.h; docs/instruments.md, "Adding an instrument").
//
// Estimator: quantum q of wavelength k enters uniformly over the beam's disc (radius
// beam_radius_um in the beam's cross-section, projected on the patch) and escapes with weight w
// upwards or downwards; R̂_k = Σ w·1{up} / N, T̂_k likewise, N the quanta so far, with the sample
// standard error of the mean. Unbiased for any Scatterer that honours sample()'s contract.
// Random streams: quantum q (counted over all passes) of wavelength k draws from
// Rng(derive_seed(seed, "integrating_sphere/quantum", k), q); items are (k, chunk of 4096
// quanta), so results are the same bits at any thread or rank count.
// Stop rule: passes of quanta_per_pass quanta per wavelength until Σ_k σ(R̂_k) / Σ_k R̂_k (the
// power-weighted relative error of R) is at most target_relative_error, or time_budget_s has
// passed at the end of a pass, or max_passes are done.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/interrupt.h"
#include "sim/scatterer/scatterer.h"
#include "virtual_gonio/pass_loop.h"

namespace plumage::gonio {

// Parameter table:
//  | name                  | unit | default    | range                          |
//  |-----------------------|------|------------|--------------------------------|
//  | wavelengths_nm        | nm   | {550}      | 1 … 4701 finite values > 0     |
//  | light                 | 1    | +z         | unit vector with z > 0         |
//  | beam_radius_um        | µm   | 10         | finite, > 0                    |
//  | quanta_per_pass       | 1    | 100000     | [1, 10⁹] per wavelength        |
//  | max_passes            | 1    | 10         | [1, 100000]                    |
//  | target_relative_error | 1    | 0.01       | [0, 1)                         |
//  | time_budget_s         | s    | ∞          | > 0                            |
struct IntegratingSphereConfig {
    std::vector<double> wavelengths_nm = {550.0};
    Vec3d light = Vec3d::UnitZ();  // towards the light, patch frame
    double beam_radius_um = 10.0;
    std::uint64_t quanta_per_pass = 100000;
    int max_passes = 10;
    double target_relative_error = 0.01;
    double time_budget_s = std::numeric_limits<double>::infinity();
    std::uint64_t seed = 1;
    std::string config_text;  // the study text, for provenance

    void validate() const;  // InputError naming the field
};

struct IntegratingSphereRecord {
    IntegratingSphereConfig config;
    std::string scatterer;
    // Per wavelength: R, T and their standard errors.
    std::vector<double> reflectance, reflectance_error, transmittance, transmittance_error;
    std::uint64_t quanta = 0;  // per wavelength
    int passes = 0;
    std::vector<ConvergenceRow> convergence;
    double wall_time_s = 0.0, cpu_time_s = 0.0;
};

// Measures until the stop rule; throws Interrupted on Ctrl-C (a partial R must not flow on).
IntegratingSphereRecord measure_integrating_sphere(const Scatterer& scatterer,
                                                   const IntegratingSphereConfig& config,
                                                   bool progress = false);

// Self-describing HDF5 (virtual_gonio/RECORD.md, "Integrating sphere").
void write_integrating_sphere_record(const IntegratingSphereRecord& record,
                                     const std::filesystem::path& path);

}  // namespace plumage::gonio
