// The 3D spongy slabs of tests/reference/spongy_3d (the suite's full-wave level, Meep's C++
// library) through the media routes the studies offer: each structure's keratin indicator
// (structures.h, regenerated from its seed) → its power spectrum → first Born (born_medium.h),
// and for sphere packings the centres' S(q) → Mie × S(q) in the Bruggeman medium
// (sphere_medium) → a 2 µm slab of that medium with Fresnel faces at n_eff, traced by the
// tracer (sim/scattering_slab.h), in air, at normal incidence. Compared per (structure, keratin
// index) on the seed means: the peak of the total reflectance and its 50-nm band means, and the
// diffuse (non-specular) part alone. What is asserted, and why: README.md there, "Against the
// routes". Every (structure, index, seed) in reflectance.csv is read, so runs added later are
// picked up.
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/seed.h"
#include "sim/optics/material.h"
#include "sim/scattering_medium.h"
#include "sim/scattering_slab.h"
#include "sim/tracer.h"
#include "sim/wave/volume/born_medium.h"
#include "sim/wave/volume/effective_index.h"
#include "sim/wave/volume/power_spectrum.h"
#include "sim/wave/volume/strong_contrast.h"
#include "sim/wave/volume/structure_factor.h"
#include "studies/spongy_medium.h"
#include "tests/reference/spongy_3d/structures.h"

