// The RGL tensor ".bsdf" writer and reader (virtual_gonio/rgl_bsdf.h), checked against things
// that do not come from the code under test:
//  - the warp: invert(sample(u)) = u, its pdf integrates to 1 and equals eval() (the
//    marginal/conditional inversion is exact for the bilinear density);
//  - the round trip: every stored float32 reads back bit-equal; at the nodes of the sample
//    square the reader returns the source's f to float32 rounding (Lambertian ρ/π, Huang 2022);
//    between nodes the interpolation error is measured and bounded (bounds stated below);
//  - bad files: truncated, wrong magic or version, missing field, wrong shape or dtype: an
//    InputError that names the file and the field.
#include "virtual_gonio/rgl_bsdf.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/models/huang2022.h"
#include "analysis/models/lambertian.h"
#include "common/constants.h"
#include "common/error.h"
#include "sim/scatterer/random.h"
#include "tests/test_util.h"

namespace plumage::gonio {
namespace {

// A folder of this process, removed when the process ends.
struct ScratchFolder {
    std::filesystem::path path = std::filesystem::temp_directory_path() /
                                 ("plumage_rgl_bsdf_test_" + std::to_string(::getpid()));
    ScratchFolder() { std::filesystem::create_directories(path); }
    ~ScratchFolder() {
        std::error_code ignored;
        std::filesystem::remove_all(path, ignored);
    }
};
std::filesystem::path scratch(const std::string& name) {
    static const ScratchFolder folder;
    return folder.path / name;
}

Vec3d spherical(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// Direction pairs at the nodes of the written tables: for every stored parameter direction
// (θ_i, φ_i node) and every node s of the sample square, the light direction the writer
// tabulated there (the reflection of ω_v about the warped half vector).
struct NodePair {
    Vec3d wi, wo;
    Vec2 s;  // the node of the sample square
};
std::vector<NodePair> node_pairs(const RglBsdf& bsdf) {
    const auto& t = bsdf.tables();
    const int n = t.sample_resolution;
    std::vector<NodePair> pairs;
    // The last φ node repeats the first (φ = ±π): skip it.
    const std::size_t n_phi = t.phi_i.size() == 1 ? 1 : t.phi_i.size() - 1;
    for (std::size_t p = 0; p < n_phi; ++p) {
        for (float theta : t.theta_i) {
            const double phi_v = t.phi_i[p];
            const Vec3d wv = spherical(theta, phi_v);
            for (int j = 0; j < n; ++j) {
                for (int i = 0; i < n; ++i) {
                    const Vec2 s(static_cast<double>(i) / (n - 1),
                                 static_cast<double>(j) / (n - 1));
                    const Vec2 u = bsdf.warp_sample(wv, s);
                    const double theta_m = u.x() * u.x() * kPi / 2.0;
                    const double phi_m =
                        (2.0 * u.y() - 1.0) * kPi + (bsdf.isotropic() ? phi_v : 0.0);
                    const Vec3d m = spherical(theta_m, phi_m);
                    const Vec3d wl = (2.0 * wv.dot(m) * m - wv).normalized();
                    pairs.push_back({wl, wv, s});
                }
            }
        }
    }
    return pairs;
}

void expect_bit_equal(const std::vector<float>& a, const std::vector<float>& b, const char* name) {
    ASSERT_EQ(a.size(), b.size()) << name;
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << name;
}

void expect_tables_bit_equal(const RglBsdfTables& a, const RglBsdfTables& b) {
    EXPECT_EQ(a.description, b.description);
    EXPECT_EQ(a.jacobian, b.jacobian);
    expect_bit_equal(a.theta_i, b.theta_i, "theta_i");
    expect_bit_equal(a.phi_i, b.phi_i, "phi_i");
    expect_bit_equal(a.wavelengths, b.wavelengths, "wavelengths");
    expect_bit_equal(a.ndf, b.ndf, "ndf");
    expect_bit_equal(a.sigma, b.sigma, "sigma");
    expect_bit_equal(a.vndf, b.vndf, "vndf");
    expect_bit_equal(a.luminance, b.luminance, "luminance");
    expect_bit_equal(a.spectra, b.spectra, "spectra");
}

// Writes the tables, reads the file back and checks that every stored value is bit-equal.
RglBsdf written_and_read_back(const RglBsdfTables& written, const std::string& name) {
    const auto path = scratch(name);
    write_rgl_bsdf(path, written);
    RglBsdf bsdf = RglBsdf::read(path);
    expect_tables_bit_equal(written, bsdf.tables());
    return bsdf;
}

TEST(RglBsdfWarp, SampleIsTheInverseOfInvertAndItsPdfIsTheDensity) {
    // Two parameters (3 × 2 nodes), a 5 × 4 grid per slice with one zero node.
    const int w = 5, h = 4;
    std::vector<float> data;
    Rng rng(7, 0);
    for (int k = 0; k < 6 * w * h; ++k) data.push_back(static_cast<float>(0.1 + rng.uniform()));
    data[3] = 0.0f;
    const BilinearWarp2D warp(data, w, h, {{0.0, 1.0, 3.0}, {-1.0, 2.0}}, true);
    for (const auto& param : {std::array<double, 2>{0.0, -1.0}, std::array<double, 2>{0.4, 0.7},
                              std::array<double, 2>{2.9, 2.0}}) {
        // ∫ eval over the square = 1 (midpoint rule on a fine grid).
        double integral = 0.0;
        const int q = 400;
        for (int j = 0; j < q; ++j) {
            for (int i = 0; i < q; ++i) {
                integral += warp.eval(Vec2((i + 0.5) / q, (j + 0.5) / q), param) / (q * q);
            }
        }
        EXPECT_NEAR(integral, 1.0, 1e-5);
        for (int j = 0; j <= 20; ++j) {
            for (int i = 0; i <= 20; ++i) {
                const Vec2 u(0.001 + 0.998 * i / 20.0, 0.001 + 0.998 * j / 20.0);
                const auto forward = warp.sample(u, param);
                const auto back = warp.invert(forward.point, param);
                EXPECT_NEAR(back.point.x(), u.x(), 1e-9);
                EXPECT_NEAR(back.point.y(), u.y(), 1e-9);
                EXPECT_NEAR(forward.pdf, warp.eval(forward.point, param), 1e-9 * forward.pdf);
                EXPECT_NEAR(back.pdf, forward.pdf, 1e-9 * forward.pdf);
            }
        }
    }
}

// A Lambertian file at its nodes: ρ/π to float32 rounding.
void check_lambertian_nodes(const RglBsdf& bsdf, const std::vector<double>& wavelengths_nm,
                            double expected) {
    // At the nodes: ρ/π to float32 rounding (a few ulps through spectra, ndf, σ; measured
    // 1.9e-6, bound 5e-6).
    double worst_node = 0.0;
    for (const NodePair& pair : node_pairs(bsdf)) {
        if (pair.wi.z() < 0.05) continue;  // the writer stored 0 below the horizon
        for (double lambda : wavelengths_nm) {
            worst_node = std::max(worst_node,
                                  std::abs(bsdf.eval(pair.wi, pair.wo, lambda) / expected - 1.0));
        }
    }
    EXPECT_LT(worst_node, 5e-6);
    std::printf("Lambertian: max relative error at nodes %.3g\n", worst_node);
}

// A Lambertian file between its nodes, at random pairs and wavelengths.
void check_lambertian_between_nodes(const RglBsdf& bsdf, double expected) {
    // Between nodes: random pairs, wavelengths between the nodes. The error is bilinear
    // interpolation of spectra = (ρ/π) cos θ_i · 4σ/D over the sample square, largest in the
    // cells at the half vector's pole: they are equal-VNDF-probability cells, so the first
    // column spans θ_m up to ~17° on this 24² grid, and for a grazing view the reflected
    // direction sweeps ~35° across it (mirror configurations, Δφ ≈ 180°). Measured on this grid:
    //   both θ ≤ 60°: max 0.14, mean 0.008;   both θ ≤ 80°: max 0.28, mean 0.014.
    // Bounds: max 0.2 / 0.4, mean 0.012 / 0.02.
    Rng rng(11, 0);
    for (const double theta_max : {60.0 * kDeg, 80.0 * kDeg}) {
        double worst = 0.0, sum = 0.0;
        const int count = 4000;
        for (int k = 0; k < count; ++k) {
            const double c = 1.0 - std::cos(theta_max);
            const Vec3d wi = spherical(std::acos(1.0 - rng.uniform() * c), kTwoPi * rng.uniform());
            const Vec3d wo = spherical(std::acos(1.0 - rng.uniform() * c), kTwoPi * rng.uniform());
            const double lambda = 450.0 + 200.0 * rng.uniform();
            const double e = std::abs(bsdf.eval(wi, wo, lambda) / expected - 1.0);
            worst = std::max(worst, e);
            sum += e;
        }
        std::printf("Lambertian, both θ <= %.0f°: relative error max %.4f, mean %.5f\n",
                    theta_max / kDeg, worst, sum / count);
        const bool low = theta_max < 70.0 * kDeg;
        EXPECT_LT(worst, low ? 0.2 : 0.4);
        EXPECT_LT(sum / count, low ? 0.012 : 0.02);
    }
}

// Mitsuba's sampling density of a Lambertian file: normalised and following f cos θ.
void check_lambertian_sampling(const RglBsdf& bsdf) {
    // Mitsuba's sampling density from the vndf and luminance tables integrates to 1 over the
    // upper hemisphere, less the share of the sample square that maps below the horizon (the
    // luminance floor there is 1e-3 of the maximum): 0.97 ≤ ∫ pdf ≤ 1 + quadrature error.
    // And it follows f cos θ: max/min of f cos θ / pdf over the hemisphere (θ ≤ 80°) is the
    // sampling's weight spread, stated, bounded by 3 (measured below).
    for (const double theta_v : {0.0, 30.0 * kDeg, 70.0 * kDeg}) {
        const Vec3d wv = spherical(theta_v, 0.3);
        double integral = 0.0, ratio_min = 1e300, ratio_max = 0.0;
        const int n_theta = 300, n_phi = 600;
        for (int a = 0; a < n_theta; ++a) {
            const double theta = (a + 0.5) * (kPi / 2) / n_theta;
            for (int b = 0; b < n_phi; ++b) {
                const Vec3d wl = spherical(theta, (b + 0.5) * kTwoPi / n_phi);
                const double pdf = bsdf.pdf_mitsuba(wv, wl);
                integral += pdf * std::sin(theta) * (kPi / 2 / n_theta) * (kTwoPi / n_phi);
                if (theta < 80 * kDeg) {
                    const double ratio = bsdf.eval_mitsuba(wv, wl, 550.0) / pdf;
                    ratio_min = std::min(ratio_min, ratio);
                    ratio_max = std::max(ratio_max, ratio);
                }
            }
        }
        std::printf("Lambertian, view θ %.0f°: ∫ pdf = %.4f, f cos/pdf in [%.3f, %.3f]\n",
                    theta_v / kDeg, integral, ratio_min, ratio_max);
        EXPECT_GT(integral, 0.97);
        EXPECT_LT(integral, 1.005);
        EXPECT_LT(ratio_max / ratio_min, 3.0);
    }
}

TEST(RglBsdfRoundTrip, LambertianReadsBackAsAlbedoOverPi) {
    const double albedo = 0.8;
    const analysis::LambertianScatterer lambert(albedo);
    RglBsdfSettings settings;
    settings.wavelengths_nm = {450.0, 550.0, 650.0};
    settings.theta_i_count = 8;
    settings.sample_resolution = 24;
    settings.vndf_resolution = 32;
    settings.ndf_resolution = 32;
    settings.description = "Lambertian 0.8";
    const RglBsdf bsdf =
        written_and_read_back(tabulate_rgl_bsdf(lambert, settings), "lambert.bsdf");
    EXPECT_TRUE(bsdf.isotropic());

    const double expected = albedo / kPi;
    check_lambertian_nodes(bsdf, settings.wavelengths_nm, expected);
    check_lambertian_between_nodes(bsdf, expected);
    check_lambertian_sampling(bsdf);
    EXPECT_EQ(bsdf.eval(Vec3d(0, 0, 1), Vec3d(0, 0.1, -1).normalized(), 550.0), 0.0);
}

TEST(RglBsdfRoundTrip, Huang2022AnisotropicNodesAndInterpolation) {
    const analysis::Huang2022Bsdf huang{analysis::Huang2022Params{}};
    RglBsdfSettings settings;
    settings.wavelengths_nm = {480.0, 620.0};
    settings.theta_i_count = 5;
    settings.theta_max_deg = 80.0;
    settings.phi_i_count = 9;  // 45° steps over [−π, π]
    settings.sample_resolution = 24;
    settings.vndf_resolution = 32;
    settings.ndf_resolution = 32;
    const RglBsdf bsdf = written_and_read_back(tabulate_rgl_bsdf(huang, settings), "huang.bsdf");
    EXPECT_FALSE(bsdf.isotropic());

    // At the nodes: the source's f to float32 rounding, wherever f is not negligible (above
    // 1e-4 of its largest node value). Measured 5.5e-7 (18 186 values); bound 1e-6. (Before the φ_i
    // end nodes were rounded into [−π, π], the nodes at φ_i = ±π read 4.7e-6 off: their directions
    // came back from atan2 on the other end of the circle.) The model's f at every node pair above
    // the horizon, once (Huang's eval is the cost here).
    const auto pairs = node_pairs(bsdf);
    const std::size_t n_lambda = settings.wavelengths_nm.size();
    std::vector<double> node_truth(pairs.size() * n_lambda, 0.0);
    double largest = 0.0;
    for (std::size_t k = 0; k < pairs.size(); ++k) {
        if (pairs[k].wi.z() < 0.05) continue;
        for (std::size_t l = 0; l < n_lambda; ++l) {
            node_truth[k * n_lambda + l] =
                huang.eval(pairs[k].wi, pairs[k].wo, settings.wavelengths_nm[l]);
            largest = std::max(largest, node_truth[k * n_lambda + l]);
        }
    }
    double worst_node = 0.0;
    int checked = 0;
    for (std::size_t k = 0; k < pairs.size(); ++k) {
        for (std::size_t l = 0; l < n_lambda; ++l) {
            const double f = node_truth[k * n_lambda + l];
            if (f <= 1e-4 * largest) continue;  // includes the pairs below 0.05 (left at 0)
            const double read = bsdf.eval(pairs[k].wi, pairs[k].wo, settings.wavelengths_nm[l]);
            worst_node = std::max(worst_node, std::abs(read / f - 1.0));
            ++checked;
        }
    }
    EXPECT_GT(checked, 1000);
    EXPECT_LT(worst_node, 1e-6);

    // Between nodes: the relative L1 error Σ|f_read − f|cos θ_i / Σ f cos θ_i over random pairs
    // (θ ≤ 75°, the parameter direction between the θ and φ nodes). Huang's R lobe is narrow
    // (θ_d = 4.5°) and on this coarse test grid (24², 45° in φ_i) it is resolved only in part.
    // Measured: 0.27; bound 0.35. The export's default grid (32², 10 θ_i, 25 φ_i) is finer.
    Rng rng(13, 0);
    double error = 0.0, total = 0.0;
    for (int k = 0; k < 3000; ++k) {
        const Vec3d wi = spherical(std::acos(1.0 - rng.uniform() * (1.0 - std::cos(75 * kDeg))),
                                   kTwoPi * rng.uniform());
        const Vec3d wo = spherical(std::acos(1.0 - rng.uniform() * (1.0 - std::cos(75 * kDeg))),
                                   kTwoPi * rng.uniform());
        const double truth = huang.eval(wi, wo, 480.0) * wi.z();
        error += std::abs(bsdf.eval(wi, wo, 480.0) * wi.z() - truth);
        total += truth;
    }
    std::printf(
        "Huang 2022: max relative error at nodes %.3g (%d values), relative L1 between "
        "nodes %.4f\n",
        worst_node, checked, error / total);
    EXPECT_LT(error / total, 0.35);
}

// A model's own NDF (settings.model_ndf) only moves the nodes: any positive NDF gives a correct
// file (spectra = q · 4σ / D compensates). A Lambertian tabulated with a narrow band of normals
// (|m_y| ≤ sin 5°, anisotropic) at share 1 and 0.5 still reads back ρ/π at every node to
// float32 rounding (bound 5e-6 as above), and the stored NDF is higher in the band than off
// it (the cell means of the band, plus the cosine floor).
TEST(RglBsdfRoundTrip, ModelNdfMovesTheNodesNotTheValues) {
    const double albedo = 0.6;
    const analysis::LambertianScatterer lambert(albedo);
    RglBsdfSettings settings;
    settings.wavelengths_nm = {550.0};
    settings.theta_i_count = 4;
    settings.phi_i_count = 5;
    settings.sample_resolution = 12;
    settings.vndf_resolution = 16;
    settings.ndf_resolution = 16;
    settings.model_ndf = [](const Vec3d& m) {
        return std::abs(m.y()) <= std::sin(5.0 * kDeg) ? 1.0 : 0.0;
    };
    for (const double share : {1.0, 0.5}) {
        settings.model_ndf_share = share;
        const RglBsdf bsdf =
            written_and_read_back(tabulate_rgl_bsdf(lambert, settings), "model_ndf.bsdf");
        double worst = 0.0;
        for (const NodePair& pair : node_pairs(bsdf)) {
            if (pair.wi.z() < 0.05 || pair.s.x() == 0.0) continue;  // the pole column, as above
            worst =
                std::max(worst, std::abs(bsdf.eval(pair.wi, pair.wo, 550.0) * kPi / albedo - 1.0));
        }
        EXPECT_LT(worst, 5e-6) << share;
        // Row 8 of 16 is φ = 0 (the band, m_y = 0); row 4 is φ = −π/2 (off it); column 10 θ ≈ 35°.
        const auto& t = bsdf.tables();
        EXPECT_GT(t.ndf[8 * 16 + 10], 3.0f * t.ndf[4 * 16 + 10]) << share;
    }
}

// ---- bad files -------------------------------------------------------------------------------

std::vector<char> bytes_of(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}
void write_bytes(const std::filesystem::path& path, const std::vector<char>& bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

class RglBsdfBadFile : public ::testing::Test {
protected:
    void SetUp() override {
        const analysis::LambertianScatterer lambert(0.5);
        RglBsdfSettings settings;
        settings.wavelengths_nm = {550.0};
        settings.theta_i_count = 3;
        settings.sample_resolution = 4;
        settings.vndf_resolution = 4;
        settings.ndf_resolution = 4;
        settings.ndf_iterations = 2;
        tables_ = tabulate_rgl_bsdf(lambert, settings);
        good_ = scratch("good.bsdf");
        write_rgl_bsdf(good_, tables_);
    }
    std::string error_of(const std::filesystem::path& path) {
        return plumage::testing::input_error_message([&] { RglBsdf::read(path); });
    }
    RglBsdfTables tables_;
    std::filesystem::path good_;
};

TEST_F(RglBsdfBadFile, TruncatedWrongMagicAndVersion) {
    const std::vector<char> good = bytes_of(good_);
    const auto path = scratch("bad.bsdf");
    write_bytes(path, std::vector<char>(good.begin(), good.begin() + 10));
    EXPECT_NE(error_of(path).find("shorter than its 18-byte header"), std::string::npos)
        << error_of(path);
    write_bytes(path, std::vector<char>(good.begin(), good.begin() + 40));
    EXPECT_NE(error_of(path).find("truncated tensor file"), std::string::npos) << error_of(path);
    write_bytes(path, std::vector<char>(good.begin(), good.end() - 16));
    EXPECT_NE(error_of(path).find("lies outside the file"), std::string::npos) << error_of(path);
    EXPECT_NE(error_of(path).find(path.string()), std::string::npos);
    std::vector<char> magic = good;
    magic[0] = 'T';
    write_bytes(path, magic);
    EXPECT_NE(error_of(path).find("not a tensor file"), std::string::npos) << error_of(path);
    std::vector<char> version = good;
    version[12] = 2;
    write_bytes(path, version);
    EXPECT_NE(error_of(path).find("version 2.0: expected 1.0"), std::string::npos)
        << error_of(path);
    EXPECT_NE(error_of(scratch("absent.bsdf")).find("cannot open"), std::string::npos);
}

TEST_F(RglBsdfBadFile, MissingFieldWrongShapeWrongDtype) {
    const auto path = scratch("bad_fields.bsdf");
    TensorFields fields = tables_.to_fields();
    fields.erase("sigma");
    write_tensor_file(path, fields);
    EXPECT_NE(error_of(path).find("field 'sigma' is missing"), std::string::npos) << error_of(path);
    EXPECT_NE(error_of(path).find(path.string()), std::string::npos);

    fields = tables_.to_fields();
    fields["spectra"].shape[2] = 2;  // claims two wavelengths, file has one
    fields["spectra"].bytes.resize(fields["spectra"].bytes.size() * 2);
    write_tensor_file(path, fields);
    EXPECT_NE(error_of(path).find("field 'spectra': shape"), std::string::npos) << error_of(path);

    fields = tables_.to_fields();
    fields["jacobian"].dtype = 2;  // int8
    write_tensor_file(path, fields);
    EXPECT_NE(error_of(path).find("field 'jacobian': dtype code 2, expected 1"), std::string::npos)
        << error_of(path);

    fields = tables_.to_fields();
    const float nan = std::nanf("");
    std::memcpy(fields["ndf"].bytes.data() + 4, &nan, sizeof nan);
    write_tensor_file(path, fields);
    EXPECT_NE(error_of(path).find("field 'ndf': element 1 is not finite"), std::string::npos)
        << error_of(path);
}

// A sampling table with nothing to sample: the error names the field as well as the slice.
TEST_F(RglBsdfBadFile, ATableWithoutDensityNamesItsField) {
    const auto path = scratch("no_density.bsdf");
    for (const std::string field : {"vndf", "luminance"}) {
        TensorFields fields = tables_.to_fields();
        std::fill(fields[field].bytes.begin(), fields[field].bytes.end(), std::uint8_t{0});
        write_tensor_file(path, fields);
        const std::string message = error_of(path);
        EXPECT_NE(message.find(path.string() + ": field '" + field + "': warp: slice 0"),
                  std::string::npos)
            << message;
        EXPECT_NE(message.find("has no positive density"), std::string::npos) << message;
    }
}

TEST(RglBsdfSettingsTest, RejectsBadSettingsAndModelsWithoutEval) {
    RglBsdfSettings settings;
    settings.wavelengths_nm = {550.0};
    settings.phi_i_count = 2;
    EXPECT_NE(
        plumage::testing::input_error_message([&] { settings.validate(); }).find("phi_i_count"),
        std::string::npos);
    settings.phi_i_count = 1;
    settings.theta_max_deg = 90.0;
    EXPECT_NE(
        plumage::testing::input_error_message([&] { settings.validate(); }).find("theta_max_deg"),
        std::string::npos);
}

}  // namespace
}  // namespace plumage::gonio
