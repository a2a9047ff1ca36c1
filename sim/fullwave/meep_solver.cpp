#include "sim/fullwave/meep_solver.h"

#include <deque>
#include <limits>
#include <memory>

#include <fmt/format.h>

#include "common/interrupt.h"
#include "common/memory_limit.h"
#include "common/require.h"

namespace plumage::sim::fullwave::detail {

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

Dress add_poles(const SectionMaterial& material, const std::vector<const LorentzFit*>& body_fits,
                double h) {
    return [&material, &body_fits, h](meep::structure& s) {
        for (std::size_t b = 0; b < body_fits.size(); ++b)
            for (const LorentzPole& p : body_fits[b]->model.poles) {
                PoleStrength<SectionMaterial> strength(material, static_cast<int>(b), p.strength,
                                                       h);
                s.add_susceptibility(
                    strength, meep::E_stuff,
                    meep::lorentzian_susceptibility(p.frequency_per_um, p.damping_per_um));
            }
    };
}

meep::component field_component(Polarisation2d pol) {
    return pol == Polarisation2d::te ? meep::Ez : meep::Hz;
}

double exact_extent(double half, double res) {
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
}

meep::grid_volume centred_grid(double half_x, double half_y, double res) {
    meep::grid_volume gv = meep::vol2d(exact_extent(half_x, res), exact_extent(half_y, res), res);
    gv.center_origin();
    return gv;
}

meep::grid_volume centred_grid_3d(double half_x, double half_y, double half_z, double res) {
    meep::grid_volume gv = meep::vol3d(exact_extent(half_x, res), exact_extent(half_y, res),
                                       exact_extent(half_z, res), res);
    gv.center_origin();
    return gv;
}

void grid_ticks(meep::fields& f, const meep::volume& where, std::vector<double>& xs,
                std::vector<double>& ys) {
    const std::vector<double> meta = f.get_array_metadata(where);
    const auto nx = static_cast<std::size_t>(meta[0]);
    xs.assign(meta.begin() + 1, meta.begin() + 1 + static_cast<std::ptrdiff_t>(nx));
    const auto ny = static_cast<std::size_t>(meta[1 + nx]);
    ys.assign(meta.begin() + 2 + static_cast<std::ptrdiff_t>(nx),
              meta.begin() + 2 + static_cast<std::ptrdiff_t>(nx + ny));
}

namespace {

// Whether to stop before the next step. Serial: the flag, at every step. MPI: the ranks' flags
// or-ed every kStopAgreementSteps steps (a collective call at the same steps on every rank), so
// no rank stops while another steps on.
bool stop_before_step(const FullWave2dOptions& o, double steps) {
    const bool flag = o.stop && o.stop->load(std::memory_order_relaxed);
    if constexpr (kMeepMpi) {
        if (std::fmod(steps, kStopAgreementSteps) != 0.0) return false;
        return meep::or_to_all(flag);
    }
    return flag;
}

}  // namespace

double step_until_decayed(meep::fields& f, meep::component c, const meep::vec& probe,
                          double source_end, const FullWave2dOptions& o) {
    const double interval = 20.0;
    double peak = 0.0, window = 0.0, next_check = source_end + interval, steps = 0.0;
    while (true) {
        if (stop_before_step(o, steps))
            throw Interrupted("full wave: interrupted during a time-stepping run");
        f.step();
        steps += 1.0;
        const double u2 = std::norm(f.get_field(c, probe));
        peak = std::max(peak, u2);
        window = std::max(window, u2);
        if (o.max_time > 0.0 && f.time() >= source_end + o.max_time) return steps;
        if (f.time() >= next_check) {
            if (window <= o.decay * peak) return steps;
            window = 0.0;
            next_check += interval;
        }
    }
}

double step_until_converged(meep::fields& f, double start, double interval, double window,
                            double tolerance, const Watch& watch, const FullWave2dOptions& o) {
    const auto checks = static_cast<std::size_t>(std::ceil(window / interval - 1e-9)) + 1;
    double steps = 0.0, next_check = start;
    std::deque<std::vector<Watched>> recent;
    while (true) {
        if (stop_before_step(o, steps))
            throw Interrupted("full wave: interrupted during a time-stepping run");
        f.step();
        steps += 1.0;
        if (f.time() < next_check) continue;
        next_check += interval;
        recent.push_back(watch());
        if (recent.size() > checks) recent.pop_front();
        if (recent.size() < checks) continue;
        double spread = 0.0;  // the largest (max − min) / scale over the window
        for (std::size_t i = 0; i < recent.back().size(); ++i) {
            double lo = recent.back()[i].value, hi = lo;
            for (const std::vector<Watched>& w : recent) {
                lo = std::min(lo, w[i].value);
                hi = std::max(hi, w[i].value);
            }
            const double scale = recent.back()[i].scale;
            if (hi > lo)  // a value that has not moved is settled even at scale 0
                spread = std::max(spread, scale > 0.0 ? (hi - lo) / scale
                                                      : std::numeric_limits<double>::infinity());
        }
        if (spread <= tolerance) return steps;
    }
}

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
    require(std::isfinite(o.max_time) && o.max_time >= 0.0, "full wave", "max_time", o.max_time,
            "0 (no cap) or a time > 0 µm/c");
    require(o.far_field_tolerance == 0.0 ||
                (o.far_field_tolerance >= 1e-6 && o.far_field_tolerance <= 1e-2),
            "full wave", "far_field_tolerance", o.far_field_tolerance,
            "0 (the probe's decay) or a tolerance in [1e-6, 1e-2]");
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

void require_grid_memory(double cells, std::size_t poles, const std::string& what) {
    require_memory(cells * (kBytesPerCell + static_cast<double>(poles) * kBytesPerPoleCell), what);
}

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

std::pair<double, double> pulse(std::span<const double> freqs) {
    const auto [lo, hi] = std::minmax_element(freqs.begin(), freqs.end());
    const double centre = 0.5 * (*lo + *hi);
    return {centre, std::max(1.5 * (*hi - *lo), 0.5 * centre)};
}

}  // namespace plumage::sim::fullwave::detail
