// Power spectra of indicator fields with FFTW3 (conventions in the header).
//
// Parameter table:
//  | name      | unit | valid range                                           |
//  |-----------|------|-------------------------------------------------------|
//  | n (N)     | 1    | [4, 1024] (3D: N³ doubles in memory, N <= 512 in use) |
//  | nx, ny    | 1    | [4, 1024] each (rectangular 2D fields)                |
//  | voxel_um  | µm   | finite, > 0                                           |
//  | values    | 1    | finite; N³, N² or nx·ny of them, last axis fastest    |
//
// FFTW plan creation (fftw_plan_*) is not thread-safe, execution is: plans are made under
// one process-wide mutex. FFTW_ESTIMATE keeps planning cheap and the result independent of
// timing measurements, so the output is deterministic run to run.
#include "sim/wave/volume/power_spectrum.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>

#include <fftw3.h>
#include <fmt/format.h>
#include <Eigen/Eigenvalues>

#include "common/constants.h"
#include "common/error.h"

namespace plumage::sim::wave {
namespace {

std::mutex& fftw_planner_mutex() {
    static std::mutex mutex;
    return mutex;
}

// Owns an FFTW plan and its buffers (RAII).
struct R2cTransform {
    double* in = nullptr;
    fftw_complex* out = nullptr;
    fftw_plan plan = nullptr;
    R2cTransform(int dimension, const std::array<int, 3>& shape, std::size_t real_size,
                 std::size_t complex_size) {
        in = fftw_alloc_real(real_size);
        out = fftw_alloc_complex(complex_size);
        if (in == nullptr || out == nullptr) {
            release();
            throw std::bad_alloc();
        }
        std::lock_guard<std::mutex> lock(fftw_planner_mutex());
        plan = dimension == 3
                   ? fftw_plan_dft_r2c_3d(shape[0], shape[1], shape[2], in, out, FFTW_ESTIMATE)
                   : fftw_plan_dft_r2c_2d(shape[1], shape[2], in, out, FFTW_ESTIMATE);
        PLUMAGE_CHECK(plan != nullptr, "FFTW returned no plan");
    }
    ~R2cTransform() { release(); }
    R2cTransform(const R2cTransform&) = delete;
    R2cTransform& operator=(const R2cTransform&) = delete;
    void release() {
        if (plan != nullptr) {
            std::lock_guard<std::mutex> lock(fftw_planner_mutex());
            fftw_destroy_plan(plan);
        }
        fftw_free(in);
        fftw_free(out);
        plan = nullptr;
        in = nullptr;
        out = nullptr;
    }
};

int signed_frequency(int i, int n) { return 2 * i <= n ? i : i - n; }

// Multiplicity of a half-complex mode along the last axis: modes strictly between 0 and
// N/2 stand for themselves and their mirror.
double multiplicity(int k_last, int n) { return (k_last == 0 || 2 * k_last == n) ? 1.0 : 2.0; }

void require_grid(const char* what, std::size_t size, std::size_t expected,
                  const std::array<int, 3>& shape, int dimension, double voxel_um) {
    const bool square = shape[1] == shape[2] && (dimension == 2 || shape[0] == shape[2]);
    for (int axis = 3 - dimension; axis < 3; ++axis) {
        const int n = shape[axis];
        if (n >= 4 && n <= 1024) continue;
        if (square) {
            throw InputError(
                fmt::format("{}: N = {} voxels per side: expected 4 <= N <= 1024", what, n));
        }
        throw InputError(fmt::format("{}: {} = {} pixels: expected 4 <= {} <= 1024", what,
                                     axis == 2 ? "nx" : "ny", n, axis == 2 ? "nx" : "ny"));
    }
    if (!(std::isfinite(voxel_um) && voxel_um > 0.0)) {
        throw InputError(
            fmt::format("{}: voxel_um = {}: expected a finite voxel size > 0", what, voxel_um));
    }
    if (size != expected) {
        throw InputError(fmt::format("{}: {} values: expected {} = {}", what, size,
                                     square ? "N^d" : "nx * ny", expected));
    }
}

}  // namespace

PowerSpectrum PowerSpectrum::measure(const std::vector<double>& values, int dimension,
                                     std::array<int, 3> shape, double voxel_um) {
    const char* what = dimension == 3 ? "power spectrum (3D)" : "power spectrum (2D)";
    require_grid(what, values.size(),
                 static_cast<std::size_t>(std::max(shape[0], 0)) *
                     static_cast<std::size_t>(std::max(shape[1], 0)) *
                     static_cast<std::size_t>(std::max(shape[2], 0)),
                 shape, dimension, voxel_um);
    const auto nn = static_cast<std::size_t>(shape[2]);
    const std::size_t rows =
        static_cast<std::size_t>(shape[0]) * static_cast<std::size_t>(shape[1]);
    const std::size_t half = nn / 2 + 1;
    R2cTransform fft(dimension, shape, rows * nn, rows * half);
    double mean = 0.0;
    for (double v : values) mean += v;
    mean /= static_cast<double>(values.size());
    for (std::size_t p = 0; p < values.size(); ++p) {
        if (!std::isfinite(values[p])) {
            throw InputError(fmt::format("{}: value {} at index {}: expected finite values", what,
                                         values[p], p));
        }
        fft.in[p] = values[p] - mean;
    }
    fftw_execute(fft.plan);
    PowerSpectrum s;
    s.dimension_ = dimension;
    s.shape_ = shape;
    s.voxel_um_ = voxel_um;
    s.fraction_ = mean;
    // S = |h^d DFT|² / L^d = h^d |DFT|² / N^d (L^d → Lx Ly, N^d → nx ny for a rectangle).
    const double cell = dimension == 3 ? voxel_um * voxel_um * voxel_um : voxel_um * voxel_um;
    const double scale = cell / static_cast<double>(rows * nn);
    s.power_.resize(rows * half);
    for (std::size_t p = 0; p < s.power_.size(); ++p) {
        s.power_[p] = scale * (fft.out[p][0] * fft.out[p][0] + fft.out[p][1] * fft.out[p][1]);
    }
    s.power_[0] = 0.0;  // the mean is subtracted; round-off only
    return s;
}

PowerSpectrum PowerSpectrum::measure_3d(const std::vector<double>& values, int n, double voxel_um) {
    return measure(values, 3, {n, n, n}, voxel_um);
}

PowerSpectrum PowerSpectrum::measure_2d(const std::vector<double>& values, int n, double voxel_um) {
    return measure(values, 2, {1, n, n}, voxel_um);
}

PowerSpectrum PowerSpectrum::measure_2d(const std::vector<double>& values, int nx, int ny,
                                        double voxel_um) {
    return measure(values, 2, {1, ny, nx}, voxel_um);
}

double PowerSpectrum::cell_measure() const {
    const double lx = shape_[2] * voxel_um_, ly = shape_[1] * voxel_um_;
    return dimension_ == 3 ? shape_[0] * voxel_um_ * ly * lx : ly * lx;
}

double PowerSpectrum::variance() const {
    const int n_last = shape_[2];
    const int half = n_last / 2 + 1;
    // Compensated (Kahan) sum: the Parseval check is held to 1e-12.
    double sum = 0.0, carry = 0.0;
    for (std::size_t p = 0; p < power_.size(); ++p) {
        const int k_last = static_cast<int>(p % static_cast<std::size_t>(half));
        const double term = multiplicity(k_last, n_last) * power_[p] - carry;
        const double next = sum + term;
        carry = (next - sum) - term;
        sum = next;
    }
    // A cube or square keeps L^d (the numbers before rectangles existed).
    const bool square = shape_[1] == shape_[2] && (dimension_ == 2 || shape_[0] == shape_[2]);
    return sum / (square ? std::pow(box_um(), dimension_) : cell_measure());
}

RadialSpectrum PowerSpectrum::radial() const {
    const int n = shape_[2];  // the last (half-complex) axis
    const int half = n / 2 + 1;
    // The longest side sets the shell width (header); a lattice index m_a along axis a is
    // the wavenumber m_a · (L_long / L_a) in units of Δq.
    const int n_long = dimension_ == 3 ? std::max({shape_[0], shape_[1], shape_[2]})
                                       : std::max(shape_[1], shape_[2]);
    const int shells = n_long / 2;
    const double dq = kTwoPi / (n_long * voxel_um_);
    const double scale0 = static_cast<double>(n_long) / shape_[0];
    const double scale1 = static_cast<double>(n_long) / shape_[1];
    const double scale2 = static_cast<double>(n_long) / shape_[2];
    std::vector<double> power(shells + 1, 0.0), q_sum(shells + 1, 0.0), count(shells + 1, 0.0);
    // Second-moment tensor per shell (only the peak's is kept, but the peak is not known
    // before the sums: keep all, they are small).
    std::vector<Eigen::Matrix3d> moment(shells + 1, Eigen::Matrix3d::Zero());
    const int outer = dimension_ == 3 ? shape_[0] : 1;
    const int middle = shape_[1];
    for (int i = 0; i < outer; ++i) {
        for (int j = 0; j < middle; ++j) {
            for (int k = 0; k < half; ++k) {
                // Exactly the integers m for a cube or square (the scales are 1).
                Eigen::Vector3d m(dimension_ == 3 ? scale0 * signed_frequency(i, shape_[0]) : 0.0,
                                  scale1 * signed_frequency(j, middle), scale2 * k);
                const double radius = m.norm();
                const auto shell = static_cast<int>(std::floor(radius + 0.5));
                if (shell < 1 || shell > shells) continue;
                const std::size_t p =
                    (static_cast<std::size_t>(i) * middle + j) * static_cast<std::size_t>(half) + k;
                const double w = multiplicity(k, n);
                power[shell] += w * power_[p];
                q_sum[shell] += w * radius * dq;
                count[shell] += w;
                const Eigen::Vector3d u = m / radius;
                moment[shell] += w * power_[p] * u * u.transpose();  // even in q
            }
        }
    }
    RadialSpectrum r;
    r.shell_width_per_um = dq;
    for (int j = 1; j <= shells; ++j) {
        PLUMAGE_CHECK(count[j] > 0.0, "every shell up to N/2 holds modes");
        r.q_per_um.push_back(q_sum[j] / count[j]);
        r.power.push_back(power[j] / count[j]);
        r.modes.push_back(static_cast<std::size_t>(count[j]));
    }
    std::size_t peak = 0;
    for (std::size_t s = 1; s < r.power.size(); ++s) {
        if (r.power[s] > r.power[peak]) peak = s;
    }
    r.peak_shell = peak;
    r.peak_q_per_um = r.q_per_um[peak];
    if (peak > 0 && peak + 1 < r.power.size()) {
        const double x0 = r.q_per_um[peak - 1], x1 = r.q_per_um[peak], x2 = r.q_per_um[peak + 1];
        const double y0 = r.power[peak - 1], y1 = r.power[peak], y2 = r.power[peak + 1];
        const double d = (x0 - x1) * (x0 - x2) * (x1 - x2);
        const double a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / d;
        const double b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / d;
        if (a < 0.0) r.peak_q_per_um = -b / (2.0 * a);
    }
    // Isotropy on the peak shell. In 2D the tensor lives in the (y, last) plane: drop the
    // empty first axis.
    const Eigen::Matrix3d& m3 = moment[peak + 1];
    if (power[peak + 1] > 0.0) {
        if (dimension_ == 3) {
            Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(m3 / power[peak + 1]);
            const auto& ev = solver.eigenvalues();
            r.moment_eigenvalues = {ev[0], ev[1], ev[2]};
            r.isotropy_eigenvalue_ratio = ev[2] / ev[0];
        } else {
            Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(m3.bottomRightCorner<2, 2>() /
                                                                  power[peak + 1]);
            const auto& ev = solver.eigenvalues();
            r.moment_eigenvalues = {ev[0], ev[1]};
            r.isotropy_eigenvalue_ratio = ev[1] / ev[0];
        }
    }
    return r;
}

double RadialSpectrum::at(double q) const {
    const auto& qs = q_per_um;
    const auto& ps = power;
    if (q <= qs.front()) return ps.front();
    if (q >= qs.back()) {
        PLUMAGE_CHECK(q <= qs.back() + shell_width_per_um,
                      fmt::format("q = {} beyond the spectrum's last shell {}", q, qs.back()));
        return ps.back();
    }
    const auto upper = std::upper_bound(qs.begin(), qs.end(), q);
    const auto i = static_cast<std::size_t>(upper - qs.begin());
    const double w = (q - qs[i - 1]) / (qs[i] - qs[i - 1]);
    return (1.0 - w) * ps[i - 1] + w * ps[i];
}

}  // namespace plumage::sim::wave
