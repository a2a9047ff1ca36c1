// Internals shared by the full-wave solvers (full_wave_2d.cpp: isolated cross-sections;
// full_wave_periodic.cpp: stacks and periodic rows; full_wave_slab.cpp: 3D slabs): the section as
// Meep's material, the grid, the stop rule, the input checks and the runs' materials. Not an
// interface: only those files include it (it pulls in meep.hpp).
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <complex>
#include <exception>
#include <functional>
#include <numbers>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <omp.h>
#include <meep.hpp>

#include "common/error.h"
#include "common/interrupt.h"
#include "sim/fullwave/full_wave_2d.h"

namespace plumage::sim::fullwave::detail {

using Complex = std::complex<double>;

constexpr double kPi = std::numbers::pi;

// Meep's MPI build (library plumage_fullwave_mpi, which defines PLUMAGE_FULLWAVE_MPI): every
// rank holds a part of each run's grid and takes part in the run's collective calls (the
// exchange at each step, get_field's sum over ranks, the DFT arrays' sums), so every rank makes
// the same runs in the same order, one at a time, and stops at the same step.
#ifdef PLUMAGE_FULLWAVE_MPI
inline constexpr bool kMeepMpi = true;
#else
inline constexpr bool kMeepMpi = false;
#endif
// Under MPI the ranks agree on the stop flag every this many steps (one collective "or"; a
// rank that stopped alone would leave the others waiting in the next step's exchange).
inline constexpr double kStopAgreementSteps = 50.0;

// Meep's memory per grid cell for one 2D polarisation: three field and three flux-density
// components, their PML auxiliaries, the inverse-ε rows and the conductivity arrays. A run of
// 100 000 cells peaks at 70 MB resident, the process and libraries included: 400 bytes per
// cell is an upper estimate.
constexpr double kBytesPerCell = 400.0;

constexpr double kCourant = 0.5;  // Meep's default, passed to every structure

// Samples in a pixel cut by a boundary, for subpixel smoothing (SectionMaterial): the
// Fibonacci lattice of 233 points (i, 144 i mod 233), whose projections on either axis are 233
// distinct levels, so a boundary along a grid axis (every layer of a stack) is placed to
// h/466, and any straight boundary to O(log N / N) of the pixel.
constexpr int kSubpixelSamples = 233, kSubpixelStride = 144;

inline double to_um(double lambda_nm) { return lambda_nm * 1e-3; }

// ε' and Meep's D conductivity of each body at one wavelength (σ_D = ω ε''/ε').
struct BodyMedia {
    std::vector<double> eps, sigma_d;
    bool absorbing = false;
};

BodyMedia media_at(const CrossSection2d& section, double lambda_nm);

// Bodies with per-body media as Meep's material: ε and the D conductivity of the body that owns a
// point (−1: air), and the stop flag, which a derived class checks in owner() (Meep's set-up of a
// large grid asks every pixel, seconds at fine grids: a set flag ends it at the next question).
class BodiesMaterial : public meep::material_function {
public:
    explicit BodiesMaterial(BodyMedia media) : media_(std::move(media)) {}
    double chi1p1(meep::field_type ft, const meep::vec& r) override {
        if (ft != meep::E_stuff && ft != meep::D_stuff) return 1.0;
        const int b = owner(r);
        return b < 0 ? 1.0 : media_.eps[static_cast<std::size_t>(b)];
    }
    bool has_conductivity(meep::component c) override {
        return media_.absorbing && meep::type(c) == meep::D_stuff;
    }
    double conductivity(meep::component, const meep::vec& r) override {
        const int b = owner(r);
        return b < 0 ? 0.0 : media_.sigma_d[static_cast<std::size_t>(b)];
    }
    void interrupt_on(const std::atomic<bool>* stop) { stop_ = stop; }

protected:
    virtual int owner(const meep::vec& r) const = 0;
    void throw_if_stopped() const {
        // Under MPI a rank sets up only its own part of the grid: one that stopped here would
        // leave the others waiting in the fields' first exchange. The step loop's agreed check
        // stops them all instead (step_until_decayed).
        if constexpr (kMeepMpi) return;
        if (stop_ != nullptr && stop_->load(std::memory_order_relaxed)) [[unlikely]]
            throw Interrupted("full wave: interrupted while Meep set up its grid");
    }

private:
    BodyMedia media_;
    const std::atomic<bool>* stop_ = nullptr;
};

// The section in Meep's frame (ours turned by −θ_i) at one wavelength; air where no body is.
class SectionMaterial final : public BodiesMaterial {
public:
    // Meep's point (x, y) is our point turned by −θ_i and lowered by z_offset.
    SectionMaterial(const CrossSection2d& section, double theta_i, BodyMedia media,
                    double z_offset = 0.0)
        : BodiesMaterial(std::move(media)),
          section_(section),
          c_(std::cos(theta_i)),
          s_(std::sin(theta_i)),
          z_offset_(z_offset) {}
    // Meep's anisotropic (Kottke) averaging over the pixel v: the effective inverse ε is
    // P ⟨1/ε⟩ + (1 − P) / ⟨ε⟩, P the projection on the boundary's normal. Meep's generic
    // version doubles its sampling until the averages converge to 1e-4, which a pixel cut by a
    // boundary reaches only at its 100 000-sample cap (minutes for a barbule); here a pixel is
    // tested at 3 × 3 points (bodies are at least two cells thick, so a boundary crossing it
    // almost always shows) and, when cut, averaged over a Fibonacci lattice (kSubpixelSamples),
    // the normal being the direction of ε's first moment.
    void eff_chi1inv_row(meep::component c, double row[3], const meep::volume& v, double,
                         int) override {
        const meep::field_type ft = meep::type(c);
        const int along = meep::component_direction(c) % 3;
        row[0] = row[1] = row[2] = 0.0;
        const double x0 = v.get_min_corner().x(), y0 = v.get_min_corner().y();
        const double dx = v.get_max_corner().x() - x0, dy = v.get_max_corner().y() - y0;
        const double first = chi1p1(ft, meep::vec(x0, y0));
        bool uniform = true;
        for (int j = 0; j < 3 && uniform; ++j)
            for (int i = 0; i < 3 && uniform; ++i)
                uniform = chi1p1(ft, meep::vec(x0 + 0.5 * i * dx, y0 + 0.5 * j * dy)) == first;
        if (uniform) {
            row[along] = 1.0 / first;
            return;
        }
        double mean = 0.0, mean_inverse = 0.0, gx = 0.0, gy = 0.0;
        for (int i = 0; i < kSubpixelSamples; ++i) {
            const long j = (static_cast<long>(i) * kSubpixelStride) % kSubpixelSamples;
            const double u = (i + 0.5) / kSubpixelSamples - 0.5;
            const double w = (static_cast<double>(j) + 0.5) / kSubpixelSamples - 0.5;
            const double e = chi1p1(ft, meep::vec(x0 + (u + 0.5) * dx, y0 + (w + 0.5) * dy));
            mean += e;
            mean_inverse += 1.0 / e;
            gx += e * u * dx;
            gy += e * w * dy;
        }
        const double n_samples = kSubpixelSamples;
        mean /= n_samples;
        mean_inverse /= n_samples;
        const double g = std::hypot(gx, gy);
        const double n[3] = {g > 0.0 ? gx / g : 0.0, g > 0.0 ? gy / g : 0.0, 0.0};
        for (int i = 0; i < 3; ++i) row[i] = n[along] * n[i] * (mean_inverse - 1.0 / mean);
        row[along] += 1.0 / mean;
    }
    // The fraction of the h × h pixel centred on r that body b fills (the pole strengths'
    // average, Dispersion::fitted): 0 or 1 unless a 3 × 3 test finds the pixel cut, then the
    // Fibonacci lattice's fraction.
    double fraction_of_body(int b, const meep::vec& r, double h) const {
        const double x0 = r.x() - 0.5 * h, y0 = r.y() - 0.5 * h;
        const bool first = owner(meep::vec(x0, y0)) == b;
        bool uniform = true;
        for (int j = 0; j < 3 && uniform; ++j)
            for (int i = 0; i < 3 && uniform; ++i)
                uniform = (owner(meep::vec(x0 + 0.5 * i * h, y0 + 0.5 * j * h)) == b) == first;
        if (uniform) return first ? 1.0 : 0.0;
        int inside = 0;
        for (int i = 0; i < kSubpixelSamples; ++i) {
            const long j = (static_cast<long>(i) * kSubpixelStride) % kSubpixelSamples;
            const double u = (i + 0.5) / kSubpixelSamples;
            const double w = (static_cast<double>(j) + 0.5) / kSubpixelSamples;
            inside += owner(meep::vec(x0 + u * h, y0 + w * h)) == b ? 1 : 0;
        }
        return static_cast<double>(inside) / kSubpixelSamples;
    }

