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
#include "sim/fullwave/meep_solver.h"

namespace plumage::sim::fullwave {

using namespace detail;

namespace {

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
    // the far-field stop rule's window: light's round trip around the bodies' bounding box at
    // their largest index (a wave guided around a cortex leaks a burst each trip), >= 3 checks
    double round_trip = 0.0;
    double h = 0.0;  // grid step
};

struct RunResult {
    std::array<SideField, 4> sides;
    double time_steps = 0.0;
};

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

// What a run of the bodies watches when it stops on its far field (far_field_tolerance > 0):
// the widths its DFTs give so far. Empty: the probe's decay.
using FarFieldWatch = std::function<std::vector<Watched>(const RunResult&)>;

// Interval of the far-field stop rule's checks, in Meep's time unit (µm/c): 14 periods of 700 nm
// light; a check (the DFTs read, 720 directions per wavelength) costs under 1 % of it.
constexpr double kWatchInterval = 10.0;

// One FDTD run: the source, the DFT strips, time steps until the probe's field has decayed or
// (`watch`) the far field has converged.
RunResult run(meep::material_function& material, const Dress& dress, Polarisation2d pol,
              const Layout& l, std::span<const double> freqs, double f_centre, double f_width,
              const FarFieldWatch& watch, const FullWave2dOptions& o) {
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
    const auto read_sides = [&] {
        for (std::size_t i = 0; i < 4; ++i)
            r.sides[i] = read_side(f, strips[i], sides[i], where[i], c, freqs.size());
    };
    if (watch) {
        // no check before the scattered light can have reached every side of the box
        const double crossing = 2.0 * std::hypot(l.half_x, l.half_y);
        r.time_steps = step_until_converged(
            f, src.last_time() + crossing, kWatchInterval, l.round_trip, o.far_field_tolerance,
            [&] {
                read_sides();
                return watch(r);
            },
            o);
    } else {
        r.time_steps = step_until_decayed(f, c, meep::vec(0.0, -l.box_y), src.last_time(), o);
    }
    read_sides();
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

// The far-field stop rule's watch for a run holding the wavelengths first … first + count − 1:
// the sums over them of the back-hemisphere width, against itself, and of the scattering and
// absorption widths, against the sum of both (absorption alone may be near zero). Sums, not
// each wavelength: light guided around a barbule's cortex leaks out in bursts (one per round
// trip), which move single wavelengths by per cent long after the band has settled.
FarFieldWatch far_field_watch(const IncidentProfile& incident, std::size_t first, std::size_t count,
                              std::span<const double> freqs, std::span<const double> lambdas_nm,
                              double theta_i_rad, const Layout& l) {
    return [&incident, first, count, freqs, lambdas_nm, theta_i_rad, l](const RunResult& run) {
        double back = 0.0, scattering = 0.0, absorption = 0.0;
        for (std::size_t j = 0; j < count; ++j) {
            const std::size_t k = first + j;
            const FarField2d ff =
                far_field_of_run(run, j, incident, k, freqs[k], lambdas_nm[k], theta_i_rad, {}, l);
            back += ff.back_scattering_width_um;
            scattering += ff.scattering_width_um;
            absorption += ff.absorption_width_um;
        }
        const double both = std::abs(scattering) + std::abs(absorption);
        return std::vector<Watched>{
            {back, std::max(std::abs(back), 1e-6 * both)}, {scattering, both}, {absorption, both}};
    };
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

    Layout l = isolated_layout(section, theta_i_rad, o);
    double eps_max = 1.0;
    for (const BodyMedia& m : materials.exact)
        for (const double e : m.eps) eps_max = std::max(eps_max, e);
    l.round_trip = std::max(3.0 * kWatchInterval,
                            std::sqrt(eps_max) * 4.0 * (l.box_x + l.box_y - 2.0 * o.gap_um));
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
        const std::size_t first = fitted ? 0 : i, count = fitted ? freqs.size() : 1;
        const FarFieldWatch watch =
            o.far_field_tolerance > 0.0
                ? far_field_watch(incident, first, count, freqs, lambdas_nm, theta_i_rad, l)
                : FarFieldWatch{};
        if (fitted) {
            SectionMaterial material(section, theta_i_rad, materials.instantaneous);
            material.interrupt_on(o.stop);
            return run(material, add_poles(material, materials.body_fits, l.h), pol, l, freqs,
                       f_centre, f_width, watch, o);
        }
        SectionMaterial material(section, theta_i_rad, materials.exact[i]);
        material.interrupt_on(o.stop);
        const std::array<double, 1> one{freqs[i]};
        return run(material, conductivities(material, pol, materials.exact[i].absorbing), pol, l,
                   one, f_centre, f_width, watch, o);
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

}  // namespace plumage::sim::fullwave
