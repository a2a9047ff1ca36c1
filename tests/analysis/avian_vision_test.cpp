// Avian vision against independent checks: the template's peak and width against Lamb's (1995)
// template (a separate published fit to the same pigments), the oil-droplet curve against the
// definitions of its parameters (T(λmid) = 1/2, slope B_mid), the RNL closed form against the
// generalised-least-squares form it reduces to and a case derived by hand, the model's
// invariances, and the first-order noise floor against a Monte Carlo of the same noise.
#include "analysis/metrics/avian_vision.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "common/error.h"

namespace plumage::analysis {
namespace {

// Lamb 1995 (Vision Res. 35:3083), Eq. 2': A 0.880, B 0.924, C 1.104, D 0.655, a 70, b 28.5,
// c −14.1, in x = λmax/λ.
double lamb1995(double lambda_max_nm, double lambda_nm) {
    const double x = lambda_max_nm / lambda_nm;
    return 1.0 / (std::exp(70.0 * (0.880 - x)) + std::exp(28.5 * (0.924 - x)) +
                  std::exp(-14.1 * (1.104 - x)) + 0.655);
}

// Full width at half maximum of f on a 0.01 nm walk from the peak.
template <typename F>
double fwhm(F f, double peak_nm) {
    const double half = 0.5 * f(peak_nm);
    double lo = peak_nm, hi = peak_nm;
    while (f(lo) > half) lo -= 0.01;
    while (f(hi) > half) hi += 0.01;
    return hi - lo;
}

double argmax(double lambda_max_nm, bool beta) {
    double best = 0.0, at = 0.0;
    for (double l = 300.0; l <= 800.0; l += 0.05) {
        const double v = govardovskii_a1(lambda_max_nm, l, beta);
        if (v > best) best = v, at = l;
    }
    return at;
}

TEST(AvianVision, TemplatePeaksAtLambdaMaxWithLambsWidth) {
    for (double lmax : {371.0, 448.0, 502.0, 563.0}) {
        // α band: peak at λmax (0.5 nm: the fitted constants put a 371 nm pigment's maximum
        // 0.3 nm short of it) and value 1 there (the template's normalisation, 0.2 %).
        EXPECT_NEAR(argmax(lmax, false), lmax, 0.5) << lmax;
        EXPECT_NEAR(govardovskii_a1(lmax, lmax, false), 1.0, 2e-3) << lmax;
    }
    // The β band (26 % at 189 + 0.315 λmax) moves a 502 nm peak by well under 1 nm.
    EXPECT_NEAR(argmax(502.0, true), 502.0, 1.0);
    // Width: Lamb's template and Govardovskii's agree on the α band for mid-spectrum pigments
    // (Govardovskii et al. changed the short-λmax behaviour only); 2 % of the FWHM.
    for (double lmax : {500.0, 563.0}) {
        const double g = fwhm([&](double l) { return govardovskii_a1(lmax, l, false); }, lmax);
        const double l = fwhm([&](double x) { return lamb1995(lmax, x); }, lmax);
        EXPECT_NEAR(g / l, 1.0, 0.02) << lmax << " nm: " << g << " against " << l;
        // λmax/λ invariance: the width in wavenumber is nearly the same for both pigments.
        EXPECT_GT(g, 80.0);
        EXPECT_LT(g, 140.0);
    }
}

TEST(AvianVision, OilDropletMatchesTheDefinitionsOfItsParameters) {
    for (auto [type, a, b] : {std::tuple{OilDroplet::clear_c, 0.99, 24.38},
                              std::tuple{OilDroplet::yellow_y, 0.90, 70.03},
                              std::tuple{OilDroplet::red_r, 0.99, 28.65}}) {
        const double cut = 500.0;
        const double mid = a * cut + b;
        const double b_mid = oil_droplet_b_mid(type, cut);
        // Half transmittance at λmid; slope B_mid there (the constants 2.89 and 1.08 of Hart &
        // Vorobyev give 0.4995 and 1.003 B_mid).
        EXPECT_NEAR(oil_droplet_transmittance(type, cut, mid), 0.5, 1e-3);
        const double h = 1e-3;
        const double slope = (oil_droplet_transmittance(type, cut, mid + h) -
                              oil_droplet_transmittance(type, cut, mid - h)) /
                             (2.0 * h);
        EXPECT_NEAR(slope / b_mid, 1.0, 5e-3);
        // Opaque well below λcut, clear well above.
        EXPECT_LT(oil_droplet_transmittance(type, cut, cut - 30.0), 1e-3);
        EXPECT_GT(oil_droplet_transmittance(type, cut, cut + 100.0), 0.98);
    }
    EXPECT_EQ(oil_droplet_transmittance(OilDroplet::transparent, 0.0, 350.0), 1.0);
}

// ΔS² = Δfᵀ W Δf, W = Σ⁻¹ − Σ⁻¹11ᵀΣ⁻¹/(1ᵀΣ⁻¹1): the generalised-least-squares form of the RNL
// model (the chromatic part of Δf after removing the best-fitting achromatic shift).
double gls_delta_s(const ConeVector& df, const ConeVector& omega) {
    ConeVector a{};
    double total = 0.0, weighted = 0.0;
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        a[i] = 1.0 / (omega[i] * omega[i]);
        total += a[i];
        weighted += a[i] * df[i];
    }
    double s2 = 0.0;
    for (std::size_t i = 0; i < kAvianCones; ++i) s2 += a[i] * df[i] * df[i];
    return std::sqrt(s2 - weighted * weighted / total);
}

ConeVector catches_from_log(const ConeVector& f) {
    ConeVector q{};
    for (std::size_t i = 0; i < kAvianCones; ++i) q[i] = std::exp(f[i]);
    return q;
}

TEST(AvianVision, ClosedFormEqualsTheGeneralFormAndTheHandDerivedSingleConeCase) {
    for (const AvianVisualSystem* system :
         {&ultraviolet_sensitive_system(), &violet_sensitive_system()}) {
        const ConeVector omega = receptor_noise(*system);
        // ω_LWS is the Weber fraction itself; the others scale with 1/√η.
        EXPECT_DOUBLE_EQ(omega[3], 0.1);
        const ConeVector base{0.3, 0.5, 0.7, 0.9};
        const ConeVector df{0.05, -0.02, 0.01, 0.03};
        ConeVector shifted{};
        for (std::size_t i = 0; i < kAvianCones; ++i) shifted[i] = std::log(base[i]) + df[i];
        const double closed = rnl_delta_s(catches_from_log(shifted), base, *system);
        EXPECT_NEAR(closed, gls_delta_s(df, omega), 1e-12 * (1.0 + closed));
        // One cone only (Δf = δ e_1): ΔS = δ / √(ω_1² + 1/Σ_{j≠1} ω_j⁻²) — by hand from W: the
        // part of the change an achromatic shift can absorb is not a colour difference, so the
        // distance is below δ/ω_1 (which holds only when the other cones are noiseless).
        const double delta = 0.04;
        double others = 0.0;
        for (std::size_t j = 1; j < kAvianCones; ++j) others += 1.0 / (omega[j] * omega[j]);
        const double expected = delta / std::sqrt(omega[0] * omega[0] + 1.0 / others);
        ConeVector one = base;
        one[0] *= std::exp(delta);
        EXPECT_NEAR(rnl_delta_s(one, base, *system), expected, 1e-12);
        EXPECT_LT(expected, delta / omega[0]);
    }
}

// The blue tit built from templates (Hart et al. 2000's λmax and droplet cut-offs): a system
// without a table, as a user would build for a bird pavo does not carry.
AvianVisualSystem template_blue_tit() {
    AvianVisualSystem s;
    s.name = "UVS (blue tit, templates)";
    s.source = "Hart et al. 2000 λmax and λcut; Govardovskii 2000; Hart & Vorobyev 2005";
    s.cones = {{{"UVS", 371.0, OilDroplet::transparent, 0.0, 1.0},
                {"SWS", 448.0, OilDroplet::clear_c, 413.0, 2.0},
                {"MWS", 502.0, OilDroplet::yellow_y, 507.0, 2.0},
                {"LWS", 563.0, OilDroplet::red_r, 572.0, 4.0}}};
    return s;
}

TEST(AvianVision, IdenticalSpectraAreZeroAndScalingChangesNothing) {
    const auto grid = optics::WavelengthGrid::uniform(300.0, 800.0, 5.0);
    std::vector<double> a(grid.size()), b(grid.size()), a2(grid.size()), b3(grid.size());
    for (std::size_t k = 0; k < grid.size(); ++k) {
        const double l = grid[k];
        a[k] = 0.2 + 0.5 * std::exp(-std::pow((l - 520.0) / 40.0, 2));  // a green peak
        b[k] = 0.2 + 0.5 * std::exp(-std::pow((l - 380.0) / 40.0, 2));  // a UV-violet peak
        a2[k] = 2.0 * a[k];
        b3[k] = 0.3 * b[k];
    }
    const AvianVisualSystem templates = template_blue_tit();
    for (const AvianVisualSystem* system :
         {&ultraviolet_sensitive_system(), &violet_sensitive_system(), &templates}) {
        const ConeCatches catches(*system, grid);
        EXPECT_EQ(rnl_delta_s(catches(a), catches(a), *system), 0.0);
        const double d = rnl_delta_s(catches(a), catches(b), *system);
        EXPECT_GT(d, 1.0) << system->name;  // green against UV-violet: clearly discriminable
        EXPECT_NEAR(rnl_delta_s(catches(a2), catches(b3), *system), d, 1e-9 * d);
        EXPECT_NEAR(rnl_delta_s(catches(a2), catches(a), *system), 0.0, 1e-9);
        // von Kries: a perfect white has q_i = 1 for every cone.
        const ConeVector white = catches(std::vector<double>(grid.size(), 1.0));
        for (double q : white) EXPECT_NEAR(q, 1.0, 1e-12);
    }
    // The UVS bird tells the UV peak from the same peak moved to 420 nm better than the VS bird.
    std::vector<double> violet(grid.size());
    for (std::size_t k = 0; k < grid.size(); ++k) {
        violet[k] = 0.2 + 0.5 * std::exp(-std::pow((grid[k] - 420.0) / 40.0, 2));
    }
    const ConeCatches uvs(ultraviolet_sensitive_system(), grid),
        vs(violet_sensitive_system(), grid);
    EXPECT_GT(rnl_delta_s(uvs(b), uvs(violet), ultraviolet_sensitive_system()),
              rnl_delta_s(vs(b), vs(violet), violet_sensitive_system()));
}

TEST(AvianVision, DoubleConeContrastIsTheLogRatioOverItsWeberFraction) {
    const auto grid = optics::WavelengthGrid::uniform(300.0, 700.0, 25.0);
    std::vector<double> a(grid.size()), half(grid.size());
    for (std::size_t k = 0; k < grid.size(); ++k) {
        a[k] = 0.1 + 0.4 * (grid[k] - 300.0) / 400.0;
        half[k] = 0.5 * a[k];
    }
    for (const char* name : {"bluetit", "pfowl", "avg.uv", "avg.v"}) {
        const AvianVisualSystem& system = pavo_visual_system(name);
        const ConeCatches catches(system, grid);
        // von Kries: white catches 1; halving the light is ln 2 / 0.1 = 6.93 JND, whatever the
        // spectrum, and no colour.
        EXPECT_NEAR(catches.double_cone(std::vector<double>(grid.size(), 1.0)), 1.0, 1e-12);
        EXPECT_NEAR(achromatic_contrast(catches.double_cone(a), catches.double_cone(half), system),
                    std::log(2.0) / 0.1, 1e-9)
            << name;
        EXPECT_NEAR(rnl_delta_s(catches(a), catches(half), system), 0.0, 1e-9) << name;
    }
    EXPECT_THROW(ConeCatches(template_blue_tit(), grid).double_cone(a), InputError);
}

// pavo sums on whole nanometres after interpolating linearly: a spectrum that is linear between
// the grid's points gives the same catches on its 25 nm samples as on all 401 nanometres.
TEST(AvianVision, CatchesAreTheOneNanometreSumOfTheInterpolatedSpectrum) {
    const auto coarse = optics::WavelengthGrid::uniform(300.0, 700.0, 25.0);
    const auto fine = optics::WavelengthGrid::uniform(300.0, 700.0, 1.0);
    auto zigzag = [](double l) {  // piecewise linear with kinks on the 25 nm grid
        const double phase = std::fmod(l - 300.0, 50.0);
        return 0.2 + 0.01 * (phase <= 25.0 ? phase : 50.0 - phase) + 0.0005 * (l - 300.0);
    };
    std::vector<double> r_coarse, r_fine;
    for (double l : coarse.nm()) r_coarse.push_back(zigzag(l));
    for (double l : fine.nm()) r_fine.push_back(zigzag(l));
    for (const char* name : {"bluetit", "pfowl"}) {
        const AvianVisualSystem& system = pavo_visual_system(name);
        const ConeVector a = ConeCatches(system, coarse)(r_coarse);
        const ConeVector b = ConeCatches(system, fine)(r_fine);
        for (std::size_t i = 0; i < kAvianCones; ++i) EXPECT_NEAR(a[i], b[i], 1e-12) << name;
    }
}

TEST(AvianVision, CapturedShareSaysWhatAGridStartingAt400MissesOfTheUvCone) {
    const ConeCatches full(ultraviolet_sensitive_system(),
                           optics::WavelengthGrid::uniform(300.0, 800.0, 10.0));
    for (double s : full.captured_share()) EXPECT_NEAR(s, 1.0, 1e-12);
    const ConeCatches visible(ultraviolet_sensitive_system(),
                              optics::WavelengthGrid::uniform(400.0, 700.0, 25.0));
    EXPECT_LT(visible.captured_share()[0], 0.5);  // most of a 371 nm cone's light is below 400
    EXPECT_GT(visible.captured_share()[3], 0.95);
}

TEST(AvianVision, FirstOrderNoiseFloorMatchesMonteCarlo) {
    const auto grid = optics::WavelengthGrid::uniform(300.0, 800.0, 20.0);
    const AvianVisualSystem& system = ultraviolet_sensitive_system();
    const ConeCatches catches(system, grid);
    std::vector<double> r(grid.size()), sigma(grid.size());
    for (std::size_t k = 0; k < grid.size(); ++k) {
        r[k] = 0.3 + 0.2 * std::sin(grid[k] / 40.0);
        sigma[k] = 0.01 * r[k];
    }
    const double floor = rnl_noise_floor(catches.log_catch_covariance(r, sigma), system);
    std::mt19937_64 rng(7);  // test-only stream, fixed
    std::normal_distribution<double> normal;
    constexpr int kDraws = 4000;
    double sum2 = 0.0;
    const ConeVector q = catches(r);
    std::vector<double> noisy(r.size());
    for (int d = 0; d < kDraws; ++d) {
        for (std::size_t k = 0; k < r.size(); ++k) noisy[k] = r[k] + sigma[k] * normal(rng);
        const double s = rnl_delta_s(catches(noisy), q, system);
        sum2 += s * s;
    }
    // ΔS² is a sum of three squared normals: its mean has relative standard error √(2/3)/√N
    // (1.3 % for 4000 draws); 5 % is 4 σ, and the first-order error at σ/R = 1 % is ~1e-4.
    EXPECT_NEAR(std::sqrt(sum2 / kDraws) / floor, 1.0, 0.05);
}

TEST(AvianVision, RejectsWhatItCannotModel) {
    EXPECT_THROW(govardovskii_a1(250.0, 400.0), InputError);
    EXPECT_THROW(oil_droplet_b_mid(OilDroplet::transparent, 400.0), InputError);
    EXPECT_THROW(ConeCatches(ultraviolet_sensitive_system(),
                             optics::WavelengthGrid::uniform(290.0, 700.0, 10.0)),
                 InputError);
}

}  // namespace
}  // namespace plumage::analysis