    // A periodic row (full_wave_row): the section repeats every period_um along x, its bodies
    // reaching up to `reach_um` from x = 0 (they may cross into the neighbouring periods); a
    // point belongs to the last body that holds it or one of its images x + m·period.
    void repeat_along_x(double period_um, double reach_um) {
        period_ = period_um;
        images_ = static_cast<int>(std::ceil(reach_um / period_um)) + 1;
    }

private:
    int owner(const meep::vec& r) const override {
        throw_if_stopped();
        const Eigen::Vector2d p(c_ * r.x() + s_ * r.y(), c_ * r.y() - s_ * r.x() + z_offset_);
        if (period_ == 0.0) return section_.body_at(p);
        int owner = -1;
        for (int m = -images_; m <= images_; ++m)
            owner = std::max(owner, section_.body_at({p.x() + m * period_, p.y()}));
        return owner;
    }
    const CrossSection2d& section_;
    double c_, s_, z_offset_;
    double period_ = 0.0;
    int images_ = 0;
};

class AirMaterial final : public meep::material_function {};

// One Lorentz pole's strength σ_k over the grid (Dispersion::fitted): σ_k times the fraction of
// the pixel that its body fills, isotropic. `Bodies`: SectionMaterial (2D) or the 3D slab's
// material, anything with fraction_of_body(body, r, h).
template <class Bodies>
class PoleStrength final : public meep::material_function {
public:
    PoleStrength(const Bodies& bodies, int body, double strength, double h)
        : bodies_(bodies), body_(body), strength_(strength), h_(h) {}
    void sigma_row(meep::component c, double row[3], const meep::vec& r) override {
        row[0] = row[1] = row[2] = 0.0;
        row[meep::component_direction(c) % 3] = strength_ * bodies_.fraction_of_body(body_, r, h_);
    }

private:
    const Bodies& bodies_;
    int body_;
    double strength_, h_;
};

// What a run adds to its structure after Meep has built ε: conductivities or poles.
using Dress = std::function<void(meep::structure&)>;

// Each body's poles (Dispersion::fitted; body_fits[b] is body b's material's fit) for the
// structure of `material` (Meep samples the strengths when a susceptibility is added).
Dress add_poles(const SectionMaterial& material, const std::vector<const LorentzFit*>& body_fits,
                double h);

meep::component field_component(Polarisation2d pol);

// Meep's 2D grid of at least 2·half_x × 2·half_y µm, centred on the origin. Meep checks
// exactly that size × resolution is an integer; for some counts no double size hits it, so
// the count grows by two cells (one each side, in PML) until one does (a few at most).
double exact_extent(double half, double res);  // one side's size
meep::grid_volume centred_grid(double half_x, double half_y, double res);
meep::grid_volume centred_grid_3d(double half_x, double half_y, double half_z, double res);

// A half-width rounded up to whole grid cells: the cell is then an even number of cells wide
// and its centre, our origin, a grid point.
inline double whole_cells(double half_width, double h) {
    return std::ceil(half_width / h - 1e-9) * h;
}

// x and y grid coordinates of a DFT volume (Meep's get_array_metadata: [NX, x…, NY, y…, NZ, z…,
// w…]).
void grid_ticks(meep::fields& f, const meep::volume& where, std::vector<double>& xs,
                std::vector<double>& ys);

// Steps until the largest |u|² at the probe over the last 20 time units is below decay × its
// peak (Meep's stop_when_fields_decayed), or until max_time (if > 0) after source_end, polling
// the stop flag (under MPI, agreed by the ranks every kStopAgreementSteps steps); returns the
// steps taken. The probe's field is summed over the ranks (Meep's get_field), so every rank ends
// the run at the same step.
double step_until_decayed(meep::fields& f, meep::component c, const meep::vec& probe,
                          double source_end, const FullWave2dOptions& o);

// What a run watches to decide it has converged: values, each with the scale its change is
// measured against.
struct Watched {
    double value = 0.0, scale = 1.0;
};
using Watch = std::function<std::vector<Watched>()>;

// Steps until every value of watch() has stayed within `tolerance` (max − min over its scale)
// over the last `window` time units, watch() being called every `interval` time units from
// `start` on; polls the stop flag; returns the steps taken.
double step_until_converged(meep::fields& f, double start, double interval, double window,
                            double tolerance, const Watch& watch, const FullWave2dOptions& o);

// The D conductivity of absorbing bodies (Dispersion::per_wavelength) on the polarisation's
// electric components (Ez for TE; Ex, Ey for TM).
Dress conductivities(meep::material_function& material, Polarisation2d pol, bool absorbing);

void check_wavelengths(std::span<const double> lambdas_nm);

void check_options(const CrossSection2d& section, std::span<const double> lambdas_nm,
                   const FullWave2dOptions& o);

// Meep's memory per cell for one Lorentz pole: its strength and two polarisation arrays (now and
// one step back) on up to two electric components (TM: Ex, Ey), doubles.
constexpr double kBytesPerPoleCell = 48.0;

void require_grid_memory(double cells, std::size_t poles, const std::string& what);

// Lorentz poles are capped at this frequency (1/µm; λ = 100 nm) so that one fit serves every
// grid the λ/(10 n) rule allows in the visible (lorentz_fit.h).
constexpr double kMaxPoleFrequencyPerUm = 10.0;

// The materials of the runs: exact at each wavelength (always: the checks, and the materials of
// Dispersion::per_wavelength) and, for Dispersion::fitted, each material's Lorentz fit and the
// bodies' ε_∞.
struct RunMaterials {
    std::vector<BodyMedia> exact;              // per wavelength asked
    std::vector<LorentzFit> fits;              // fitted: one per distinct material
    std::vector<const LorentzFit*> body_fits;  // fitted: body b's material's fit
    BodyMedia instantaneous;                   // fitted: each body's ε_∞, no conductivity
    std::size_t poles() const {
        std::size_t n = 0;
        for (const LorentzFit* f : body_fits) n += f->model.poles.size();
        return n;
    }
    std::size_t runs(std::size_t wavelengths) const {
        return fits.empty() ? wavelengths + 1 : 2;  // the empty run, then the bodies'
    }
};

RunMaterials run_materials(const CrossSection2d& section, std::span<const double> lambdas_nm,
                           const FullWave2dOptions& o);

// The Gaussian pulse covering all the frequencies: Meep's (centre, width).
std::pair<double, double> pulse(std::span<const double> freqs);

// Runs job(0 … n − 1) on FullWave2dOptions::threads threads (dynamic: runs differ in length)
// and returns their results in order; the first exception (an Interrupted among them) is
// rethrown after all have stopped. Under MPI on one thread, in order (kMeepMpi): concurrent runs
// would interleave their collective calls on the ranks.
template <class Job>
auto run_all(std::size_t n, const FullWave2dOptions& o, const Job& job) {
    using Result = decltype(job(std::size_t{0}));
    std::vector<Result> results(n);
    std::vector<std::exception_ptr> errors(n);
    const int threads = kMeepMpi ? 1 : o.threads > 0 ? o.threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
        try {
            results[static_cast<std::size_t>(i)] = job(static_cast<std::size_t>(i));
        } catch (...) {
            errors[static_cast<std::size_t>(i)] = std::current_exception();
        }
    }
    for (const std::exception_ptr& e : errors)
        if (e) std::rethrow_exception(e);
    return results;
}

struct Quiet {
    Quiet() : old(meep::verbosity) { meep::verbosity = 0; }
    ~Quiet() { meep::verbosity = old; }
    int old;
};

}  // namespace plumage::sim::fullwave::detail
