// Statistical checks every Scatterer with eval() and pdf() should pass (the tests pbrt-v4 and
// Mitsuba 3 run on every BSDF):
//
//  1. chi_square_test(): does sample() draw ωo from the density pdf() reports? (pbrt-v4's
//     bsdfs_test.cpp recipe.) N quanta from one ωi are binned on the sphere, cos θ × φ
//     (cos θ bins have equal solid angle, so a flat density fills them evenly); the expected count
//     of a bin is N ∫_bin pdf dω by composite Gauss–Legendre quadrature (nodes never on a bin
//     edge, so a density that jumps at the patch plane costs no accuracy); quanta that the
//     scatterer absorbs (no event) or that belong to a discrete lobe (options.outside_density,
//     e.g. Huang's T lobe) fill one extra cell whose expectation is N (1 − ∫ pdf). Cells expected
//     to hold fewer than 5 are pooled; a quantum in a cell of zero expectation fails at once.
//     The p-value of Pearson's statistic (regularized incomplete gamma, below) is compared with
//     the significance 0.01, Šidák-corrected for the number of incident directions tested:
//     1 − (1 − 0.01)^(1/m). On failure the observed and expected histograms are written to a
//     file named in the result.
//  2. eval_pdf_consistency(): (a) every sampled weight equals f |cos θo| / pdf at its ωo, to
//     round-off; (b) the Monte Carlo estimate of ∫ f |cos θo| dωo (mean weight) agrees with
//     deterministic quadrature of eval() within 4 standard errors of the Monte Carlo mean plus the
//     quadrature's own error estimate, in total and per lobe (the lobe a quantum reports).
//
// Usable for any Scatterer: nothing here knows about a particular model.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/metrics/statistics.h"
#include "sim/scatterer/random.h"
#include "sim/scatterer/scatterer.h"

namespace plumage::testing {

// Named constants of the recipe (pbrt-v4 uses the same significance and pooling threshold).
inline constexpr double kChiSquareSignificance = 0.01;  // family-wise, before Šidák
inline constexpr double kChiSquareMinExpected = 5.0;    // cells below are pooled
inline constexpr int kChiSquareCosThetaBins = 20;       // over [−1, 1]; even: z = 0 is an edge
inline constexpr int kChiSquarePhiBins = 40;            // over [0, 2π)
inline constexpr std::int64_t kChiSquareSamples = 400'000;
inline constexpr double kConsistencySigmas = 4.0;

// The distribution functions live in analysis/metrics/statistics.h (the studies use them too).
using analysis::chi_square_p_value;
using analysis::regularized_gamma_q;
using analysis::sidak_significance;

namespace detail {

inline constexpr std::array<double, 5> kGauss5Nodes = {-0.9061798459386640, -0.5384693101056831,
                                                       0.0, 0.5384693101056831, 0.9061798459386640};
inline constexpr std::array<double, 5> kGauss5Weights = {0.2369268850561891, 0.4786286704993665,
                                                         0.5688888888888889, 0.4786286704993665,
                                                         0.2369268850561891};
inline constexpr std::array<double, 3> kGauss3Nodes = {-0.7745966692414834, 0.0,
                                                       0.7745966692414834};
inline constexpr std::array<double, 3> kGauss3Weights = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};

inline Vec3d direction(double z, double phi) {
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {s * std::cos(phi), s * std::sin(phi), z};
}

// ∫ g dω over [z0, z1] × [phi0, phi1] (dω = dz dφ): `cells` sub-cells per axis, 5 × 5 nodes each.
template <typename G>
double integrate_cell(G&& g, double z0, double z1, double phi0, double phi1, int cells) {
    const double dz = (z1 - z0) / cells;
    const double dphi = (phi1 - phi0) / cells;
    double sum = 0.0;
    for (int iz = 0; iz < cells; ++iz) {
        for (int a = 0; a < 5; ++a) {
            const double z = z0 + (iz + 0.5 + 0.5 * kGauss5Nodes[a]) * dz;
            for (int ip = 0; ip < cells; ++ip) {
                for (int b = 0; b < 5; ++b) {
                    const double phi = phi0 + (ip + 0.5 + 0.5 * kGauss5Nodes[b]) * dphi;
                    sum += kGauss5Weights[a] * kGauss5Weights[b] * g(direction(z, phi));
                }
            }
        }
    }
    return sum * 0.25 * dz * dphi;
}

// Visits 3 × 3 Gauss nodes of every cell of each hemisphere (polar_cells in cos θ, twice as many
// in φ): visit(ωo, quadrature weight). The hemispheres are separate so z = 0 is an edge.
template <typename V>
void for_each_sphere_node(int polar_cells, V&& visit) {
    const int azimuth_cells = 2 * polar_cells;
    const double dz = 1.0 / polar_cells;
    const double dphi = 2.0 * std::numbers::pi / azimuth_cells;
    for (double sign : {1.0, -1.0}) {
        for (int iz = 0; iz < polar_cells; ++iz) {
            for (int a = 0; a < 3; ++a) {
                const double z = sign * (iz + 0.5 + 0.5 * kGauss3Nodes[a]) * dz;
                for (int ip = 0; ip < azimuth_cells; ++ip) {
                    for (int b = 0; b < 3; ++b) {
                        const double phi = (ip + 0.5 + 0.5 * kGauss3Nodes[b]) * dphi;
                        visit(direction(z, phi),
                              0.25 * dz * dphi * kGauss3Weights[a] * kGauss3Weights[b]);
                    }
                }
            }
        }
    }
}

inline std::filesystem::path default_dump_directory() {
    if (const char* dir = std::getenv("PLUMAGE_TEST_OUTPUT_DIR")) return dir;
    return std::filesystem::temp_directory_path();
}

}  // namespace detail

