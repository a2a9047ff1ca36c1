#include "sim/wave/compare/ray_optics_validity.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <string>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/cpu_time.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/relative_l1.h"

namespace plumage::sim::wave {
namespace {

[[noreturn]] void refuse(const std::string& message) {
    throw InputError("ray optics validity: " + message);
}

// Wall and process CPU seconds of the work between construction and stop(), added to a pair.
class Stopwatch {
public:
    Stopwatch(double& wall, double& cpu) : wall_(wall), cpu_(cpu) {}
    void stop() {
        wall_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0_).count();
        cpu_ += process_cpu_seconds() - cpu0_;
    }

private:
    double& wall_;
    double& cpu_;
    std::chrono::steady_clock::time_point wall0_ = std::chrono::steady_clock::now();
    double cpu0_ = process_cpu_seconds();
};

// The support of the window's kernel on either side of a centre.
double window_support(const DetectorWindow& w) {
    return w.kernel == WindowKernel::box ? w.half_angle_rad
                                         : 4.0 * w.half_angle_rad / std::sqrt(3.0);
}

double max_radius(const SampledCrossSection2d& placed) {
    double r = 0.0;
    for (const SurfaceSample2d& s : placed.samples) r = std::max(r, s.point.norm());
    return r;
}

// Mean and standard error of the mean over realisations (0 for one).
struct MeanError {
    double mean = 0.0, error = 0.0;
};
MeanError mean_error(const std::vector<double>& v) {
    MeanError m;
    const double n = static_cast<double>(v.size());
    for (double x : v) m.mean += x / n;
    if (v.size() < 2) return m;
    double ss = 0.0;
    for (double x : v) ss += (x - m.mean) * (x - m.mean);
    m.error = std::sqrt(ss / (n - 1.0) / n);
    return m;
}

}  // namespace

Row2d barbule_row_2d(double semi_major_um, double b, double phi0, double phi1, double film_um,
                     double gap_um, double H, double mu, int count) {
    Row2d row;
    row.cell = barbule_arc(geometry::EllipticalArc(semi_major_um, b * semi_major_um, phi0, phi1),
                           film_um, gap_um);
    row.count = count;
    row.spacing_um = H * semi_major_um;
    row.tilt_rad = mu;
    return row;
}

double barbule_row_min_radius_um(double semi_major_um, double b, double phi0, double phi1) {
    const geometry::EllipticalArc arc(semi_major_um, b * semi_major_um, phi0, phi1);
    // ρ(φ) is smallest where the normal is closest to ±x (the tips, φ = ±π/2 mod 2π) or at an
    // end: check the ends and every tip inside.
    double r = std::min(arc.radius_of_curvature(phi0), arc.radius_of_curvature(phi1));
    for (double tip = -2.5 * kPi; tip <= 2.5 * kPi; tip += kPi)
        if (tip > phi0 && tip < phi1) r = std::min(r, arc.radius_of_curvature(tip));
    return r;
}

