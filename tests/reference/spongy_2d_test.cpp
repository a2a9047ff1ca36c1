// The 2D spongy slab of tests/reference/spongy_2d (Meep, full wave) through the pipeline:
// the PBM field's rectangular power spectrum (power_spectrum.h) → 2D first Born per
// polarisation (born_2d.h) → flatland slab transport (flatland_slab.h), at the CSV's
// wavelengths, compared per seed and polarisation on the peak wavelength and the 50-nm band
// means of R. What is asserted, and why those tolerances: README.md there, section "Against
// the pipeline". Reads every field_seed<S>.pbm and every (seed, polarisation) in
// reflectance.csv, so seeds and resolutions added later are picked up.
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "common/seed.h"
#include "sim/optics/material.h"
#include "sim/wave/volume/born_2d.h"
#include "sim/wave/volume/flatland_slab.h"
#include "sim/wave/volume/power_spectrum.h"

namespace plumage::sim::wave {
namespace {

namespace fs = std::filesystem;

constexpr double kPixelUm = 0.01;        // spongy_slab_2d.py: FIELD_PIXEL_UM
constexpr double kKeratin = 1.55;        // N_KERATIN
constexpr std::uint64_t kPaths = 16000;  // per wavelength (≈ 18 wavelengths per band)
constexpr double kBandNm = 50.0;

std::string fmt_double(double x) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.2f", x);
    return buffer;
}

fs::path reference_dir() { return fs::path(PLUMAGE_SOURCE_DIR) / "tests/reference/spongy_2d"; }

struct Field {
    int nx = 0, ny = 0;
    std::vector<double> values;  // rows from the top face down, x fastest; 1 = keratin
};

// A binary PBM (P4): "P4", comments (#…), width, height, one whitespace, rows of packed bits
// (MSB first, each row padded to whole bytes); 1 = black = keratin.
Field read_pbm(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    EXPECT_TRUE(in.good()) << path;
    auto token = [&] {
        std::string t;
        char c;
        while (in.get(c)) {
            if (c == '#') {
                std::string rest;
                std::getline(in, rest);
            } else if (std::isspace(static_cast<unsigned char>(c))) {
                if (!t.empty()) break;
            } else {
                t += c;
            }
        }
        return t;
    };
    Field f;
    EXPECT_EQ(token(), "P4") << path;
    f.nx = std::stoi(token());
    f.ny = std::stoi(token());  // the whitespace after the height was consumed by token()
    const std::size_t row_bytes = (static_cast<std::size_t>(f.nx) + 7) / 8;
    std::vector<unsigned char> bytes(row_bytes * f.ny);
    in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    EXPECT_EQ(static_cast<std::size_t>(in.gcount()), bytes.size()) << path;
    f.values.resize(static_cast<std::size_t>(f.nx) * f.ny);
    for (int row = 0; row < f.ny; ++row) {
        for (int col = 0; col < f.nx; ++col) {
            const unsigned char byte = bytes[row * row_bytes + col / 8];
            f.values[static_cast<std::size_t>(row) * f.nx + col] = (byte >> (7 - col % 8)) & 1U;
        }
    }
    return f;
}

struct Curve {
    std::vector<double> lambda_nm, r, t;
};
// (seed, polarisation) → resolution → curve.
using MeepData = std::map<std::pair<int, std::string>, std::map<int, Curve>>;

MeepData read_meep(const fs::path& path) {
    std::ifstream in(path);
    std::string line;
    auto strip = [](std::string& l) {  // the CSV may carry CRLF line ends
        while (!l.empty() && (l.back() == '\r' || l.back() == '\n')) l.pop_back();
    };
    std::getline(in, line);
    strip(line);
    EXPECT_EQ(line, "seed,resolution_px_per_um,polarisation,wavelength_nm,R,T");
    MeepData data;
    while (std::getline(in, line)) {
        strip(line);
        if (line.empty()) continue;
        std::stringstream s(line);
        std::string seed, res, pol, lam, r, t;
        std::getline(s, seed, ',');
        std::getline(s, res, ',');
        std::getline(s, pol, ',');
        std::getline(s, lam, ',');
        std::getline(s, r, ',');
        std::getline(s, t, ',');
        Curve& c = data[{std::stoi(seed), pol}][std::stoi(res)];
        c.lambda_nm.push_back(std::stod(lam));
        c.r.push_back(std::stod(r));
        c.t.push_back(std::stod(t));
    }
    return data;
}

// Mean over each 50-nm band [400 + 50 j, 450 + 50 j) of the samples in it (the CSV's
// wavelengths are uniform in frequency, so this is the plain sample mean, as a detector
// averaging over the band would weigh them).
std::vector<double> band_means(const std::vector<double>& lambda, const std::vector<double>& v) {
    std::vector<double> sum(8, 0.0), count(8, 0.0);
    for (std::size_t i = 0; i < lambda.size(); ++i) {
        const int band = std::clamp(static_cast<int>((lambda[i] - 400.0) / kBandNm), 0, 7);
        sum[band] += v[i];
        count[band] += 1.0;
    }
    for (int b = 0; b < 8; ++b) sum[b] = count[b] > 0.0 ? sum[b] / count[b] : NAN;
    return sum;
}

// Peak wavelength: the vertex of the least-squares parabola through the samples within
// ±25 nm of the largest one (a three-point vertex would follow the sample noise of a single
// realisation's speckle and of the Monte Carlo).
double peak_nm(const std::vector<double>& lambda, const std::vector<double>& v) {
    const auto top = static_cast<std::size_t>(std::max_element(v.begin(), v.end()) - v.begin());
    double s[5] = {0, 0, 0, 0, 0}, b[3] = {0, 0, 0};
    for (std::size_t i = 0; i < lambda.size(); ++i) {
        const double x = lambda[i] - lambda[top];
        if (std::abs(x) > 25.0) continue;
        double p = 1.0;
        for (int k = 0; k < 5; ++k, p *= x) {
            s[k] += p;
            if (k < 3) b[k] += p * v[i];
        }
    }
    // Normal equations [s0 s1 s2; s1 s2 s3; s2 s3 s4] (c0 c1 c2) = b, Cramer's rule.
    auto det3 = [](double a, double b_, double c, double d, double e, double f, double g, double h,
                   double i) {
        return a * (e * i - f * h) - b_ * (d * i - f * g) + c * (d * h - e * g);
    };
    const double d = det3(s[0], s[1], s[2], s[1], s[2], s[3], s[2], s[3], s[4]);
    const double c1 = det3(s[0], b[0], s[2], s[1], b[1], s[3], s[2], b[2], s[4]) / d;
    const double c2 = det3(s[0], s[1], b[0], s[1], s[2], b[1], s[2], s[3], b[2]) / d;
    if (!(c2 < 0.0)) return lambda[top];
    // Kept inside the sampled range: a curve still rising at an end peaks "at the edge".
    return std::clamp(lambda[top] + std::clamp(-c1 / (2.0 * c2), -25.0, 25.0), lambda.front(),
                      lambda.back());
}

// The effective slab's coherent two-interface reflectance at normal incidence (thin-film
// fringes of the ballistic beam, amplitude attenuated by e^{−τ/2} per crossing), for the
// fringe diagnostic: its band mean minus the incoherent one (flatland_slab.h's
// incoherent_slab) is what the transport model leaves out of the specular part.
double coherent_slab_reflectance(double n, double d_um, double tau, double lambda_nm) {
    const double r = (1.0 - n) / (1.0 + n);  // air → slab; slab → air is −r
    const double t_in = 2.0 / (1.0 + n), t_out = 2.0 * n / (1.0 + n);
    const std::complex<double> loop =
        std::exp(-tau) * std::polar(1.0, 4.0 * kPi * n * d_um / (lambda_nm * 1e-3));
    const std::complex<double> total = r + t_in * t_out * (-r) * loop / (1.0 - r * r * loop);
    return std::norm(total);
}

struct SeedRun {
    int seed = 0;
    std::string pol;
    int resolution = 0;  // Meep's, the finest of this (seed, polarisation)
    std::vector<double> lambda_nm, meep_r, pipe_r, pipe_var, mu_s, g;
    std::vector<FlatlandTable> tables;
    double n_eff = 0.0, thickness_um = 0.0, spectrum_peak_q = 0.0, isotropy = 0.0;
    double meep_resolution_spread = NAN;  // max over bands of |R_coarse / R_finest − 1|
};

int band_of(double lambda_nm) {
    return std::clamp(static_cast<int>((lambda_nm - 400.0) / kBandNm), 0, 7);
}

FlatlandSlabOptions mc_options(const SeedRun& run, std::size_t i, std::uint64_t paths,
                               std::uint64_t salt = 0) {
    FlatlandSlabOptions o;
    o.paths = paths;
    o.seed = derive_seed(
        20261125, "tests/spongy_2d",
        ((static_cast<std::uint64_t>(run.seed) * 2 + (run.pol == "TM")) * 1000 + i) * 16 + salt);
    return o;
}

// Band-mean R of a run with μ_s scaled by `scale` (the scaling diagnostic).
double scaled_band_mean(const SeedRun& run, int band, double scale, std::uint64_t paths) {
    double sum = 0.0, count = 0.0;
    for (std::size_t i = 0; i < run.lambda_nm.size(); ++i) {
        if (band_of(run.lambda_nm[i]) != band) continue;
        FlatlandSlab slab = FlatlandSlab::from_table(run.tables[i], run.thickness_um);
        slab.mu_s_per_um *= scale;
        sum += simulate_flatland_slab(slab, mc_options(run, i, paths, 1)).reflectance;
        count += 1.0;
    }
    return sum / count;
}

// What the test holds the pipeline to, per polarisation and band (README.md, "Against the
// pipeline", says why), recorded from the committed data (seeds 1–3):
//  - agrees: |R_pipe / R_Meep − 1| <= 15 % (the criterion) + 3 σ_MC;
//  - differs: the recorded R_pipe / R_Meep − 1 within ± 8 points (what a rerun of Meep at
//    another resolution may move it by: its 50 vs 100 px/µm spread is up to 5 %, 10 % in the
//    last band; plus 3 σ_MC), and still more than 15 % apart. Not a pass for the physics: a guard,
//    so that a change that moves the disagreement (better physics, new Meep runs) fails here and
//    the README's table gets updated. Nothing is widened to pass.
struct BandExpectation {
    bool agrees = true;
    double recorded = 0.0;  // R_pipe / R_Meep − 1 when it does not agree
};
BandExpectation expectation(const std::string& pol, int band) {
    if (pol == "TE") {
        if (band == 5) return {false, -0.164};  // 650–700 nm
        if (band == 6) return {false, -0.230};  // 700–750 nm
        return {};
    }
    constexpr double kTmRed[4] = {-0.289, -0.371, -0.325, -0.412};  // 600–800 nm
    if (band >= 4) return {false, kTmRed[band - 4]};
    return {};
}

// Every field_seed<S>.pbm of a folder, by seed.
std::map<int, Field> read_fields(const fs::path& dir) {
    std::map<int, Field> fields;
    for (const auto& entry : fs::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind("field_seed", 0) != 0 || entry.path().extension() != ".pbm") continue;
        fields[std::stoi(name.substr(10))] = read_pbm(entry.path());
    }
    return fields;
}

