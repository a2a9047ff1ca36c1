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
// one process-wide mutex, and run by many threads on their own parts of the arrays (new-array
// execute). FFTW_ESTIMATE keeps planning cheap and the result independent of timing
// measurements, so the output is deterministic run to run; RowColumnR2c (below) makes it
// independent of the thread count too.
#include "sim/wave/volume/power_spectrum.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <memory>
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

// An FFTW array of complex values (RAII).
class FftwArray final {
public:
    explicit FftwArray(std::size_t size) : data(fftw_alloc_complex(size)) {
        if (data == nullptr) throw std::bad_alloc();
    }
    ~FftwArray() { fftw_free(data); }
    FftwArray(const FftwArray&) = delete;
    FftwArray& operator=(const FftwArray&) = delete;
    fftw_complex* const data;
};

// One FFTW plan (RAII): made and destroyed under the planner mutex.
class Plan final {
public:
    explicit Plan(const std::function<fftw_plan()>& make) {
        std::lock_guard<std::mutex> lock(fftw_planner_mutex());
        plan_ = make();
        PLUMAGE_CHECK(plan_ != nullptr, "FFTW returned no plan");
    }
    ~Plan() {
        std::lock_guard<std::mutex> lock(fftw_planner_mutex());
        fftw_destroy_plan(plan_);
    }
    Plan(const Plan&) = delete;
    Plan& operator=(const Plan&) = delete;
    fftw_plan get() const { return plan_; }

private:
    fftw_plan plan_ = nullptr;
};

// The r2c DFT of a real row-major array of shape (n0, n1, n2) (n0 = 1 in 2D), done as FFTW's
// one-dimensional transforms along each axis in turn: along the last axis row by row, then
// along axis 1 and axis 0 for every column of the half-complex result. Why not one FFTW plan of
// the whole array: FFTW's threaded plans are chosen by the thread count, and their results
// differ between thread counts in the last bits (48 × 48 × 196 at 16 threads, 100³ at 8,
// measured), which would break the suite's records' independence of threads; and single-
// threaded, FFTW_ESTIMATE's three-dimensional plan takes 0.40 s at 256³ where these passes take
// 0.12 s (0.07 s on 2 threads). The transforms are dealt out in blocks of kBlock that depend on
// the shape alone, each block computed by the same plan whichever thread runs it, so the
// result is the same on any number of threads. In place: one array, whose pages the threads
// fault in once (a second array's took a third of the measurement at 256³: 1.03 s against
// 0.64 s on one thread).
class RowColumnR2c final {
public:
    explicit RowColumnR2c(const std::array<int, 3>& shape)
        : n0_(shape[0]),
          n1_(shape[1]),
          n2_(shape[2]),
          half_(shape[2] / 2 + 1),
          array_(static_cast<std::size_t>(n0_) * n1_ * half_) {
        const int rows = n0_ * n1_;
        double* const in = real_row(0);
        rows_ = batch_plans(rows, [&](int howmany) {
            return fftw_plan_many_dft_r2c(1, &n2_, howmany, in, nullptr, 1, 2 * half_, out(),
                                          nullptr, 1, half_, kFlags);
        });
        axis1_ = batch_plans(half_, [&](int howmany) {
            return fftw_plan_many_dft(1, &n1_, howmany, out(), nullptr, half_, 1, out(), nullptr,
                                      half_, 1, FFTW_FORWARD, kFlags);
        });
        if (n0_ > 1) {
            const int stride = n1_ * half_;
            axis0_ = batch_plans(half_, [&](int howmany) {
                return fftw_plan_many_dft(1, &n0_, howmany, out(), nullptr, stride, 1, out(),
                                          nullptr, stride, 1, FFTW_FORWARD, kFlags);
            });
        }
    }

    // Row r's n2 real values before execute(): FFTW's in-place layout, rows 2 (n2 / 2 + 1)
    // doubles apart.
    double* real_row(std::size_t r) { return reinterpret_cast<double*>(out() + r * half_); }

