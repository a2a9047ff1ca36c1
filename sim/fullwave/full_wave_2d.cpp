#include "sim/fullwave/full_wave_2d.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <complex>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>

#include <fmt/format.h>
#include <omp.h>
#include <meep.hpp>

#include "common/error.h"
#include "common/interrupt.h"
#include "common/memory_limit.h"
#include "common/require.h"

namespace plumage::sim::fullwave {

namespace {

using Complex = std::complex<double>;
constexpr double kPi = std::numbers::pi;

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

double to_um(double lambda_nm) { return lambda_nm * 1e-3; }

// ε' and Meep's D conductivity of each body at one wavelength (σ_D = ω ε''/ε').
struct BodyMedia {
    std::vector<double> eps, sigma_d;
    bool absorbing = false;
};

BodyMedia media_at(const CrossSection2d& section, double lambda_nm) {
    BodyMedia m;
    const double omega = 2.0 * kPi / to_um(lambda_nm);
    for (const Body2d& b : section.bodies) {
        const Complex n = b.material->index(lambda_nm);
        const Complex eps = n * n;
        if (!(eps.real() >= 1.0))
            throw InputError(
                fmt::format("full wave: material '{}' at {} nm has Re ε = {:.4g} < 1 (n = {:.4g} + "
                            "{:.4g}i): metals and "
                            "ε' < 1 are outside this level's scope",
                            b.material->name(), lambda_nm, eps.real(), n.real(), n.imag()));
        m.eps.push_back(eps.real());
        m.sigma_d.push_back(omega * eps.imag() / eps.real());
        m.absorbing = m.absorbing || eps.imag() > 0.0;
    }
    return m;
}

// The section in Meep's frame (ours turned by −θ_i) at one wavelength; air where no body is.
class SectionMaterial final : public meep::material_function {
public:
    // Meep's point (x, y) is our point turned by −θ_i and lowered by z_offset.
    SectionMaterial(const CrossSection2d& section, double theta_i, BodyMedia media,
                    double z_offset = 0.0)
        : section_(section),
          c_(std::cos(theta_i)),
          s_(std::sin(theta_i)),
          z_offset_(z_offset),
          media_(std::move(media)) {}
    double chi1p1(meep::field_type ft, const meep::vec& r) override {
        if (ft != meep::E_stuff && ft != meep::D_stuff) return 1.0;
        const int b = body(r);
        return b < 0 ? 1.0 : media_.eps[static_cast<std::size_t>(b)];
    }
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
    bool has_conductivity(meep::component c) override {
        return media_.absorbing && meep::type(c) == meep::D_stuff;
    }
    double conductivity(meep::component, const meep::vec& r) override {
        const int b = body(r);
        return b < 0 ? 0.0 : media_.sigma_d[static_cast<std::size_t>(b)];
    }

    // The fraction of the h × h pixel centred on r that body b fills (the pole strengths'
    // average, Dispersion::fitted): 0 or 1 unless a 3 × 3 test finds the pixel cut, then the
    // Fibonacci lattice's fraction.
    double fraction_of_body(int b, const meep::vec& r, double h) const {
        const double x0 = r.x() - 0.5 * h, y0 = r.y() - 0.5 * h;
        const bool first = body(meep::vec(x0, y0)) == b;
        bool uniform = true;
        for (int j = 0; j < 3 && uniform; ++j)
            for (int i = 0; i < 3 && uniform; ++i)
                uniform = (body(meep::vec(x0 + 0.5 * i * h, y0 + 0.5 * j * h)) == b) == first;
        if (uniform) return first ? 1.0 : 0.0;
        int inside = 0;
        for (int i = 0; i < kSubpixelSamples; ++i) {
            const long j = (static_cast<long>(i) * kSubpixelStride) % kSubpixelSamples;
            const double u = (i + 0.5) / kSubpixelSamples;
            const double w = (static_cast<double>(j) + 0.5) / kSubpixelSamples;
            inside += body(meep::vec(x0 + u * h, y0 + w * h)) == b ? 1 : 0;
        }
        return static_cast<double>(inside) / kSubpixelSamples;
    }

