// The virtual imaging scatterometer (Stavenga et al. 2009, as used by Huang et al.
// 2022, Fig. 6): a spot of light on the patch, the scattered light of the whole upper
// hemisphere imaged at once as a disc, spectrally.
//
// Illumination (ω_i points towards the light, sim/scatterer/scatterer.h):
//  - beam: a collimated beam from `beam_direction`;
//  - cone: uniform radiance within a cone of full aperture `cone_aperture_rad` (16° in
//    Huang's setup) around `beam_direction` (irradiance ∝ cos θ_i within it);
//  - hemisphere: uniform radiance from the whole upper hemisphere ("omnidirectional",
//    diaphragm D2 removed).
// The spot is a disc of radius beam_radius_um in the beam's cross-section, projected
// on the patch.
//
// Stratified illumination: see ScatterometerConfig::illumination_strata.
//
// Image: an azimuthal equidistant map of the hemisphere. Pixel centre (u, v) ∈ [−1, 1]²
// (u right, v up; row 0 at the top) maps to polar angle ϑ = (π/2)·hypot(u, v) and
// azimuth φ = atan2(v, u) from +x (the barb axis) towards +y; the rim is ϑ = 90°.
// Rings in previews mark ϑ = 5°, 30°, 60°, 90°. A pixel of side 2/N spans
// Ω = (π/2) sin(πr/2)/r · (2/N)² sr.
//
// Value per pixel and wavelength: radiant intensity per unit incident power,
// I(ω_o) = dP/dω / P_in (1/sr) = the mean over the illumination of f(ω_i, ω_o) cos θ_o,
// estimated by quanta counted into the pixel: mean(weight · 1[pixel]) / Ω_pixel, with
// its standard error. The standard error treats as one sample each group of quanta that
// shares randomness beyond its own stream. Under the beam a group is one quantum: the spread
// of the quanta about the mean. Under cone and hemisphere light a group is one illumination
// direction's quanta of one wavelength, and directions 2j, 2j + 1 of a pass (neighbouring
// cells of the grid, see illumination_strata) form a pair whose difference estimates the
// pair's variance (Cochran's collapsed strata: unbiased where neighbouring cells have
// equal means, otherwise a slight overestimate; it keeps most of the stratification's gain, which
// the spread over all groups would not). Deterministic streams: under the beam
// Rng(derive_seed(seed, "scatterometer/beam-quantum", wavelength), quantum); otherwise
// (seed, "scatterometer/quantum", wavelength) with the quantum's index in the run;
// reduced in a fixed order, so the image does not depend on the thread count. Under MPI
// (common/distributed.h) a pass's work items are dealt in blocks over the ranks and their hit
// lists come back to every rank, added in the same item order: nor on the rank count.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "sim/scatterer/scatterer.h"
#include "virtual_gonio/goniometer.h"  // ConvergenceRow, RunControl
#include "virtual_gonio/record/png_image.h"

namespace plumage::gonio {

enum class Illumination { beam, cone, hemisphere };

struct ScatterometerConfig {
    Illumination illumination = Illumination::beam;
    Vec3d beam_direction = Vec3d::UnitZ();
    double cone_aperture_rad = 0.2792526803190927;  // 16°
    int image_size = 129;                           // pixels across the disc
    std::vector<double> wavelengths_nm = {450.0, 500.0, 550.0, 600.0, 650.0};
    double beam_radius_um = 60.0;
    std::uint64_t seed = kDefaultSeed;
    std::uint64_t quanta_per_pass = 200000;  // per wavelength
    // Cone and hemisphere light: each pass draws this many illumination directions, one
    // per cell of a rows × columns grid (rows · columns = illumination_strata exactly) over
    // the unit square that maps area-preservingly onto the (cosine-weighted) illumination,
    // jittered anew every pass from the stream (seed, "scatterometer/illumination", pass),
    // and sends ⌈quanta_per_pass / strata⌉ quanta of every wavelength along each (so a pass
    // may hold up to strata − 1 more quanta than asked). All wavelengths share a pass's
    // directions, so the directions' noise is common to them and does not colour the image;
    // a scatterer that prepares per incident direction (the Huang model's visibility)
    // prepares once per direction for all wavelengths. Many directions with few quanta
    // each give smooth images; few directions give spokes, one per direction.
    int illumination_strata = 256;
    // One traced path per quantum for every wavelength (a scatterer with path_tracing(),
    // sim/tracer.h: spectral path sharing), and with split_paths both branches of its first
    // film event (sim/scatterer/scatterer.h): as the goniometer's options of the same names
    // (docs/estimators.md). A shared quantum is one sample of every wavelength, so the groups of
    // the standard error stay those above (a quantum, or a direction's quanta) for each λ.
    // Streams: (seed, "scatterometer/shared", quantum) under the beam, (seed,
    // "scatterometer/shared-directional", quantum) otherwise. Ignored (separate paths) for a
    // scatterer that cannot share; split_paths needs share_wavelength_paths or one wavelength.
    bool share_wavelength_paths = false;
    bool split_paths = false;
    int max_passes = 10;
    double time_budget_s = std::numeric_limits<double>::infinity();
    double target_relative_error = 0.0;  // on the image's power-weighted relative error
    // Stop once median_relative_standard_error(image, 0.01) (below) is at most this; 0: off.
    // Checked after every pass, like the two limits above.
    double target_median_relative_error = 0.0;
    std::string config_text;