namespace plumage::reference::spongy3d {
namespace {

namespace fs = std::filesystem;
using sim::Vec3d;

// Paths per wavelength, structure and route. At keratin's contrast the slab scatters tens of per
// cent of the light; at low contrast (n < 1.5) μ_s falls with |Δε|² (45 times at n = 1.10) and
// the slab scatters 1–2 % in the blue, 0.01 % in the red, so it takes more paths for the
// route's Monte Carlo to stay under full wave's realisation noise where there is signal.
std::size_t paths_for(double n_keratin) { return n_keratin >= 1.5 ? 4000 : 40000; }
constexpr double kBandNm = 50.0;
constexpr int kBands = 6;  // 400–450 … 650–700 (700 nm in the last)

fs::path reference_csv() {
    return fs::path(PLUMAGE_SOURCE_DIR) / "tests/reference/spongy_3d/reflectance.csv";
}

// One spectrum: per wavelength the total and diffuse reflectance and the total transmittance,
// with the Monte Carlo variance of the total and diffuse R (zero for full wave).
struct Spectrum {
    std::vector<double> lambda_nm, r, r_diffuse, t, r_var, r_diffuse_var;
    // A route's slab: its thickness in the medium's transport lengths, L μ_s (1 − g); empty for
    // full wave.
    std::vector<double> transport_thickness;
    double run_wall_s = 0.0;  // full wave: the run's wall time (reflectance.csv); else 0
    bool capped = false;      // full wave: stopped at max_time, not by the probe's decay
};

struct Key {
    std::string kind;
    double n = 0.0;
    bool operator<(const Key& o) const { return std::tie(kind, n) < std::tie(o.kind, o.n); }
};

struct FullWaveRuns {
    // per seed: the coarse and the fine grid's spectra
    std::map<std::uint64_t, std::map<double, Spectrum>> seeds;
};

std::map<Key, FullWaveRuns> read_reference(const fs::path& path) {
    std::ifstream in(path);
    EXPECT_TRUE(in.good()) << path;
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line,
              "structure,n_keratin,seed,resolution_px_per_um,keratin_fraction,lambda_nm,"
              "specular_reflectance,diffuse_reflectance,specular_transmittance,"
              "diffuse_transmittance,grid_cells,time_steps,run_wall_s,stop_rule");
    std::map<Key, FullWaveRuns> out;
    while (std::getline(in, line)) {
        if (line.empty()) continue;
        std::stringstream ss(line);
        std::vector<std::string> c;
        for (std::string cell; std::getline(ss, cell, ',');) c.push_back(cell);
        EXPECT_EQ(c.size(), 14u) << line;
        if (c.size() != 14) continue;
        Spectrum& s = out[{c[0], std::stod(c[1])}].seeds[std::stoull(c[2])][std::stod(c[3])];
        const double rs = std::stod(c[6]), rd = std::stod(c[7]);
        s.lambda_nm.push_back(std::stod(c[5]));
        s.run_wall_s = std::stod(c[12]);
        s.capped = c[13].find("max_time") != std::string::npos;
        s.r.push_back(rs + rd);
        s.r_diffuse.push_back(rd);
        s.t.push_back(std::stod(c[8]) + std::stod(c[9]));
        s.r_var.push_back(0.0);
        s.r_diffuse_var.push_back(0.0);
    }
    return out;
}

// R, diffuse R and T of a 2 µm slab of the medium of `tables` (one per wavelength) in air at
// normal incidence, by the tracer. A path leaving exactly along ±z was never scattered (the
// faces' specular paths): specular.
Spectrum trace_slab(std::vector<sim::MediumTable> tables, const std::vector<double>& lambdas,
                    std::size_t paths, std::uint64_t seed) {
    Spectrum s;
    for (const sim::MediumTable& t : tables) {
        const sim::TabulatedPhaseFunction phase(t.cos_theta, t.phase_per_sr, "route table");
        s.transport_thickness.push_back(kThicknessUm * t.mu_s_per_um * (1.0 - phase.mean_cosine()));
    }
    auto medium = std::make_shared<const sim::ScatteringMedium>(std::move(tables));
    sim::ScatteringSlabParams p;
    p.thickness_um = kThicknessUm;
    p.half_width_um = 1000.0;
    const sim::ExplicitScatterer tracer(sim::scattering_slab_scene(std::move(medium), p));
    for (std::size_t w = 0; w < lambdas.size(); ++w) {
        const auto events = sim::trace_many(tracer, Vec3d(0.0, 0.0, 1.0), lambdas[w],
                                            {{-1.0, -1.0}, {1.0, 1.0}}, seed, w * paths, paths, 2);
        double r = 0.0, r2 = 0.0, d = 0.0, d2 = 0.0, t = 0.0;
        for (const auto& e : events) {
            if (!e) continue;
            const bool specular = std::hypot(e->wo.x(), e->wo.y()) < 1e-9;
            if (e->wo.z() < 0.0) {
                t += e->weight;
                continue;
            }
            r += e->weight;
            r2 += e->weight * e->weight;
            if (!specular) {
                d += e->weight;
                d2 += e->weight * e->weight;
            }
        }
        const double n = static_cast<double>(paths);
        const auto var = [n](double sum, double sum2) {
            return std::max(0.0, sum2 / n - (sum / n) * (sum / n)) / (n - 1.0);
        };
        s.lambda_nm.push_back(lambdas[w]);
        s.r.push_back(r / n);
        s.r_diffuse.push_back(d / n);
        s.t.push_back(t / n);
        s.r_var.push_back(var(r, r2));
        s.r_diffuse_var.push_back(var(d, d2));
    }
    return s;
}

// First Born of the reference's own periodic slab, order by order: the exact weak-contrast limit
// of what full wave computes, with none of the routes' steps between (no orientation average,
// no radial spectrum, no transport). The slab (0 <= z <= 2 µm, the cube repeated along z) is a
// uniform medium ε̄ (its volume mean) perturbed by δε(r) = ε(r) − ε̄. Under E_x incident along
// −z, e^{−i k̄ z} with k̄ = k0 √ε̄, the scalar periodic Green's function of (∇² + k̄²) gives the
// amplitude of each reflected order G (lateral wavevector, k_z = √(k̄² − |G|²)):
//     a_G = k0² / (2 A k_z) ∫ δε(r) e^{−i q·r} dr,  q = (G, k_z + k̄),  A = P² (P the period),
// its power fraction |a_G|² k_z / k̄, times 1 − k̂_x² (the transverse part of the x dipole's
// field along k̂ = (G, k_z) / k̄). Orders with |G| >= k0 cannot leave into air and are left out.
// Left out too: the faces' reflections (|r|² = 6e-4 at n = 1.10) and every second-order term
// (scattering of the scattered field, the field inside the keratin differing from the
// incident one). The integral is a sum over a 96³ sampling of the cube (160 layers in z), each
// sample weighted by its cell's Fourier transform (sinc per axis).
std::vector<double> periodic_first_born_diffuse_r(const Structure& st, double n_keratin,
                                                  const std::vector<double>& lambdas) {
    constexpr int kSamples = 96;  // per period
    const double h = kPeriodUm / kSamples;
    const int layers = static_cast<int>(std::lround(kThicknessUm / h));
    // the keratin indicator on the samples: one period in z, the slab's layers wrap onto it
    std::vector<double> chi(static_cast<std::size_t>(kSamples) * kSamples * kSamples);
    double fraction = 0.0;
    for (int k = 0; k < kSamples; ++k)
        for (int j = 0; j < kSamples; ++j)
            for (int i = 0; i < kSamples; ++i) {
                const double v =
                    st.keratin(Eigen::Vector3d((i + 0.5) * h, (j + 0.5) * h, (k + 0.5) * h)) ? 1.0
                                                                                             : 0.0;
                chi[(static_cast<std::size_t>(k) * kSamples + j) * kSamples + i] = v;
            }
    for (int k = 0; k < layers; ++k)
        for (int p = 0; p < kSamples * kSamples; ++p)
            fraction += chi[static_cast<std::size_t>(k % kSamples) * kSamples * kSamples + p];
    fraction /= static_cast<double>(layers) * kSamples * kSamples;
    const double d_eps = n_keratin * n_keratin - 1.0;
    const double eps_mean = 1.0 + d_eps * fraction;
    // each layer's lateral Fourier sums of δε at the orders that can leave into air
    const double k0_max = 2.0 * std::numbers::pi / (lambdas.front() * 1e-3);
    const double g_step = 2.0 * std::numbers::pi / kPeriodUm;
    const int m_max = static_cast<int>(std::floor(k0_max / g_step));
    const int side = 2 * m_max + 1;
    using C = std::complex<double>;
    std::vector<C> layer_sum(static_cast<std::size_t>(kSamples) * side * side);
    std::vector<C> phase(static_cast<std::size_t>(side) * kSamples);  // e^{−i G_m x_i}
    for (int m = -m_max; m <= m_max; ++m)
        for (int i = 0; i < kSamples; ++i)
            phase[static_cast<std::size_t>(m + m_max) * kSamples + i] =
                std::polar(1.0, -g_step * m * (i + 0.5) * h);
    for (int k = 0; k < kSamples; ++k)
        for (int mx = 0; mx < side; ++mx) {
            std::vector<C> row(kSamples);  // Σ_i over x, per y
            for (int j = 0; j < kSamples; ++j)
                for (int i = 0; i < kSamples; ++i)
                    row[j] +=
                        (d_eps * chi[(static_cast<std::size_t>(k) * kSamples + j) * kSamples + i] -
                         (eps_mean - 1.0)) *
                        phase[static_cast<std::size_t>(mx) * kSamples + i];
            for (int my = 0; my < side; ++my) {
                C sum = 0.0;
                for (int j = 0; j < kSamples; ++j)
                    sum += row[j] * phase[static_cast<std::size_t>(my) * kSamples + j];
                layer_sum[(static_cast<std::size_t>(k) * side + mx) * side + my] = sum;
            }
        }
    const auto sinc = [](double x) { return std::abs(x) < 1e-12 ? 1.0 : std::sin(x) / x; };
    const double area = kPeriodUm * kPeriodUm;
    std::vector<double> out;
    for (const double lambda : lambdas) {
        const double k0 = 2.0 * std::numbers::pi / (lambda * 1e-3);
        const double kbar = k0 * std::sqrt(eps_mean);
        double r = 0.0;
        for (int mx = 0; mx < side; ++mx)
            for (int my = 0; my < side; ++my) {
                const double gx = g_step * (mx - m_max), gy = g_step * (my - m_max);
                const double g2 = gx * gx + gy * gy;
                if ((mx == m_max && my == m_max) || g2 >= k0 * k0) continue;
                const double kz = std::sqrt(kbar * kbar - g2);
                const double qz = kz + kbar;
                C integral = 0.0;
                for (int k = 0; k < layers; ++k)
                    integral +=
                        layer_sum[(static_cast<std::size_t>(k % kSamples) * side + mx) * side +
                                  my] *
                        std::polar(1.0, -qz * (k + 0.5) * h);
                integral *=
                    h * h * h * sinc(0.5 * gx * h) * sinc(0.5 * gy * h) * sinc(0.5 * qz * h);
                const double a2 = std::norm(integral) * std::pow(k0 * k0 / (2.0 * area * kz), 2);
                r += a2 * kz / kbar * (1.0 - gx * gx / (kbar * kbar));
            }
        out.push_back(r);
    }
    return out;
}

// The same first Born for the statistically isotropic medium the routes describe: the sample's
// orientation-averaged spectrum S̄(q) (E|∫ δε e^{−i q·r}|² = Δε² V S̄(|q|)) over every direction
// that leaves into air, as the sum above over a lattice of directions fine enough to be its
// integral (spacing 0.1/µm against the period's 5.2/µm):
//     Σ k0⁴ L Δε² S̄(|q|) / (4 A k_z k̄) (1 − G_x²/k̄²),  L the thickness, A = (2π / spacing)².
// Its ratio to periodic_first_born_diffuse_r is how far what the reference probes departs from
// that medium at first order: one normal incidence on one 1.2 µm period reflects into a few
// dozen orders, which see the sample's own |χ̂(q)|² near the z axis, not the average over
// directions and realisations; the (0, 0) order, which takes the back-scattering cone, counts as
// specular.
std::vector<double> isotropic_first_born_diffuse_r(const sim::wave::RadialSpectrum& radial,
                                                   double n_keratin, double fraction,
                                                   const std::vector<double>& lambdas) {
    constexpr double kSpacingPerUm = 0.1;
    const double d_eps = n_keratin * n_keratin - 1.0;
    const double eps_mean = 1.0 + d_eps * fraction;
    const double area = std::pow(2.0 * std::numbers::pi / kSpacingPerUm, 2);
    std::vector<double> out;
    for (const double lambda : lambdas) {
        const double k0 = 2.0 * std::numbers::pi / (lambda * 1e-3);
        const double kbar = k0 * std::sqrt(eps_mean);
        const int m_max = static_cast<int>(std::floor(k0 / kSpacingPerUm));
        double r = 0.0;
        for (int mx = -m_max; mx <= m_max; ++mx)
            for (int my = -m_max; my <= m_max; ++my) {
                const double gx = kSpacingPerUm * mx, gy = kSpacingPerUm * my;
                const double g2 = gx * gx + gy * gy;
                if (g2 >= k0 * k0) continue;
                const double kz = std::sqrt(kbar * kbar - g2);
                const double q = std::sqrt(g2 + (kz + kbar) * (kz + kbar));
                r += std::pow(k0, 4) * kThicknessUm * d_eps * d_eps * radial.at(q) /
                     (4.0 * area * kz * kbar) * (1.0 - gx * gx / (kbar * kbar));
            }
        out.push_back(r);
    }
    return out;
}

struct RouteSpectra {
    Spectrum born, sphere;  // sphere: empty for the channel
    // Single-scattering first Born of the sample's periodic slab and of the isotropic medium of
    // its spectrum (periodic_first_born_diffuse_r, isotropic_first_born_diffuse_r): diffuse R
    // per wavelength.
    std::vector<double> sample_first_born, isotropic_first_born;
    // The strong-contrast expansion with each phase as host, and self-consistent.
    Spectrum strong_keratin_host, strong_air_host, strong_self_consistent;
};

Spectrum strong_contrast_spectrum(const sim::wave::PowerSpectrum& spectrum,
                                  const optics::Material& keratin, const optics::Material& air,
                                  sim::wave::StrongContrastHost host,
                                  const std::vector<double>& lambdas, std::size_t paths,
                                  std::uint64_t seed) {
    std::vector<sim::MediumTable> tables;
    for (const double l : lambdas)
        tables.push_back(
            sim::medium_table(sim::wave::strong_contrast_medium(spectrum, keratin, air, l, host)));
    return trace_slab(std::move(tables), lambdas, paths, seed);
}

RouteSpectra route_spectra(const std::string& kind_text, double n_keratin, std::uint64_t seed,
                           const std::vector<double>& lambdas) {
    const Kind kind = kind_from(kind_text);
    const Structure s = make_structure(kind, seed);
    const optics::ConstantMaterial keratin("keratin", n_keratin);
    const auto air = optics::air();
    const sim::wave::PowerSpectrum spectrum =
        sim::wave::PowerSpectrum::measure_3d(s.indicator, s.voxels_per_side, kVoxelUm);
    std::vector<sim::MediumTable> born;
    for (const double l : lambdas)
        born.push_back(sim::medium_table(sim::wave::born_medium(spectrum, keratin, *air, l)));
    RouteSpectra out;
    out.sample_first_born = periodic_first_born_diffuse_r(s, n_keratin, lambdas);
    out.isotropic_first_born =
        isotropic_first_born_diffuse_r(spectrum.radial(), n_keratin, s.keratin_fraction, lambdas);
    const std::size_t paths = paths_for(n_keratin);
    out.born = trace_slab(std::move(born), lambdas, paths,
                          derive_seed(seed, "spongy3d/born", static_cast<std::uint64_t>(kind)));
    out.strong_keratin_host = strong_contrast_spectrum(
        spectrum, keratin, *air, sim::wave::StrongContrastHost::keratin, lambdas, paths,
        derive_seed(seed, "spongy3d/strong_keratin_host", static_cast<std::uint64_t>(kind)));
    out.strong_air_host = strong_contrast_spectrum(
        spectrum, keratin, *air, sim::wave::StrongContrastHost::air, lambdas, paths,
        derive_seed(seed, "spongy3d/strong_air_host", static_cast<std::uint64_t>(kind)));
    out.strong_self_consistent = strong_contrast_spectrum(
        spectrum, keratin, *air, sim::wave::StrongContrastHost::bruggeman, lambdas, paths,
        derive_seed(seed, "spongy3d/strong_self_consistent", static_cast<std::uint64_t>(kind)));
    if (kind == Kind::channel) return out;
    const double q_max = 4.0 * std::numbers::pi * n_keratin / (lambdas.front() * 1e-3) +
                         2.0 * std::numbers::pi / kPeriodUm;
    const sim::wave::MeasuredStructureFactor sq =
        sim::wave::measure_structure_factor(s.centres, kPeriodUm, q_max);
    const double density =
        static_cast<double>(s.centres.size()) / (kPeriodUm * kPeriodUm * kPeriodUm);
    const bool air_spheres = kind == Kind::air_spheres;
    std::vector<sim::MediumTable> sphere;
    for (const double l : lambdas)
        sphere.push_back(sim::medium_table(sim::wave::sphere_medium(
            s.sphere_radius_um, density, air_spheres ? *air : keratin, air_spheres ? keratin : *air,
            [&sq](double q) { return sq.at(q); }, l)));
    out.sphere = trace_slab(std::move(sphere), lambdas, paths,
                            derive_seed(seed, "spongy3d/sphere", static_cast<std::uint64_t>(kind)));
    return out;
}

// The mean over seeds (variances of the mean).
Spectrum seed_mean(const std::vector<Spectrum>& list) {
    Spectrum m = list.front();
    const double k = static_cast<double>(list.size());
    for (std::size_t i = 0; i < m.lambda_nm.size(); ++i) {
        m.r[i] = m.r_diffuse[i] = m.t[i] = m.r_var[i] = m.r_diffuse_var[i] = 0.0;
        for (const Spectrum& s : list) {
            m.r[i] += s.r[i] / k;
            m.r_diffuse[i] += s.r_diffuse[i] / k;
            m.t[i] += s.t[i] / k;
            m.r_var[i] += s.r_var[i] / (k * k);
            m.r_diffuse_var[i] += s.r_diffuse_var[i] / (k * k);
        }
    }
    for (std::size_t i = 0; i < m.transport_thickness.size(); ++i) {
        m.transport_thickness[i] = 0.0;
        for (const Spectrum& s : list) m.transport_thickness[i] += s.transport_thickness[i] / k;
    }
    return m;
}

int band_of(double lambda_nm) {
    return std::clamp(static_cast<int>((lambda_nm - 400.0) / kBandNm), 0, kBands - 1);
}

// Band means of `values` and (optionally) the standard errors from per-sample variances.
std::vector<double> band_means(const Spectrum& s, const std::vector<double>& values) {
    std::vector<double> sum(kBands, 0.0), count(kBands, 0.0);
    for (std::size_t i = 0; i < s.lambda_nm.size(); ++i) {
        sum[band_of(s.lambda_nm[i])] += values[i];
        count[band_of(s.lambda_nm[i])] += 1.0;
    }
    for (int b = 0; b < kBands; ++b) sum[b] /= count[b];
    return sum;
}

std::vector<double> band_errors(const Spectrum& s, const std::vector<double>& variances) {
    std::vector<double> sum(kBands, 0.0), count(kBands, 0.0);
    for (std::size_t i = 0; i < s.lambda_nm.size(); ++i) {
        sum[band_of(s.lambda_nm[i])] += variances[i];
        count[band_of(s.lambda_nm[i])] += 1.0;
    }
    for (int b = 0; b < kBands; ++b) sum[b] = std::sqrt(sum[b]) / count[b];
    return sum;
}

// The peak: the vertex of the parabola through the largest sample and its neighbours (the
// sample itself at the ends of the range).
double peak_nm(const Spectrum& s, const std::vector<double>& values) {
    const auto i =
        static_cast<std::size_t>(std::max_element(values.begin(), values.end()) - values.begin());
    if (i == 0 || i + 1 == values.size()) return s.lambda_nm[i];
    const double a = values[i - 1], b = values[i], c = values[i + 1];
    const double h = s.lambda_nm[i + 1] - s.lambda_nm[i];
    const double denom = a - 2.0 * b + c;
    return denom == 0.0 ? s.lambda_nm[i] : s.lambda_nm[i] + 0.5 * h * (a - c) / denom;
}

// Standard error of the full-wave seed mean per band (realisation noise).
std::vector<double> seed_errors(const std::vector<Spectrum>& list,
                                std::vector<double> Spectrum::*field) {
    std::vector<std::vector<double>> bands;
    for (const Spectrum& s : list) bands.push_back(band_means(s, s.*field));
    std::vector<double> out(kBands, 0.0);
    const double k = static_cast<double>(list.size());
    if (list.size() < 2) return out;
    for (int b = 0; b < kBands; ++b) {
        double mean = 0.0, ss = 0.0;
        for (const auto& v : bands) mean += v[b] / k;
        for (const auto& v : bands) ss += (v[b] - mean) * (v[b] - mean);
        out[b] = std::sqrt(ss / (k - 1.0) / k);
    }
    return out;
}

// The criteria (issue 37): the peak within 10 nm and every 50-nm band mean within 15 % at
// keratin's n = 1.55, within 10 % at low contrast (n < 1.5), each beyond its floor; a pass
// counts (the studies' validated range) only where at least one band's floor is within the
// tolerance, else it lies within its floors only. A band's floor: three standard errors of the
// difference (full wave's realisation noise over seeds, the route's Monte Carlo), full wave's own
// grid difference where it was measured, and the power its runs left unaccounted for. The peak's
// floor: three jackknife standard errors (leave one seed out of both seed means) of the peak
// difference. A single 1.2 µm period sees its own few diffraction orders, so each seed's diffuse
// R jumps by tens of per cent from one wavelength to the next, and where a spectrum is flat
// (the air spheres over 400–470 nm) the seed mean's largest sample wanders by tens of nm.
constexpr double kPeakToleranceNm = 10.0;

// One route on one (structure, index): what the README's tables print.
struct RouteCheck {
    std::string route;
    double fw_peak_nm = 0.0, peak_nm = 0.0;
    double peak_floor_nm = 0.0;  // three jackknife standard errors of peak_nm − fw_peak_nm
    double fw_run_wall_s = 0.0;  // full wave's mean wall time per run (the seeds' coarse grid)
    std::vector<double> fw_diffuse, diffuse, rel, floor_rel, fw_specular, specular;
    std::vector<double> transport_thickness;  // the route's slab, L / ℓ*, band means
    // The reference's sampling bias per band at first Born: the seeds' periodic slabs over the
    // isotropic medium of their spectra (single scattering; the same for every route).
    std::vector<double> sampling_bias;
    bool passes = false;
    int decided_bands = 0;  // bands whose floor is within the tolerance (a miss was visible)
};

// Full wave's grid difference of the diffuse R per band: (fine − coarse) / coarse, averaged over
// the seeds run on two grids; NaN where none was.
std::vector<double> grid_differences(const FullWaveRuns& runs) {
    std::vector<double> sum(kBands, 0.0);
    double count = 0.0;
    for (const auto& [seed, grids] : runs.seeds) {
        if (grids.size() < 2) continue;
        const Spectrum &c = grids.begin()->second, &f = grids.rbegin()->second;
        const auto bc = band_means(c, c.r_diffuse), bf = band_means(f, f.r_diffuse);
        for (int b = 0; b < kBands; ++b) sum[b] += bf[b] / bc[b] - 1.0;
        count += 1.0;
    }
    for (double& v : sum) v = count > 0.0 ? v / count : NAN;
    return sum;
}

// The jackknife standard error of the diffuse-R peak difference, route − full wave, over the
// seeds (paired: the same structures), each seed left out of both seed means in turn.
double peak_difference_jackknife_se(const std::vector<Spectrum>& fw_seeds,
                                    const std::vector<Spectrum>& route_seeds) {
    const std::size_t k = fw_seeds.size();
    if (k < 2) return 0.0;
    std::vector<double> d;
    for (std::size_t left_out = 0; left_out < k; ++left_out) {
        std::vector<Spectrum> fw, rm;
        for (std::size_t i = 0; i < k; ++i)
            if (i != left_out) {
                fw.push_back(fw_seeds[i]);
                rm.push_back(route_seeds[i]);
            }
        const Spectrum f = seed_mean(fw), r = seed_mean(rm);
        d.push_back(peak_nm(r, r.r_diffuse) - peak_nm(f, f.r_diffuse));
    }
    double mean = 0.0, ss = 0.0;
    for (const double v : d) mean += v / static_cast<double>(k);
    for (const double v : d) ss += (v - mean) * (v - mean);
    return std::sqrt(static_cast<double>(k - 1) / static_cast<double>(k) * ss);
}

// Full wave's power not accounted for per band, |1 − (R + T)|, averaged over the seeds: its flux
// error, and in runs stopped at max_time the power still in the cell, some of which could yet
// leave as diffuse reflection. Part of every band's floor.
std::vector<double> flux_deficits(const std::vector<Spectrum>& fw_seeds) {
    std::vector<double> out(kBands, 0.0);
    for (const Spectrum& s : fw_seeds) {
        std::vector<double> lost(s.r.size());
        for (std::size_t i = 0; i < s.r.size(); ++i) lost[i] = std::abs(1.0 - s.r[i] - s.t[i]);
        const auto bands = band_means(s, lost);
        for (int b = 0; b < kBands; ++b) out[b] += bands[b] / static_cast<double>(fw_seeds.size());
    }
    return out;
}

RouteCheck check_route(const std::string& route, double n, const std::vector<Spectrum>& fw_seeds,
                       const std::vector<Spectrum>& route_seeds, const std::vector<double>& grid) {
    const Spectrum fw = seed_mean(fw_seeds), rm = seed_mean(route_seeds);
    RouteCheck c;
    c.route = route;
    c.fw_peak_nm = peak_nm(fw, fw.r_diffuse);
    c.peak_nm = peak_nm(rm, rm.r_diffuse);
    for (const Spectrum& f : fw_seeds)
        c.fw_run_wall_s += f.run_wall_s / static_cast<double>(fw_seeds.size());
    c.fw_diffuse = band_means(fw, fw.r_diffuse);
    c.diffuse = band_means(rm, rm.r_diffuse);
    std::vector<double> fw_spec(fw.r.size()), spec(rm.r.size());
    for (std::size_t i = 0; i < fw.r.size(); ++i) fw_spec[i] = fw.r[i] - fw.r_diffuse[i];
    for (std::size_t i = 0; i < rm.r.size(); ++i) spec[i] = rm.r[i] - rm.r_diffuse[i];
    c.fw_specular = band_means(fw, fw_spec);
    c.specular = band_means(rm, spec);
    c.transport_thickness = band_means(rm, rm.transport_thickness);
    const auto seed_se = seed_errors(fw_seeds, &Spectrum::r_diffuse);
    const auto mc_se = band_errors(rm, rm.r_diffuse_var);
    const auto lost = flux_deficits(fw_seeds);
    // both at the short end of the range: both peak at or below it, which agrees
    const bool both_at_edge =
        c.fw_peak_nm <= fw.lambda_nm.front() + 1e-9 && c.peak_nm <= rm.lambda_nm.front() + 1e-9;
    c.peak_floor_nm = 3.0 * peak_difference_jackknife_se(fw_seeds, route_seeds);
    c.passes =
        both_at_edge || std::abs(c.peak_nm - c.fw_peak_nm) <= kPeakToleranceNm + c.peak_floor_nm;
    for (int b = 0; b < kBands; ++b) {
        const double g = std::isnan(grid[b]) ? 0.0 : grid[b] * c.fw_diffuse[b];
        c.rel.push_back(c.diffuse[b] / c.fw_diffuse[b] - 1.0);
        c.floor_rel.push_back(3.0 * std::hypot(seed_se[b], mc_se[b]) / c.fw_diffuse[b] +
                              (std::abs(g) + lost[b]) / c.fw_diffuse[b]);
        const double tolerance = studies::spongy_band_tolerance(n);
        if (std::abs(c.rel[b]) > tolerance + c.floor_rel[b]) c.passes = false;
        if (c.floor_rel[b] <= tolerance) ++c.decided_bands;
    }
    return c;
}

void print_check(const Key& key, std::size_t seeds, const RouteCheck& c,
                 const std::vector<double>& grid) {
    std::printf(
        "%s", fmt::format("\n{}, n = {:.2f}, {} seed(s), route {}: diffuse-R peak full "
                          "wave {:.1f} nm, route {:.1f} nm (floor {:.1f} nm): {}\n"
                          "| band (nm) | full wave diffuse R | its grid diff. | route "
                          "diffuse R | difference | floor | full wave specular R | "
                          "route specular R | route's slab, L / ℓ* | sampling bias | "
                          "difference, bias removed |\n"
                          "|---|---|---|---|---|---|---|---|---|---|---|\n",
                          key.kind, key.n, seeds, c.route, c.fw_peak_nm, c.peak_nm, c.peak_floor_nm,
                          !c.passes              ? "misses"
                          : c.decided_bands == 0 ? "within its floors only"
                                                 : "PASSES")
                  .c_str());
    for (int b = 0; b < kBands; ++b)
        std::printf(
            "%s",
            fmt::format("| {}–{} | {:.4f} | {} | {:.4f} | {:+.1f} % | {:.1f} % | "
                        "{:.4f} | {:.4f} | {:.2f} | {:+.1f} % | {:+.1f} % |\n",
                        400 + 50 * b, 450 + 50 * b, c.fw_diffuse[b],
                        std::isnan(grid[b]) ? std::string("not run")
                                            : fmt::format("{:+.1f} %", 100.0 * grid[b]),
                        c.diffuse[b], 100.0 * c.rel[b], 100.0 * c.floor_rel[b], c.fw_specular[b],
                        c.specular[b], c.transport_thickness[b], 100.0 * (c.sampling_bias[b] - 1.0),
                        100.0 * (c.diffuse[b] * c.sampling_bias[b] / c.fw_diffuse[b] - 1.0))
                .c_str());
}

// Every route on one (structure, index), against the seeds' coarse grid (the grid every seed
// was run on).
std::vector<RouteCheck> compare(const Key& key, const FullWaveRuns& runs) {
    std::vector<Spectrum> fw, born, sphere, strong_keratin_host, strong_air_host,
        strong_self_consistent;
    std::vector<double> sample_sum, isotropic_sum;  // first Born, summed over the seeds
    for (const auto& [seed, grids] : runs.seeds) {
        fw.push_back(grids.begin()->second);
        const RouteSpectra r = route_spectra(key.kind, key.n, seed, fw.back().lambda_nm);
        sample_sum.resize(r.sample_first_born.size());
        isotropic_sum.resize(r.isotropic_first_born.size());
        for (std::size_t i = 0; i < sample_sum.size(); ++i) {
            sample_sum[i] += r.sample_first_born[i];
            isotropic_sum[i] += r.isotropic_first_born[i];
        }
        born.push_back(r.born);
        if (!r.sphere.r.empty()) sphere.push_back(r.sphere);
        strong_keratin_host.push_back(r.strong_keratin_host);
        strong_air_host.push_back(r.strong_air_host);
        strong_self_consistent.push_back(r.strong_self_consistent);
    }
    const std::vector<double> grid = grid_differences(runs);
    std::vector<RouteCheck> out{check_route("born", key.n, fw, born, grid)};
    if (!sphere.empty()) out.push_back(check_route("sphere", key.n, fw, sphere, grid));
    out.push_back(check_route("strong_keratin_host", key.n, fw, strong_keratin_host, grid));
    out.push_back(check_route("strong_air_host", key.n, fw, strong_air_host, grid));
    out.push_back(check_route("strong_self_consistent", key.n, fw, strong_self_consistent, grid));
    const auto sample = band_means(fw.front(), sample_sum);
    const auto isotropic = band_means(fw.front(), isotropic_sum);
    for (RouteCheck& c : out)
        for (int b = 0; b < kBands; ++b) c.sampling_bias.push_back(sample[b] / isotropic[b]);
    for (const RouteCheck& c : out) print_check(key, fw.size(), c, grid);
    return out;
}

// Lossless keratin: R + T = 1 within the runs' flux accuracy. Meep stops at a field decay of
// 1e-6 under the slab; a periodic cell's quasi-guided resonances ring longer, and single
// wavelengths near them (660–670 nm here) are off by up to 0.042 (README); 50-nm band means
// within 0.01. A run stopped at max_time (n = 1.10: its probe never decays, README) may leave
// power in the cell, up to 0.020 of a band's (measured), never create it: R + T at most 1 within
// the same accuracy; what it leaves is part of full wave's floor (flux_deficits).
TEST(Spongy3dReference, FullWaveConservesPower) {
    const auto reference = read_reference(reference_csv());
    ASSERT_FALSE(reference.empty());
    for (const auto& [key, runs] : reference)
        for (const auto& [seed, grids] : runs.seeds)
            for (const auto& [res, s] : grids) {
                std::vector<double> sum(s.r.size());
                for (std::size_t i = 0; i < s.r.size(); ++i) {
                    sum[i] = s.r[i] + s.t[i];
                    if (s.capped)
                        EXPECT_LE(sum[i], 1.05);
                    else
                        EXPECT_NEAR(sum[i], 1.0, 0.05)
                            << key.kind << " n " << key.n << " seed " << seed << " at " << res
                            << " px/um, " << s.lambda_nm[i] << " nm";
                }
                std::string line;
                for (const double band : band_means(s, sum)) {
                    line += fmt::format(" {:+.4f}", 1.0 - band);
                    if (s.capped)
                        EXPECT_LE(band, 1.01);
                    else
                        EXPECT_NEAR(band, 1.0, 0.01)
                            << key.kind << " n " << key.n << " seed " << seed << " at " << res;
                }
                std::printf("%s n %.2f seed %llu at %g px/um%s: 1 - (R + T) per band:%s\n",
                            key.kind.c_str(), key.n, static_cast<unsigned long long>(seed), res,
                            s.capped ? " (max_time)" : "", line.c_str());
            }
}

// route_check.csv: one row per (structure, index, route, band), the numbers print_check prints.
// The spongy study embeds it (studies/spongy_reference.h.in) and states its route's verdict.
constexpr const char* kRouteCheckHeader =
    "structure,n_keratin,route,seeds,fw_peak_nm,route_peak_nm,passes,band_lo_nm,band_hi_nm,"
    "fw_diffuse_r,route_diffuse_r,difference,floor,fw_run_wall_s,peak_floor_nm";

std::string route_check_rows(const Key& key, std::size_t seeds, const RouteCheck& c) {
    std::string out;
    for (int b = 0; b < kBands; ++b)
        out += fmt::format(
            "{},{:g},{},{},{:.1f},{:.1f},{},{},{},{:.4f},{:.4f},{:.3f},{:.3f},{:.0f},{:.1f}\n",
            key.kind, key.n, c.route, seeds, c.fw_peak_nm, c.peak_nm, c.passes ? 1 : 0,
            400 + 50 * b, 450 + 50 * b, c.fw_diffuse[b], c.diffuse[b], c.rel[b], c.floor_rel[b],
            c.fw_run_wall_s, c.peak_floor_nm);
    return out;
}

fs::path route_check_csv() {
    return fs::path(PLUMAGE_SOURCE_DIR) / "tests/reference/spongy_3d/route_check.csv";
}

// Every route against every (structure, index) of the reference; the committed route_check.csv
// must be what this computes (deterministic: the routes' Monte Carlo is seeded per structure and
// route), so what the spongy study quotes is what the test measured. To rewrite it after new
// runs: PLUMAGE_WRITE_ROUTE_CHECK=1 build/tests/plumage_tests --gtest_filter='Spongy3d*'.
TEST(Spongy3dReference, RoutesAgainstFullWave) {
    const auto reference = read_reference(reference_csv());
    ASSERT_FALSE(reference.empty());
    std::string rows = std::string(kRouteCheckHeader) + "\n";
    for (const auto& [key, runs] : reference) {
        const std::vector<RouteCheck> checks = compare(key, runs);
        for (const RouteCheck& c : checks) rows += route_check_rows(key, runs.seeds.size(), c);
        // The decision between the routes' contrasts, by the mean |difference| over the bands
        // (README, "Against the routes"): on air spheres in keratin (the sphere-type barbs)
        // first Born's full two-phase contrast is nearer full wave than the sphere route's
        // contrast to the Bruggeman medium; on keratin spheres in air neither comes within 30 %.
        const auto route = [&checks](const std::string& name) -> const RouteCheck* {
            for (const RouteCheck& c : checks)
                if (c.route == name) return &c;
            return nullptr;
        };
        const auto mean_abs = [](const RouteCheck& c) {
            double sum = 0.0;
            for (const double r : c.rel) sum += std::abs(r);
            return sum / static_cast<double>(c.rel.size());
        };
        if (route("sphere") != nullptr) {
            const double born = mean_abs(*route("born")), sphere = mean_abs(*route("sphere"));
            std::printf("%s n = %.2f: mean |difference| first Born %.1f %%, sphere route %.1f %%\n",
                        key.kind.c_str(), key.n, 100.0 * born, 100.0 * sphere);
            if (key.n >= 1.5 && key.kind == "air_spheres") {
                EXPECT_LT(born, sphere);
            }
            if (key.n >= 1.5 && key.kind == "keratin_spheres") {
                EXPECT_GT(born, 0.3);
                EXPECT_GT(sphere, 0.3);
            }
        }
        // The strong-contrast forms (README, "A better medium, tried"): the self-consistent one
        // stays near first Born (its weak-contrast limit), within 10 points of mean |difference|.
        if (key.n >= 1.5) {
            const double born = mean_abs(*route("born"));
            const double self_consistent = mean_abs(*route("strong_self_consistent"));
            std::printf("%s n = %.2f: mean |difference| strong contrast, self-consistent %.1f %%\n",
                        key.kind.c_str(), key.n, 100.0 * self_consistent);
            EXPECT_NEAR(self_consistent, born, 0.10) << key.kind;
        }
        // At low contrast (README, "The low-contrast control"): with the reference's sampling
        // bias removed, first Born is within 10 % of full wave beyond the floor in every band
        // where full wave's diffuse R is at least 1e-3; the sphere route, whose contrast to the
        // Bruggeman medium scatters (1 − φ)² = ¼ of first Born's power at φ = 0.5, stays more
        // than 50 % low there.
        if (key.n < 1.5) {
            for (const RouteCheck& c : checks) {
                if (c.route != "born" && c.route != "sphere") continue;
                for (int b = 0; b < kBands; ++b) {
                    if (c.fw_diffuse[b] < 1e-3) continue;
                    const double unbiased = c.diffuse[b] * c.sampling_bias[b] / c.fw_diffuse[b];
                    if (c.route == "born") {
                        EXPECT_LE(std::abs(unbiased - 1.0), 0.10 + c.floor_rel[b])
                            << key.kind << " band " << b;
                    } else {
                        EXPECT_LT(unbiased, 0.5) << key.kind << " band " << b;
                    }
                }
            }
        }
    }
    if (std::getenv("PLUMAGE_WRITE_ROUTE_CHECK")) std::ofstream(route_check_csv()) << rows;
    std::ifstream in(route_check_csv());
    const std::string committed((std::istreambuf_iterator<char>(in)),
                                std::istreambuf_iterator<char>());
    EXPECT_EQ(committed, rows) << route_check_csv()
                               << " is not what the reference gives now: rewrite it (above)";
}

// At low contrast full wave must be first Born of the same periodic slab: seed by seed, every
// 50-nm band where the diffuse R is at least 1e-3 (below it, full wave's flux error, R + T − 1 up
// to 2e-3 at single wavelengths, is not negligible) within 10 % plus the band's power that full
// wave has not accounted for, over its diffuse R (flux_deficits: runs stopped at max_time leave
// up to 0.020 of the power in the cell at 400–450 nm, as much as the diffuse R there): first Born
// leaves out terms of relative size δε/ε̄ ≈ ±0.1 at n = 1.10 (the field inside the keratin
// differs from the incident one by its depolarisation, ±3 % in amplitude). An independent check
// of the full-wave level in 3D, and of what the routes are compared with.
// At n = 1.55 the same numbers are printed: there single-scattering first Born of the sample is
// not the physics (the slab is up to 1.6 transport lengths thick).
TEST(Spongy3dReference, LowContrastFullWaveIsPeriodicFirstBorn) {
    const auto reference = read_reference(reference_csv());
    std::size_t checked = 0;
    for (const auto& [key, runs] : reference) {
        for (const auto& [seed, grids] : runs.seeds) {
            const Spectrum& fw = grids.begin()->second;
            const Structure st = make_structure(kind_from(key.kind), seed);
            const auto fb = band_means(fw, fw.r_diffuse);
            const auto bb = band_means(fw, periodic_first_born_diffuse_r(st, key.n, fw.lambda_nm));
            const auto lost = flux_deficits({fw});
            std::string line;
            for (int b = 0; b < kBands; ++b) {
                line += fmt::format(" {:+.1f} ({:.0f})", 100.0 * (bb[b] / fb[b] - 1.0),
                                    100.0 * lost[b] / fb[b]);
                if (key.n < 1.5 && fb[b] >= 1e-3) {
                    EXPECT_NEAR(bb[b] / fb[b], 1.0, 0.10 + lost[b] / fb[b])
                        << key.kind << " n " << key.n << " seed " << seed << " band " << b;
                    ++checked;
                }
            }
            std::printf(
                "%s n %.2f seed %llu: periodic first Born / full wave - 1 per band (%%; full "
                "wave's unaccounted power over its diffuse R):%s\n",
                key.kind.c_str(), key.n, static_cast<unsigned long long>(seed), line.c_str());
        }
    }
    std::printf("%zu low-contrast bands checked\n", checked);
}

// The studies state a route's validated range from their own copy of these structures' numbers
// (studies/spongy_medium.h, spongy_reference_structures): it must be this header's.
TEST(Spongy3dReference, StudiesKnowItsStructures) {
    const auto known = studies::spongy_reference_structures();
    ASSERT_EQ(known.size(), kKinds.size());
    for (const Kind k : kKinds) {
        const auto it = std::find_if(known.begin(), known.end(),
                                     [k](const auto& s) { return s.name == kind_name(k); });
        ASSERT_NE(it, known.end()) << kind_name(k);
        if (k == Kind::channel) {
            EXPECT_EQ(it->keratin_fraction, kChannelKeratinFraction);
            EXPECT_EQ(it->length_um, kChannelLengthUm);
        } else {
            EXPECT_EQ(it->keratin_fraction,
                      k == Kind::keratin_spheres ? kSphereFraction : 1.0 - kSphereFraction);
            EXPECT_EQ(it->length_um, 0.5 * kSphereDiameterUm);
        }
    }
}

// Where full wave puts the air spheres' diffuse-R peak (README): it peaks where the
// packing's structure factor meets back-scattering, 2 k n_eff = q* (q* the S(q) peak of each
// seed's centres, n_eff Bruggeman's), while first Born's k⁴ rise and the sphere's form factor
// carry the routes' peak to the range's short end. The Bragg wavelength 4π n_eff / q* of the
// seeds' mean q* lies within the box's q resolution (one shell, 2π/L = 5.2/µm, about ±7 % in λ)
// of full wave's seed-mean peak.
TEST(Spongy3dReference, AirSpherePeakIsTheirBraggCondition) {
    const auto reference = read_reference(reference_csv());
    const auto it = reference.find(Key{"air_spheres", 1.55});
    ASSERT_NE(it, reference.end());
    std::vector<Spectrum> fw;
    double q_sum = 0.0, f_sum = 0.0;
    for (const auto& [seed, grids] : it->second.seeds) {
        fw.push_back(grids.begin()->second);
        const Structure st = make_structure(Kind::air_spheres, seed);
        const sim::wave::MeasuredStructureFactor sq =
            sim::wave::measure_structure_factor(st.centres, kPeriodUm, 80.0);
        const double q_peak = sim::wave::structure_factor_peak(sq, 15.0, 60.0);
        std::printf("air spheres seed %llu: S(q) peak at q* = %.2f /um (shell width %.2f)\n",
                    static_cast<unsigned long long>(seed), q_peak, sq.shell_width_per_um);
        q_sum += q_peak;
        f_sum += st.keratin_fraction;
    }
    const double k = static_cast<double>(fw.size());
    const double n_eff = sim::wave::bruggeman_index({1.55, 0.0}, {1.0, 0.0}, f_sum / k).real();
    const double bragg_nm = 4.0 * std::numbers::pi * n_eff / (q_sum / k) * 1e3;
    const Spectrum mean = seed_mean(fw);
    const double fw_peak = peak_nm(mean, mean.r_diffuse);
    std::printf(
        "Bragg back-scattering 4 pi n_eff / q* = %.0f nm (n_eff %.3f); full wave's diffuse-R "
        "peak %.0f nm\n",
        bragg_nm, n_eff, fw_peak);
    EXPECT_NEAR(bragg_nm / fw_peak, 1.0, 0.07);
}

}  // namespace
}  // namespace plumage::reference::spongy3d
