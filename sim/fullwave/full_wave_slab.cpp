#include "sim/fullwave/full_wave_slab.h"

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

// Samples per axis of a cut pixel (Kottke's average, and the pole strengths' fraction).
constexpr int kSamplesPerAxis = 5;

// The slab in Meep's frame: x, y lateral (Meep's −period/2 … period/2, ours 0 … period), our
// z = Meep's z + z_offset. Body 0 is the slab's material, body 1 the substrate (if any).
class SlabMaterial final : public BodiesMaterial {
public:
    SlabMaterial(const Slab3d& slab, BodyMedia media, double z_offset)
        : BodiesMaterial(std::move(media)), slab_(slab), z_offset_(z_offset) {}

    // Kottke's average over the pixel v (full_wave_2d.h's rule in 3D): a 3 × 3 × 3 test, then,
    // when the pixel is cut, ⟨ε⟩, ⟨1/ε⟩ and ε's first moment (the boundary's normal) over a
    // 5 × 5 × 5 lattice.
    void eff_chi1inv_row(meep::component c, double row[3], const meep::volume& v, double,
                         int) override {
        const meep::field_type ft = meep::type(c);
        const int along = meep::component_direction(c) % 3;
        row[0] = row[1] = row[2] = 0.0;
        const meep::vec lo = v.get_min_corner(), hi = v.get_max_corner();
        const std::array<double, 3> o{lo.x(), lo.y(), lo.z()},
            d{hi.x() - lo.x(), hi.y() - lo.y(), hi.z() - lo.z()};
        const auto at = [&](double u, double w, double t) {
            return chi1p1(ft, meep::vec(o[0] + u * d[0], o[1] + w * d[1], o[2] + t * d[2]));
        };
        const double first = at(0.0, 0.0, 0.0);
        bool uniform = true;
        for (int k = 0; k < 3 && uniform; ++k)
            for (int j = 0; j < 3 && uniform; ++j)
                for (int i = 0; i < 3 && uniform; ++i)
                    uniform = at(0.5 * i, 0.5 * j, 0.5 * k) == first;
        if (uniform) {
            row[along] = 1.0 / first;
            return;
        }
        double mean = 0.0, mean_inverse = 0.0;
        std::array<double, 3> g{0.0, 0.0, 0.0};
        for (int k = 0; k < kSamplesPerAxis; ++k)
            for (int j = 0; j < kSamplesPerAxis; ++j)
                for (int i = 0; i < kSamplesPerAxis; ++i) {
                    const std::array<double, 3> u{(i + 0.5) / kSamplesPerAxis,
                                                  (j + 0.5) / kSamplesPerAxis,
                                                  (k + 0.5) / kSamplesPerAxis};
                    const double e = at(u[0], u[1], u[2]);
                    mean += e;
                    mean_inverse += 1.0 / e;
                    for (int a = 0; a < 3; ++a) g[a] += e * (u[a] - 0.5) * d[a];
                }
        const double n_samples = kSamplesPerAxis * kSamplesPerAxis * kSamplesPerAxis;
        mean /= n_samples;
        mean_inverse /= n_samples;
        const double norm = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        std::array<double, 3> n{0.0, 0.0, 0.0};
        if (norm > 0.0)
            for (int a = 0; a < 3; ++a) n[a] = g[a] / norm;
        for (int a = 0; a < 3; ++a) row[a] = n[along] * n[a] * (mean_inverse - 1.0 / mean);
        row[along] += 1.0 / mean;
    }
    // The fraction of the h³ pixel centred on r that body b fills (Dispersion::fitted).
    double fraction_of_body(int b, const meep::vec& r, double h) const {
        const meep::vec lo(r.x() - 0.5 * h, r.y() - 0.5 * h, r.z() - 0.5 * h);
        const auto is_b = [&](double u, double w, double t) {
            return owner(meep::vec(lo.x() + u * h, lo.y() + w * h, lo.z() + t * h)) == b;
        };
        const bool first = is_b(0.0, 0.0, 0.0);
        bool uniform = true;
        for (int k = 0; k < 3 && uniform; ++k)
            for (int j = 0; j < 3 && uniform; ++j)
                for (int i = 0; i < 3 && uniform; ++i)
                    uniform = is_b(0.5 * i, 0.5 * j, 0.5 * k) == first;
        if (uniform) return first ? 1.0 : 0.0;
        int inside = 0;
        for (int k = 0; k < kSamplesPerAxis; ++k)
            for (int j = 0; j < kSamplesPerAxis; ++j)
                for (int i = 0; i < kSamplesPerAxis; ++i)
                    inside += is_b((i + 0.5) / kSamplesPerAxis, (j + 0.5) / kSamplesPerAxis,
                                   (k + 0.5) / kSamplesPerAxis)
                                  ? 1
                                  : 0;
        return inside / static_cast<double>(kSamplesPerAxis * kSamplesPerAxis * kSamplesPerAxis);
    }

private:
    int owner(const meep::vec& r) const override {
        throw_if_stopped();
        const double z = r.z() + z_offset_;
        if (z < 0.0) return slab_.substrate ? 1 : -1;
        if (z > slab_.thickness_um) return -1;
        const double p = slab_.period_um;
        const double x = r.x() + 0.5 * p - p * std::floor((r.x() + 0.5 * p) / p);
        const double y = r.y() + 0.5 * p - p * std::floor((r.y() + 0.5 * p) / p);
        return slab_.inside({x, y, z}) ? 0 : -1;
    }
    const Slab3d& slab_;
    double z_offset_;
};