struct ChiSquareOptions {
    int cos_theta_bins = kChiSquareCosThetaBins;
    int phi_bins = kChiSquarePhiBins;
    std::int64_t samples = kChiSquareSamples;
    double family_significance = kChiSquareSignificance;
    int tests_in_family = 1;   // Šidák: the number of incident directions tested together
    int quadrature_cells = 3;  // per axis and bin, 5 Gauss nodes each
    std::uint64_t seed = kDefaultSeed;
    std::uint64_t stream = 0;
    std::string name = "scatterer";  // names the dump file
    std::filesystem::path dump_directory = detail::default_dump_directory();
    // Quanta that sample() returns but that pdf() does not describe (discrete lobes).
    std::function<bool(const ScatterEvent&)> outside_density;
};

struct ChiSquareResult {
    double statistic = 0.0;
    int degrees_of_freedom = 0;
    double p_value = 0.0;
    double threshold = 0.0;     // the Šidák-corrected per-test significance
    double density_mass = 0.0;  // ∫ pdf over the sphere (quadrature)
    bool passed = false;
    std::string failure;         // why, when not passed
    std::filesystem::path dump;  // histograms, written on failure
    std::string summary() const {
        return fmt::format(
            "chi2 = {:.1f}, dof = {}, p = {:.3g} (threshold {:.3g}), pdf mass {:.6f}{}{}",
            statistic, degrees_of_freedom, p_value, threshold, density_mass,
            failure.empty() ? "" : ": " + failure,
            dump.empty() ? "" : ", histograms in " + dump.string());
    }
};