    // Meep's set-up of a large grid asks every pixel (seconds at fine grids): a set stop flag
    // ends it at the next question.
    void interrupt_on(const std::atomic<bool>* stop) { stop_ = stop; }

private:
    int body(const meep::vec& r) const {
        if (stop_ != nullptr && stop_->load(std::memory_order_relaxed)) [[unlikely]]
            throw Interrupted("full wave: interrupted while Meep set up its grid");
        return section_.body_at({c_ * r.x() + s_ * r.y(), c_ * r.y() - s_ * r.x() + z_offset_});
    }
    const CrossSection2d& section_;
    double c_, s_, z_offset_;
    BodyMedia media_;
    const std::atomic<bool>* stop_ = nullptr;
};

class AirMaterial final : public meep::material_function {};

// One Lorentz pole's strength σ_k over the grid (Dispersion::fitted): σ_k times the fraction of
// the pixel that its body fills, isotropic.
class PoleStrength final : public meep::material_function {
public:
    PoleStrength(const SectionMaterial& section, int body, double strength, double h)
        : section_(section), body_(body), strength_(strength), h_(h) {}
    void sigma_row(meep::component c, double row[3], const meep::vec& r) override {
        row[0] = row[1] = row[2] = 0.0;
        row[meep::component_direction(c) % 3] = strength_ * section_.fraction_of_body(body_, r, h_);
    }

private:
    const SectionMaterial& section_;
    int body_;
    double strength_, h_;
};

// What a run adds to its structure after Meep has built ε: conductivities or poles.
using Dress = std::function<void(meep::structure&)>;

// Each body's poles (Dispersion::fitted; body_fits[b] is body b's material's fit) for the
// structure of `material` (Meep samples the strengths when a susceptibility is added).
Dress add_poles(const SectionMaterial& material, const std::vector<const LorentzFit*>& body_fits,
                double h) {
    return [&material, &body_fits, h](meep::structure& s) {
        for (std::size_t b = 0; b < body_fits.size(); ++b)
            for (const LorentzPole& p : body_fits[b]->model.poles) {
                PoleStrength strength(material, static_cast<int>(b), p.strength, h);
                s.add_susceptibility(
                    strength, meep::E_stuff,
                    meep::lorentzian_susceptibility(p.frequency_per_um, p.damping_per_um));
            }
    };
}

// One side of the monitor box in Meep's frame: the DFT of u on a strip a few cells thick.
struct Side {
    bool horizontal = true;  // normal along Meep's y
    double at = 0.0;         // nominal position across
    double sign = 1.0;       // outward normal: +1 or −1 along its axis
};

// u on the two grid lines that straddle a side, per frequency.
struct SideField {
    std::vector<double> along;               // grid coordinates along the side
    double line_a = 0.0, line_b = 0.0;       // coordinates across of the two lines (a < b)
    std::vector<std::vector<Complex>> a, b;  // [frequency][along]
};

struct Layout {
    double half_x = 0.0, half_y = 0.0;  // the cell
    double box_x = 0.0, box_y = 0.0;    // monitor box half-widths
    double source_y = 0.0;
    double h = 0.0;  // grid step
};

struct RunResult {
    std::array<SideField, 4> sides;
    double time_steps = 0.0;
};

meep::component field_component(Polarisation2d pol) {
    return pol == Polarisation2d::te ? meep::Ez : meep::Hz;
}

// Meep's 2D grid of at least 2·half_x × 2·half_y µm, centred on the origin. Meep checks
// exactly that size × resolution is an integer; for some counts no double size hits it, so
// the count grows by two cells (one each side, in PML) until one does (a few at most).
meep::grid_volume centred_grid(double half_x, double half_y, double res) {
    const auto exact = [res](double half) {
        const double n0 = 2.0 * std::round(half * res);
        for (double n = n0; n < n0 + 64.0; n += 2.0) {
            double up = n / res, down = up;
            for (int i = 0; i < 4;
                 ++i, up = std::nextafter(up, 2.0 * up), down = std::nextafter(down, 0.0)) {
                if (up * res == n) return up;
                if (down * res == n) return down;
            }
        }
        return n0 / res;  // Meep rounds to whole cells, with a warning
    };
    meep::grid_volume gv = meep::vol2d(exact(half_x), exact(half_y), res);
    gv.center_origin();
    return gv;
}

// A half-width rounded up to whole grid cells: the cell is then an even number of cells wide
// and its centre, our origin, a grid point.
double whole_cells(double half_width, double h) { return std::ceil(half_width / h - 1e-9) * h; }

meep::volume strip_volume(const Side& s, const Layout& l) {
    const double w = 2.0 * l.h;
    if (s.horizontal)
        return {meep::vec(-l.box_x - 3.0 * l.h, s.at - w),
                meep::vec(l.box_x + 3.0 * l.h, s.at + w)};
    return {meep::vec(s.at - w, -l.box_y - 3.0 * l.h), meep::vec(s.at + w, l.box_y + 3.0 * l.h)};
}

std::array<Side, 4> box_sides(const Layout& l) {
    return {{{true, l.box_y, 1.0},
             {true, -l.box_y, -1.0},
             {false, l.box_x, 1.0},
             {false, -l.box_x, -1.0}}};
}

// x and y grid coordinates of a DFT volume (Meep's get_array_metadata: [NX, x…, NY, y…, NZ, z…,
// w…]).
void grid_ticks(meep::fields& f, const meep::volume& where, std::vector<double>& xs,
                std::vector<double>& ys) {
    const std::vector<double> meta = f.get_array_metadata(where);
    const auto nx = static_cast<std::size_t>(meta[0]);
    xs.assign(meta.begin() + 1, meta.begin() + 1 + static_cast<std::ptrdiff_t>(nx));
    const auto ny = static_cast<std::size_t>(meta[1 + nx]);
    ys.assign(meta.begin() + 2 + static_cast<std::ptrdiff_t>(nx),
              meta.begin() + 2 + static_cast<std::ptrdiff_t>(nx + ny));
}

SideField read_side(meep::fields& f, meep::dft_fields& dft, const Side& side,
                    const meep::volume& where, meep::component c, std::size_t n_freq) {
    std::vector<double> xs, ys;
    grid_ticks(f, where, xs, ys);
    const std::vector<double>& across = side.horizontal ? ys : xs;
    std::size_t below = 0;
    for (std::size_t i = 0; i < across.size(); ++i)
        if (across[i] <= side.at + 1e-9) below = i;
    if (below + 1 >= across.size())
        throw InvariantError("full wave: a monitor strip holds no grid line above its side");
    SideField out;
    out.along = side.horizontal ? xs : ys;
    out.line_a = across[below];
    out.line_b = across[below + 1];
    for (std::size_t k = 0; k < n_freq; ++k) {
        int rank = 0;
        std::size_t dims[3] = {1, 1, 1};
        std::unique_ptr<std::complex<meep::realnum>[]> arr(
            f.get_dft_array(dft, c, static_cast<int>(k), &rank, dims));
        if (rank != 2 || dims[0] != xs.size() || dims[1] != ys.size())
            throw InvariantError(
                fmt::format("full wave: DFT array of rank {} ({} × {}) on a {} × {} strip", rank,
                            dims[0], dims[1], xs.size(), ys.size()));
        std::vector<Complex> a(out.along.size()), b(out.along.size());
        for (std::size_t i = 0; i < out.along.size(); ++i) {
            const std::size_t ia = side.horizontal ? i * ys.size() + below : below * ys.size() + i;
            const std::size_t ib =
                side.horizontal ? i * ys.size() + below + 1 : (below + 1) * ys.size() + i;
            a[i] = Complex(arr[ia]);
            b[i] = Complex(arr[ib]);
        }
        out.a.push_back(std::move(a));
        out.b.push_back(std::move(b));
    }
    return out;
}

// Steps until the largest |u|² at the probe over the last 20 time units is below decay × its
// peak (Meep's stop_when_fields_decayed), polling the stop flag; returns the steps taken.
double step_until_decayed(meep::fields& f, meep::component c, const meep::vec& probe,
                          double source_end, const FullWave2dOptions& o) {
    const double interval = 20.0;
    double peak = 0.0, window = 0.0, next_check = source_end + interval, steps = 0.0;
    while (true) {
        if (o.stop && o.stop->load(std::memory_order_relaxed))
            throw Interrupted("full wave: interrupted during a time-stepping run");
        f.step();
        steps += 1.0;
        const double u2 = std::norm(f.get_field(c, probe));
        peak = std::max(peak, u2);
        window = std::max(window, u2);
        if (f.time() >= next_check) {
            if (window <= o.decay * peak) return steps;
            window = 0.0;
            next_check += interval;
        }
    }
}

// The D conductivity of absorbing bodies (Dispersion::per_wavelength) on the polarisation's
// electric components (Ez for TE; Ex, Ey for TM).
Dress conductivities(meep::material_function& material, Polarisation2d pol, bool absorbing) {
    if (!absorbing) return {};
    return [&material, pol](meep::structure& s) {
        if (pol == Polarisation2d::te) {
            s.set_conductivity(meep::Dz, material);
        } else {
            s.set_conductivity(meep::Dx, material);
            s.set_conductivity(meep::Dy, material);
        }
    };
}

// One FDTD run: the source, the DFT strips, time steps until the probe's field has decayed.
RunResult run(meep::material_function& material, const Dress& dress, Polarisation2d pol,
              const Layout& l, std::span<const double> freqs, double f_centre, double f_width,
              const FullWave2dOptions& o) {
    const meep::grid_volume gv = centred_grid(l.half_x, l.half_y, o.resolution_px_per_um);
    meep::structure s(gv, material, meep::pml(o.pml_um), meep::identity(), 0, kCourant,
                      o.subpixel_smoothing);
    const meep::component c = field_component(pol);
    if (dress) dress(s);
    meep::fields f(&s);
    f.use_real_fields();
    meep::gaussian_src_time src(f_centre, f_width);
    f.add_volume_source(
        c, src, meep::volume(meep::vec(-l.half_x, l.source_y), meep::vec(l.half_x, l.source_y)),
        1.0);

    const std::array<Side, 4> sides = box_sides(l);
    std::vector<meep::dft_fields> strips;
    std::vector<meep::volume> where;
    meep::component comps[1] = {c};
    for (const Side& side : sides) {
        where.push_back(strip_volume(side, l));
        strips.push_back(f.add_dft_fields(comps, 1, where.back(), freqs.data(), freqs.size()));
    }
    RunResult r;
    r.time_steps = step_until_decayed(f, c, meep::vec(0.0, -l.box_y), src.last_time(), o);
    for (std::size_t i = 0; i < 4; ++i)
        r.sides[i] = read_side(f, strips[i], sides[i], where[i], c, freqs.size());
    return r;
}

// The incident wave alone, u(y) on the grid's rows, per frequency: it does not depend on x
// (a line source across the whole cell), so it is computed on a cell four columns wide,
// periodic in x, with the same rows, PML, source and stop rule as the bodies' cell, at a few
// per cent of an empty run of the whole cell (full_wave_2d.h: how far the two differ).
struct IncidentProfile {
    std::vector<double> y;                // grid rows from under the box to over it
    std::vector<std::vector<Complex>> u;  // [frequency][row]
    std::vector<Complex> u0;              // amplitude referred to the origin
    double time_steps = 0.0;
    Complex at(std::size_t k, double row) const {
        for (std::size_t j = 0; j < y.size(); ++j)
            if (std::abs(y[j] - row) <= 1e-9) return u[k][j];
        throw InvariantError(
            fmt::format("full wave: the incident profile has no grid row at y = {}", row));
    }
};

IncidentProfile run_incident(Polarisation2d pol, const Layout& l, std::span<const double> freqs,
                             double f_centre, double f_width, const FullWave2dOptions& o) {
    const double half_x = 2.0 * l.h;
    const meep::grid_volume gv = centred_grid(half_x, l.half_y, o.resolution_px_per_um);
    AirMaterial air;
    meep::structure s(gv, air, meep::pml(o.pml_um, meep::Y), meep::identity(), 0, kCourant, false);
    const meep::component c = field_component(pol);
    meep::fields f(&s);
    f.use_real_fields();
    f.use_bloch(meep::vec(0.0, 0.0));
    meep::gaussian_src_time src(f_centre, f_width);
    f.add_volume_source(
        c, src, meep::volume(meep::vec(-half_x, l.source_y), meep::vec(half_x, l.source_y)), 1.0);
    meep::component comps[1] = {c};
    const meep::volume column(meep::vec(-half_x, -l.box_y - 3.0 * l.h),
                              meep::vec(half_x, l.box_y + 3.0 * l.h));
    meep::dft_fields dft = f.add_dft_fields(comps, 1, column, freqs.data(), freqs.size());
    IncidentProfile p;
    p.time_steps = step_until_decayed(f, c, meep::vec(0.0, -l.box_y), src.last_time(), o);
    std::vector<double> xs;
    grid_ticks(f, column, xs, p.y);
    for (std::size_t k = 0; k < freqs.size(); ++k) {
        int rank = 0;
        std::size_t dims[3] = {1, 1, 1};
        std::unique_ptr<std::complex<meep::realnum>[]> arr(
            f.get_dft_array(dft, c, static_cast<int>(k), &rank, dims));
        // every column holds the same wave: the middle one
        const std::size_t i = xs.size() / 2;
        std::vector<Complex> row(p.y.size());
        for (std::size_t j = 0; j < p.y.size(); ++j) row[j] = Complex(arr[i * p.y.size() + j]);
        // u_0 as before: the wave u_0 e^{−iky} (travelling down) near the box's bottom side
        const double kk = 2.0 * kPi * freqs[k];
        Complex sum = 0.0;
        std::size_t n = 0;
        for (std::size_t j = 0; j < p.y.size(); ++j)
            if (std::abs(p.y[j] + l.box_y) <= 2.0 * l.h + 1e-9) {
                sum += row[j] * std::exp(Complex(0.0, kk * p.y[j]));
                ++n;
            }
        p.u0.push_back(sum / static_cast<double>(n));
        p.u.push_back(std::move(row));
    }
    return p;
}

// The incident field on the box's strips, on the same grid points as a bodies' run's strips
// (`geometry`), at frequency k.
std::array<SideField, 4> incident_on(const IncidentProfile& p,
                                     const std::array<SideField, 4>& geometry, std::size_t k) {
    std::array<SideField, 4> out;
    for (std::size_t i = 0; i < 4; ++i) {
        const SideField& g = geometry[i];
        SideField& sf = out[i];
        sf.along = g.along;
        sf.line_a = g.line_a;
        sf.line_b = g.line_b;
        std::vector<Complex> a(g.along.size()), b(g.along.size());
        const bool horizontal = i < 2;  // box_sides: top, bottom, then right, left
        for (std::size_t j = 0; j < g.along.size(); ++j) {
            a[j] = p.at(k, horizontal ? g.line_a : g.along[j]);
            b[j] = p.at(k, horizontal ? g.line_b : g.along[j]);
        }
        sf.a = {std::move(a)};
        sf.b = {std::move(b)};
    }
    return out;
}

// The box's sides as midpoint lines: u and ∂u/∂ν on each, with the sample weights.
struct BoxSample {
    double x = 0.0, y = 0.0, nx = 0.0, ny = 0.0, weight = 0.0;
    Complex u, dudn;
};

std::vector<BoxSample> box_samples(const std::array<SideField, 4>& scattered, std::size_t k,
                                   const Layout& l) {
    const std::array<Side, 4> sides = box_sides(l);
    // positions of the four midpoint lines: top, bottom (y), right, left (x)
    std::array<double, 4> mid{};
    for (std::size_t i = 0; i < 4; ++i) mid[i] = 0.5 * (scattered[i].line_a + scattered[i].line_b);
    std::vector<BoxSample> out;
    for (std::size_t i = 0; i < 4; ++i) {
        const Side& s = sides[i];
        const SideField& sf = scattered[i];
        const double lo = s.horizontal ? mid[3] : mid[1], hi = s.horizontal ? mid[2] : mid[0];
        const double d = sf.line_b - sf.line_a;
        for (std::size_t j = 0; j < sf.along.size(); ++j) {
            const double t = sf.along[j];
            if (t <= lo || t >= hi) continue;
            BoxSample b;
            b.u = 0.5 * (sf.a[k][j] + sf.b[k][j]);
            b.dudn = s.sign * (sf.b[k][j] - sf.a[k][j]) / d;
            b.weight = l.h;
            if (s.horizontal) {
                b.x = t, b.y = mid[i], b.ny = s.sign;
            } else {
                b.x = mid[i], b.y = t, b.nx = s.sign;
            }
            out.push_back(b);
        }
    }
    return out;
}

// f(θ) (Meep-frame angle, from +y towards +x) of the exterior Green's representation.
Complex far_amplitude(const std::vector<BoxSample>& box, double k, double theta) {
    const double sx = std::sin(theta), sy = std::cos(theta);
    Complex total = 0.0;
    for (const BoxSample& b : box) {
        const Complex phase = std::exp(Complex(0.0, -k * (sx * b.x + sy * b.y)));
        total += b.weight * phase * (Complex(0.0, -k * (sx * b.nx + sy * b.ny)) * b.u - b.dudn);
    }
    return std::exp(Complex(0.0, kPi / 4.0)) / std::sqrt(8.0 * kPi * k) * total;
}

// ∮ Im(u* ∂u/∂ν) ds: 2ω × the outward power per unit length.
double outward_flux(const std::vector<BoxSample>& box) {
    double sum = 0.0;
    for (const BoxSample& b : box) sum += b.weight * std::imag(std::conj(b.u) * b.dudn);
    return sum;
}

std::array<SideField, 4> difference(const std::array<SideField, 4>& total,
                                    const std::array<SideField, 4>& incident) {
    std::array<SideField, 4> out = total;
    for (std::size_t i = 0; i < 4; ++i)
        for (std::size_t k = 0; k < out[i].a.size(); ++k)
            for (std::size_t j = 0; j < out[i].along.size(); ++j) {
                out[i].a[k][j] -= incident[i].a[k][j];
                out[i].b[k][j] -= incident[i].b[k][j];
            }
    return out;
}

void check_wavelengths(std::span<const double> lambdas_nm) {
    require(!lambdas_nm.empty(), "full wave", "no wavelengths asked");
    for (const double l : lambdas_nm)
        require(std::isfinite(l) && l > 200.0 && l <= 2000.0, "full wave", "lambda_nm", l,
                "a wavelength in (200, 2000] nm");
}

void check_options(const CrossSection2d& section, std::span<const double> lambdas_nm,
                   const FullWave2dOptions& o) {
    check_wavelengths(lambdas_nm);
    require(std::isfinite(o.resolution_px_per_um) && o.resolution_px_per_um > 0.0 &&
                o.resolution_px_per_um <= 400.0,
            "full wave", "resolution_px_per_um", o.resolution_px_per_um,
            "a finite resolution in (0, 400] px/µm");
    const double h = 1.0 / o.resolution_px_per_um;
    require(std::isfinite(o.pml_um) && o.pml_um >= h, "full wave", "pml_um", o.pml_um,
            fmt::format("a PML at least one grid cell ({} µm) thick", h));
    require(std::isfinite(o.gap_um) && o.gap_um >= 4.0 * h, "full wave", "gap_um", o.gap_um,
            fmt::format("a gap of at least four grid cells ({} µm)", 4.0 * h));
    require(std::isfinite(o.decay) && o.decay > 0.0 && o.decay <= 1e-2, "full wave", "decay",
            o.decay, "a decay in (0, 1e-2]");
    double lambda_min = lambdas_nm.front(), n_max = 1.0;
    for (const double l : lambdas_nm) {
        lambda_min = std::min(lambda_min, l);
        for (const Body2d& b : section.bodies) n_max = std::max(n_max, b.material->index(l).real());
    }
    const double h_wave = to_um(lambda_min) / (10.0 * n_max);
    if (h > h_wave * (1.0 + 1e-12))
        throw InputError(
            fmt::format("full wave: resolution_px_per_um = {} gives a grid step of {:.4g} µm, "
                        "coarser than λ/(10 n) = {:.4g} µm "
                        "({} nm, n = {:.4g}): at least {:.4g} px/µm needed",
                        o.resolution_px_per_um, h, h_wave, lambda_min, n_max, 1.0 / h_wave));
    for (const Body2d& b : section.bodies) {
        const double thin = b.shape->thinnest_um();
        if (thin < 2.0 * h * (1.0 - 1e-12))
            throw InputError(
                fmt::format("full wave: {} ({}) is {:.4g} µm thin at its narrowest, under two grid "
                            "cells ({:.4g} µm at {} px/µm): "
                            "at least {:.4g} px/µm needed",
                            b.shape->describe(), b.material->name(), thin, 2.0 * h,
                            o.resolution_px_per_um, 2.0 / thin));
    }
}

// Meep's memory per cell for one Lorentz pole: its strength and two polarisation arrays (now and
// one step back) on up to two electric components (TM: Ex, Ey), doubles.
constexpr double kBytesPerPoleCell = 48.0;

void require_grid_memory(double cells, std::size_t poles, const std::string& what) {
    require_memory(cells * (kBytesPerCell + static_cast<double>(poles) * kBytesPerPoleCell), what);
}

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
                           const FullWave2dOptions& o) {
    RunMaterials m;
    for (const double l : lambdas_nm) m.exact.push_back(media_at(section, l));
    if (o.dispersion == Dispersion::per_wavelength) return m;
    require(std::isfinite(o.max_fit_index_error) && o.max_fit_index_error > 0.0, "full wave",
            "max_fit_index_error", o.max_fit_index_error, "a finite value > 0");
    const auto [lo, hi] = std::minmax_element(lambdas_nm.begin(), lambdas_nm.end());
    const double band_lo = std::min(380.0, *lo), band_hi = std::max(780.0, *hi);
    std::vector<const optics::Material*> fitted;
    std::vector<std::size_t> index_of_body;
    for (const Body2d& b : section.bodies) {
        const auto at = std::find(fitted.begin(), fitted.end(), b.material.get());
        index_of_body.push_back(static_cast<std::size_t>(at - fitted.begin()));
        if (at != fitted.end()) continue;
        fitted.push_back(b.material.get());
        LorentzFit fit = fit_lorentz(*b.material, band_lo, band_hi, kMaxPoleFrequencyPerUm);
        if (fit.max_index_error > o.max_fit_index_error)
            throw InputError(fmt::format(
                "full wave: the Lorentz fit of '{}' over {}–{} nm misses its index by {:.3g} "
                "(max_fit_index_error = {:.3g}): use Dispersion::per_wavelength",
                b.material->name(), band_lo, band_hi, fit.max_index_error, o.max_fit_index_error));
        for (const LorentzPole& p : fit.model.poles) {
            // Meep's Lorentz update is stable while 2π f Δt < 2, Δt = courant / resolution
            const double needed = kPi * p.frequency_per_um * kCourant;
            if (!(o.resolution_px_per_um > needed))
                throw InputError(fmt::format(
                    "full wave: resolution_px_per_um = {} is too coarse for the Lorentz pole of "
                    "'{}' at {:.4g} 1/µm (Meep's update is unstable): more than {:.4g} px/µm "
                    "needed",
                    o.resolution_px_per_um, b.material->name(), p.frequency_per_um, needed));
        }
        m.fits.push_back(std::move(fit));
    }
    for (std::size_t b = 0; b < section.bodies.size(); ++b) {
        m.body_fits.push_back(&m.fits[index_of_body[b]]);
        m.instantaneous.eps.push_back(m.body_fits.back()->model.eps_infinity);
        m.instantaneous.sigma_d.push_back(0.0);
    }
    return m;
}

// The Gaussian pulse covering all the frequencies: Meep's (centre, width).
std::pair<double, double> pulse(std::span<const double> freqs) {
    const auto [lo, hi] = std::minmax_element(freqs.begin(), freqs.end());
    const double centre = 0.5 * (*lo + *hi);
    return {centre, std::max(1.5 * (*hi - *lo), 0.5 * centre)};
}

// Runs job(0 … n − 1) on FullWave2dOptions::threads threads (dynamic: runs differ in length)
// and returns their results in order; the first exception (an Interrupted among them) is
// rethrown after all have stopped.
template <class Job>
auto run_all(std::size_t n, const FullWave2dOptions& o, const Job& job) {
    using Result = decltype(job(std::size_t{0}));
    std::vector<Result> results(n);
    std::vector<std::exception_ptr> errors(n);
    const int threads = o.threads > 0 ? o.threads : omp_get_max_threads();
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

// The cell around isolated bodies in Meep's frame (ours turned by −θ_i): monitor box gap_um
// outside the bodies, the source gap_um above it, then gap_um and the PML, in whole cells.
Layout isolated_layout(const CrossSection2d& section, double theta_i_rad,
                       const FullWave2dOptions& o) {
    // the bodies' extent in Meep's frame (ours turned by −θ_i)
    const double c = std::cos(theta_i_rad), s = std::sin(theta_i_rad);
    double ex = 0.0, ey = 0.0;
    for (const Body2d& b : section.bodies) {
        const Box2d box = b.shape->bounds();
        for (const double x : {box.min.x(), box.max.x()})
            for (const double z : {box.min.y(), box.max.y()}) {
                ex = std::max(ex, std::abs(x * c - z * s));
                ey = std::max(ey, std::abs(z * c + x * s));
            }
    }
    Layout l;
    l.h = 1.0 / o.resolution_px_per_um;
    l.box_x = ex + o.gap_um;
    l.box_y = ey + o.gap_um;
    l.source_y = l.box_y + o.gap_um;
    l.half_x = whole_cells(l.box_x + o.gap_um + o.pml_um, l.h);
    l.half_y = whole_cells(l.source_y + o.gap_um + o.pml_um, l.h);
    return l;
}

// The sides' fields at one of their frequencies only.
std::array<SideField, 4> at_frequency(const std::array<SideField, 4>& sides, std::size_t k) {
    std::array<SideField, 4> out = sides;
    for (SideField& sf : out) {
        sf.a = {sf.a[k]};
        sf.b = {sf.b[k]};
    }
    return out;
}

// One wavelength's far field and widths from the run holding it (`run`, at its frequency
// k_run) and the incident wave (all wavelengths; k is this one's index there).
FarField2d far_field_of_run(const RunResult& run, std::size_t k_run,
                            const IncidentProfile& incident, std::size_t k, double freq,
                            double lambda_nm, double theta_i_rad,
                            std::span<const double> theta_s_rad, const Layout& l) {
    const std::array<SideField, 4> total = at_frequency(run.sides, k_run);
    const std::vector<BoxSample> scattered =
        box_samples(difference(total, incident_on(incident, run.sides, k)), 0, l);
    const std::vector<BoxSample> whole = box_samples(total, 0, l);
    const double kk = 2.0 * kPi * freq;
    const Complex u0 = incident.u0[k];
    const double intensity_times_2w = kk * std::norm(u0);  // 2ω I = ω |u_0|²
    FarField2d ff;
    ff.lambda_nm = lambda_nm;
    ff.time_steps = run.time_steps;
    for (const double t : theta_s_rad)
        ff.sigma_um_per_rad.push_back(std::norm(far_amplitude(scattered, kk, t - theta_i_rad)) /
                                      std::norm(u0));
    ff.scattering_width_um = outward_flux(scattered) / intensity_times_2w;
    ff.absorption_width_um = -outward_flux(whole) / intensity_times_2w;
    // ∫σ over the back hemisphere (ω_s·ω_i > 0: Meep angles |θ| < π/2), midpoint rule on
    // 720 directions (σ is smooth on the scale of kΔθ·(box size) ≪ 1 for these boxes)
    const int n_back = 720;
    for (int j = 0; j < n_back; ++j) {
        const double t = -kPi / 2.0 + kPi * (j + 0.5) / n_back;
        ff.back_scattering_width_um +=
            std::norm(far_amplitude(scattered, kk, t)) / std::norm(u0) * kPi / n_back;
    }
    const Complex forward =
        far_amplitude(scattered, kk, kPi) / u0;  // Meep's forward: straight down
    ff.extinction_width_um =
        -2.0 * std::sqrt(2.0 * kPi / kk) * std::real(forward * std::exp(Complex(0.0, kPi / 4.0)));
    return ff;
}

}  // namespace

double minimum_resolution_px_per_um(const CrossSection2d& section,
                                    std::span<const double> lambdas_nm) {
    check_wavelengths(lambdas_nm);
    double res = 0.0;
    for (const double l : lambdas_nm) {
        double n_max = 1.0;
        for (const Body2d& b : section.bodies) n_max = std::max(n_max, b.material->index(l).real());
        res = std::max(res, 10.0 * n_max / to_um(l));
    }
    for (const Body2d& b : section.bodies) res = std::max(res, 2.0 / b.shape->thinnest_um());
    return res;
}

FullWave2dResult full_wave_far_field(const CrossSection2d& section, Polarisation2d pol,
                                     double theta_i_rad, std::span<const double> lambdas_nm,
                                     std::span<const double> theta_s_rad,
                                     const FullWave2dOptions& o) {
    require(!section.bodies.empty(), "full wave", "the cross-section has no bodies");
    require(std::isfinite(theta_i_rad), "full wave", "theta_i", theta_i_rad,
            "a finite angle (rad)");
    for (const Body2d& b : section.bodies)
        require(!b.shape->is_layer(), "full wave",
                fmt::format("{} is a layer: an isolated cross-section needs bounded bodies "
                            "(layers: full_wave_stack)",
                            b.shape->describe()));
    for (const double t : theta_s_rad)
        require(std::isfinite(t), "full wave", "theta_s", t, "a finite angle (rad)");
    check_options(section, lambdas_nm, o);
    const RunMaterials materials = run_materials(section, lambdas_nm, o);

    const Layout l = isolated_layout(section, theta_i_rad, o);
    const double cells =
        (2.0 * l.half_x * o.resolution_px_per_um) * (2.0 * l.half_y * o.resolution_px_per_um);
    require_grid_memory(
        cells, materials.poles(),
        fmt::format("full wave: a {:.3g} × {:.3g} µm cell at resolution_px_per_um = {}",
                    2.0 * l.half_x, 2.0 * l.half_y, o.resolution_px_per_um));

    const auto started = std::chrono::steady_clock::now();
    const Quiet quiet;
    std::vector<double> freqs;
    for (const double lam : lambdas_nm) freqs.push_back(1.0 / to_um(lam));
    // Plain names, not a structured binding: clang 14 (the instrumented build) cannot capture
    // structured bindings in a lambda.
    const std::pair<double, double> band = pulse(freqs);
    const double f_centre = band.first, f_width = band.second;
    // The incident wave (a cheap run), then one run per wavelength (or one for all, fitted),
    // independent: spread over threads (each Meep run is serial; runs share nothing but the
    // read-only section).
    const IncidentProfile incident = run_incident(pol, l, freqs, f_centre, f_width, o);
    const bool fitted = o.dispersion == Dispersion::fitted;
    const std::vector<RunResult> runs = run_all(fitted ? 1 : freqs.size(), o, [&](std::size_t i) {
        if (fitted) {
            SectionMaterial material(section, theta_i_rad, materials.instantaneous);
            material.interrupt_on(o.stop);
            return run(material, add_poles(material, materials.body_fits, l.h), pol, l, freqs,
                       f_centre, f_width, o);
        }
        SectionMaterial material(section, theta_i_rad, materials.exact[i]);
        material.interrupt_on(o.stop);
        const std::array<double, 1> one{freqs[i]};
        return run(material, conductivities(material, pol, materials.exact[i].absorbing), pol, l,
                   one, f_centre, f_width, o);
    });

    FullWave2dResult result;
    result.polarisation = pol;
    result.theta_i_rad = theta_i_rad;
    result.resolution_px_per_um = o.resolution_px_per_um;
    result.theta_s_rad.assign(theta_s_rad.begin(), theta_s_rad.end());
    result.grid_cells = static_cast<std::size_t>(cells);
    for (std::size_t k = 0; k < freqs.size(); ++k)
        result.wavelengths.push_back(far_field_of_run(fitted ? runs[0] : runs[k], fitted ? k : 0,
                                                      incident, k, freqs[k], lambdas_nm[k],
                                                      theta_i_rad, theta_s_rad, l));
    result.dispersion_fits = materials.fits;
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return result;
}

namespace {

// u on two grid lines straddling y = at across the whole (periodic) cell, per frequency: the
// mean over x of u and ∂u/∂y at their midpoint.
struct LineField {
    std::vector<Complex> u, dudy;
};

LineField read_line(meep::fields& f, meep::dft_fields& dft, const meep::volume& where, double at,
                    meep::component c, std::size_t n_freq) {
    std::vector<double> xs, ys;
    grid_ticks(f, where, xs, ys);
    std::size_t below = 0;
    for (std::size_t i = 0; i < ys.size(); ++i)
        if (ys[i] <= at + 1e-9) below = i;
    if (below + 1 >= ys.size())
        throw InvariantError("full wave: a flux strip holds no grid line above its line");
    const double d = ys[below + 1] - ys[below];
    LineField out;
    for (std::size_t k = 0; k < n_freq; ++k) {
        int rank = 0;
        std::size_t dims[3] = {1, 1, 1};
        std::unique_ptr<std::complex<meep::realnum>[]> arr(
            f.get_dft_array(dft, c, static_cast<int>(k), &rank, dims));
        Complex u = 0.0, du = 0.0;
        for (std::size_t i = 0; i < xs.size(); ++i) {
            const Complex a(arr[i * ys.size() + below]), b(arr[i * ys.size() + below + 1]);
            u += 0.5 * (a + b);
            du += (b - a) / d;
        }
        out.u.push_back(u / static_cast<double>(xs.size()));
        out.dudy.push_back(du / static_cast<double>(xs.size()));
    }
    return out;
}

struct StackRun {
    LineField above, below;
};

StackRun run_stack(meep::material_function& material, const Dress& dress, Polarisation2d pol,
                   double half_x, double half_y, double y_reflect, double y_source,
                   double y_transmit, std::span<const double> freqs, double f_centre,
                   double f_width, const FullWave2dOptions& o, bool smoothing) {
    const meep::grid_volume gv = centred_grid(half_x, half_y, o.resolution_px_per_um);
    meep::structure s(gv, material, meep::pml(o.pml_um, meep::Y), meep::identity(), 0, kCourant,
                      smoothing);
    const meep::component c = field_component(pol);
    if (dress) dress(s);
    meep::fields f(&s);
    f.use_bloch(meep::vec(0.0, 0.0));  // periodic in x (normal incidence)
    meep::gaussian_src_time src(f_centre, f_width);
    f.add_volume_source(
        c, src, meep::volume(meep::vec(-half_x, y_source), meep::vec(half_x, y_source)), 1.0);
    const double h = 1.0 / o.resolution_px_per_um;
    meep::component comps[1] = {c};
    const meep::volume above(meep::vec(-half_x, y_reflect - 2.0 * h),
                             meep::vec(half_x, y_reflect + 2.0 * h));
    const meep::volume below(meep::vec(-half_x, y_transmit - 2.0 * h),
                             meep::vec(half_x, y_transmit + 2.0 * h));
    meep::dft_fields dft_above = f.add_dft_fields(comps, 1, above, freqs.data(), freqs.size());
    meep::dft_fields dft_below = f.add_dft_fields(comps, 1, below, freqs.data(), freqs.size());
    step_until_decayed(f, c, meep::vec(0.0, y_transmit), src.last_time(), o);
    return {read_line(f, dft_above, above, y_reflect, c, freqs.size()),
            read_line(f, dft_below, below, y_transmit, c, freqs.size())};
}

}  // namespace

namespace {

// R and T at one wavelength from the incident run (all wavelengths; k is this one) and the
// stack's run holding it (at its index kt). Fluxes along +y in units of 1/(2ω): Im(u* ∂u/∂y).
// Under the stack, in body `under` (−1: air), T is power only where that medium is lossless;
// for TM (u = H) the flux is divided by its ε.
StackReflectance stack_reflectance(const StackRun& incident, std::size_t k, const StackRun& total,
                                   std::size_t kt, const BodyMedia& media, int under,
                                   Polarisation2d pol, double lambda_nm) {
    const Complex ui = incident.above.u[k], dui = incident.above.dudy[k];
    const double incident_flux = -std::imag(std::conj(ui) * dui);  // downward
    const Complex us = total.above.u[kt] - ui, dus = total.above.dudy[kt] - dui;
    StackReflectance r;
    r.lambda_nm = lambda_nm;
    r.reflectance = std::imag(std::conj(us) * dus) / incident_flux;
    const bool lossless_under = under < 0 || media.sigma_d[static_cast<std::size_t>(under)] == 0.0;
    const double eps_under = under < 0 ? 1.0 : media.eps[static_cast<std::size_t>(under)];
    const double flux_under =
        -std::imag(std::conj(total.below.u[kt]) * total.below.dudy[kt]) / incident_flux;
    r.transmittance = !lossless_under             ? std::numeric_limits<double>::quiet_NaN()
                      : pol == Polarisation2d::te ? flux_under
                                                  : flux_under / eps_under;
    return r;
}

}  // namespace

std::vector<StackReflectance> full_wave_stack(const CrossSection2d& layers, Polarisation2d pol,
                                              std::span<const double> lambdas_nm,
                                              const FullWave2dOptions& o) {
    require(!layers.bodies.empty(), "full wave stack", "the stack has no layers");
    double z_hi = -std::numeric_limits<double>::infinity(),
           z_lo = std::numeric_limits<double>::infinity();
    for (const Body2d& b : layers.bodies) {
        require(b.shape->is_layer(), "full wave stack",
                fmt::format("{} is not a layer: a planar stack takes layers only",
                            b.shape->describe()));
        const Box2d box = b.shape->bounds();
        z_hi = std::max(z_hi, box.max.y());
        z_lo = std::min(z_lo, std::isfinite(box.min.y()) ? box.min.y() : box.max.y());
    }
    check_options(layers, lambdas_nm, o);
    const RunMaterials materials = run_materials(layers, lambdas_nm, o);

    // Meep's y = our z − z_centre; from the top: PML, gap, source, gap, reflection line, gap,
    // the stack, gap, transmission line, gap, PML
    const double h = 1.0 / o.resolution_px_per_um;
    const double top = z_hi + 3.0 * o.gap_um + o.pml_um, bottom = z_lo - 2.0 * o.gap_um - o.pml_um;
    const double z_centre = 0.5 * (top + bottom), half_y = whole_cells(0.5 * (top - bottom), h),
                 half_x = 2.0 * h;
    const double y_reflect = z_hi + o.gap_um - z_centre,
                 y_source = z_hi + 2.0 * o.gap_um - z_centre;
    const double y_transmit = z_lo - o.gap_um - z_centre;
    require_grid_memory(
        4.0 * 2.0 * half_y * o.resolution_px_per_um, materials.poles(),
        fmt::format("full wave stack: a {:.3g} µm column at resolution_px_per_um = {}",
                    2.0 * half_y, o.resolution_px_per_um));
    // the medium under the stack, where T is measured
    const int under = layers.body_at({0.0, z_lo - o.gap_um});

    const Quiet quiet;
    std::vector<double> freqs;
    for (const double lam : lambdas_nm) freqs.push_back(1.0 / to_um(lam));
    // Plain names, not a structured binding: clang 14 (the instrumented build) cannot capture
    // structured bindings in a lambda.
    const std::pair<double, double> band = pulse(freqs);
    const double f_centre = band.first, f_width = band.second;
    const std::vector<StackRun> runs = run_all(materials.runs(freqs.size()), o, [&](std::size_t i) {
        if (i == 0) {
            AirMaterial air;
            return run_stack(air, {}, pol, half_x, half_y, y_reflect, y_source, y_transmit, freqs,
                             f_centre, f_width, o, false);
        }
        if (o.dispersion == Dispersion::fitted) {
            SectionMaterial material(layers, 0.0, materials.instantaneous, z_centre);
            material.interrupt_on(o.stop);
            return run_stack(material, add_poles(material, materials.body_fits, h), pol, half_x,
                             half_y, y_reflect, y_source, y_transmit, freqs, f_centre, f_width, o,
                             o.subpixel_smoothing);
        }
        const BodyMedia& media = materials.exact[i - 1];
        SectionMaterial material(layers, 0.0, media, z_centre);
        material.interrupt_on(o.stop);
        const std::array<double, 1> one{freqs[i - 1]};
        return run_stack(material, conductivities(material, pol, media.absorbing), pol, half_x,
                         half_y, y_reflect, y_source, y_transmit, one, f_centre, f_width, o,
                         o.subpixel_smoothing);
    });
    std::vector<StackReflectance> out;
    for (std::size_t k = 0; k < freqs.size(); ++k) {
        const bool fitted = o.dispersion == Dispersion::fitted;
        // the run holding this wavelength, and its index there
        out.push_back(stack_reflectance(runs.front(), k, runs[fitted ? 1 : k + 1], fitted ? k : 0,
                                        materials.exact[k], under, pol, lambdas_nm[k]));
    }
    return out;
}

}  // namespace plumage::sim::fullwave
