// Pieces the model-against-simulation studies share (rock_dove, ablation, extremes).
#pragma once

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "analysis/huang2022.h"
#include "geometry/barbule.h"
#include "virtual_gonio/png_image.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::studies {

// The Huang model of the same barbules: b, φ0, φ1, θ_d, H, μ and the film thickness.
analysis::Huang2022Params huang_params_of(const geometry::BarbuleRowParams& row);

// Images left to right on white, 6 px apart, top-aligned.
record::RgbImage side_by_side(const std::vector<const record::RgbImage*>& images);

// Σ|a − b| Ω / Σ b Ω over pixels and wavelengths, for one lobe of each (or all: −1).
double image_relative_l1(const gonio::Scatterogram& a, const gonio::Scatterogram& b, int lobe_a,
                         int lobe_b);

// Index of a lobe name, or −1.
int lobe_index(const std::vector<std::string>& lobes, const std::string& name);

// A study's wall clock and its progress lines on stderr, "plumage: [  12.3 s] what".
class StudyProgress {
public:
    explicit StudyProgress(bool enabled) : enabled_(enabled) {}
    double elapsed_s() const;
    // Starts a stage: throws Interrupted if Ctrl-C arrived, then prints (when enabled).
    void say(const std::string& what) const;
    // Prints without the interrupt check: a result line, or the last line once committed.
    void done(const std::string& what) const;

private:
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
    bool enabled_;
};

// Where a study keeps the checkpoints of its measurements: <results root>/.checkpoints/<name>/.
std::filesystem::path checkpoint_folder(const std::filesystem::path& results_root,
                                        const std::string& name);
// After the commit: the finished records supersede the study's checkpoints; .checkpoints goes
// too when no other study's remain.
void remove_checkpoints(const std::filesystem::path& results_root, const std::string& name);

// The Interrupted message of a measurement stopped with a checkpoint, after `passes` completed
// passes: where to resume from, or, with no pass completed, nothing kept (the empty checkpoint
// folders are removed).
std::string interrupted_with_checkpoint(const std::string& what, int passes,
                                        const std::filesystem::path& checkpoint);

// Unit vector at polar θ from +z and azimuth φ from +x (patch frame).
Vec3d polar(double theta, double phi);

}  // namespace plumage::studies