// Every (seed, polarisation) of a Meep CSV through the pipeline, keratin of index
// `n_keratin` in air, by polarisation. Checks on the way: the fields' f = ½ and variance, Meep's
// flux balance (|R + T − 1| <= flux_tolerance), the pipeline's energy conservation and lost
// paths.
std::map<std::string, std::vector<SeedRun>> pipeline_runs(const MeepData& meep,
                                                          const std::map<int, Field>& fields,
                                                          double n_keratin, double flux_tolerance) {
    const optics::ConstantMaterial keratin("keratin", n_keratin), air("air", 1.0);
    std::map<std::string, std::vector<SeedRun>> runs;  // by polarisation
    for (const auto& [key, by_resolution] : meep) {
        const auto& [seed, pol_name] = key;
        EXPECT_TRUE(fields.count(seed)) << "no field_seed" << seed << ".pbm for the CSV's rows";
        if (!fields.count(seed)) continue;
        EXPECT_TRUE(pol_name == "TE" || pol_name == "TM") << pol_name;
        const Polarisation2d pol = pol_name == "TE" ? Polarisation2d::te : Polarisation2d::tm;
        const Field& field = fields.at(seed);
        const PowerSpectrum spectrum =
            PowerSpectrum::measure_2d(field.values, field.nx, field.ny, kPixelUm);
        EXPECT_NEAR(spectrum.filling_fraction(), 0.5, 1e-9);  // round(f N) pixels, f = ½
        EXPECT_NEAR(spectrum.variance(), 0.25, 1e-9);         // Σ S / A = f (1 − f)
        const RadialSpectrum radial = spectrum.radial();
        // The finest resolution is the reference; a coarser one measures the resolution spread.
        const auto& [resolution, curve] = *by_resolution.rbegin();
        SeedRun run;
        run.seed = seed;
        run.pol = pol_name;
        run.resolution = resolution;
        run.thickness_um = field.ny * kPixelUm;
        run.spectrum_peak_q = radial.peak_q_per_um;
        run.isotropy = radial.isotropy_eigenvalue_ratio;
        run.lambda_nm = curve.lambda_nm;
        run.meep_r = curve.r;
        for (std::size_t i = 0; i < curve.lambda_nm.size(); ++i) {
            EXPECT_NEAR(curve.r[i] + curve.t[i], 1.0, flux_tolerance)
                << "Meep's own flux balance at " << curve.lambda_nm[i] << " nm, seed " << seed;
            const FlatlandTable table =
                born_flatland(spectrum, keratin, air, curve.lambda_nm[i], pol);
            run.n_eff = table.n_eff;
            const FlatlandSlabResult r = simulate_flatland_slab(
                FlatlandSlab::from_table(table, run.thickness_um), mc_options(run, i, kPaths));
            EXPECT_EQ(r.lost, 0u);
            EXPECT_NEAR(r.reflectance + r.transmittance, 1.0, 1e-12);
            run.pipe_r.push_back(r.reflectance);
            run.pipe_var.push_back(r.reflectance_se * r.reflectance_se);
            run.mu_s.push_back(table.mu_s_per_um);
            run.g.push_back(table.g);
            run.tables.push_back(table);
            if (std::getenv("PLUMAGE_SPONGY2D_CURVES") != nullptr) {
                std::printf("curve %d %s %.3f meep %.4f pipe %.4f mu_s %.4f g %.4f\n", seed,
                            pol_name.c_str(), curve.lambda_nm[i], curve.r[i], r.reflectance,
                            table.mu_s_per_um, table.g);
            }
        }
        if (by_resolution.size() > 1) {
            const Curve& coarse = by_resolution.begin()->second;
            const auto coarse_band = band_means(coarse.lambda_nm, coarse.r);
            const auto fine_band = band_means(curve.lambda_nm, curve.r);
            run.meep_resolution_spread = 0.0;
            for (int b = 0; b < 8; ++b) {
                run.meep_resolution_spread = std::max(
                    run.meep_resolution_spread, std::abs(coarse_band[b] / fine_band[b] - 1.0));
            }
        }
        runs[pol_name].push_back(std::move(run));
    }
    return runs;
}