namespace {

void validate(std::span<const double> lambda_nm, std::span<const double> theta_i_rad,
              const RayOpticsValidityOptions& options) {
    if (lambda_nm.empty() || theta_i_rad.empty())
        refuse(fmt::format("needs at least one wavelength and one incidence (got {} and {})",
                           lambda_nm.size(), theta_i_rad.size()));
    for (double t : theta_i_rad)
        if (!std::isfinite(t) || std::abs(t) >= 0.5 * kPi)
            refuse(fmt::format("incidence {:.4g} rad must be finite and within ±π/2", t));
    // At least 0.01°: at most 17 800 detector centres over ±89° (a smaller step made the centres'
    // table grow until memory ran out).
    if (!std::isfinite(options.output_step_rad) || !(options.output_step_rad >= 0.01 * kDeg) ||
        options.output_step_rad > 10.0 * kDeg)
        refuse(fmt::format("detector step {:.4g} rad must be in [0.01°, 10°]",
                           options.output_step_rad));
    if (!std::isfinite(options.max_step_um) || options.max_step_um < 0.0)
        refuse(fmt::format("max_step_um {:.4g} must be finite and >= 0", options.max_step_um));
    if (!(options.window.half_angle_rad > 0.0) || options.window.half_angle_rad > 0.25 * kPi)
        refuse(fmt::format("detector window half-angle {:.4g} rad must be in (0, π/4]",
                           options.window.half_angle_rad));
}

// The angles physical optics is sampled at: uniform, fine enough for the row's reach r_max
// (0.8π/(k r_max), at most 0.25°), over the detector centres plus the window's support.
struct SampleGrid {
    std::vector<double> theta;
    double cell_width = 0.0;
};
SampleGrid sample_grid(double k, double r_max, double support) {
    const double delta = std::min(0.8 * kPi / (k * std::max(r_max, 1e-6)), 0.25 * kDeg);
    const double lo = -89.0 * kDeg - support - delta, hi = 89.0 * kDeg + support + delta;
    const int n_grid = static_cast<int>(std::ceil((hi - lo) / delta)) + 1;
    SampleGrid g;
    g.theta.resize(static_cast<std::size_t>(n_grid));
    for (int j = 0; j < n_grid; ++j)
        g.theta[static_cast<std::size_t>(j)] = lo + (hi - lo) * j / (n_grid - 1.0);
    g.cell_width = (hi - lo) / (n_grid - 1.0);
    return g;
}

// One realisation of the row at one wavelength and incidence, unpolarised: PO's σ on the sample
// grid, GO's windowed signal at the centres and its reflected power.
struct Realisation {
    std::vector<double> sigma, go_w;
    double go_power = 0.0;
};

// Each level with its own outgoing-visibility rule, per polarisation.
Realisation levels_with_visibility(const Row2d& row, const SampledCrossSection2d& p, double lambda,
                                   double theta_i, const SampleGrid& grid,
                                   const PhysicalOpticsOptions& po_options,
                                   const RayOpticsValidityOptions& options,
                                   RayOpticsValidity2d& v) {
    const double k = 2.0 * kPi / (1e-3 * lambda);
    Realisation r{std::vector<double>(grid.theta.size(), 0.0),
                  std::vector<double>(v.theta_out_rad.size(), 0.0), 0.0};
    for (Polarisation2d pol : {Polarisation2d::te, Polarisation2d::tm}) {
        const Incidence2d incidence{lambda, theta_i, pol};
        Stopwatch po_clock(v.po_wall_s, v.po_cpu_s);
        const std::vector<std::complex<double>> u =
            far_field_integral(row.cell, p, incidence, grid.theta, po_options);
        po_clock.stop();
        for (std::size_t j = 0; j < grid.theta.size(); ++j)
            r.sigma[j] += 0.5 * k / (8.0 * kPi) * std::norm(u[j]);
        Stopwatch go_clock(v.go_wall_s, v.go_cpu_s);
        const FarFieldKernel2d kernel =
            prepare_far_field(row.cell, p, incidence, FarFieldPart::reflected);
        const std::vector<GeometricRay2d> rays = geometric_rays(kernel, p, true);
        go_clock.stop();
        const std::vector<double> w = windowed(rays, options.window, v.theta_out_rad);
        for (std::size_t i = 0; i < r.go_w.size(); ++i) r.go_w[i] += 0.5 * w[i];
        r.go_power += 0.5 * total_power(rays, 0.5 * kPi);
    }
    return r;
}

// Without visibility: the lit test and the stack amplitudes serve both levels, their time
// charged to each (either level alone would pay it); TE and TM in one far-field pass.
Realisation levels_sharing_kernels(const Row2d& row, const SampledCrossSection2d& p, double lambda,
                                   double theta_i, const SampleGrid& grid,
                                   const RayOpticsValidityOptions& options,
                                   RayOpticsValidity2d& v) {
    const double k = 2.0 * kPi / (1e-3 * lambda);
    Realisation r{std::vector<double>(grid.theta.size(), 0.0),
                  std::vector<double>(v.theta_out_rad.size(), 0.0), 0.0};
    double shared_wall = 0.0, shared_cpu = 0.0;
    Stopwatch shared_clock(shared_wall, shared_cpu);
    const FarFieldKernel2d te = prepare_far_field(
        row.cell, p, {lambda, theta_i, Polarisation2d::te}, FarFieldPart::reflected);
    const FarFieldKernel2d tm = prepare_far_field(
        row.cell, p, {lambda, theta_i, Polarisation2d::tm}, FarFieldPart::reflected);
    shared_clock.stop();
    v.po_wall_s += shared_wall, v.po_cpu_s += shared_cpu;
    v.go_wall_s += shared_wall, v.go_cpu_s += shared_cpu;
    Stopwatch po_clock(v.po_wall_s, v.po_cpu_s);
    std::vector<std::complex<double>> u_te, u_tm;
    far_field_pair(te, tm, grid.theta, u_te, u_tm);
    po_clock.stop();
    for (std::size_t j = 0; j < grid.theta.size(); ++j)
        r.sigma[j] = 0.5 * k / (8.0 * kPi) * (std::norm(u_te[j]) + std::norm(u_tm[j]));
    for (const FarFieldKernel2d* kernel : {&te, &tm}) {
        Stopwatch go_clock(v.go_wall_s, v.go_cpu_s);
        const std::vector<GeometricRay2d> rays = geometric_rays(*kernel, p, false);
        go_clock.stop();
        const std::vector<double> w = windowed(rays, options.window, v.theta_out_rad);
        for (std::size_t i = 0; i < r.go_w.size(); ++i) r.go_w[i] += 0.5 * w[i];
        r.go_power += 0.5 * total_power(rays, 0.5 * kPi);
    }
    return r;
}

// The realisations' means, the per-centre standard error of PO − GO, the relative L1 with its
// noise floor, and the reflected powers with their difference's error.
void summarise(const std::vector<std::vector<double>>& po_m,
               const std::vector<std::vector<double>>& go_m, const std::vector<double>& po_power,
               const std::vector<double>& go_power, LevelComparison2d& c) {
    const std::size_t n_out = po_m.front().size();
    const int m_count = static_cast<int>(po_m.size());
    c.po.assign(n_out, 0.0);
    c.go.assign(n_out, 0.0);
    c.difference_error.assign(n_out, 0.0);
    RelativeL1 l1;  // physical optics the reference
    double sum_err = 0.0;
    std::vector<double> d(m_count);
    for (std::size_t i = 0; i < n_out; ++i) {
        for (int m = 0; m < m_count; ++m) {
            c.po[i] += po_m[m][i] / m_count;
            c.go[i] += go_m[m][i] / m_count;
            d[m] = po_m[m][i] - go_m[m][i];
        }
        c.difference_error[i] = mean_error(d).error;
        l1.add(c.go[i], c.po[i]);
        sum_err += c.difference_error[i];
    }
    c.relative_l1 = l1.value();
    c.relative_l1_noise_floor = RelativeL1::of(std::sqrt(2.0 / kPi) * sum_err, l1.reference());
    for (int m = 0; m < m_count; ++m) d[m] = po_power[m] - go_power[m];
    c.po_power_um = mean_error(po_power).mean;
    c.go_power_um = mean_error(go_power).mean;
    if (c.go_power_um > 0.0) {
        c.power_error = c.po_power_um / c.go_power_um - 1.0;
        c.power_error_standard_error = mean_error(d).error / c.go_power_um;
    }
}

// One wavelength and incidence: the row's realisations sampled at the case's step, each level's
// windowed signal and power, summarised.
LevelComparison2d compare_case(const Row2d& row, double lambda, double theta_i,
                               const RayOpticsValidityOptions& options, RayOpticsValidity2d& v) {
    LevelComparison2d c;
    c.theta_i_rad = theta_i;
    c.lambda_nm = lambda;
    if (!std::isfinite(lambda) || !(lambda > 0.0))
        refuse(fmt::format("wavelength {} nm must be finite and > 0", lambda));
    c.step_um = 1e-3 * lambda / 10.0;
    if (options.max_step_um > 0.0) c.step_um = std::min(c.step_um, options.max_step_um);
    PhysicalOpticsOptions po_options;
    po_options.part = FarFieldPart::reflected;
    po_options.outgoing_visibility = options.outgoing_visibility;
    po_options.step_um = c.step_um;
    const SampledCrossSection2d cell = sample_cross_section(row.cell, c.step_um);
    const int m_count = v.realisations;
    std::vector<SampledCrossSection2d> placed;
    double r_max = 0.0;
    for (int m = 0; m < m_count; ++m) {
        placed.push_back(place_row(row, cell, m));
        r_max = std::max(r_max, max_radius(placed.back()));
    }
    c.samples = placed.front().samples.size();
    const SampleGrid grid =
        sample_grid(2.0 * kPi / (1e-3 * lambda), r_max, window_support(options.window));
    c.grid_angles = static_cast<int>(grid.theta.size());
    std::vector<std::vector<double>> po_m(m_count), go_m(m_count);
    std::vector<double> po_power(m_count, 0.0), go_power(m_count, 0.0);
    for (int m = 0; m < m_count; ++m) {
        // Ctrl-C stops the comparison within one realisation's sums (common/interrupt.h).
        throw_if_interrupted(
            fmt::format("PO vs GO at {:g} nm, θ_i = {:.4g} rad, row {}", lambda, theta_i, m));
        const SampledCrossSection2d& p = placed[static_cast<std::size_t>(m)];
        Realisation r =
            options.outgoing_visibility
                ? levels_with_visibility(row, p, lambda, theta_i, grid, po_options, options, v)
                : levels_sharing_kernels(row, p, lambda, theta_i, grid, options, v);
        po_m[static_cast<std::size_t>(m)] =
            windowed(grid.theta, r.sigma, options.window, v.theta_out_rad);
        go_m[static_cast<std::size_t>(m)] = std::move(r.go_w);
        for (std::size_t j = 0; j < grid.theta.size(); ++j)
            if (std::abs(grid.theta[j]) < 0.5 * kPi) po_power[m] += r.sigma[j] * grid.cell_width;
        go_power[m] = r.go_power;
    }
    summarise(po_m, go_m, po_power, go_power, c);
    return c;
}

}  // namespace