// The cell in Meep's frame: `columns` grid cells each way laterally; from the top, PML, gap,
// source, gap, reflection plane, gap, the slab, gap, transmission plane, gap, PML.
struct SlabCell {
    std::size_t columns = 0;
    double half_xy = 0.0, half_z = 0.0, z_offset = 0.0;
    double z_reflect = 0.0, z_source = 0.0, z_transmit = 0.0;
};

// E_x, E_y, H_x, H_y on a plane, per frequency, on the period's grid points.
struct PlaneFields {
    std::array<std::vector<std::vector<Complex>>, 4> c;  // [component][frequency][point]
};

constexpr std::array<meep::component, 4> kPlaneComponents{meep::Ex, meep::Ey, meep::Hx, meep::Hy};

PlaneFields read_plane(meep::fields& f, meep::dft_flux& flux, std::size_t n_freq,
                       std::size_t columns) {
    PlaneFields out;
    for (std::size_t i = 0; i < 4; ++i) {
        for (std::size_t k = 0; k < n_freq; ++k) {
            int rank = 0;
            std::size_t dims[3] = {1, 1, 1};
            std::unique_ptr<std::complex<meep::realnum>[]> arr(
                f.get_dft_array(flux, kPlaneComponents[i], static_cast<int>(k), &rank, dims));
            if (rank != 2 || dims[0] < columns || dims[1] < columns)
                throw InvariantError(
                    fmt::format("full wave slab: a DFT plane of rank {} ({} × {}) for {} columns",
                                rank, dims[0], dims[1], columns));
            // where Meep returns both ends of the period, the second is the first again
            std::vector<Complex> v;
            v.reserve(columns * columns);
            for (std::size_t a = 0; a < columns; ++a)
                for (std::size_t b = 0; b < columns; ++b) v.emplace_back(arr[a * dims[1] + b]);
            out.c[i].push_back(std::move(v));
        }
    }
    return out;
}

// Re(E* × H)·ẑ of one field sample.
double poynting_z(Complex ex, Complex ey, Complex hx, Complex hy) {
    return std::real(std::conj(ex) * hy - std::conj(ey) * hx);
}

struct SlabRun {
    PlaneFields above, below;
    double time_steps = 0.0;
};

