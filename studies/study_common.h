// Pieces the model-against-simulation studies share (rock_dove, ablation, extremes).
#pragma once

#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/models/huang2022.h"
#include "geometry/barbule.h"
#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/record/png_image.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::studies {

// The Huang model of the same barbules: b, φ0, φ1, θ_d, H, μ and the film thickness.
analysis::Huang2022Params huang_params_of(const geometry::BarbuleRowParams& row);

// Images left to right on white, 6 px apart, top-aligned.
record::RgbImage side_by_side(const std::vector<const record::RgbImage*>& images);

// Σ|a − b| Ω / Σ b Ω over pixels and wavelengths, for one lobe of each (or all: −1).
double image_relative_l1(const gonio::Scatterogram& a, const gonio::Scatterogram& b, int lobe_a,
                         int lobe_b);

// What image_relative_l1(a, b, −1, −1) would be if a and b were the same image measured with
// their standard errors: sqrt(2/π) Σ sqrt(σ_a² + σ_b²) Ω / Σ b Ω (the mean |N(0, σ)|). Totals
// only: the records carry no per-lobe standard errors.
double image_relative_l1_noise_floor(const gonio::Scatterogram& a, const gonio::Scatterogram& b);

// "p = 0.011", or "p < 1e-15" where the χ² tail underflows the double's resolution near 1.
std::string p_value_text(double p);

// Index of a lobe name, or −1.
int lobe_index(const std::vector<std::string>& lobes, const std::string& name);

// One stage of a study: from the say() that named it to the next say() (or, for the stage still
// open, to now). CPU time is the process's, all threads (common/cpu_time.h), so cpu_s / wall_s
// is the number of threads the stage kept busy on average.
struct StageTiming {
    std::string name;
    double wall_s;
    double cpu_s;
};

// A study's wall clock and its progress lines on stderr, "plumage: [  12.3 s] what", and the
// wall and CPU time of each stage. The first stage, "reading the study file", opens at
// construction (the studies construct their clock first), so the stages add up to the run.
class StudyProgress {
public:
    explicit StudyProgress(bool enabled);
    double elapsed_s() const;
    // Starts a stage: throws Interrupted if Ctrl-C arrived, then prints (when enabled), closes
    // the open stage and opens one named `what`.
    void say(const std::string& what) const;
    // Prints without the interrupt check: a result line, or the last line once committed. Opens
    // no stage.
    void done(const std::string& what) const;
    // The stages so far, in order; the open one measured up to now.
    std::vector<StageTiming> stages() const;

private:
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
    bool enabled_;
    // Stage accounting is bookkeeping beside the run, not its state: the studies hand their
    // steps the clock by const reference and say() is const, so these are mutable. The mutex
    // keeps them whole should a say() ever come from a worker thread.
    mutable std::mutex mutex_;
    mutable std::vector<StageTiming> closed_;
    mutable std::string open_name_;
    mutable std::chrono::steady_clock::time_point open_wall_;
    mutable double open_cpu_ = 0.0;
};

// The stages as a markdown table, "| stage | wall (s) | CPU (s) | CPU/wall |" with a total row,
// after one sentence giving the OpenMP thread count and how to read CPU/wall.
std::string stage_table(std::span<const StageTiming> stages);

// Closes `out`, a file written to `path`, and throws IoError naming the path if opening it, a
// write or the close failed: an ofstream reports none of these itself, so a full disk would
// otherwise leave a short file and a run that says it succeeded.
void close_written(std::ofstream& out, const std::filesystem::path& path);

// Writes `text` to `path` (replacing it); IoError naming the path as close_written.
void write_text_file(const std::filesystem::path& path, std::string_view text);

// The same figures as CSV: stage,wall time (s),cpu time (s),cpu/wall (names quoted as needed).
// IoError if the file cannot be written.
void write_stages_csv(const std::filesystem::path& path, std::span<const StageTiming> stages);

// The report section "## Run time by stage" (stage_table of the clock's stages now), with the
// same figures written to <dir>/stages.csv.
std::string run_time_by_stage(const StudyProgress& clock, const std::filesystem::path& dir);

// One measurement's accuracy and what it cost, for a report's "Error and time per
// measurement" table: every measurement says how accurate it is and what that took.
struct MeasurementCost {
    std::string measurement;  // "scatterogram (beam): simulation"
    std::string samples;      // "photon estimator, 6000 quanta/λ × 1 pass"
    std::string error_kind;   // what `error` is (its definition, briefly)
    double error;             // relative, 1 = 100 %
    double wall_s, cpu_s;
};
// A scatterogram: its median per-pixel relative standard error over the cells above
// signal_fraction of their wavelength's brightest pixel (gonio::median_relative_standard_error).
MeasurementCost scatterogram_cost(const std::string& measurement, const gonio::Scatterogram& s,
                                  double signal_fraction);
// A BRDF record: the estimated relative RMS error of its last pass (its convergence table), the
// photon estimator's standard errors or the eval cubature's against half its rings.
MeasurementCost brdf_cost(const std::string& measurement, const gonio::BrdfRecord& r);
// "## Error and time per measurement": the table, one row each, in measuring order.
std::string measurement_cost_section(std::span<const MeasurementCost> costs);

// Where a study keeps the checkpoints of its measurements: <results root>/.checkpoints/<name>/,
// created, and held in use by this process (a shared flock on its kCheckpointsInUse file, until
// remove_checkpoints or exit) so that another run of the same study sharing --out, finishing
// first, leaves it to this one (runs of one study may share checkpoints: goniometer.h,
// "Checkpoints"). The same path on every call.
inline constexpr const char* kCheckpointsInUse = ".plumage-in-use";
std::filesystem::path checkpoint_folder(const std::filesystem::path& results_root,
                                        const std::string& name);
// An input file as a part of a checkpoint's identity (virtual_gonio/goniometer.h, "Checkpoints"):
// the FNV-1a hash and size of its content, so that a checkpoint made before the file changed is
// not resumed. `what` names it for the user ("the content of the sample file 'plate.obj'").
// IoError if it cannot be read.
gonio::CheckpointPart input_file_part(const std::string& what, const std::filesystem::path& file);
// After the commit: the finished records supersede the study's checkpoints; .checkpoints goes
// too when no other study's remain. Left in place while another live run of the study uses them
// (it removes them when it finishes).
void remove_checkpoints(const std::filesystem::path& results_root, const std::string& name);

// The Interrupted message of a measurement stopped with a checkpoint, after `passes` completed
// passes: where to resume from, or, with no pass completed, nothing kept (the empty checkpoint
// folders are removed).
std::string interrupted_with_checkpoint(const std::string& what, int passes,
                                        const std::filesystem::path& checkpoint);

// Unit vector at polar θ from +z and azimuth φ from +x (patch frame).
Vec3d polar(double theta, double phi);

// The rows of a CSV embedded in the binary (a committed reference, configured into a generated
// header) as cells, header first; blank lines skipped, no quoting (the references have none).
std::vector<std::vector<std::string>> embedded_csv_rows(std::string_view text);

}  // namespace plumage::studies
