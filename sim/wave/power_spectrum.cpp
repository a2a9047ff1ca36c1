// Power spectra of indicator fields with FFTW3 (conventions in the header).
//
// Parameter table:
//  | name      | unit | valid range                                           |
//  |-----------|------|-------------------------------------------------------|
//  | n (N)     | 1    | [4, 1024] (3D: N³ doubles in memory, N <= 512 in use) |
//  | voxel_um  | µm   | finite, > 0                                           |
//  | values    | 1    | finite; N³ (3D) or N² (2D) of them, k fastest         |
//
// FFTW plan creation (fftw_plan_*) is not thread-safe, execution is: plans are made under
// one process-wide mutex. FFTW_ESTIMATE keeps planning cheap and the result independent of
// timing measurements, so the output is deterministic run to run.
#include "sim/wave/power_spectrum.h"

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
    R2cTransform(int dimension, int n, std::size_t real_size, std::size_t complex_size) {
        in = fftw_alloc_real(real_size);
        out = fftw_alloc_complex(complex_size);
        if (in == nullptr || out == nullptr) {
            release();
            throw std::bad_alloc();
        }
        std::lock_guard<std::mutex> lock(fftw_planner_mutex());
        plan = dimension == 3 ? fftw_plan_dft_r2c_3d(n, n, n, in, out, FFTW_ESTIMATE)
                              : fftw_plan_dft_r2c_2d(n, n, in, out, FFTW_ESTIMATE);
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

void require_grid(const char* what, std::size_t size, std::size_t expected, int n,
                  double voxel_um) {
    if (n < 4 || n > 1024) {
        throw InputError(
            fmt::format("{}: N = {} voxels per side: expected 4 <= N <= 1024", what, n));
    }
    if (!(std::isfinite(voxel_um) && voxel_um > 0.0)) {
        throw InputError(
            fmt::format("{}: voxel_um = {}: expected a finite voxel size > 0", what, voxel_um));
    }
    if (size != expected) {
        throw InputError(fmt::format("{}: {} values: expected N^d = {}", what, size, expected));
    }
}

}  // namespace

PowerSpectrum PowerSpectrum::measure(const std::vector<double>& values, int dimension, int n,
                                     double voxel_um) {
    const auto nn = static_cast<std::size_t>(n);
    const char* what = dimension == 3 ? "power spectrum (3D)" : "power spectrum (2D)";
    const std::size_t rows = dimension == 3 ? nn * nn : nn;  // all but the last axis
    require_grid(what, values.size(), rows * nn, n, voxel_um);
    const std::size_t half = nn / 2 + 1;
    R2cTransform fft(dimension, n, rows * nn, rows * half);
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
    s.n_ = n;
    s.voxel_um_ = voxel_um;
    s.fraction_ = mean;
    // S = |h^d DFT|² / L^d = h^d |DFT|² / N^d.
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
    return measure(values, 3, n, voxel_um);
}

PowerSpectrum PowerSpectrum::measure_2d(const std::vector<double>& values, int n, double voxel_um) {
    return measure(values, 2, n, voxel_um);
}

double PowerSpectrum::variance() const {
    const int half = n_ / 2 + 1;
    // Compensated (Kahan) sum: the Parseval check is held to 1e-12.
    double sum = 0.0, carry = 0.0;
    for (std::size_t p = 0; p < power_.size(); ++p) {
        const int k_last = static_cast<int>(p % static_cast<std::size_t>(half));
        const double term = multiplicity(k_last, n_) * power_[p] - carry;
        const double next = sum + term;
        carry = (next - sum) - term;
        sum = next;
    }
    return sum / std::pow(box_um(), dimension_);
}

RadialSpectrum PowerSpectrum::radial() const {
    const int n = n_;
    const int half = n / 2 + 1;
    const int shells = n / 2;
    const double dq = kTwoPi / box_um();
    std::vector<double> power(shells + 1, 0.0), q_sum(shells + 1, 0.0), count(shells + 1, 0.0);
    // Second-moment tensor per shell (only the peak's is kept, but the peak is not known
    // before the sums: keep all, they are small).
    std::vector<Eigen::Matrix3d> moment(shells + 1, Eigen::Matrix3d::Zero());
    const int outer = dimension_ == 3 ? n : 1;
    for (int i = 0; i < outer; ++i) {
        for (int j = 0; j < n; ++j) {
            for (int k = 0; k < half; ++k) {
                Eigen::Vector3d m(dimension_ == 3 ? signed_frequency(i, n) : 0,
                                  signed_frequency(j, n), k);
                const double radius = m.norm();
                const auto shell = static_cast<int>(std::floor(radius + 0.5));
                if (shell < 1 || shell > shells) continue;
                const std::size_t p =
                    (static_cast<std::size_t>(i) * n + j) * static_cast<std::size_t>(half) + k;
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

}  // namespace plumage::sim::wave