// Each seed's numbers and band means, printed (the README's per-seed table).
void print_seeds(const std::string& pol, const std::vector<SeedRun>& list) {
    for (const SeedRun& run : list) {
        const auto mb = band_means(run.lambda_nm, run.meep_r);
        const auto pb = band_means(run.lambda_nm, run.pipe_r);
        std::printf(
            "seed %d %s (Meep at %d px/um): n_eff %.4f, spectrum peak q %.2f 1/um "
            "(isotropy ratio %.2f), peak Meep %.1f nm, pipeline %.1f nm, "
            "resolution spread %.3f\n",
            run.seed, pol.c_str(), run.resolution, run.n_eff, run.spectrum_peak_q, run.isotropy,
            peak_nm(run.lambda_nm, run.meep_r), peak_nm(run.lambda_nm, run.pipe_r),
            run.meep_resolution_spread);
        std::printf("  seed %d %s band R, Meep / pipeline:", run.seed, pol.c_str());
        for (int b = 0; b < 8; ++b) std::printf(" %.3f/%.3f", mb[b], pb[b]);
        std::printf("\n");
    }
}

// Diagnostic (not a fix): the μ_s scale that would make the seed-mean band R match Meep's
// `target`, by linear interpolation between trial scales; "-" where they agree within 15 %.
std::string mu_s_scale_to_match(const std::vector<SeedRun>& list, int b, double target,
                                double pipeline) {
    if (std::abs(pipeline / target - 1.0) <= 0.15) return "-";
    double prev_s = 1.0, prev_r = pipeline;
    for (double s_try : {1.5, 2.0, 3.0, 4.0, 6.0, 8.0}) {
        double r_try = 0.0;
        for (const SeedRun& run : list) r_try += scaled_band_mean(run, b, s_try, 2000);
        r_try /= static_cast<double>(list.size());
        if ((r_try - target) * (prev_r - target) <= 0.0) {
            return fmt_double(prev_s + (target - prev_r) * (s_try - prev_s) / (r_try - prev_r));
        }
        prev_s = s_try;
        prev_r = r_try;
    }
    return "> 8";
}