SlabRun run_slab(meep::material_function& material,
                 const std::function<void(meep::structure&)>& dress, meep::component source,
                 const SlabCell& cell, std::span<const double> freqs, double f_centre,
                 double f_width, const FullWave2dOptions& o, bool smoothing) {
    const double half = cell.half_xy;
    const meep::grid_volume gv = centred_grid_3d(half, half, cell.half_z, o.resolution_px_per_um);
    meep::structure s(gv, material, meep::pml(o.pml_um, meep::Z), meep::identity(), 0, kCourant,
                      smoothing);
    if (dress) dress(s);
    meep::fields f(&s);
    f.use_real_fields();
    f.use_bloch(meep::vec(0.0, 0.0, 0.0));
    meep::gaussian_src_time src(f_centre, f_width);
    f.add_volume_source(
        source, src,
        meep::volume(meep::vec(-half, -half, cell.z_source), meep::vec(half, half, cell.z_source)),
        1.0);
    const std::vector<double> freq(freqs.begin(), freqs.end());
    meep::dft_flux above =
        f.add_dft_flux_plane(meep::volume(meep::vec(-half, -half, cell.z_reflect),
                                          meep::vec(half, half, cell.z_reflect)),
                             freq);
    meep::dft_flux below =
        f.add_dft_flux_plane(meep::volume(meep::vec(-half, -half, cell.z_transmit),
                                          meep::vec(half, half, cell.z_transmit)),
                             freq);
    const double steps =
        step_until_decayed(f, source, meep::vec(0.0, 0.0, cell.z_transmit), src.last_time(), o);
    return {read_plane(f, above, freq.size(), cell.columns),
            read_plane(f, below, freq.size(), cell.columns), steps};
}

Complex mean_of(const std::vector<Complex>& v) {
    Complex sum = 0.0;
    for (const Complex& x : v) sum += x;
    return sum / static_cast<double>(v.size());
}

// Power through a plane over the period (mean of the Poynting flux) and that of order (0, 0)
// (the plane-averaged fields), of the fields minus a uniform `minus` (the incident wave).
struct PlanePower {
    double total = 0.0, specular = 0.0;
};

PlanePower plane_power(const PlaneFields& p, std::size_t k, const std::array<Complex, 4>& minus) {
    const std::size_t n = p.c[0][k].size();
    PlanePower out;
    std::array<Complex, 4> mean{};
    for (std::size_t j = 0; j < n; ++j) {
        std::array<Complex, 4> v;
        for (std::size_t i = 0; i < 4; ++i) {
            v[i] = p.c[i][k][j] - minus[i];
            mean[i] += v[i];
        }
        out.total += poynting_z(v[0], v[1], v[2], v[3]);
    }
    out.total /= static_cast<double>(n);
    for (Complex& m : mean) m /= static_cast<double>(n);
    out.specular = poynting_z(mean[0], mean[1], mean[2], mean[3]);
    return out;
}

// The slab's checks, and the grid: the period in whole, even cells (the resolution is refined,
// never coarsened, to fit).
FullWave2dOptions slab_grid(const Slab3d& slab, const FullWave2dOptions& o) {
    require(static_cast<bool>(slab.inside) && slab.material != nullptr, "full wave slab",
            "the slab needs an inside test and a material");
    require(std::isfinite(slab.period_um) && slab.period_um > 0.0 && slab.period_um <= 100.0,
            "full wave slab", "period_um", slab.period_um, "a lateral period in (0, 100] µm");
    require(
        std::isfinite(slab.thickness_um) && slab.thickness_um > 0.0 && slab.thickness_um <= 100.0,
        "full wave slab", "thickness_um", slab.thickness_um, "a thickness in (0, 100] µm");
    require(std::isfinite(slab.thinnest_um) && slab.thinnest_um > 0.0, "full wave slab",
            "thinnest_um", slab.thinnest_um, "the body's smallest feature, > 0 µm");
    require(std::isfinite(o.resolution_px_per_um) && o.resolution_px_per_um > 0.0, "full wave slab",
            "resolution_px_per_um", o.resolution_px_per_um, "a finite resolution > 0 px/µm");
    require(slab.period_um >= 4.0 / o.resolution_px_per_um, "full wave slab", "period_um",
            slab.period_um,
            fmt::format("a period of at least four grid cells ({:.4g} µm)",
                        4.0 / o.resolution_px_per_um));
    FullWave2dOptions grid = o;
    grid.resolution_px_per_um =
        2.0 * std::ceil(0.5 * slab.period_um * o.resolution_px_per_um - 1e-9) / slab.period_um;
    return grid;
}