    // The real rows → their DFT, in out().
    void execute() {
        const int row_blocks = blocks(n0_ * n1_);
#pragma omp parallel for schedule(static)
        for (int b = 0; b < row_blocks; ++b) {
            const std::size_t first = static_cast<std::size_t>(b) * kBlock;
            fftw_execute_dft_r2c(plan(rows_, n0_ * n1_, b), real_row(first), out() + first * half_);
        }
        // Axis 1: for each slab i and block of columns k, transforms of stride half_.
        const int column_blocks = blocks(half_);
        const int units1 = n0_ * column_blocks;
#pragma omp parallel for schedule(static)
        for (int u = 0; u < units1; ++u) {
            const int i = u / column_blocks, b = u % column_blocks;
            fftw_complex* at = out() + static_cast<std::size_t>(i) * n1_ * half_ +
                               static_cast<std::size_t>(b) * kBlock;
            fftw_execute_dft(plan(axis1_, half_, b), at, at);
        }
        if (n0_ == 1) return;
        // Axis 0: for each row j and block of columns k, transforms of stride n1_ · half_.
        const int units0 = n1_ * column_blocks;
#pragma omp parallel for schedule(static)
        for (int u = 0; u < units0; ++u) {
            const int j = u / column_blocks, b = u % column_blocks;
            fftw_complex* at =
                out() + static_cast<std::size_t>(j) * half_ + static_cast<std::size_t>(b) * kBlock;
            fftw_execute_dft(plan(axis0_, half_, b), at, at);
        }
    }

    // The real rows before execute() (real_row), their DFT after.
    fftw_complex* out() const { return array_.data; }

private:
    // Transforms per block; the offsets of blocks are then multiples of 16 bytes, and
    // FFTW_UNALIGNED lets a plan run at any of them.
    static constexpr int kBlock = 16;
    static constexpr unsigned kFlags = FFTW_ESTIMATE | FFTW_UNALIGNED;
    // A full block's plan and, when `count` is not a multiple of kBlock, the last block's.
    struct Batch {
        std::unique_ptr<Plan> full, last;
    };
    static int blocks(int count) { return (count + kBlock - 1) / kBlock; }
    static Batch batch_plans(int count, const std::function<fftw_plan(int)>& make) {
        Batch batch;
        if (count >= kBlock) batch.full = std::make_unique<Plan>([&] { return make(kBlock); });
        if (count % kBlock != 0)
            batch.last = std::make_unique<Plan>([&] { return make(count % kBlock); });
        return batch;
    }
    static fftw_plan plan(const Batch& batch, int count, int block) {
        const bool last = block == blocks(count) - 1 && count % kBlock != 0;
        return (last ? batch.last : batch.full)->get();
    }

    int n0_, n1_, n2_, half_;
    FftwArray array_;
    Batch rows_, axis1_, axis0_;
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
    RowColumnR2c fft(shape);
    double mean = 0.0;  // summed in order: the same bits on any number of threads
    for (double v : values) mean += v;
    mean /= static_cast<double>(values.size());
    // Row by row in parallel; the threads also touch the buffer's pages first.
    const auto row_count = static_cast<std::ptrdiff_t>(rows);
    const auto size = static_cast<std::ptrdiff_t>(values.size());
    std::ptrdiff_t first_bad = size;
#pragma omp parallel for schedule(static) reduction(min : first_bad)
    for (std::ptrdiff_t r = 0; r < row_count; ++r) {
        const std::size_t first = static_cast<std::size_t>(r) * nn;
        double* row = fft.real_row(static_cast<std::size_t>(r));
        for (std::size_t c = 0; c < nn; ++c) {
            const double v = values[first + c];
            if (!std::isfinite(v))
                first_bad = std::min(first_bad, static_cast<std::ptrdiff_t>(first + c));
            row[c] = v - mean;
        }
    }
    if (first_bad < size) {
        throw InputError(fmt::format("{}: value {} at index {}: expected finite values", what,
                                     values[static_cast<std::size_t>(first_bad)], first_bad));
    }
    fft.execute();
    PowerSpectrum s;
    s.dimension_ = dimension;
    s.shape_ = shape;
    s.voxel_um_ = voxel_um;
    s.fraction_ = mean;
    // S = |h^d DFT|² / L^d = h^d |DFT|² / N^d (L^d → Lx Ly, N^d → nx ny for a rectangle).
    const double cell = dimension == 3 ? voxel_um * voxel_um * voxel_um : voxel_um * voxel_um;
    const double scale = cell / static_cast<double>(rows * nn);
    s.power_.resize(rows * half);
    const auto modes = static_cast<std::ptrdiff_t>(s.power_.size());
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t p = 0; p < modes; ++p) {
        s.power_[static_cast<std::size_t>(p)] =
            scale * (fft.out()[p][0] * fft.out()[p][0] + fft.out()[p][1] * fft.out()[p][1]);
    }
    s.power_[0] = 0.0;  // the mean is subtracted; round-off only
    s.radial_ = s.radial_average();
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

RadialSpectrum PowerSpectrum::radial_average() const {
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
