// The imaging scatterometer: a Lambertian plate images as ρ cos θ / π under every
// illumination; a mirror does too under hemisphere light (which tests the sampled light
// directions); the per-pixel standard error matches the scatter over seeds; the image does
// not depend on the thread count; power is accounted for; Huang's T lobe leaves below the
// patch in the proportion Eq. 15 predicts; images and records are written.
#include "virtual_gonio/scatterometer.h"
#include "common/constants.h"

#include <omp.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "analysis/metrics/statistics.h"
#include "analysis/models/huang2022.h"
#include "analysis/models/lambertian.h"
#include "common/error.h"
#include "geometry/barbule.h"
#include "sim/tracer.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::gonio {
namespace {

TEST(Scatterometer, LambertianPlateImagesAsCosineUnderEveryIllumination) {
    const analysis::LambertianScatterer plate(0.7);
    for (Illumination mode : {Illumination::beam, Illumination::cone, Illumination::hemisphere}) {
        ScatterometerConfig c;
        c.illumination = mode;
        c.image_size = 33;
        c.wavelengths_nm = {550.0};
        c.quanta_per_pass = 400000;
        c.max_passes = 1;
        const Scatterogram s = measure_scatterogram(plate, c);
        double power = 0.0, worst = 0.0;
        for (int row = 0; row < c.image_size; ++row) {
            for (int column = 0; column < c.image_size; ++column) {
                const std::size_t p = static_cast<std::size_t>(row) * c.image_size + column;
                const auto w = s.direction(column, row);
                if (!w || s.solid_angle_sr[p] <= 0.0) continue;
                power += s.intensity[p] * s.solid_angle_sr[p];
                // Pixel-centre cos θ vs the pixel average: curvature error ≲ 1e-3 here.
                const double expected = 0.7 * w->z() / kPi;
                if (s.standard_error[p] > 0.0) {
                    worst = std::max(worst, std::abs(s.intensity[p] - expected) /
                                                (s.standard_error[p] + 2e-3 * expected));
                }
            }
        }
        // Pixels at the rim are cut by the disc edge: power within 2 % of ρ.
        EXPECT_NEAR(power, 0.7, 0.014) << static_cast<int>(mode);
        EXPECT_LT(worst, std::sqrt(2.0 * std::log(900.0 / 1e-3))) << static_cast<int>(mode);
    }
}

// A mirror of reflectance rho, optionally blurred: the reflected direction turned by a
// uniform angle up to blur_rad about a random axis. Its image follows the light's direction,
// so under hemisphere light it tests the illumination sampling (a Lambertian plate's image
// does not depend on where the light comes from).
class BlurredMirror final : public Scatterer {
public:
    BlurredMirror(double rho, double blur_rad) : rho_(rho), blur_(blur_rad) {}
    std::string name() const override { return "blurred mirror"; }
    const std::vector<std::string>& lobe_names() const override {
        static const std::vector<std::string> names = {"R"};
        return names;
    }
    std::optional<ScatterEvent> sample(const Vec3d& wi, double, const Vec2& position_um,
                                       Rng& rng) const override {
        Vec3d wo(-wi.x(), -wi.y(), wi.z());
        if (blur_ > 0.0) {
            Vec3d e1, e2;
            orthonormal_frame(wo, e1, e2);
            const double t = blur_ * rng.uniform(), a = 2.0 * kPi * rng.uniform();
            wo = std::cos(t) * wo + std::sin(t) * (std::cos(a) * e1 + std::sin(a) * e2);
        }
        return ScatterEvent{wo.normalized(), rho_, 0, position_um};
    }

private:
    double rho_, blur_;
};

// Pixels wholly inside the disc (a pixel cut by the rim catches less than its Ω says).
bool inside_disc(int column, int row, int n) {
    for (int dc : {0, 1}) {
        for (int dr : {0, 1}) {
            const double u = (column + dc) * 2.0 / n - 1.0, v = 1.0 - (row + dr) * 2.0 / n;
            if (std::hypot(u, v) >= 1.0) return false;
        }
    }
    return true;
}

// χ² of the image against ρ cos θ / π over the pixels inside the disc, with each pixel's
// own standard error (plus the pixel-centre curvature error, ≲ 2e-3 relative).
struct ChiSquare {
    double value = 0.0;
    int pixels = 0;
};
ChiSquare cosine_chi_square(const Scatterogram& s, double rho) {
    ChiSquare c;
    const int n = s.config.image_size;
    for (int row = 0; row < n; ++row) {
        for (int column = 0; column < n; ++column) {
            const auto w = s.direction(column, row);
            if (!w || !inside_disc(column, row, n)) continue;
            const std::size_t p = static_cast<std::size_t>(row) * n + column;
            const double expected = rho * w->z() / kPi;
            const double sigma2 = std::pow(s.standard_error[p], 2) + std::pow(2e-3 * expected, 2);
            c.value += std::pow(s.intensity[p] - expected, 2) / sigma2;
            ++c.pixels;
        }
    }
    return c;
}

// Hemisphere light on a 21-pixel image at 550 nm: the setting of the tests below.
ScatterometerConfig hemisphere_config(std::uint64_t quanta_per_pass, int passes, int strata) {
    ScatterometerConfig c;
    c.illumination = Illumination::hemisphere;
    c.image_size = 21;
    c.wavelengths_nm = {550.0};
    c.quanta_per_pass = quanta_per_pass;
    c.max_passes = passes;
    c.illumination_strata = strata;
    return c;
}

// Uniform radiance from the hemisphere on a mirror leaves as uniform radiance: I = ρ cos θ/π,
// whatever the number of light directions per pass (7: prime, one row of cells; 60: not a
// square, which the earlier square grid left partly unlit; 10 000), with 10 quanta each. The
// per-pixel σ treats a direction's quanta as one sample, so the mirror's fully correlated
// quanta do not make it too small: χ² over the pixels stays below its 99.9 % bound.
TEST(Scatterometer, MirrorUnderHemisphereLightImagesAsCosineForAnyStrata) {
    const BlurredMirror mirror(0.8, 0.0);
    for (int strata : {7, 60, 10000}) {
        SCOPED_TRACE(strata);
        // 10 quanta per direction, 20 000 directions in all.
        const ScatterometerConfig c =
            hemisphere_config(10 * static_cast<std::uint64_t>(strata), 20000 / strata, strata);
        const Scatterogram s = measure_scatterogram(mirror, c);
        const ChiSquare chi = cosine_chi_square(s, 0.8);
        ASSERT_GT(chi.pixels, 200);
        // Wilson–Hilferty: the 99.9 % quantile of χ²_k ≈ k (1 − 2/(9k) + 3.09 √(2/(9k)))³.
        const double k = chi.pixels, z = 3.09;
        const double bound =
            k * std::pow(1.0 - 2.0 / (9.0 * k) + z * std::sqrt(2.0 / (9.0 * k)), 3);
        EXPECT_LT(chi.value, bound) << "strata " << strata << ", " << chi.pixels << " pixels";
        EXPECT_GT(chi.value, 0.0);
    }
}

// The Lambertian plate under hemisphere light: χ² of the image against ρ cos θ/π within
// its 0.1 % bounds on both sides (here the quanta are independent, so σ is exact, not
// conservative).
TEST(Scatterometer, LambertianUnderHemisphereLightPassesChiSquare) {
    const analysis::LambertianScatterer plate(0.7);
    const ScatterometerConfig c = hemisphere_config(100000, 2, 10000);
    const Scatterogram s = measure_scatterogram(plate, c);
    const ChiSquare chi = cosine_chi_square(s, 0.7);
    const double k = chi.pixels;
    auto quantile = [&](double z) {
        return k * std::pow(1.0 - 2.0 / (9.0 * k) + z * std::sqrt(2.0 / (9.0 * k)), 3);
    };
    EXPECT_GT(chi.value, quantile(-3.09)) << chi.pixels << " pixels";
    EXPECT_LT(chi.value, quantile(3.09)) << chi.pixels << " pixels";
}

// Over independent seeds, the pixels' scatter matches the standard error each run reports:
// the mean of σ² over seeds against the variance of the intensity over seeds, pooled over
// the pixels with signal. A blurred mirror's image follows the light direction, and the 20
// quanta of each direction are correlated: counting them as independent samples would report
// σ² several times too small.
TEST(Scatterometer, StandardErrorMatchesTheScatterOverSeeds) {
    const BlurredMirror mirror(1.0, 0.25);
    constexpr int kSeeds = 24;
    ScatterometerConfig c = hemisphere_config(40000, 1, 2000);
    std::vector<double> sum, sum_sq, reported;
    for (int seed = 0; seed < kSeeds; ++seed) {
        c.seed = 1000 + static_cast<std::uint64_t>(seed);
        const Scatterogram s = measure_scatterogram(mirror, c);
        sum.resize(s.pixels(), 0.0), sum_sq.resize(s.pixels(), 0.0);
        reported.resize(s.pixels(), 0.0);
        for (std::size_t p = 0; p < s.pixels(); ++p) {
            sum[p] += s.intensity[p];
            sum_sq[p] += s.intensity[p] * s.intensity[p];
            reported[p] += s.standard_error[p] * s.standard_error[p] / kSeeds;
        }
    }
    double empirical = 0.0, estimated = 0.0;
    int pixels = 0;
    for (int row = 0; row < c.image_size; ++row) {
        for (int column = 0; column < c.image_size; ++column) {
            const std::size_t p = static_cast<std::size_t>(row) * c.image_size + column;
            if (!inside_disc(column, row, c.image_size)) continue;
            const double mean = sum[p] / kSeeds;
            empirical += (sum_sq[p] - kSeeds * mean * mean) / (kSeeds - 1);
            estimated += reported[p];
            ++pixels;
        }
    }
    ASSERT_GT(pixels, 200);
    // The pooled empirical variance has a relative error of about √(2/23)/√(pixels) ≈ 2 %
    // (neighbouring pixels are correlated: more). Pairs of neighbouring light directions
    // differ in mean where the lobe moves across a pixel, which makes the reported σ²
    // conservative: 1.5× here (σ 1.24×), the 2000 directions 9° apart in azimuth and a lobe
    // 14° wide on 8.6° pixels. Quanta counted as independent would report too small a σ².
    EXPECT_GT(estimated / empirical, 0.9);
    EXPECT_LT(estimated / empirical, 1.7);
}

// One thread or two: the same bits, for the Huang model (which caches a frame per thread and
// incident direction) and for the blurred mirror, under cone and hemisphere light.
TEST(Scatterometer, ImageIsBitIdenticalOnOneAndTwoThreads) {
    const analysis::Huang2022Bsdf model(analysis::Huang2022Params{});
    const BlurredMirror mirror(0.9, 0.2);
    const int threads = omp_get_max_threads();
    for (Illumination mode : {Illumination::cone, Illumination::hemisphere}) {
        for (const Scatterer* scatterer :
             {static_cast<const Scatterer*>(&model), static_cast<const Scatterer*>(&mirror)}) {
            ScatterometerConfig c;
            c.illumination = mode;
            c.image_size = 17;
            c.wavelengths_nm = {450.0, 600.0};
            c.quanta_per_pass = 6000;
            c.max_passes = 2;
            c.illumination_strata = 500;
            omp_set_num_threads(1);
            const Scatterogram one = measure_scatterogram(*scatterer, c);
            omp_set_num_threads(2);
            const Scatterogram two = measure_scatterogram(*scatterer, c);
            omp_set_num_threads(threads);
            EXPECT_EQ(one.intensity, two.intensity) << scatterer->name();
            EXPECT_EQ(one.standard_error, two.standard_error) << scatterer->name();
            EXPECT_EQ(one.lobe_intensity, two.lobe_intensity) << scatterer->name();
            EXPECT_EQ(one.transmitted, two.transmitted) << scatterer->name();
        }
    }
}

// The median relative error: cells above the fraction of their wavelength's peak; the lower
// median; NaN without signal.
TEST(Scatterometer, MedianRelativeStandardErrorOverCellsWithSignal) {
    Scatterogram s;
    s.config.image_size = 9;
    s.config.wavelengths_nm = {500.0, 600.0};
    const std::size_t nl = 2;
    s.solid_angle_sr.assign(s.pixels(), 0.0);
    s.intensity.assign(s.pixels() * nl, 0.0);
    s.standard_error.assign(s.pixels() * nl, 0.0);
    EXPECT_TRUE(std::isnan(median_relative_standard_error(s, 0.01)));
    // Pixels 40..43 in the disc; wavelength 0 peaks at 10, wavelength 1 at 1000.
    const std::array<double, 4> i0 = {10.0, 5.0, 0.05, 1.0}, e0 = {1.0, 1.5, 0.05, 0.5};
    const std::array<double, 4> i1 = {1000.0, 20.0, 5.0, 0.0}, e1 = {10.0, 2.0, 5.0, 0.0};
    for (std::size_t j = 0; j < 4; ++j) {
        const std::size_t p = 40 + j;
        s.solid_angle_sr[p] = 0.1;
        s.intensity[p * nl] = i0[j], s.standard_error[p * nl] = e0[j];
        s.intensity[p * nl + 1] = i1[j], s.standard_error[p * nl + 1] = e1[j];
    }
    s.intensity[0] = 1e6;  // outside the disc: neither a peak nor a cell
    // Above 1 %: wavelength 0 cells 10, 5, 1 (σ/I 0.1, 0.3, 0.5); wavelength 1 cells 1000 and
    // 20 (0.01, 0.1); 5 is below 10. Sorted 0.01, 0.1, 0.1, 0.3, 0.5: median 0.1.
    EXPECT_DOUBLE_EQ(median_relative_standard_error(s, 0.01), 0.1);
    // Above 50 %: 10 (0.1) and 1000 (0.01): the lower median 0.01.
    EXPECT_DOUBLE_EQ(median_relative_standard_error(s, 0.5), 0.01);
}

TEST(Scatterometer, HuangTLobeLeavesBelowInTheProportionOfEq15) {
    analysis::Huang2022Params p;
    p.H = 2.0;  // gaps between barbules: a sizeable T lobe at oblique light
    const analysis::Huang2022Bsdf model(p);
    ScatterometerConfig c;
    c.beam_direction = Vec3d(std::sin(0.6), 0.0, std::cos(0.6));
    c.image_size = 33;
    c.wavelengths_nm = {500.0, 600.0};
    c.quanta_per_pass = 100000;
    c.max_passes = 1;
    const Scatterogram s = measure_scatterogram(model, c);
    const double expected = model.t_lobe_mass(c.beam_direction);
    EXPECT_GT(expected, 0.05);
    for (std::size_t k = 0; k < c.wavelengths_nm.size(); ++k) {
        // The T lobe's share below the patch; binomial σ = sqrt(p(1 − p)/N). (R can also
        // leave downwards, off the barbules' steep edges: the total below is larger.)
        const double t =
            s.transmitted_lobes[analysis::Huang2022Bsdf::kT * c.wavelengths_nm.size() + k];
        EXPECT_NEAR(t, expected, 4.0 * std::sqrt(expected * (1.0 - expected) / 1e5));
        EXPECT_GE(s.transmitted[k], t);
    }
}

TEST(Scatterometer, WritesImagesAndARecord) {
    const analysis::LambertianScatterer plate(0.5);
    ScatterometerConfig c;
    c.image_size = 31;
    c.quanta_per_pass = 20000;
    c.max_passes = 2;
    const Scatterogram s = measure_scatterogram(plate, c);
    const auto dir = std::filesystem::temp_directory_path() /
                     ("plumage_scatterometer_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    write_scatterogram_record(s, dir / "s.h5");
    record::write_png(dir / "s.png", scatterogram_srgb(s));
    const auto intensity = record::read_dataset(dir / "s.h5", "image/intensity");
    EXPECT_EQ(intensity.dims, (std::vector<std::uint64_t>{31, 31, 5}));
    EXPECT_EQ(record::read_string_attribute(dir / "s.h5", "/instrument", "illumination"), "beam");
    EXPECT_EQ(record::read_dataset(dir / "s.h5", "convergence").dims,
              (std::vector<std::uint64_t>{2, 4}));
    // A white plate images grey: equal sRGB channels, averaged over the central 9 × 9
    // pixels (each pixel alone carries ~10 % Monte Carlo noise per wavelength here).
    const auto img = scatterogram_srgb(s, 0.0, false);
    std::array<double, 3> mean{};
    for (int row = 11; row < 20; ++row)
        for (int column = 11; column < 20; ++column)
            for (int ch = 0; ch < 3; ++ch)
                mean[ch] += img.pixels[(row * 31 + column) * 3 + ch] / 81.0;
    EXPECT_NEAR(mean[0], mean[1], 3.0);
    EXPECT_NEAR(mean[1], mean[2], 3.0);
    std::filesystem::remove_all(dir);
}

TEST(Scatterometer, RejectsBadConfigurations) {
    const analysis::LambertianScatterer plate(0.5);
    ScatterometerConfig c;
    c.beam_direction = Vec3d(0.0, 0.0, -1.0);
    EXPECT_THROW(measure_scatterogram(plate, c), InputError);
    c = {};
    c.illumination = Illumination::cone;
    c.beam_direction = Vec3d(std::sin(1.5), 0.0, std::cos(1.5));
    EXPECT_THROW(measure_scatterogram(plate, c), InputError);
    c = {};
    c.image_size = 3;
    EXPECT_THROW(measure_scatterogram(plate, c), InputError);
}

}  // namespace
}  // namespace plumage::gonio