// Band means of μ_s d and g over band b of one run, and of the fringe term (coherent minus
// incoherent two-face reflectance of the effective slab).
struct BandDiagnostics {
    double tau = 0.0, g = 0.0, fringe = 0.0;
};
BandDiagnostics band_diagnostics(const SeedRun& run, int b) {
    BandDiagnostics d;
    double count = 0.0;
    for (std::size_t i = 0; i < run.lambda_nm.size(); ++i) {
        if (band_of(run.lambda_nm[i]) != b) continue;
        const double t = run.mu_s[i] * run.thickness_um;
        d.tau += t;
        d.g += run.g[i];
        d.fringe += coherent_slab_reflectance(run.n_eff, run.thickness_um, t, run.lambda_nm[i]) -
                    incoherent_slab(run.n_eff, t).reflectance;
        count += 1.0;
    }
    d.tau /= count;
    d.g /= count;
    d.fringe /= count;
    return d;
}

// Seed means of Meep's and the pipeline's R (and the variance of the latter's mean): every
// run of a polarisation shares the CSV's wavelength grid.
struct SeedMean {
    std::vector<double> meep, pipe, pipe_var;
};
SeedMean seed_mean(const std::vector<SeedRun>& list) {
    const SeedRun& first = list.front();
    const std::size_t m = first.lambda_nm.size();
    const double n = static_cast<double>(list.size());
    SeedMean mean{std::vector<double>(m, 0.0), std::vector<double>(m, 0.0),
                  std::vector<double>(m, 0.0)};
    for (const SeedRun& run : list) {
        EXPECT_EQ(run.lambda_nm.size(), m);
        for (std::size_t i = 0; i < m && i < run.lambda_nm.size(); ++i) {
            EXPECT_NEAR(run.lambda_nm[i], first.lambda_nm[i], 1e-6);
            mean.meep[i] += run.meep_r[i] / n;
            mean.pipe[i] += run.pipe_r[i] / n;
            mean.pipe_var[i] += run.pipe_var[i] / (n * n);
        }
    }
    return mean;
}

