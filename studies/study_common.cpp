#include "studies/study_common.h"

#include <algorithm>
#include <cmath>
#include <iostream>

#include <fmt/format.h>

#include "common/interrupt.h"

namespace plumage::studies {

analysis::Huang2022Params huang_params_of(const geometry::BarbuleRowParams& row) {
    analysis::Huang2022Params p;
    p.b = row.cell.b;
    p.phi0 = row.cell.phi0;
    p.phi1 = row.cell.phi1;
    p.theta_d = row.cell.theta_d;
    p.H = row.H;
    p.mu = row.mu;
    p.d_um = row.cell.film_thickness_um;
    return p;
}

record::RgbImage side_by_side(const std::vector<const record::RgbImage*>& images) {
    int width = 0, height = 0;
    for (const auto* im : images) width += im->width + 6, height = std::max(height, im->height);
    record::RgbImage out(width - 6, height);
    out.fill(255, 255, 255);
    int x0 = 0;
    for (const auto* im : images) {
        for (int y = 0; y < im->height; ++y)
            for (int x = 0; x < im->width; ++x) {
                const std::size_t i = (static_cast<std::size_t>(y) * im->width + x) * 3;
                out.set(x0 + x, y, im->pixels[i], im->pixels[i + 1], im->pixels[i + 2]);
            }
        x0 += im->width + 6;
    }
    return out;
}

// Σ|a − b| Ω / Σ b Ω over pixels and wavelengths, for one lobe (or all when lobe < 0).
double image_relative_l1(const gonio::Scatterogram& a, const gonio::Scatterogram& b, int lobe_a,
                         int lobe_b) {
    const std::size_t n = a.pixels() * a.config.wavelengths_nm.size();
    const auto& va = lobe_a < 0 ? a.intensity : a.lobe_intensity;
    const auto& vb = lobe_b < 0 ? b.intensity : b.lobe_intensity;
    const std::size_t oa = lobe_a < 0 ? 0 : static_cast<std::size_t>(lobe_a) * n;
    const std::size_t ob = lobe_b < 0 ? 0 : static_cast<std::size_t>(lobe_b) * n;
    double diff = 0.0, ref = 0.0;
    const std::size_t nl = a.config.wavelengths_nm.size();
    for (std::size_t i = 0; i < n; ++i) {
        const double omega = a.solid_angle_sr[i / nl];
        diff += std::abs(va[oa + i] - vb[ob + i]) * omega;
        ref += vb[ob + i] * omega;
    }
    return ref > 0.0 ? diff / ref : 0.0;
}

int lobe_index(const std::vector<std::string>& lobes, const std::string& name) {
    for (std::size_t i = 0; i < lobes.size(); ++i)
        if (lobes[i] == name) return static_cast<int>(i);
    return -1;
}

Vec3d polar(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

std::filesystem::path checkpoint_folder(const std::filesystem::path& results_root,
                                        const std::string& name) {
    return results_root / ".checkpoints" / name;
}

void remove_checkpoints(const std::filesystem::path& results_root, const std::string& name) {
    std::error_code ignored;
    std::filesystem::remove_all(checkpoint_folder(results_root, name), ignored);
    std::filesystem::remove(results_root / ".checkpoints", ignored);  // only when empty
}

std::string interrupted_with_checkpoint(const std::string& what, int passes,
                                        const std::filesystem::path& checkpoint) {
    if (passes > 0) {
        return fmt::format(
            "interrupted in {} after {} completed passes, kept in {}; run the same "
            "command again to resume from them",
            what, passes, checkpoint.string());
    }
    // <root>/.checkpoints/<name>/<file>: remove the two folders if nothing is in them.
    std::error_code ignored;
    std::filesystem::remove(checkpoint.parent_path(), ignored);
    std::filesystem::remove(checkpoint.parent_path().parent_path(), ignored);
    return fmt::format("interrupted in {} before its first pass completed (nothing to resume)",
                       what);
}

double StudyProgress::elapsed_s() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void StudyProgress::say(const std::string& what) const {
    // Every stage starts here, so a Ctrl-C between stages stops the study before the next.
    throw_if_interrupted(what);
    done(what);
}

void StudyProgress::done(const std::string& what) const {
    if (enabled_) std::cerr << fmt::format("plumage: [{:6.1f} s] {}\n", elapsed_s(), what);
}

}  // namespace plumage::studies