namespace detail {

// The (cos θ, φ) cell of a direction on a grid of nz × nphi cells.
inline std::size_t sphere_cell(const Vec3d& wo, int nz, int nphi) {
    const double two_pi = 2.0 * std::numbers::pi;
    const int iz = std::clamp(static_cast<int>((wo.z() + 1.0) / 2.0 * nz), 0, nz - 1);
    double phi = std::atan2(wo.y(), wo.x());
    if (phi < 0.0) phi += two_pi;
    const int ip = std::clamp(static_cast<int>(phi / two_pi * nphi), 0, nphi - 1);
    return static_cast<std::size_t>(iz) * nphi + ip;
}

// Counts of sample()'s directions per cell, then the outside cell (absorbed or discrete quanta).
inline std::vector<double> observed_counts(const Scatterer& scatterer, const Vec3d& wi,
                                           double lambda_nm, const ChiSquareOptions& options) {
    const std::size_t bins = static_cast<std::size_t>(options.cos_theta_bins) * options.phi_bins;
    std::vector<double> observed(bins + 1, 0.0);
    Rng rng(options.seed, options.stream);
    const Vec2 position(0.0, 0.0);
    for (std::int64_t k = 0; k < options.samples; ++k) {
        const auto event = scatterer.sample(wi, lambda_nm, position, rng);
        if (!event || (options.outside_density && options.outside_density(*event))) {
            observed[bins] += 1.0;
            continue;
        }
        observed[sphere_cell(event->wo, options.cos_theta_bins, options.phi_bins)] += 1.0;
    }
    return observed;
}

// pdf()'s expected counts per cell and outside; `mass` gets pdf()'s integral over the sphere.
inline std::vector<double> expected_counts(const Scatterer& scatterer, const Vec3d& wi,
                                           double lambda_nm, const ChiSquareOptions& options,
                                           double& mass) {
    const int nz = options.cos_theta_bins, nphi = options.phi_bins;
    const double two_pi = 2.0 * std::numbers::pi;
    const auto n = static_cast<double>(options.samples);
    const std::size_t bins = static_cast<std::size_t>(nz) * nphi;
    std::vector<double> expected(bins + 1, 0.0);
    mass = 0.0;
    auto density = [&](const Vec3d& wo) { return scatterer.pdf(wi, wo, lambda_nm); };
    for (int iz = 0; iz < nz; ++iz) {
        for (int ip = 0; ip < nphi; ++ip) {
            const double cell_mass = integrate_cell(
                density, -1.0 + 2.0 * iz / nz, -1.0 + 2.0 * (iz + 1) / nz, two_pi * ip / nphi,
                two_pi * (ip + 1) / nphi, options.quadrature_cells);
            expected[static_cast<std::size_t>(iz) * nphi + ip] = n * cell_mass;
            mass += cell_mass;
        }
    }
    expected[bins] = n * std::max(0.0, 1.0 - mass);
    return expected;
}

// Pearson's statistic with pooling of the cells expected to hold fewer than kMinExpected:
// fills statistic, degrees of freedom and p-value, and a failure where quanta land where
// pdf() is zero.
inline void pooled_pearson(const std::vector<double>& observed, const std::vector<double>& expected,
                           double n, ChiSquareResult& result) {
    struct Cell {
        double observed, expected;
    };
    std::vector<Cell> cells;
    for (std::size_t i = 0; i < observed.size(); ++i) {
        if (expected[i] <= 0.0 && observed[i] > 0.0) {
            result.failure =
                fmt::format("{} quanta in a cell where pdf() integrates to {} (cell {})",
                            observed[i], expected[i] / n, i);
        }
        cells.push_back({observed[i], expected[i]});
    }
    std::sort(cells.begin(), cells.end(),
              [](const Cell& a, const Cell& b) { return a.expected < b.expected; });
    Cell pool{0.0, 0.0};
    std::size_t next = 0;
    while (next < cells.size() && cells[next].expected < kChiSquareMinExpected) {
        pool.observed += cells[next].observed;
        pool.expected += cells[next].expected;
        ++next;
    }
    int used_cells = 0;
    double statistic = 0.0;
    auto add = [&](const Cell& c) {
        statistic += (c.observed - c.expected) * (c.observed - c.expected) / c.expected;
        ++used_cells;
    };
    if (pool.expected > 0.0) {
        if (pool.expected < kChiSquareMinExpected && next < cells.size()) {
            cells[next].observed += pool.observed;  // too small even pooled: join the next cell
            cells[next].expected += pool.expected;
        } else {
            add(pool);
        }
    } else if (pool.observed > 0.0 && result.failure.empty()) {
        result.failure = fmt::format("{} quanta where pdf() is zero", pool.observed);
    }
    for (std::size_t i = next; i < cells.size(); ++i) add(cells[i]);

    result.statistic = statistic;
    result.degrees_of_freedom = used_cells - 1;
    result.p_value = result.degrees_of_freedom > 0
                         ? chi_square_p_value(statistic, result.degrees_of_freedom)
                         : 1.0;
}

// Where a failed test's histograms go.
inline std::filesystem::path histogram_file(const ChiSquareOptions& options) {
    return options.dump_directory / fmt::format("chi2_{}_{}.tsv", options.name, options.stream);
}

// The histograms of a failed test, one row per cell, for a look at where they differ.
inline void dump_histograms(const std::filesystem::path& dump, const Scatterer& scatterer,
                            const Vec3d& wi, double lambda_nm, const ChiSquareOptions& options,
                            const std::vector<double>& observed,
                            const std::vector<double>& expected, const std::string& summary) {
    const int nz = options.cos_theta_bins, nphi = options.phi_bins;
    const double two_pi = 2.0 * std::numbers::pi;
    const std::size_t bins = static_cast<std::size_t>(nz) * nphi;
    std::error_code ignored;
    std::filesystem::create_directories(options.dump_directory, ignored);
    std::ofstream out(dump);
    out << fmt::format("# {} wi = ({}, {}, {}) lambda = {} nm: {}\n", scatterer.name(), wi.x(),
                       wi.y(), wi.z(), lambda_nm, summary);
    out << "cos_theta_lo\tcos_theta_hi\tphi_lo\tphi_hi\tobserved\texpected\n";
    for (int iz = 0; iz < nz; ++iz) {
        for (int ip = 0; ip < nphi; ++ip) {
            const std::size_t i = static_cast<std::size_t>(iz) * nphi + ip;
            out << fmt::format("{}\t{}\t{}\t{}\t{}\t{}\n", -1.0 + 2.0 * iz / nz,
                               -1.0 + 2.0 * (iz + 1) / nz, two_pi * ip / nphi,
                               two_pi * (ip + 1) / nphi, observed[i], expected[i]);
        }
    }
    out << fmt::format("outside\t-\t-\t-\t{}\t{}\n", observed[bins], expected[bins]);
}

}  // namespace detail

