#include "sim/wave/surface/geometric_optics_2d.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"

namespace plumage::sim::wave {
namespace {

using Vec = Eigen::Vector2d;

[[noreturn]] void refuse(const std::string& message) {
    throw InputError("geometric optics 2D: " + message);
}

double sampling_step(const Incidence2d& incidence, double step_um) {
    if (!std::isfinite(incidence.lambda_nm) || !(incidence.lambda_nm > 0.0))
        refuse(fmt::format("lambda_nm = {} must be finite and > 0", incidence.lambda_nm));
    // prepare_far_field refuses samples coarser than λ/10 with the limit named.
    return step_um > 0.0 ? step_um : 1e-3 * incidence.lambda_nm / 10.0;
}

void check_window(const DetectorWindow& window) {
    if (!std::isfinite(window.half_angle_rad) || !(window.half_angle_rad > 0.0) ||
        window.half_angle_rad > 0.25 * kPi)
        refuse(fmt::format("detector window half-angle {:.4g} rad must be in (0, π/4]",
                           window.half_angle_rad));
}

// θ − θ' wrapped to [−π, π].
double wrapped(double d) { return std::remainder(d, 2.0 * kPi); }

// Gaussian with the box's variance: σ = w/√3, cut at 4σ.
double gaussian_sigma(const DetectorWindow& w) { return w.half_angle_rad / std::sqrt(3.0); }

double kernel_at(const DetectorWindow& w, double d) {
    const double a = std::abs(d);
    if (w.kernel == WindowKernel::box) return a <= w.half_angle_rad ? 0.5 / w.half_angle_rad : 0.0;
    const double s = gaussian_sigma(w);
    if (a > 4.0 * s) return 0.0;
    return std::exp(-0.5 * (d / s) * (d / s)) / (std::sqrt(2.0 * kPi) * s);
}

}  // namespace

std::vector<GeometricRay2d> geometric_rays(const FarFieldKernel2d& kernel,
                                           const SampledCrossSection2d& sampled,
                                           bool outgoing_visibility) {
    const std::size_t n = kernel.px.size();
    std::vector<GeometricRay2d> rays;
    rays.reserve(n);
    std::vector<Vec> mirror(n);
    for (std::size_t j = 0; j < n; ++j) {
        const Vec normal(kernel.nx[j], kernel.nz[j]);
        const double c = std::min(1.0, normal.dot(kernel.wi));
        // Reflected part: a = r ds and b = r cos θ ds (prepare_far_field); the shadow or total
        // part has a != b / cos θ.
        const std::complex<double> r = kernel.a[j] / kernel.ds[j];
        if (std::abs(kernel.b[j] - kernel.a[j] * c) > 1e-9 * (std::abs(kernel.a[j]) + 1e-300) &&
            std::abs(kernel.b[j]) + std::abs(kernel.a[j]) > 0.0)
            refuse("the kernel must hold the reflected part (FarFieldPart::reflected)");
        mirror[j] = 2.0 * c * normal - kernel.wi;
        rays.push_back({std::atan2(mirror[j].x(), mirror[j].y()), std::norm(r) * c * kernel.ds[j]});
    }
    if (!outgoing_visibility) return rays;
    const std::vector<unsigned char> open = rays_unblocked(sampled, kernel.index, mirror);
    std::vector<GeometricRay2d> kept;
    kept.reserve(n);
    for (std::size_t j = 0; j < n; ++j)
        if (open[j]) kept.push_back(rays[j]);
    return kept;
}

std::vector<GeometricRay2d> geometric_rays(const CrossSection2d& section,
                                           const Incidence2d& incidence,
                                           const GeometricOpticsOptions& options) {
    const SampledCrossSection2d sampled =
        sample_cross_section(section, sampling_step(incidence, options.step_um));
    const FarFieldKernel2d kernel =
        prepare_far_field(section, sampled, incidence, FarFieldPart::reflected);
    return geometric_rays(kernel, sampled, options.outgoing_visibility);
}

std::vector<GeometricRay2d> geometric_rays(const Row2d& row, const Incidence2d& incidence,
                                           const GeometricOpticsOptions& options) {
    const SampledCrossSection2d cell =
        sample_cross_section(row.cell, sampling_step(incidence, options.step_um));
    const bool jittered = row.jitter_position_um > 0.0 || row.jitter_rotation_rad > 0.0;
    const int realisations = jittered ? row.realisations : 1;
    std::vector<GeometricRay2d> all;
    for (int m = 0; m < realisations; ++m) {
        const SampledCrossSection2d placed = place_row(row, cell, m);
        const FarFieldKernel2d kernel =
            prepare_far_field(row.cell, placed, incidence, FarFieldPart::reflected);
        for (GeometricRay2d ray : geometric_rays(kernel, placed, options.outgoing_visibility)) {
            ray.power_um /= realisations;
            all.push_back(ray);
        }
    }
    return all;
}

double total_power(std::span<const GeometricRay2d> rays, double max_abs_theta_rad) {
    double sum = 0.0;
    for (const GeometricRay2d& r : rays)
        if (std::abs(r.theta_s_rad) < max_abs_theta_rad) sum += r.power_um;
    return sum;
}

std::vector<double> windowed(std::span<const GeometricRay2d> rays, const DetectorWindow& window,
                             std::span<const double> theta_out_rad) {
    check_window(window);
    // Rays sorted by angle; each centre visits those within the kernel's support (and their
    // images 2π away), in sorted order.
    std::vector<GeometricRay2d> sorted(rays.begin(), rays.end());
    std::sort(sorted.begin(), sorted.end(), [](const GeometricRay2d& a, const GeometricRay2d& b) {
        return a.theta_s_rad < b.theta_s_rad;
    });
    const double support =
        window.kernel == WindowKernel::box ? window.half_angle_rad : 4.0 * gaussian_sigma(window);
    auto below = [&](double t) {
        return std::lower_bound(
            sorted.begin(), sorted.end(), t,
            [](const GeometricRay2d& r, double x) { return r.theta_s_rad < x; });
    };
    std::vector<double> out(theta_out_rad.size(), 0.0);
    for (std::size_t i = 0; i < out.size(); ++i) {
        double sum = 0.0;
        for (double shift : {-2.0 * kPi, 0.0, 2.0 * kPi}) {
            const double c = theta_out_rad[i] + shift;
            for (auto it = below(c - support * (1.0 + 1e-12)); it != sorted.end(); ++it) {
                if (it->theta_s_rad > c + support * (1.0 + 1e-12)) break;
                sum +=
                    it->power_um * kernel_at(window, wrapped(theta_out_rad[i] - it->theta_s_rad));
            }
        }
        out[i] = sum;
    }
    return out;
}

std::vector<double> windowed(std::span<const double> theta_grid_rad, std::span<const double> sigma,
                             const DetectorWindow& window, std::span<const double> theta_out_rad) {
    check_window(window);
    const std::size_t n = theta_grid_rad.size();
    if (n < 2 || sigma.size() != n)
        refuse(
            fmt::format("a windowed scattering width needs >= 2 grid angles and as many σ "
                        "values (got {} and {})",
                        n, sigma.size()));
    const double delta = (theta_grid_rad[n - 1] - theta_grid_rad[0]) / static_cast<double>(n - 1);
    if (!(delta > 0.0)) refuse("the θ grid must be increasing");
    const double w = window.half_angle_rad;
    std::vector<double> out(theta_out_rad.size(), 0.0);
    for (std::size_t i = 0; i < out.size(); ++i) {
        double sum = 0.0;
        for (std::size_t j = 0; j < n; ++j) {
            const double d = wrapped(theta_out_rad[i] - theta_grid_rad[j]);
            if (window.kernel == WindowKernel::box) {
                // Overlap of the cell [d − δ/2, d + δ/2] with [−w, w].
                const double overlap = std::min(d + 0.5 * delta, w) - std::max(d - 0.5 * delta, -w);
                if (overlap > 0.0) sum += sigma[j] * overlap / (2.0 * w);
            } else {
                sum += sigma[j] * kernel_at(window, d) * delta;
            }
        }
        out[i] = sum;
    }
    return out;
}

}  // namespace plumage::sim::wave