// The materials as bodies of a section, for the checks and the runs' media: the body (its
// smallest feature as its thickness) and the substrate.
CrossSection2d slab_bodies(const Slab3d& slab) {
    CrossSection2d bodies;
    bodies.bodies.push_back({layer(0.0, slab.thinnest_um), slab.material});
    if (slab.substrate)
        bodies.bodies.push_back(
            {layer(-std::numeric_limits<double>::infinity(), 0.0), slab.substrate});
    return bodies;
}

SlabCell slab_cell(const Slab3d& slab, const FullWave2dOptions& grid) {
    const double h = 1.0 / grid.resolution_px_per_um;
    const double top = slab.thickness_um + 3.0 * grid.gap_um + grid.pml_um,
                 bottom = -2.0 * grid.gap_um - grid.pml_um;
    SlabCell cell;
    cell.columns = static_cast<std::size_t>(std::llround(slab.period_um / h));
    cell.half_xy = 0.5 * static_cast<double>(cell.columns) * h;
    cell.z_offset = 0.5 * (top + bottom);
    cell.half_z = whole_cells(0.5 * (top - bottom), h);
    // The monitor planes on grid rows: between rows Meep's DFT arrays interpolate E and H,
    // which scales a plane's power by where it falls (0.13 % between two planes of one air
    // run at 135 px/µm); on rows the planes agree to 2e-5 and Meep's own flux() to 1e-5.
    const auto on_grid = [h](double z) { return std::round(z / h) * h; };
    cell.z_reflect = on_grid(slab.thickness_um + grid.gap_um - cell.z_offset);
    cell.z_source = slab.thickness_um + 2.0 * grid.gap_um - cell.z_offset;
    cell.z_transmit = on_grid(-grid.gap_um - cell.z_offset);
    return cell;
}

// One wavelength's spectrum, unpolarised, from the runs (per polarisation: the incident run at
// runs[pol · per_pol], then the bodies' runs).
SlabSpectrum slab_spectrum(const std::vector<SlabRun>& runs, std::size_t k, std::size_t per_pol,
                           bool fitted, bool lossless_under, double lambda_nm) {
    SlabSpectrum w;
    w.lambda_nm = lambda_nm;
    const std::size_t pols = runs.size() / per_pol;
    const double share = 1.0 / static_cast<double>(pols);
    for (std::size_t pol = 0; pol < pols; ++pol) {
        const SlabRun& incident = runs[pol * per_pol];
        const SlabRun& total = runs[pol * per_pol + 1 + (fitted ? 0 : k)];
        const std::size_t kt = fitted ? k : 0;
        std::array<Complex, 4> wave{};
        for (std::size_t c = 0; c < 4; ++c) wave[c] = mean_of(incident.above.c[c][k]);
        const double incident_power = -poynting_z(wave[0], wave[1], wave[2], wave[3]);
        const PlanePower reflected = plane_power(total.above, kt, wave);
        const PlanePower transmitted = plane_power(total.below, kt, {});
        w.specular_reflectance += share * reflected.specular / incident_power;
        w.diffuse_reflectance += share * (reflected.total - reflected.specular) / incident_power;
        w.specular_transmittance += -share * transmitted.specular / incident_power;
        w.diffuse_transmittance +=
            -share * (transmitted.total - transmitted.specular) / incident_power;
    }
    if (!lossless_under)
        w.specular_transmittance = w.diffuse_transmittance =
            std::numeric_limits<double>::quiet_NaN();
    return w;
}

}  // namespace