RayOpticsValidity2d compare_ray_and_physical_optics(const Row2d& row,
                                                    std::span<const double> lambda_nm,
                                                    std::span<const double> theta_i_rad,
                                                    const RayOpticsValidityOptions& options) {
    validate(lambda_nm, theta_i_rad, options);
    RayOpticsValidity2d v;
    const double reach = 89.0 * kDeg + 1e-9;
    for (double t = -89.0 * kDeg; t <= reach; t += options.output_step_rad)
        v.theta_out_rad.push_back(t);
    const bool jittered = row.jitter_position_um > 0.0 || row.jitter_rotation_rad > 0.0;
    v.realisations = jittered ? row.realisations : 1;
    for (double theta_i : theta_i_rad) {
        for (double lambda : lambda_nm) {
            LevelComparison2d c = compare_case(row, lambda, theta_i, options, v);
            if (v.cases.empty() || c.relative_l1 > v.max_relative_l1) {
                v.max_relative_l1 = c.relative_l1;
                v.max_relative_l1_noise_floor = c.relative_l1_noise_floor;
                v.worst_case = v.cases.size();
            }
            v.max_abs_power_error = std::max(v.max_abs_power_error, std::abs(c.power_error));
            v.cases.push_back(std::move(c));
        }
    }
    v.ray_optics_suffices = v.max_relative_l1 <= options.threshold;
    return v;
}

L1WithFloor worst_over_wavelengths(const RayOpticsValidity2d& v, std::size_t incidence,
                                   std::size_t wavelengths) {
    L1WithFloor w;
    for (std::size_t l = 0; l < wavelengths; ++l) {
        const std::size_t i = incidence * wavelengths + l;
        if (i >= v.cases.size())
            refuse(fmt::format("case {} beyond the {} computed", i, v.cases.size()));
        const LevelComparison2d& c = v.cases[i];
        if (l == 0 || c.relative_l1 > w.relative_l1)
            w = {c.relative_l1, c.relative_l1_noise_floor, c.lambda_nm};
    }
    return w;
}

}  // namespace plumage::sim::wave