TEST(Spongy2dReference, PipelineAgainstMeep) {
    const fs::path dir = reference_dir();
    const MeepData meep = read_meep(dir / "reflectance.csv");
    ASSERT_FALSE(meep.empty());
    const std::map<int, Field> fields = read_fields(dir);
    ASSERT_FALSE(fields.empty());
    const std::map<std::string, std::vector<SeedRun>> runs =
        pipeline_runs(meep, fields, kKeratin, 0.02);

    for (const auto& [pol, list] : runs) {
        print_seeds(pol, list);
        const SeedRun& first = list.front();
        const std::size_t m = first.lambda_nm.size();
        const SeedMean mean = seed_mean(list);
        const std::vector<double>& meep_mean = mean.meep;
        const std::vector<double>& pipe_mean = mean.pipe;
        const std::vector<double>& pipe_var = mean.pipe_var;
        std::vector<std::vector<double>> meep_bands;
        for (const SeedRun& run : list) meep_bands.push_back(band_means(run.lambda_nm, run.meep_r));
        const auto mb = band_means(first.lambda_nm, meep_mean);
        const auto pb = band_means(first.lambda_nm, pipe_mean);
        std::vector<double> count(8, 0.0), var_sum(8, 0.0);
        for (std::size_t i = 0; i < m; ++i) {
            count[band_of(first.lambda_nm[i])] += 1.0;
            var_sum[band_of(first.lambda_nm[i])] += pipe_var[i];
        }
        const double meep_peak = peak_nm(first.lambda_nm, meep_mean);
        const double pipe_peak = peak_nm(first.lambda_nm, pipe_mean);
        std::printf("\n%s, %zu seed(s): peak Meep %.1f nm, pipeline %.1f nm\n", pol.c_str(),
                    list.size(), meep_peak, pipe_peak);
        // The peak: Meep's seed-mean R is a plateau over ~405–465 nm with a maximum at 420–440
        // nm; the pipeline's R keeps rising to the 400-nm edge (README). The 10 nm is
        // not met; the recorded shift is asserted, so a change shows up.
        EXPECT_GT(meep_peak - pipe_peak, 10.0) << pol;
        EXPECT_LT(meep_peak - pipe_peak, 45.0) << pol;
        EXPECT_LE(pipe_peak, 415.0) << pol;
        std::printf(
            "| band (nm) | Meep R | pipeline R | difference | mu_s d | g | dlnR/dln mu_s | "
            "fringe dR | mu_s scale to match |\n|---|---|---|---|---|---|---|---|---|\n");
        for (int b = 0; b < 8; ++b) {
            double lo = mb[b], hi = mb[b];
            for (const auto& seed_bands : meep_bands) {
                lo = std::min(lo, seed_bands[b]);
                hi = std::max(hi, seed_bands[b]);
            }
            const double se = std::sqrt(var_sum[b]) / count[b];
            const double rel = pb[b] / mb[b] - 1.0;
            double se_seeds = NAN;  // standard error of Meep's seed mean
            if (meep_bands.size() > 1) {
                double ss = 0.0;
                for (const auto& seed_bands : meep_bands) ss += std::pow(seed_bands[b] - mb[b], 2);
                const double n = static_cast<double>(meep_bands.size());
                se_seeds = std::sqrt(ss / (n - 1.0) / n);
            }
            // d ln R / d ln μ_s from R at 1.5 μ_s: how much a band's R says about μ_s at all.
            double r_up = 0.0;
            for (const SeedRun& run : list) r_up += scaled_band_mean(run, b, 1.5, 2000);
            r_up /= static_cast<double>(list.size());
            const double sensitivity = std::log(r_up / pb[b]) / std::log(1.5);
            // Band means of μ_s d and g (seed 1 of the list), and the fringe term.
            const auto [tau, g, fringe] = band_diagnostics(first, b);
            const std::string scale = mu_s_scale_to_match(list, b, mb[b], pb[b]);
            std::printf(
                "| %d–%d | %.3f ± %.3f (SE %.3f) | %.3f ± %.3f | %+.1f %% | %.2f | %.2f | "
                "%.2f | %+.3f | %s |\n",
                400 + 50 * b, 450 + 50 * b, mb[b], 0.5 * (hi - lo), se_seeds, pb[b], se,
                100.0 * rel, tau, g, sensitivity, fringe, scale.c_str());
            const BandExpectation e = expectation(pol, b);
            const double mc = 3.0 * se / mb[b];  // 3 σ_MC, relative
            if (e.agrees) {
                EXPECT_LE(std::abs(rel), 0.15 + mc) << pol << " band " << b;
            } else {
                EXPECT_NEAR(rel, e.recorded, 0.08 + mc) << pol << " band " << b;
                EXPECT_GT(std::abs(rel), 0.15 - mc) << pol << " band " << b << " now agrees: "
                                                    << "update README.md and this table";
            }
        }
        std::printf("\n");
    }
}