FullWaveSlabResult full_wave_slab(const Slab3d& slab, std::span<const double> lambdas_nm,
                                  const FullWave2dOptions& o) {
    const FullWave2dOptions grid = slab_grid(slab, o);
    const CrossSection2d bodies = slab_bodies(slab);
    check_options(bodies, lambdas_nm, grid);
    const RunMaterials materials = run_materials(bodies, lambdas_nm, grid);
    const SlabCell cell = slab_cell(slab, grid);
    const double h = 1.0 / grid.resolution_px_per_um;
    const double grid_cells = static_cast<double>(cell.columns * cell.columns) * 2.0 * cell.half_z *
                              grid.resolution_px_per_um;
    require_grid_memory(
        1.5 * grid_cells, materials.poles(),  // 3D: six components where 2D has three
        fmt::format("full wave slab: a {:.3g} × {:.3g} × {:.3g} µm cell at resolution_px_per_um "
                    "= {:.4g}",
                    slab.period_um, slab.period_um, 2.0 * cell.half_z, grid.resolution_px_per_um));

    const auto started = std::chrono::steady_clock::now();
    const Quiet quiet;
    std::vector<double> freqs;
    for (const double lam : lambdas_nm) freqs.push_back(1.0 / to_um(lam));
    const std::pair<double, double> band = pulse(freqs);
    const bool fitted = grid.dispersion == Dispersion::fitted;
    const std::size_t n = freqs.size(), body_runs = fitted ? 1 : n;
    SlabCell narrow = cell;
    narrow.columns = 4;
    narrow.half_xy = 2.0 * h;
    // per polarisation (E_x, E_y): the incident run, then the bodies' runs
    const std::size_t per_pol = 1 + body_runs, pols = slab.e_x_only ? 1 : 2;
    const std::vector<SlabRun> runs = run_all(pols * per_pol, grid, [&](std::size_t i) {
        const meep::component source = i < per_pol ? meep::Ex : meep::Ey;
        const std::size_t r = i % per_pol;
        if (r == 0) {
            AirMaterial air;
            return run_slab(air, {}, source, narrow, freqs, band.first, band.second, grid, false);
        }
        if (fitted) {
            SlabMaterial material(slab, materials.instantaneous, cell.z_offset);
            material.interrupt_on(o.stop);
            const auto poles = [&](meep::structure& s) {
                for (std::size_t b = 0; b < materials.body_fits.size(); ++b)
                    for (const LorentzPole& p : materials.body_fits[b]->model.poles) {
                        PoleStrength<SlabMaterial> strength(material, static_cast<int>(b),
                                                            p.strength, h);
                        s.add_susceptibility(
                            strength, meep::E_stuff,
                            meep::lorentzian_susceptibility(p.frequency_per_um, p.damping_per_um));
                    }
            };
            return run_slab(material, poles, source, cell, freqs, band.first, band.second, grid,
                            o.subpixel_smoothing);
        }
        const BodyMedia& media = materials.exact[r - 1];
        SlabMaterial material(slab, media, cell.z_offset);
        material.interrupt_on(o.stop);
        const auto conductivity = [&](meep::structure& s) {
            if (!media.absorbing) return;
            for (const meep::component d : {meep::Dx, meep::Dy, meep::Dz})
                s.set_conductivity(d, material);
        };
        const std::array<double, 1> one{freqs[r - 1]};
        return run_slab(material, conductivity, source, cell, one, band.first, band.second, grid,
                        o.subpixel_smoothing);
    });

    FullWaveSlabResult result;
    result.resolution_px_per_um = grid.resolution_px_per_um;
    result.grid_cells = static_cast<std::size_t>(grid_cells);
    const bool lossless_under = !slab.substrate || materials.exact.front().sigma_d.size() < 2 ||
                                std::all_of(materials.exact.begin(), materials.exact.end(),
                                            [](const BodyMedia& m) { return m.sigma_d[1] == 0.0; });
    for (std::size_t k = 0; k < n; ++k)
        result.wavelengths.push_back(
            slab_spectrum(runs, k, per_pol, fitted, lossless_under, lambdas_nm[k]));
    for (const SlabRun& r : runs) result.time_steps = std::max(result.time_steps, r.time_steps);
    result.dispersion_fits = materials.fits;
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return result;
}

}  // namespace plumage::sim::fullwave
