// Fits that find the truth or say they did not (analysis/fits/filip2024_fit.h, huang2022_fit.h,
// fit_summary.h's fit_warnings): data made from known parameters drawn at random over the
// models' ranges, with Gaussian noise of known σ, fitted from a blind start (the model's
// defaults, not the truth). A set is recovered when every free parameter lies within 3σ of its
// true value (σ: the fit's own standard error). With exact Gaussian errors the chance that all
// p parameters of a set do is 0.9973^p (95.3 % for Filip's 18, 98.7 % for Huang's 5): ≥ 19 of
// 20 is what a perfect fit achieves most of the time. A fit that stops above the truth's χ² (a
// local minimum) must be flagged by a warning, and so must every fit with χ²/dof > 3. Filip's
// fit reaches 20 of 20 (and 96 of 100 on another seed, every miss a 3.0–3.9σ excursion at the
// global minimum); Huang's 20 of 20 (16 with its grid alone: huang2022_fit.h).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/fits/filip2024_fit.h"
#include "analysis/fits/fit_summary.h"
#include "analysis/fits/huang2022_fit.h"
#include "analysis/models/filip2024.h"
#include "analysis/models/huang2022.h"
#include "common/constants.h"
#include "sim/scatterer/random.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::analysis {
namespace {

constexpr int kSets = 20;
constexpr double kNoise = 0.02;  // relative σ of every observation

double gaussian(Rng& rng) {
    const double u1 = 1.0 - rng.uniform(), u2 = rng.uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

// ---- Filip 2024 --------------------------------------------------------------------------------

using FilipValues = std::array<double, kFilip2024ParameterCount>;

// Uniform over the range Table 1's four presets span, parameter by parameter (θmax and the scale
// as the presets have them).
FilipValues random_filip_parameters(Rng& rng) {
    FilipValues lo = to_vector(filip2024_preset("parrot")), hi = lo;
    for (const auto name : filip2024_preset_names()) {
        const FilipValues v = to_vector(filip2024_preset(name));
        for (int i = 0; i < kFilip2024ParameterCount; ++i) {
            lo[i] = std::min(lo[i], v[i]);
            hi[i] = std::max(hi[i], v[i]);
        }
    }
    FilipValues v{};
    for (int i = 0; i < kFilip2024ParameterCount; ++i)
        v[i] = lo[i] + (hi[i] - lo[i]) * rng.uniform();
    return v;
}

// The Filip set's 3660 pairs × R, G, B with relative noise kNoise (σ stated per observation);
// noise 0: the exact model with the same σ.
std::vector<BrdfObservation> filip_data(const FilipValues& truth, Rng& rng, double noise) {
    const Filip2024Brdf brdf(from_vector(truth));
    std::vector<BrdfObservation> data;
    for (const auto& pair : gonio::filip2024_btf_pairs()) {
        for (RgbChannel c : {RgbChannel::kRed, RgbChannel::kGreen, RgbChannel::kBlue}) {
            const double f = brdf.eval_rgb(pair.wi, pair.wo, c);
            const double z = gaussian(rng);
            data.push_back({pair.wi, pair.wo, c, std::nullopt, f * (1.0 + noise * z), kNoise * f});
        }
    }
    return data;
}

double filip_chi_square(const std::vector<BrdfObservation>& data, const FilipValues& values) {
    const Filip2024Brdf brdf(from_vector(values));
    double sum = 0.0;
    for (const BrdfObservation& o : data) {
        const double r = (brdf.eval_rgb(o.wi, o.wo, *o.channel) - o.value) / *o.standard_error;
        sum += r * r;
    }
    return sum;
}

struct Recovery {
    bool every_parameter_within_3_sigma = true;
    double worst_z = 0.0;
    std::string worst;
};

Recovery filip_recovery(const Filip2024FitResult& fit, const FilipValues& truth) {
    Recovery r;
    for (int i : fit.free_parameters) {
        double error = fit.values[i] - truth[i];
        if (i == kFilipPhiA) error = std::remainder(error, kPi);  // φa is defined modulo π
        const double z = std::abs(error) / fit.standard_errors[i];
        if (!(z <= 3.0)) r.every_parameter_within_3_sigma = false;
        if (!(z <= r.worst_z)) {
            r.worst_z = z;
            r.worst = std::string(kFilip2024ParameterTable[i].name);
        }
    }
    // A parameter held on its bound by the active set has no σ: recovered when it is the truth's
    // bound value to 1 % of its range.
    for (int i = 0; i < kFilip2024ParameterCount; ++i) {
        if (!fit.at_bound[i]) continue;
        const auto& info = kFilip2024ParameterTable[i];
        if (std::abs(fit.values[i] - truth[i]) > 0.01 * (info.max - info.min))
            r.every_parameter_within_3_sigma = false;
    }
    return r;
}

FitSummary filip_summary(const Filip2024FitResult& fit) {
    FitProvenance provenance;
    provenance.standard_errors = true;
    return summarise_fit(fit, Filip2024FitOptions{}, provenance);
}

TEST(FitRecovery, FilipFromBlindStartsOverThePresetsRanges) {
    int recovered = 0, unflagged_failures = 0;
    for (int set = 0; set < kSets; ++set) {
        Rng rng(kDefaultSeed, 7000 + static_cast<std::uint64_t>(set));
        const FilipValues truth = random_filip_parameters(rng);
        const std::vector<BrdfObservation> data = filip_data(truth, rng, kNoise);
        const Filip2024FitResult fit = fit_filip2024(data, Filip2024Parameters{});
        const FitSummary summary = filip_summary(fit);
        const Recovery r = filip_recovery(fit, truth);
        const double truth_chi_square = filip_chi_square(data, truth);
        const bool local_minimum = fit.chi_square > truth_chi_square;
        recovered += r.every_parameter_within_3_sigma;
        const bool flagged = !summary.warnings.empty();
        if ((local_minimum || !r.every_parameter_within_3_sigma) && !flagged) ++unflagged_failures;
        std::printf(
            "[ info ] set %2d: chi2/dof %.3f (truth's %.3f), %d runs, worst %s at %.2f sigma%s%s\n",
            set, fit.reduced_chi_square, truth_chi_square / fit.degrees_of_freedom, fit.local_fits,
            r.worst.c_str(), r.worst_z, r.every_parameter_within_3_sigma ? "" : "  NOT RECOVERED",
            flagged ? "  (warned)" : "");
        EXPECT_FALSE(local_minimum && !flagged)
            << "set " << set << ": a local minimum (chi2 " << fit.chi_square
            << " above the truth's " << truth_chi_square << ") without a warning";
        if (fit.reduced_chi_square > kFitWarningReducedChiSquare) {
            EXPECT_TRUE(flagged) << set;
        }
    }
    RecordProperty("recovered", fmt::format("{} of {}", recovered, kSets));
    std::printf("[ info ] recovered %d of %d sets; %d failures without a warning\n", recovered,
                kSets, unflagged_failures);
    EXPECT_GE(recovered, 19);
}

// The case: a true parameter on its bound (the rooster's γ = 0), noise-free data, the
// fit started at the truth. The logistic map alone left it (χ²/dof 0.11); the active set holds
// γ on the bound and returns the truth, with a warning that γ is on its bound. The global stage
// also finds the rooster's exact twin (γ = 1, 2 C_r, C_s + 2 C_r: filip2024_fit.h) and says that
// the data do not decide between the two.
TEST(FitRecovery, FilipKeepsATrueParameterOnItsBound) {
    const FilipValues truth = to_vector(filip2024_preset("rooster"));
    ASSERT_EQ(truth[kFilipGamma], 0.0);
    Rng rng(kDefaultSeed, 7100);
    const std::vector<BrdfObservation> data = filip_data(truth, rng, 0.0);
    Filip2024FitOptions local;
    local.global_starts = 0;
    const Filip2024FitResult fit = fit_filip2024(data, from_vector(truth), local);
    EXPECT_LT(fit.reduced_chi_square, 1e-20);
    EXPECT_TRUE(fit.at_bound[kFilipGamma]);
    EXPECT_EQ(fit.values[kFilipGamma], 0.0);
    for (int i = 0; i < kFilip2024ParameterCount; ++i)
        EXPECT_NEAR(fit.values[i], truth[i], 1e-9) << kFilip2024ParameterTable[i].name;
    const FitSummary s = filip_summary(fit);
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_NE(s.warnings[0].find("gamma = 0 1 is on a bound"), std::string::npos) << s.warnings[0];

    const Filip2024FitResult global = fit_filip2024(data, from_vector(truth));
    EXPECT_LT(global.reduced_chi_square, 1e-20);
    const FitSummary g = filip_summary(global);
    std::string all;
    for (const auto& w : g.warnings) all += w + "\n";
    EXPECT_NE(all.find("do not decide"), std::string::npos) << all;
    EXPECT_NE(all.find("gamma"), std::string::npos) << all;
}

// Each of Table 1's presets as the truth, noisy, from the default (parrot) start: before the
// global stage the rooster ended at χ²/dof 26.5 with φa 757σ off, reported converged.
TEST(FitRecovery, FilipFindsEveryPresetFromTheDefaultStart) {
    int set = 0;
    for (const auto name : filip2024_preset_names()) {
        Rng rng(kDefaultSeed, 7200 + static_cast<std::uint64_t>(set++));
        const FilipValues truth = to_vector(filip2024_preset(name));
        const std::vector<BrdfObservation> data = filip_data(truth, rng, kNoise);
        const Filip2024FitResult fit = fit_filip2024(data, Filip2024Parameters{});
        EXPECT_LE(fit.chi_square, filip_chi_square(data, truth)) << name;
        EXPECT_NEAR(fit.reduced_chi_square, 1.0, 5.0 * std::sqrt(2.0 / fit.degrees_of_freedom))
            << name;
        const double phi_error = std::remainder(fit.values[kFilipPhiA] - truth[kFilipPhiA], kPi);
        EXPECT_LT(std::abs(phi_error), 3.0 * fit.standard_errors[kFilipPhiA]) << name;
    }
}

// ---- Huang 2022 --------------------------------------------------------------------------------

// The ranges drawn from: the rock-dove values (the model's defaults) ± 30–60 %, where the arcs'
// ends stay hidden under the neighbours (H below the arc's width), so φ0 and φ1 are held as the
// rock-dove study holds them.
struct HuangRange {
    int index;
    double min, max;
};
constexpr std::array<HuangRange, 5> kHuangRanges = {{{kHuangB, 0.15, 0.40},
                                                     {kHuangH, 1.00, 1.50},
                                                     {kHuangD, 0.40, 0.80},
                                                     {kHuangThetaD, 0.05, 0.12},
                                                     {kHuangMu, -0.50, -0.20}}};

// A beam 20° off the normal from −x, 21 × 21 pixels, three wavelengths; σ_k = 2 % of the pixel
// plus 0.2 % of the brightest (background-subtracted data: negative values occur and are fitted).
gonio::Scatterogram huang_data(const Huang2022Params& truth, Rng& rng,
                               const HuangFitOptions& options) {
    gonio::ScatterometerConfig c;
    c.illumination = gonio::Illumination::beam;
    const double t = 20.0 * kDeg;
    c.beam_direction = Vec3d(-std::sin(t), 0.0, std::cos(t));
    c.image_size = 21;
    c.wavelengths_nm = {450.0, 550.0, 650.0};
    gonio::Scatterogram data = huang2022_scatterogram(truth, c, options);
    const double brightest = *std::max_element(data.intensity.begin(), data.intensity.end());
    for (std::size_t k = 0; k < data.intensity.size(); ++k) {
        const double sigma = 0.02 * data.intensity[k] + 0.002 * brightest;
        data.standard_error[k] = sigma;
        data.intensity[k] += sigma * gaussian(rng);
    }
    return data;
}

TEST(FitRecovery, HuangFromBlindStartsOverTheRockDoveRanges) {
    HuangFitOptions options;
    options.fixed = {"phi0", "phi1"};
    options.every_pixel_with_sigma = true;
    options.relative_error_floor = 0.0;  // σ is known exactly and the model is the data's
    int recovered = 0, unflagged_failures = 0, negative_pixels = 0;
    double seconds = 0.0;
    for (int set = 0; set < kSets; ++set) {
        Rng rng(kDefaultSeed, 7300 + static_cast<std::uint64_t>(set));
        Huang2022Params truth;
        auto truth_values = huang2022_values(truth);
        for (const HuangRange& r : kHuangRanges)
            truth_values[r.index] = r.min + (r.max - r.min) * rng.uniform();
        truth = huang2022_params(truth_values);
        const gonio::Scatterogram data = huang_data(truth, rng, options);
        negative_pixels += static_cast<int>(std::count_if(
            data.intensity.begin(), data.intensity.end(), [](double v) { return v < 0.0; }));
        const HuangFitResult fit = fit_huang2022(data, Huang2022Params{}, options);
        seconds += fit.wall_time_s;
        FitProvenance provenance;
        provenance.standard_errors = true;
        const FitSummary summary = summarise_fit(fit, options, provenance);
        bool within = true;
        double worst_z = 0.0;
        std::string worst;
        for (int i : fit.free_parameters) {
            const double z = std::abs(fit.values[i] - truth_values[i]) / fit.standard_errors[i];
            if (!(z <= 3.0)) within = false;
            if (!(z <= worst_z)) {
                worst_z = z;
                worst = std::string(kHuang2022ParameterNames[i]);
            }
        }
        const double truth_chi_square = huang2022_fit_chi_square(data, truth, options);
        const bool local_minimum = fit.chi_square > truth_chi_square;
        const bool flagged = !summary.warnings.empty();
        recovered += within;
        if ((local_minimum || !within) && !flagged) ++unflagged_failures;
        std::printf(
            "[ info ] set %2d: chi2/dof %.3f (truth's %.3f), %d runs, %.1f s, worst %s at %.2f "
            "sigma%s%s\n",
            set, fit.reduced_chi_square, truth_chi_square / fit.degrees_of_freedom, fit.local_fits,
            fit.wall_time_s, worst.c_str(), worst_z, within ? "" : "  NOT RECOVERED",
            flagged ? "  (warned)" : "");
        EXPECT_FALSE(local_minimum && !flagged)
            << "set " << set << ": a local minimum (chi2 " << fit.chi_square
            << " above the truth's " << truth_chi_square << ") without a warning";
        if (fit.reduced_chi_square > kFitWarningReducedChiSquare) {
            EXPECT_TRUE(flagged) << set;
        }
    }
    RecordProperty("recovered", fmt::format("{} of {}", recovered, kSets));
    std::printf(
        "[ info ] recovered %d of %d sets; %d failures without a warning; %d negative pixels "
        "fitted; %.0f s of fits\n",
        recovered, kSets, unflagged_failures, negative_pixels, seconds);
    EXPECT_GT(negative_pixels, 0);
    EXPECT_EQ(unflagged_failures, 0);
    EXPECT_GE(recovered, 19);  // measured: 20 (16 without the scans of huang2022_fit.h)
}

}  // namespace
}  // namespace plumage::analysis