// The same fields with keratin's index lowered to kLowContrastKeratin (Meep run in
// n1.10/): a weak scatterer, k0 |Δε| ℓ / n_eff ≈ 0.2 at 425 nm against ≈ 1.4 at n = 1.55, where
// first Born must hold. Here the criteria are asserted: per polarisation, the seed-mean
// peak within 10 nm, and every 50-nm band mean within 15 % plus three standard errors of the
// difference — the pipeline's Monte Carlo and Meep's realisation noise (the standard error of
// its seed mean: Meep sees each field's own |χ̂(q)|² at its few diffraction orders, whose
// power scatters like an exponential variate per mode, the Born route the orientation
// average S̄(|q|); with R ~ 0.003–0.06 that noise is 5–20 % of a red band). At this
// contrast the effective slab's faces reflect ~1e-3 each, so the coherent (thin-film) version
// of its ballistic beam is used for the comparison: the pipeline's R plus the difference
// between the coherent and the incoherent two-face reflectance (closed forms above), the part
// of R the transport model treats by intensity. That it is this test and not the n = 1.55 one
// that meets the criteria is what shows the n = 1.55 differences to be beyond first Born.
constexpr double kLowContrastKeratin = 1.10;
// Meep stopped these runs at a field decay of 1e-6 (not 1e-8: the weakly scattering slab keeps
// long-lived guided-mode resonances of the periodic cell, and its field stalls near 1e-7);
// 6 of the 1206 samples, at those resonances (seed 2 and 3, TE, 520–600 nm), have R + T off by
// 0.005–0.035. Their R enters the band means as measured.
constexpr double kLowContrastFluxTolerance = 0.04;

