#include "sim/wave/compare/levels_against_full_wave.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/relative_l1.h"
#include "common/require.h"
#include "sim/wave/compare/ray_optics_validity.h"
#include "sim/wave/surface/physical_optics_hybrid_2d.h"

namespace plumage::sim::wave {

namespace {

LevelError2d compare(const std::vector<double>& level, const std::vector<double>& reference) {
    RelativeL1 l1;
    double sum_level = 0.0;
    for (std::size_t i = 0; i < reference.size(); ++i) {
        l1.add(level[i], reference[i]);
        sum_level += level[i];
    }
    return {l1.value(), sum_level / l1.reference() - 1.0};
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

namespace {

// The trapezoid mean of y(x) over [x.front(), x.back()] (a single point: itself).
double band_mean(const std::vector<double>& x, const std::vector<double>& y) {
    if (x.size() == 1) return y.front();
    double sum = 0.0;
    for (std::size_t i = 0; i + 1 < x.size(); ++i)
        sum += 0.5 * (y[i] + y[i + 1]) * (x[i + 1] - x[i]);
    return sum / (x.back() - x.front());
}

// The hybrid's power into the upper half-space (µm) of `count` cells of `cell` on the row's
// spacing and tilt, unpolarised: ∫ σ dθ by the midpoint rule (header).
double hybrid_reflected_power(const Row2d& row, const CrossSection2d& cell, int count,
                              double lambda_nm, double theta_i_rad, double step_um) {
    Row2d finite = row;
    finite.cell = cell;
    finite.count = count;
    const CrossSection2d section = row_cross_section(finite);
    const double k = 2.0 * kPi / (1e-3 * lambda_nm);
    const double r_max = 0.5 * count * row.spacing_um;
    const double wanted = std::min(0.8 * kPi / (k * r_max), 0.25 * kDeg);
    const auto n = static_cast<std::size_t>(std::ceil(kPi / wanted));
    const double delta = kPi / static_cast<double>(n);
    std::vector<double> theta(n);
    for (std::size_t j = 0; j < n; ++j)
        theta[j] = -0.5 * kPi + (static_cast<double>(j) + 0.5) * delta;
    HybridOptions options;
    options.step_um = step_um > 0.0 ? std::min(step_um, 1e-4 * lambda_nm) : 0.0;
    options.circle_angles = 0;
    const HybridFarFieldPair pair =
        hybrid_far_field_pair(section, lambda_nm, theta_i_rad, theta, options);
    double power = 0.0;
    for (std::size_t j = 0; j < n; ++j)
        power += 0.5 * (pair.te.sigma_um_per_rad[j] + pair.tm.sigma_um_per_rad[j]) * delta;
    return power;
}

}  // namespace

std::string cheapest_row_level(const RowVerdict2d& v) {
    if (std::abs(v.go_error) <= v.threshold) return "ray optics + thin film";
    if (std::abs(v.po_error) <= v.threshold) return "physical optics";
    if (!v.hybrid.empty() && std::abs(v.hybrid_error) <= v.threshold) return "GO–PO hybrid";
    return "full wave";
}

void add_hybrid(RowVerdict2d& v, const Row2d& row, double theta_i_rad,
                const CrossSection2d& hybrid_cell, double step_um) {
    constexpr int kShort = 4, kLong = 12;
    const double per_period = (kLong - kShort) * row.spacing_um * std::cos(theta_i_rad);
    std::vector<double> hybrid;
    for (const double lambda : v.lambda_nm)
        hybrid.push_back(
            (hybrid_reflected_power(row, hybrid_cell, kLong, lambda, theta_i_rad, step_um) -
             hybrid_reflected_power(row, hybrid_cell, kShort, lambda, theta_i_rad, step_um)) /
            per_period);
    v.hybrid = std::move(hybrid);
    v.band_hybrid = band_mean(v.lambda_nm, v.hybrid);
    v.hybrid_error = v.band_hybrid / v.band_full_wave - 1.0;
    v.level = cheapest_row_level(v);
}

RowVerdict2d judge_row_against_full_wave(const Row2d& row, double theta_i_rad,
                                         std::span<const RowReflectanceFullWave> reference,
                                         double threshold, double step_um,
                                         const CrossSection2d* hybrid_cell) {
    require(!reference.empty(), "full-wave row judge", "no full-wave reflectances");
    for (std::size_t i = 1; i < reference.size(); ++i)
        require(reference[i].lambda_nm > reference[i - 1].lambda_nm, "full-wave row judge",
                "lambda_nm", reference[i].lambda_nm, "wavelengths in increasing order");
    RowVerdict2d v;
    v.threshold = threshold;
    for (const RowReflectanceFullWave& r : reference) {
        v.lambda_nm.push_back(r.lambda_nm);
        v.full_wave.push_back(0.5 * (r.fine[0] + r.fine[1]));
        v.full_wave_coarse.push_back(0.5 * (r.coarse[0] + r.coarse[1]));
    }
    constexpr int kShort = 4, kLong = 12;
    RayOpticsValidityOptions options;
    options.max_step_um = step_um;
    const std::array<double, 1> incidence{theta_i_rad};
    std::array<RayOpticsValidity2d, 2> rows;
    for (int i = 0; i < 2; ++i) {
        Row2d finite = row;
        finite.count = i == 0 ? kShort : kLong;
        rows[static_cast<std::size_t>(i)] =
            compare_ray_and_physical_optics(finite, v.lambda_nm, incidence, options);
    }
    const double per_period = (kLong - kShort) * row.spacing_um * std::cos(theta_i_rad);
    for (std::size_t k = 0; k < v.lambda_nm.size(); ++k) {
        v.physical_optics.push_back((rows[1].cases[k].po_power_um - rows[0].cases[k].po_power_um) /
                                    per_period);
        v.ray_optics.push_back((rows[1].cases[k].go_power_um - rows[0].cases[k].go_power_um) /
                               per_period);
    }
    v.band_full_wave = band_mean(v.lambda_nm, v.full_wave);
    v.band_full_wave_coarse = band_mean(v.lambda_nm, v.full_wave_coarse);
    v.band_physical_optics = band_mean(v.lambda_nm, v.physical_optics);
    v.band_ray_optics = band_mean(v.lambda_nm, v.ray_optics);
    v.po_error = v.band_physical_optics / v.band_full_wave - 1.0;
    v.go_error = v.band_ray_optics / v.band_full_wave - 1.0;
    v.resolution_error = v.band_full_wave_coarse / v.band_full_wave - 1.0;
    v.level = cheapest_row_level(v);
    if (hybrid_cell != nullptr) add_hybrid(v, row, theta_i_rad, *hybrid_cell, step_um);
    return v;
}

}  // namespace plumage::sim::wave
