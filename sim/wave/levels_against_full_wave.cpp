#include "sim/wave/levels_against_full_wave.h"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "common/require.h"

namespace plumage::sim::wave {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

LevelError2d compare(const std::vector<double>& level, const std::vector<double>& reference) {
    double diff = 0.0, sum_level = 0.0, sum_reference = 0.0;
    for (std::size_t i = 0; i < reference.size(); ++i) {
        diff += std::abs(level[i] - reference[i]);
        sum_level += level[i];
        sum_reference += reference[i];
    }
    return {diff / sum_reference, sum_level / sum_reference - 1.0};
}

void check_curves(const FullWaveCurves2d& c) {
    const auto& t = c.theta_s_rad;
    require(t.size() >= 2, "full-wave judge",
            fmt::format("{} nm: fewer than 2 angles", c.lambda_nm));
    const double step = t[1] - t[0];
    for (std::size_t i = 1; i < t.size(); ++i)
        require(std::abs(t[i] - t[i - 1] - step) <= 1e-9 && step > 0.0, "full-wave judge",
                fmt::format("{} nm: the θ_s grid is not uniform and increasing", c.lambda_nm));
    for (const auto* v : {&c.fine[0], &c.fine[1], &c.coarse[0], &c.coarse[1]})
        require(v->size() == t.size(), "full-wave judge",
                fmt::format("{} nm: {} σ values for {} angles", c.lambda_nm, v->size(), t.size()));
}

}  // namespace

FullWaveVerdict2d judge_against_full_wave(const Row2d& row,
                                          std::span<const FullWaveCurves2d> curves,
                                          const DetectorWindow& window, double threshold,
                                          double step_um) {
    require(!curves.empty(), "full-wave judge", "no full-wave curves");
    std::vector<double> centres;
    for (int d = -89; d <= 89; ++d) centres.push_back(d * kDeg);
    FullWaveVerdict2d v;
    v.threshold = threshold;
    for (const FullWaveCurves2d& c : curves) {
        check_curves(c);
        std::vector<double> fw(centres.size(), 0.0), fw_coarse = fw, po = fw, go = fw;
        for (int p = 0; p < 2; ++p) {
            const Incidence2d incidence{c.lambda_nm, c.theta_i_rad,
                                        p == 0 ? Polarisation2d::te : Polarisation2d::tm};
            // λ/10, or the caller's step when finer (a barbule's tip radius)
            const double step = step_um > 0.0 ? std::min(step_um, 1e-4 * c.lambda_nm) : 0.0;
            PhysicalOpticsOptions po_options;
            po_options.step_um = step;
            const std::vector<double> sigma_po =
                scattering_width(row, incidence, c.theta_s_rad, po_options);
            GeometricOpticsOptions go_options;
            go_options.step_um = step;
            const std::vector<GeometricRay2d> rays = geometric_rays(row, incidence, go_options);
            const std::vector<double> w_fw = windowed(c.theta_s_rad, c.fine[p], window, centres);
            const std::vector<double> w_fc = windowed(c.theta_s_rad, c.coarse[p], window, centres);
            const std::vector<double> w_po = windowed(c.theta_s_rad, sigma_po, window, centres);
            const std::vector<double> w_go = windowed(rays, window, centres);
            for (std::size_t i = 0; i < centres.size(); ++i) {
                fw[i] += 0.5 * w_fw[i];
                fw_coarse[i] += 0.5 * w_fc[i];
                po[i] += 0.5 * w_po[i];
                go[i] += 0.5 * w_go[i];
            }
        }
        LevelsAgainstFullWave2d l;
        l.lambda_nm = c.lambda_nm;
        l.physical_optics = compare(po, fw);
        l.ray_optics = compare(go, fw);
        l.full_wave_resolution = compare(fw_coarse, fw);
        if (l.physical_optics.relative_l1 > v.worst_po_l1) {
            v.worst_po_l1 = l.physical_optics.relative_l1;
            v.worst_po_lambda_nm = c.lambda_nm;
        }
        if (l.ray_optics.relative_l1 > v.worst_go_l1) {
            v.worst_go_l1 = l.ray_optics.relative_l1;
            v.worst_go_lambda_nm = c.lambda_nm;
        }
        v.worst_resolution_l1 = std::max(v.worst_resolution_l1, l.full_wave_resolution.relative_l1);
        v.wavelengths.push_back(l);
    }
    v.level = v.worst_go_l1 <= threshold   ? "ray optics + thin film"
              : v.worst_po_l1 <= threshold ? "physical optics"
                                           : "full wave";
    return v;
}

}  // namespace plumage::sim::wave