TEST(Spongy2dReference, LowContrastMeetsTheCriteria) {
    const fs::path dir = reference_dir();
    const MeepData meep = read_meep(dir / "n1.10" / "reflectance.csv");
    ASSERT_FALSE(meep.empty());
    const std::map<std::string, std::vector<SeedRun>> runs =
        pipeline_runs(meep, read_fields(dir), kLowContrastKeratin, kLowContrastFluxTolerance);
    for (const auto& [pol, list] : runs) {
        const SeedRun& first = list.front();
        const SeedMean mean = seed_mean(list);
        std::vector<double> pipe = mean.pipe;
        for (std::size_t i = 0; i < pipe.size(); ++i) {
            const double tau = first.mu_s[i] * first.thickness_um;
            pipe[i] += coherent_slab_reflectance(first.n_eff, first.thickness_um, tau,
                                                 first.lambda_nm[i]) -
                       incoherent_slab(first.n_eff, tau).reflectance;
        }
        const auto mb = band_means(first.lambda_nm, mean.meep);
        const auto pb = band_means(first.lambda_nm, pipe);
        std::vector<double> count(8, 0.0), var_sum(8, 0.0);
        for (std::size_t i = 0; i < pipe.size(); ++i) {
            count[band_of(first.lambda_nm[i])] += 1.0;
            var_sum[band_of(first.lambda_nm[i])] += mean.pipe_var[i];
        }
        const double meep_peak = peak_nm(first.lambda_nm, mean.meep);
        const double pipe_peak = peak_nm(first.lambda_nm, pipe);
        std::printf(
            "low contrast (n = %.2f) %s, %zu seed(s): n_eff %.4f, peak Meep %.1f nm, "
            "pipeline %.1f nm\n| band (nm) | Meep R ± SE (seeds) | pipeline R ± SE (MC) | "
            "difference "
            "|\n|---|---|---|---|\n",
            kLowContrastKeratin, pol.c_str(), list.size(), first.n_eff, meep_peak, pipe_peak);
        // Both rise to the 400-nm edge: the single-scattering Bragg wavelength 4π n_eff / q_peak
        // (≈ 378 nm at n_eff ≈ 1.05) lies below the range, so the peak criterion is met but says
        // little here; the band means carry the spectral shape.
        EXPECT_NEAR(pipe_peak, meep_peak, 10.0) << pol;
        std::vector<std::vector<double>> meep_bands;
        for (const SeedRun& run : list) meep_bands.push_back(band_means(run.lambda_nm, run.meep_r));
        const double n = static_cast<double>(list.size());
        for (int b = 0; b < 8; ++b) {
            const double se_pipe = std::sqrt(var_sum[b]) / count[b];
            double ss = 0.0;
            for (const auto& seed_bands : meep_bands) ss += std::pow(seed_bands[b] - mb[b], 2);
            const double se_meep = n > 1.0 ? std::sqrt(ss / (n - 1.0) / n) : 0.0;
            const double se = std::hypot(se_pipe, se_meep);
            const double rel = pb[b] / mb[b] - 1.0;
            std::printf("| %d–%d | %.4f ± %.4f | %.4f ± %.4f | %+.1f %% (%+.1f SE) |\n",
                        400 + 50 * b, 450 + 50 * b, mb[b], se_meep, pb[b], se_pipe, 100.0 * rel,
                        (pb[b] - mb[b]) / se);
            EXPECT_LE(std::abs(pb[b] - mb[b]), 0.15 * mb[b] + 3.0 * se) << pol << " band " << b;
        }
    }
}

}  // namespace
}  // namespace plumage::sim::wave