inline ChiSquareResult chi_square_test(const Scatterer& scatterer, const Vec3d& wi,
                                       double lambda_nm, const ChiSquareOptions& options = {}) {
    const std::vector<double> observed = detail::observed_counts(scatterer, wi, lambda_nm, options);
    ChiSquareResult result;
    const std::vector<double> expected =
        detail::expected_counts(scatterer, wi, lambda_nm, options, result.density_mass);
    result.threshold = sidak_significance(options.family_significance, options.tests_in_family);
    detail::pooled_pearson(observed, expected, static_cast<double>(options.samples), result);
    if (result.failure.empty() && result.p_value < result.threshold) {
        result.failure = "sample() does not follow pdf()";
    }
    result.passed = result.failure.empty();
    if (!result.passed) {
        result.dump = detail::histogram_file(options);  // the summary names it
        detail::dump_histograms(result.dump, scatterer, wi, lambda_nm, options, observed, expected,
                                result.summary());
    }
    return result;
}

struct ConsistencyOptions {
    std::int64_t samples = 200'000;
    int polar_cells = 64;  // quadrature: per hemisphere in cos θ; twice as many in φ
    double sigmas = kConsistencySigmas;
    double weight_tolerance = 1e-9;  // relative, per sample
    std::uint64_t seed = kDefaultSeed;
    std::uint64_t stream = 0;
    std::function<bool(const ScatterEvent&)> outside_density;
};

struct ConsistencyResult {
    double mc_mean = 0.0;  // ∫ f |cos θo| dωo from sample() weights
    double mc_standard_error = 0.0;
    double quadrature = 0.0;        // the same from eval()
    double quadrature_error = 0.0;  // |Q(n) − Q(n/2)|
    std::vector<double> lobe_mc_mean, lobe_mc_standard_error, lobe_quadrature,
        lobe_quadrature_error;
    std::int64_t weight_mismatches = 0;  // samples with weight ≠ f |cos| / pdf
    double worst_weight_relative_error = 0.0;
    bool agrees = false;
    std::string failure;
    std::string summary() const {
        return fmt::format(
            "MC {:.6f} ± {:.2g}, quadrature {:.6f} (±{:.2g}), {} weight mismatches{}", mc_mean,
            mc_standard_error, quadrature, quadrature_error, weight_mismatches,
            failure.empty() ? "" : ": " + failure);
    }
};