namespace plumage::gonio {
namespace {

// Shared and split paths (ScatterometerConfig::share_wavelength_paths, split_paths) measure
// the same image as one path per wavelength: χ² per wavelength over the cells both images
// resolve to 15 % on their own (sparser cells have too few hits for a normal z), largest |z| within
// the Šidák bound of a 1 % family-wise error, under the beam and under cone light, on the rock-dove
// barbule row (film in air over melanin).
TEST(Scatterometer, SharedAndSplitPathsMeasureTheSameImage) {
    const geometry::BarbuleRow row = geometry::build_barbule_row({}, {0.01, 0.02});
    const sim::ExplicitScatterer tracer(sim::barbule_row_scene(row));
    for (const Illumination illumination : {Illumination::beam, Illumination::cone}) {
        ScatterometerConfig c;
        c.illumination = illumination;
        c.beam_direction = Vec3d(std::sin(0.3), 0.0, std::cos(0.3));
        c.image_size = 21;
        c.wavelengths_nm = {450.0, 550.0, 650.0};
        c.beam_radius_um = 8.0;
        c.quanta_per_pass = 120000;
        c.illumination_strata = 400;
        c.max_passes = 1;
        const Scatterogram separate = measure_scatterogram(tracer, c);
        c.share_wavelength_paths = true;
        c.split_paths = true;
        const Scatterogram shared = measure_scatterogram(tracer, c);
        ASSERT_TRUE(shared.wavelength_paths_shared && shared.paths_split);
        // The same bits on one thread (items and their order do not depend on the threads).
        const int threads = omp_get_max_threads();
        omp_set_num_threads(1);
        const Scatterogram alone = measure_scatterogram(tracer, c);
        omp_set_num_threads(threads);
        EXPECT_EQ(alone.intensity, shared.intensity);
        EXPECT_EQ(alone.standard_error, shared.standard_error);
        ASSERT_FALSE(separate.wavelength_paths_shared || separate.paths_split);
        const std::size_t nl = c.wavelengths_nm.size();
        std::vector<double> chi2(nl, 0.0);
        std::vector<int> dof(nl, 0);
        double max_z = 0.0;
        for (std::size_t i = 0; i < shared.intensity.size(); ++i) {
            const double a = separate.intensity[i], b = shared.intensity[i];
            const double sa = separate.standard_error[i], sb = shared.standard_error[i];
            if (!(a > 0.0 && b > 0.0) || sa > 0.15 * a || sb > 0.15 * b) continue;
            const double z = (a - b) / std::hypot(sa, sb);
            chi2[i % nl] += z * z;
            ++dof[i % nl];
            max_z = std::max(max_z, std::abs(z));
        }
        int cells = 0;
        for (std::size_t k = 0; k < nl; ++k) {
            ASSERT_GE(dof[k], 20) << k;
            EXPECT_GT(analysis::chi_square_p_value(chi2[k], dof[k]), 1e-3)
                << "illumination " << static_cast<int>(illumination) << ", wavelength " << k
                << ": chi2/dof " << chi2[k] / dof[k] << " over " << dof[k];
            cells += dof[k];
        }
        EXPECT_LT(max_z,
                  analysis::two_sided_normal_quantile(analysis::sidak_significance(0.01, cells)));
    }
}

}  // namespace
}  // namespace plumage::gonio