    void validate() const;
};

struct Scatterogram {
    ScatterometerConfig config;
    std::string scatterer;
    std::vector<std::string> lobes;
    // Row-major [row][column][wavelength]; lobe_intensity [lobe][row][column][wavelength].
    std::vector<double> intensity, standard_error, lobe_intensity;
    std::vector<double> solid_angle_sr;  // per pixel; 0 outside the disc
    std::vector<ConvergenceRow> convergence;
    std::vector<double> transmitted;        // per wavelength: fraction leaving below the patch
    std::vector<double> transmitted_lobes;  // [lobe][wavelength]
    int passes = 0;
    std::uint64_t quanta = 0;
    bool wavelength_paths_shared = false;  // the options above as they took effect
    bool paths_split = false;
    double wall_time_s = 0.0;
    double cpu_time_s = 0.0;  // process CPU time (all threads) over the same span

    std::size_t pixels() const {
        return static_cast<std::size_t>(config.image_size) * config.image_size;
    }
    // Direction of a pixel's centre, or nullopt outside the disc.
    std::optional<Vec3d> direction(int column, int row) const;
};

// Throws Interrupted (common/interrupt.h) when control.interrupt is set during a pass. With
// control.checkpoint, every pass is checkpointed and a rerun of the same study resumes from it
// (virtual_gonio/pass_checkpoint.h; its parts: the build, config_text, the instrument's
// configuration and control.checkpoint_inputs); the completed passes survive an interrupt.
Scatterogram measure_scatterogram(const Scatterer& scatterer, const ScatterometerConfig& config,
                                  const RunControl& control = {});

// How noisy the image is, in one number: the median, over the image's cells (pixel,
// wavelength) with signal, of the relative standard error σ/I. A cell has signal when its
// intensity is above signal_fraction × the largest intensity at that wavelength within the
// disc (0.01: the pixels that show in the picture). The lower median (a value that occurs);
// NaN when no cell has signal. Per wavelength, not of the pixel's colour: the colour's error
// is smaller by about √(wavelengths) where the wavelengths' errors are independent.
double median_relative_standard_error(const Scatterogram& s, double signal_fraction = 0.01);

// The image under D65 (CIE 1931), each pixel's spectrum integrated over the record's
// wavelengths; exposure scales the luminance (exposure ≤ 0: brightest pixel → Y = 1).
// The ϑ rings are drawn in grey.
record::RgbImage scatterogram_srgb(const Scatterogram& s, double exposure = 0.0, bool rings = true);
// Largest pixel luminance Y (D65): a common exposure for images that must compare.
double scatterogram_peak_luminance(const Scatterogram& s);
// Pixel-wise |a − b| luminance, normalised to a's brightest pixel (white = 100 %).
record::RgbImage scatterogram_difference(const Scatterogram& a, const Scatterogram& b);

void write_scatterogram_record(const Scatterogram& s, const std::filesystem::path& path);

}  // namespace plumage::gonio