namespace detail {

// Monte Carlo: mean and standard error of sample()'s weights, in total and per reported lobe,
// and every weight checked against f |cos θo| / pdf.
inline void sample_weights(const Scatterer& scatterer, const Vec3d& wi, double lambda_nm,
                           const ConsistencyOptions& options, ConsistencyResult& result) {
    const std::size_t lobes = scatterer.lobe_names().size();
    std::vector<double> sum(lobes, 0.0), sum_sq(lobes, 0.0);
    double total = 0.0, total_sq = 0.0;
    Rng rng(options.seed, options.stream);
    const Vec2 position(0.0, 0.0);
    for (std::int64_t k = 0; k < options.samples; ++k) {
        const auto event = scatterer.sample(wi, lambda_nm, position, rng);
        if (!event || (options.outside_density && options.outside_density(*event))) continue;
        const double f = scatterer.eval(wi, event->wo, lambda_nm);
        const double p = scatterer.pdf(wi, event->wo, lambda_nm);
        const double expected = p > 0.0 ? f * std::abs(event->wo.z()) / p : 0.0;
        const double error = std::abs(event->weight - expected);
        const double relative = error / std::max(std::abs(expected), 1e-300);
        if (error > options.weight_tolerance * std::abs(expected) + 1e-300) {
            ++result.weight_mismatches;
        }
        result.worst_weight_relative_error =
            std::max(result.worst_weight_relative_error, expected == 0.0 ? error : relative);
        total += event->weight;
        total_sq += event->weight * event->weight;
        const auto lobe = static_cast<std::size_t>(event->lobe);
        if (lobe < lobes) {
            sum[lobe] += event->weight;
            sum_sq[lobe] += event->weight * event->weight;
        }
    }
    const auto n = static_cast<double>(options.samples);
    auto mean_and_error = [n](double s, double s2) {
        const double mean = s / n;
        const double variance = std::max(0.0, s2 / n - mean * mean);
        return std::pair{mean, std::sqrt(variance / (n - 1.0))};
    };
    std::tie(result.mc_mean, result.mc_standard_error) = mean_and_error(total, total_sq);
    for (std::size_t l = 0; l < lobes; ++l) {
        const auto [m, e] = mean_and_error(sum[l], sum_sq[l]);
        result.lobe_mc_mean.push_back(m);
        result.lobe_mc_standard_error.push_back(e);
    }
}

// ∫ f |cos θo| dωo by quadrature of eval() at two resolutions, in total and per lobe; the
// difference estimates the error.
inline void quadrature_of_eval(const Scatterer& scatterer, const Vec3d& wi, double lambda_nm,
                               int polar_cells, ConsistencyResult& result) {
    const std::size_t lobes = scatterer.lobe_names().size();
    auto integrate = [&](int cells) {
        std::vector<double> acc(lobes + 1, 0.0);
        std::vector<double> per_lobe(lobes, 0.0);
        for_each_sphere_node(cells, [&](const Vec3d& wo, double weight) {
            const double f = scatterer.eval(wi, wo, lambda_nm, per_lobe);
            const double w = weight * std::abs(wo.z());
            acc[lobes] += w * f;
            for (std::size_t l = 0; l < lobes; ++l) acc[l] += w * per_lobe[l];
        });
        return acc;
    };
    const auto fine = integrate(polar_cells);
    const auto coarse = integrate(polar_cells / 2);
    result.quadrature = fine[lobes];
    result.quadrature_error = std::abs(fine[lobes] - coarse[lobes]);
    for (std::size_t l = 0; l < lobes; ++l) {
        result.lobe_quadrature.push_back(fine[l]);
        result.lobe_quadrature_error.push_back(std::abs(fine[l] - coarse[l]));
    }
}

// The first disagreement, in the order weights, total, lobes; empty when all agree.
inline std::string consistency_failure(const ConsistencyResult& result,
                                       const std::vector<std::string>& lobe_names, double sigmas) {
    // Summing 10⁵ weights costs ~1e-12 relative even when every weight is equal (σ = 0).
    constexpr double kRoundoff = 1e-10;
    auto agree = [&](double mc, double se, double quad, double quad_error) {
        return std::abs(mc - quad) <= sigmas * se + quad_error + kRoundoff * std::abs(quad);
    };
    if (result.weight_mismatches > 0) {
        return fmt::format("weights differ from f |cos| / pdf (worst relative {:.3g})",
                           result.worst_weight_relative_error);
    }
    if (!agree(result.mc_mean, result.mc_standard_error, result.quadrature,
               result.quadrature_error)) {
        return fmt::format("MC and quadrature differ by {:.3g} standard errors",
                           std::abs(result.mc_mean - result.quadrature) /
                               std::max(result.mc_standard_error, 1e-300));
    }
    for (std::size_t l = 0; l < lobe_names.size(); ++l) {
        if (!agree(result.lobe_mc_mean[l], result.lobe_mc_standard_error[l],
                   result.lobe_quadrature[l], result.lobe_quadrature_error[l])) {
            return fmt::format("lobe '{}': MC {:.6g} ± {:.2g} vs quadrature {:.6g} (±{:.2g})",
                               lobe_names[l], result.lobe_mc_mean[l],
                               result.lobe_mc_standard_error[l], result.lobe_quadrature[l],
                               result.lobe_quadrature_error[l]);
        }
    }
    return {};
}

}  // namespace detail

