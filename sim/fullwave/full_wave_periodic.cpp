#include "sim/fullwave/full_wave_2d.h"

#include <array>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>

#include <fmt/format.h>
#include <meep.hpp>

#include "common/error.h"
#include "common/require.h"
#include "sim/fullwave/meep_solver.h"

namespace plumage::sim::fullwave {

using namespace detail;

namespace {

// u and ∂u/∂y on the midpoint of two grid lines straddling y = at, at every grid column of the
// periodic cell, per frequency.
struct LineField {
    std::vector<double> x;                      // the columns, one period (no column twice)
    std::vector<std::vector<Complex>> u, dudy;  // [frequency][column]
};

LineField read_line(meep::fields& f, meep::dft_fields& dft, const meep::volume& where, double at,
                    meep::component c, std::size_t n_freq, std::size_t columns) {
    std::vector<double> xs, ys;
    grid_ticks(f, where, xs, ys);
    std::size_t below = 0;
    for (std::size_t i = 0; i < ys.size(); ++i)
        if (ys[i] <= at + 1e-9) below = i;
    if (below + 1 >= ys.size())
        throw InvariantError("full wave: a flux strip holds no grid line above its line");
    // the strip spans the whole cell; where Meep returns both ends of the period, the second is
    // the first again
    if (xs.size() < columns)
        throw InvariantError(fmt::format(
            "full wave: a flux strip holds {} columns of a {}-column period", xs.size(), columns));
    const double d = ys[below + 1] - ys[below];
    LineField out;
    out.x.assign(xs.begin(), xs.begin() + static_cast<std::ptrdiff_t>(columns));
    for (std::size_t k = 0; k < n_freq; ++k) {
        int rank = 0;
        std::size_t dims[3] = {1, 1, 1};
        std::unique_ptr<std::complex<meep::realnum>[]> arr(
            f.get_dft_array(dft, c, static_cast<int>(k), &rank, dims));
        std::vector<Complex> u(columns), du(columns);
        for (std::size_t i = 0; i < columns; ++i) {
            const Complex a(arr[i * ys.size() + below]), b(arr[i * ys.size() + below + 1]);
            u[i] = 0.5 * (a + b);
            du[i] = (b - a) / d;
        }
        out.u.push_back(std::move(u));
        out.dudy.push_back(std::move(du));
    }
    return out;
}

// The cell of a periodic run, in Meep's frame (x ours, y = our z − z_centre): from the top,
// PML, gap, source, gap, reflection line, gap, the bodies, gap, transmission line, gap, PML.
struct PeriodicCell {
    std::size_t columns = 0;  // grid columns in one period (even)
    double period_um = 0.0;
    double half_x = 0.0, half_y = 0.0, z_centre = 0.0;
    double y_reflect = 0.0, y_source = 0.0, y_transmit = 0.0;
    int under = -1;  // the body under the bodies (−1: air), where T is measured
};

struct PeriodicRun {
    LineField above, below;
    double time_steps = 0.0;
};

// The Bloch wavenumber of the run on this thread (cycles/µm): the source's phase along x.
// Meep takes the amplitude as a plain function, called during add_volume_source on the caller's
// thread.
thread_local double t_bloch_kx = 0.0;

std::complex<double> bloch_phase(const meep::vec& r) {
    return std::exp(Complex(0.0, 2.0 * kPi * t_bloch_kx * r.x()));
}

// One run on the periodic cell: a line source across it with the Bloch phase e^{2πi k_x x}
// (k_x = 0: real fields), DFT strips on the reflection and transmission lines, time steps until
// the field under the bodies has decayed.
PeriodicRun run_periodic(meep::material_function& material, const Dress& dress, Polarisation2d pol,
                         const PeriodicCell& cell, double k_x, std::span<const double> freqs,
                         double f_centre, double f_width, const FullWave2dOptions& o,
                         bool smoothing) {
    const meep::grid_volume gv = centred_grid(cell.half_x, cell.half_y, o.resolution_px_per_um);
    meep::structure s(gv, material, meep::pml(o.pml_um, meep::Y), meep::identity(), 0, kCourant,
                      smoothing);
    const meep::component c = field_component(pol);
    if (dress) dress(s);
    meep::fields f(&s);
    if (k_x == 0.0) f.use_real_fields();
    f.use_bloch(meep::vec(k_x, 0.0));
    meep::gaussian_src_time src(f_centre, f_width);
    const meep::volume line(meep::vec(-cell.half_x, cell.y_source),
                            meep::vec(cell.half_x, cell.y_source));
    if (k_x == 0.0) {
        f.add_volume_source(c, src, line, 1.0);
    } else {
        t_bloch_kx = k_x;
        f.add_volume_source(c, src, line, bloch_phase, 1.0);
    }
    const double h = 1.0 / o.resolution_px_per_um;
    meep::component comps[1] = {c};
    const meep::volume above(meep::vec(-cell.half_x, cell.y_reflect - 2.0 * h),
                             meep::vec(cell.half_x, cell.y_reflect + 2.0 * h));
    const meep::volume below(meep::vec(-cell.half_x, cell.y_transmit - 2.0 * h),
                             meep::vec(cell.half_x, cell.y_transmit + 2.0 * h));
    meep::dft_fields dft_above = f.add_dft_fields(comps, 1, above, freqs.data(), freqs.size());
    meep::dft_fields dft_below = f.add_dft_fields(comps, 1, below, freqs.data(), freqs.size());
    PeriodicRun r;
    r.time_steps = step_until_decayed(f, c, meep::vec(0.0, cell.y_transmit), src.last_time(), o);
    const std::size_t columns =
        static_cast<std::size_t>(std::llround(2.0 * cell.half_x * o.resolution_px_per_um));
    r.above = read_line(f, dft_above, above, cell.y_reflect, c, freqs.size(), columns);
    r.below = read_line(f, dft_below, below, cell.y_transmit, c, freqs.size(), columns);
    return r;
}

// The field of a line split into the cell's Bloch orders: a_m = (1/N) Σ_j u(x_j) e^{−2πi q_m x_j},
// q_m = k_x + m/Λ, and the same of ∂u/∂y; Im(a_m* ∂a_m) is order m's flux along +y in units
// of 1/(2ω) (orders are orthogonal over the period, so the fluxes add). Only the orders that
// propagate in a medium of index n, |q_m| < n f, are returned.
struct OrderFlux {
    int m = 0;
    double q = 0.0;     // cycles/µm along x
    double flux = 0.0;  // along +y, units of 1/(2ω)
};

std::vector<OrderFlux> propagating_orders(const std::vector<Complex>& u,
                                          const std::vector<Complex>& dudy,
                                          const std::vector<double>& x, double k_x,
                                          double period_um, double n_f) {
    std::vector<OrderFlux> out;
    const int m_lo = static_cast<int>(std::ceil((-n_f - k_x) * period_um));
    const int m_hi = static_cast<int>(std::floor((n_f - k_x) * period_um));
    for (int m = m_lo; m <= m_hi; ++m) {
        const double q = k_x + m / period_um;
        if (!(std::abs(q) < n_f)) continue;
        Complex a = 0.0, da = 0.0;
        for (std::size_t j = 0; j < x.size(); ++j) {
            const Complex phase = std::exp(Complex(0.0, -2.0 * kPi * q * x[j]));
            a += u[j] * phase;
            da += dudy[j] * phase;
        }
        a /= static_cast<double>(x.size());
        da /= static_cast<double>(x.size());
        out.push_back({m, q, std::imag(std::conj(a) * da)});
    }
    return out;
}

// One wavelength's orders, R and T from the incident run (`incident`, its frequency ki: the
// wave alone on a cell a few columns wide, read at its column x_c and carried to every column by
// the Bloch phase) and the bodies' run (`total`, its frequency kt).
RowSpectrum row_spectrum(const PeriodicRun& incident, std::size_t ki, const PeriodicRun& total,
                         std::size_t kt, const PeriodicCell& cell, const BodyMedia& media,
                         Polarisation2d pol, double freq, double k_x, double lambda_nm) {
    const std::size_t c = incident.above.x.size() / 2;
    const double x_c = incident.above.x[c];
    const Complex ui = incident.above.u[ki][c], dui = incident.above.dudy[ki][c];
    const double incident_flux = -std::imag(std::conj(ui) * dui);  // downward
    std::vector<Complex> us = total.above.u[kt], dus = total.above.dudy[kt];
    for (std::size_t j = 0; j < us.size(); ++j) {
        const Complex carry = std::exp(Complex(0.0, 2.0 * kPi * k_x * (total.above.x[j] - x_c)));
        us[j] -= ui * carry;
        dus[j] -= dui * carry;
    }
    RowSpectrum r;
    r.lambda_nm = lambda_nm;
    r.time_steps = total.time_steps;
    for (const OrderFlux& o :
         propagating_orders(us, dus, total.above.x, k_x, cell.period_um, freq)) {
        const double sin_s = o.q / freq;
        r.reflected.push_back(
            {o.m, std::atan2(sin_s, std::sqrt(1.0 - sin_s * sin_s)), o.flux / incident_flux});
        r.reflectance += r.reflected.back().efficiency;
    }
    const bool lossless_under =
        cell.under < 0 || media.sigma_d[static_cast<std::size_t>(cell.under)] == 0.0;
    const double eps_under = cell.under < 0 ? 1.0 : media.eps[static_cast<std::size_t>(cell.under)];
    if (!lossless_under) {
        r.transmittance = std::numeric_limits<double>::quiet_NaN();
        return r;
    }
    const double n_under = std::sqrt(eps_under);
    // for TM (u = H) the flux in a medium of permittivity ε is Im(u* ∂u/∂y)/(2ωε)
    const double per_flux = (pol == Polarisation2d::te ? 1.0 : 1.0 / eps_under) / incident_flux;
    for (const OrderFlux& o :
         propagating_orders(total.below.u[kt], total.below.dudy[kt], total.below.x, k_x,
                            cell.period_um, n_under * freq)) {
        const double sin_s = o.q / (n_under * freq);
        r.transmitted.push_back(
            {o.m, std::atan2(sin_s, -std::sqrt(1.0 - sin_s * sin_s)), -o.flux * per_flux});
        r.transmittance += r.transmitted.back().efficiency;
    }
    return r;
}

// The bodies' extent in z (a substrate layer reaches −∞: its top counts) and the cell around
// them, `columns` grid columns wide.
PeriodicCell periodic_cell(const CrossSection2d& section, std::size_t columns, double period_um,
                           const FullWave2dOptions& o) {
    double z_hi = -std::numeric_limits<double>::infinity(),
           z_lo = std::numeric_limits<double>::infinity();
    for (const Body2d& b : section.bodies) {
        const Box2d box = b.shape->bounds();
        z_hi = std::max(z_hi, box.max.y());
        z_lo = std::min(z_lo, std::isfinite(box.min.y()) ? box.min.y() : box.max.y());
    }
    const double h = 1.0 / o.resolution_px_per_um;
    const double top = z_hi + 3.0 * o.gap_um + o.pml_um, bottom = z_lo - 2.0 * o.gap_um - o.pml_um;
    PeriodicCell cell;
    cell.columns = columns;
    cell.period_um = period_um;
    cell.z_centre = 0.5 * (top + bottom);
    cell.half_y = whole_cells(0.5 * (top - bottom), h);
    cell.half_x = 0.5 * static_cast<double>(columns) * h;
    cell.y_reflect = z_hi + o.gap_um - cell.z_centre;
    cell.y_source = z_hi + 2.0 * o.gap_um - cell.z_centre;
    cell.y_transmit = z_lo - o.gap_um - cell.z_centre;
    cell.under = section.body_at({0.0, z_lo - o.gap_um});
    return cell;
}

// The period in whole grid cells, an even number of them (the cell's centre is a grid point):
// the grid is refined, never coarsened, to fit.
double period_columns(double period_um, double resolution_px_per_um) {
    return 2.0 * std::ceil(0.5 * period_um * resolution_px_per_um - 1e-9);
}

// The farthest any body reaches from x = 0 (layers: 0, they are the same in every period).
double reach_along_x(const CrossSection2d& section) {
    double reach = 0.0;
    for (const Body2d& b : section.bodies) {
        if (b.shape->is_layer()) continue;
        const Box2d box = b.shape->bounds();
        reach = std::max({reach, std::abs(box.min.x()), std::abs(box.max.x())});
    }
    return reach;
}

// Every run of a periodic section and the spectra they give: the incident wave on a cell four
// columns wide (once for all wavelengths at normal incidence; per wavelength otherwise, since
// k_x = f sin θ_i differs), then the bodies (one run per wavelength, or one for all, fitted).
FullWaveRowResult periodic_spectra(const CrossSection2d& section, const PeriodicCell& cell,
                                   Polarisation2d pol, double theta_i_rad,
                                   std::span<const double> lambdas_nm, const FullWave2dOptions& o) {
    const RunMaterials materials = run_materials(section, lambdas_nm, o);
    require_grid_memory(
        static_cast<double>(cell.columns) * 2.0 * cell.half_y * o.resolution_px_per_um,
        materials.poles(),
        fmt::format("full wave: a {:.3g} × {:.3g} µm periodic cell at resolution_px_per_um = {}",
                    2.0 * cell.half_x, 2.0 * cell.half_y, o.resolution_px_per_um));
    const auto started = std::chrono::steady_clock::now();
    const Quiet quiet;
    const double h = 1.0 / o.resolution_px_per_um;
    std::vector<double> freqs, k_xs;
    for (const double lam : lambdas_nm) {
        freqs.push_back(1.0 / to_um(lam));
        // light from ω_i = (sin θ_i, cos θ_i) travels along −ω_i: phase e^{−ik sin θ_i x}
        k_xs.push_back(-freqs.back() * std::sin(theta_i_rad));
    }
    const bool normal = theta_i_rad == 0.0, fitted = o.dispersion == Dispersion::fitted;
    // Plain names, not a structured binding: clang 14 (the instrumented build) cannot capture
    // structured bindings in a lambda.
    const std::pair<double, double> band = pulse(freqs);
    // At oblique incidence each run is one wavelength's, with a pulse narrow enough that the
    // frequencies at which order 0 turns grazing, f |sin θ_i|, are 4 widths away: they would
    // ring along the row for ever.
    const auto pulse_of = [&](std::size_t k) {
        if (normal) return band;
        return std::pair<double, double>(
            freqs[k],
            std::min(0.5 * freqs[k], 0.25 * freqs[k] * (1.0 - std::abs(std::sin(theta_i_rad)))));
    };
    const std::size_t n = freqs.size();
    const std::size_t incident_runs = normal ? 1 : n, body_runs = fitted ? 1 : n;
    PeriodicCell narrow = cell;
    narrow.columns = 4;
    narrow.half_x = 2.0 * h;
    const std::vector<PeriodicRun> runs = run_all(incident_runs + body_runs, o, [&](std::size_t i) {
        if (i < incident_runs) {
            AirMaterial air;
            const std::pair<double, double> p = pulse_of(i);
            if (normal)
                return run_periodic(air, {}, pol, narrow, 0.0, freqs, p.first, p.second, o, false);
            const std::array<double, 1> one{freqs[i]};
            return run_periodic(air, {}, pol, narrow, k_xs[i], one, p.first, p.second, o, false);
        }
        const std::size_t k = i - incident_runs;
        if (fitted) {
            SectionMaterial material(section, 0.0, materials.instantaneous, cell.z_centre);
            material.repeat_along_x(cell.period_um, reach_along_x(section));
            material.interrupt_on(o.stop);
            return run_periodic(material, add_poles(material, materials.body_fits, h), pol, cell,
                                0.0, freqs, band.first, band.second, o, o.subpixel_smoothing);
        }
        const BodyMedia& media = materials.exact[k];
        SectionMaterial material(section, 0.0, media, cell.z_centre);
        material.repeat_along_x(cell.period_um, reach_along_x(section));
        material.interrupt_on(o.stop);
        const std::array<double, 1> one{freqs[k]};
        const std::pair<double, double> p = pulse_of(k);
        return run_periodic(material, conductivities(material, pol, media.absorbing), pol, cell,
                            k_xs[k], one, p.first, p.second, o, o.subpixel_smoothing);
    });
    FullWaveRowResult result;
    result.polarisation = pol;
    result.theta_i_rad = theta_i_rad;
    result.period_um = cell.period_um;
    result.resolution_px_per_um = o.resolution_px_per_um;
    result.grid_cells =
        cell.columns *
        static_cast<std::size_t>(std::llround(2.0 * cell.half_y * o.resolution_px_per_um));
    for (std::size_t k = 0; k < n; ++k)
        result.wavelengths.push_back(row_spectrum(
            runs[normal ? 0 : k], normal ? k : 0, runs[incident_runs + (fitted ? 0 : k)],
            fitted ? k : 0, cell, materials.exact[k], pol, freqs[k], k_xs[k], lambdas_nm[k]));
    result.dispersion_fits = materials.fits;
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return result;
}

}  // namespace

FullWaveRowResult full_wave_row(const CrossSection2d& period, double period_um, Polarisation2d pol,
                                double theta_i_rad, std::span<const double> lambdas_nm,
                                const FullWave2dOptions& o) {
    require(!period.bodies.empty(), "full wave row", "the period holds no bodies");
    require(std::isfinite(theta_i_rad) && std::abs(theta_i_rad) <= 80.0 * kPi / 180.0,
            "full wave row", "theta_i", theta_i_rad,
            "an angle of incidence within ±80° (1.396 rad): nearer grazing the wave barely "
            "leaves the row");
    require(std::isfinite(o.resolution_px_per_um) && o.resolution_px_per_um > 0.0, "full wave row",
            "resolution_px_per_um", o.resolution_px_per_um, "a finite resolution > 0 px/µm");
    require(std::isfinite(period_um) && period_um >= 4.0 / o.resolution_px_per_um &&
                period_um <= 1000.0,
            "full wave row", "period_um", period_um,
            fmt::format("a period of at least four grid cells ({:.4g} µm) and at most 1000 µm",
                        4.0 / o.resolution_px_per_um));
    require(o.dispersion == Dispersion::per_wavelength || theta_i_rad == 0.0, "full wave row",
            "Dispersion::fitted needs normal incidence: at θ_i ≠ 0 the Bloch wavenumber "
            "f sin θ_i differs per wavelength, so each wavelength is its own run");
    const double cells = period_columns(period_um, o.resolution_px_per_um);
    FullWave2dOptions fitted_grid = o;
    fitted_grid.resolution_px_per_um = cells / period_um;
    check_options(period, lambdas_nm, fitted_grid);
    return periodic_spectra(
        period, periodic_cell(period, static_cast<std::size_t>(cells), period_um, fitted_grid), pol,
        theta_i_rad, lambdas_nm, fitted_grid);
}

std::size_t full_wave_row_cells(const CrossSection2d& period, double period_um,
                                const FullWave2dOptions& o) {
    const double columns = period_columns(period_um, o.resolution_px_per_um);
    FullWave2dOptions fitted_grid = o;
    fitted_grid.resolution_px_per_um = columns / period_um;
    const PeriodicCell cell =
        periodic_cell(period, static_cast<std::size_t>(columns), period_um, fitted_grid);
    return cell.columns * static_cast<std::size_t>(
                              std::llround(2.0 * cell.half_y * fitted_grid.resolution_px_per_um));
}

std::vector<StackReflectance> full_wave_stack(const CrossSection2d& layers, Polarisation2d pol,
                                              std::span<const double> lambdas_nm,
                                              const FullWave2dOptions& o) {
    require(!layers.bodies.empty(), "full wave stack", "the stack has no layers");
    for (const Body2d& b : layers.bodies)
        require(b.shape->is_layer(), "full wave stack",
                fmt::format("{} is not a layer: a planar stack takes layers only",
                            b.shape->describe()));
    check_options(layers, lambdas_nm, o);
    // a planar stack is a periodic row of any period: four columns, normal incidence, where
    // only order 0 propagates
    const double h = 1.0 / o.resolution_px_per_um;
    const FullWaveRowResult row =
        periodic_spectra(layers, periodic_cell(layers, 4, 4.0 * h, o), pol, 0.0, lambdas_nm, o);
    std::vector<StackReflectance> out;
    for (const RowSpectrum& w : row.wavelengths)
        out.push_back({w.lambda_nm, w.reflectance, w.transmittance});
    return out;
}

}  // namespace plumage::sim::fullwave