inline ConsistencyResult eval_pdf_consistency(const Scatterer& scatterer, const Vec3d& wi,
                                              double lambda_nm,
                                              const ConsistencyOptions& options = {}) {
    ConsistencyResult result;
    detail::sample_weights(scatterer, wi, lambda_nm, options, result);
    detail::quadrature_of_eval(scatterer, wi, lambda_nm, options.polar_cells, result);
    result.failure = detail::consistency_failure(result, scatterer.lobe_names(), options.sigmas);
    result.agrees = result.failure.empty();
    return result;
}

// Awkward directions: along and across every axis, in the patch plane, and random ones from
// both hemispheres; every eval and pdf must be finite and non-negative, and sample() must
// stay on the sphere with a finite, non-negative weight.
inline void expect_finite_everywhere(const Scatterer& model) {
    std::vector<Vec3d> directions = {Vec3d::UnitX(),
                                     -Vec3d::UnitX(),
                                     Vec3d::UnitY(),
                                     -Vec3d::UnitY(),
                                     Vec3d::UnitZ(),
                                     -Vec3d::UnitZ(),
                                     Vec3d(1, 1, 0).normalized(),
                                     Vec3d(0, 1, 1e-9).normalized()};
    Rng rng(kDefaultSeed, 990);
    for (int k = 0; k < 40; ++k) {
        directions.push_back(
            detail::direction(1.0 - 2.0 * rng.uniform(), 2.0 * std::numbers::pi * rng.uniform()));
    }
    for (const Vec3d& wi : directions) {
        const double lambda = 380.0 + 400.0 * rng.uniform();
        for (const Vec3d& wo : directions) {
            const double f = model.eval(wi, wo, lambda), p = model.pdf(wi, wo, lambda);
            ASSERT_TRUE(std::isfinite(f) && f >= 0.0) << wi.transpose() << " | " << wo.transpose();
            ASSERT_TRUE(std::isfinite(p) && p >= 0.0) << wi.transpose() << " | " << wo.transpose();
        }
        for (int k = 0; k < 200; ++k) {
            const auto e = model.sample(wi, lambda, Vec2(0, 0), rng);
            if (!e) continue;
            ASSERT_NEAR(e->wo.norm(), 1.0, 1e-12);
            ASSERT_TRUE(std::isfinite(e->weight) && e->weight >= 0.0);
        }
    }
}

}  // namespace plumage::testing
