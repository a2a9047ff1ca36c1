// `plumage fit` on files made from the models with known parameters and seeded Gaussian noise of
// known σ: the fit must recover every free parameter within 3 of its stated σ, and the stated σ
// must be honest — over several noise seeds the pulls (fit − truth)/σ have an RMS near 1 (neither
// absurdly large σ, which would give pulls near 0, nor too small ones).
//  - filip2024: a CSV in the documented layout (docs/user_data.md) on the 61 × 60 BTF set at
//    three wavelengths (one per colour band), σ = 3 % of f + 0.002 1/sr, four seeds;
//  - huang2022: a scatterogram record written by the instrument's own writer from the fit's
//    forward model, σ = 3 % of I (+ the fit's 1 % floor, which it adds in quadrature).
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/fits/huang2022_fit.h"
#include "analysis/fits/user_data.h"
#include "analysis/models/filip2024.h"
#include "common/constants.h"
#include "common/seed.h"
#include "sim/scatterer/random.h"
#include "studies/fit_command.h"
#include "tests/test_util.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

double gaussian(Rng& rng) {
    const double u = 1.0 - rng.uniform(), v = rng.uniform();
    return std::sqrt(-2.0 * std::log(u)) * std::cos(2.0 * std::numbers::pi * v);
}

fs::path scratch(const std::string& what) {
    const fs::path p =
        fs::temp_directory_path() / fmt::format("plumage_fit_{}_{}", what, ::getpid());
    fs::remove_all(p);
    fs::create_directories(p);
    return p;
}

// theta, phi in degrees of a unit vector (phi from +x).
std::pair<double, double> angles(const Vec3d& w) {
    return {std::acos(w.z()) / kDeg, std::atan2(w.y(), w.x()) / kDeg};
}

// The Filip model at `truth` on the BTF set × 450/550/650 nm with noise, as the documented CSV.
void write_filip_csv(
    const fs::path& path, const analysis::Filip2024Parameters& truth, std::uint64_t seed,
    const std::vector<gonio::DirectionPair>& pairs = gonio::filip2024_btf_pairs()) {
    std::ofstream csv(path);
    csv << "# synthetic: Filip 2024 parrot preset, sigma = 3 % of f + 0.002 1/sr\n"
           "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,wavelength_nm,value_per_sr,sigma_per_sr\n";
    std::array<double, analysis::kFilip2024ParameterCount> gradient{};
    for (std::size_t p = 0; p < pairs.size(); ++p) {
        Rng rng(derive_seed(seed, "test/fit/filip"), p);
        const auto [ti, pi] = angles(pairs[p].wi);
        const auto [to, po] = angles(pairs[p].wo);
        for (double lambda : {450.0, 550.0, 650.0}) {
            const double f = analysis::filip2024_value_and_gradient(
                truth, analysis::filip2024_geometry(pairs[p].wi, pairs[p].wo),
                analysis::filip2024_channel(lambda), gradient);
            const double sigma = 0.03 * f + 0.002;
            csv << fmt::format("{:.12g},{:.12g},{:.12g},{:.12g},{},{:.12g},{:.12g}\n", ti, pi, to,
                               po, lambda, f + sigma * gaussian(rng), sigma);
        }
    }
}

TEST(FitCommand, FilipFromCsvRecoversKnownParametersWithHonestSigma) {
    const fs::path dir = scratch("filip");
    const analysis::Filip2024Parameters truth = analysis::filip2024_preset("parrot");
    const auto expected = analysis::to_vector(truth);
    double pull_sum2 = 0.0;
    int pulls = 0;
    for (std::uint64_t seed = 1; seed <= 4; ++seed) {
        const fs::path csv = dir / fmt::format("parrot_{}.csv", seed);
        write_filip_csv(csv, truth, seed);
        FitCommand c;
        c.model = "filip2024";
        c.data = csv;
        // Start 5 % off in every fitted parameter (φa by 0.05 rad).
        for (int i = 0; i < analysis::kFilip2024ParameterCount; ++i) {
            if (i == analysis::kFilipThetaMax || i == analysis::kFilipBrdfScale) continue;
            const std::string name(analysis::kFilip2024ParameterTable[i].name);
            c.start[name] = i == analysis::kFilipPhiA ? expected[i] + 0.05 : expected[i] * 1.05;
        }
        const FitCommandResult r = run_fit_command(c, dir / "results");
        EXPECT_TRUE(r.summary.converged) << r.summary.termination;
        EXPECT_NEAR(r.summary.reduced_chi_square, 1.0,
                    5.0 * std::sqrt(2.0 / r.summary.degrees_of_freedom));
        for (int i = 0; i < analysis::kFilip2024ParameterCount; ++i) {
            const auto& p = r.summary.parameters[static_cast<std::size_t>(i)];
            if (p.fixed) continue;
            ASSERT_TRUE(std::isfinite(p.sigma)) << p.name;
            // φa is periodic in π (analysis/fits/filip2024_fit.h): the difference modulo π.
            double difference = p.value - expected[i];
            if (i == analysis::kFilipPhiA)
                difference -= std::numbers::pi * std::round(difference / std::numbers::pi);
            const double pull = difference / p.sigma;
            EXPECT_LT(std::abs(pull), 3.0) << p.name << " = " << p.value << " ± " << p.sigma
                                           << ", truth " << expected[i] << ", seed " << seed;
            pull_sum2 += pull * pull;
            ++pulls;
        }
        for (const char* f : {"parameters.json", "residuals.h5", "residuals.csv", "report.md"})
            EXPECT_TRUE(fs::exists(r.output_dir / f)) << f;
    }
    // 4 seeds × 18 parameters: the RMS pull of honest σ is 1 within ~±0.17 (1/sqrt(2n)); the
    // seeds' fits share the directions, so the pulls are not all independent: a factor 2.
    const double rms = std::sqrt(pull_sum2 / pulls);
    RecordProperty("rms_pull", fmt::format("{:.3f} over {} pulls", rms, pulls));
    EXPECT_GT(rms, 0.5);
    EXPECT_LT(rms, 2.0);
    fs::remove_all(dir);
}

// The Huang model's scatterogram (the fit's forward model) at `truth` with σ = 3 % Gaussian
// noise, in the documented minimal record layout (docs/user_data.md), as a user's own writer
// would give it.
void write_huang_record(const fs::path& path, const analysis::Huang2022Params& truth,
                        std::uint64_t seed) {
    gonio::ScatterometerConfig config;
    config.beam_direction = Vec3d(-std::sin(20.0 * kDeg), 0.0, std::cos(20.0 * kDeg));
    config.image_size = 25;
    config.wavelengths_nm = {500.0, 600.0};
    gonio::Scatterogram s = analysis::huang2022_scatterogram(truth, config);
    s.standard_error.assign(s.intensity.size(), 0.0);
    for (std::size_t k = 0; k < s.intensity.size(); ++k) {
        Rng rng(derive_seed(seed, "test/fit/huang"), k);
        s.standard_error[k] = 0.03 * s.intensity[k];
        s.intensity[k] += s.standard_error[k] * gaussian(rng);
    }
    using Dims = std::vector<std::uint64_t>;
    const std::uint64_t n = 25, nl = 2;
    record::Hdf5Writer h5(path);
    h5.create_group("instrument");
    h5.set_attribute("/instrument", "kind", "imaging_scatterometer");
    h5.set_attribute("/instrument", "illumination", "beam");
    h5.set_attribute("/instrument", "beam_direction",
                     fmt::format("{:.17g} {:.17g} {:.17g}", config.beam_direction.x(),
                                 config.beam_direction.y(), config.beam_direction.z()));
    h5.write("wavelength_nm", std::span<const double>(config.wavelengths_nm), Dims{nl}, {});
    h5.write("image/intensity", std::span<const double>(s.intensity), Dims{n, n, nl}, {});
    h5.write("image/standard_error", std::span<const double>(s.standard_error), Dims{n, n, nl}, {});
    h5.write("image/solid_angle_sr", std::span<const double>(s.solid_angle_sr), Dims{n, n}, {});
    h5.commit();
}

TEST(FitCommand, HuangFromScatterogramRecordRecoversKnownParametersWithHonestSigma) {
    const fs::path dir = scratch("huang");
    const analysis::Huang2022Params truth;  // rock dove; φ0, φ1 held (the command's default)
    const auto expected = analysis::huang2022_values(truth);
    double pull_sum2 = 0.0;
    int pulls = 0;
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
        FitCommand c;
        c.model = "huang2022";
        c.data = dir / fmt::format("rock_dove_{}.h5", seed);
        write_huang_record(c.data, truth, seed);
        c.start = {{"b", truth.b * 1.05},
                   {"H", truth.H * 0.95},
                   {"d_um", truth.d_um * 1.03},
                   {"theta_d", truth.theta_d * 1.05},
                   {"mu", truth.mu * 0.95}};
        c.pixel_stride = 2;
        const FitCommandResult r = run_fit_command(c, dir / "results");
        EXPECT_TRUE(r.summary.converged) << r.summary.termination;
        // 3 % noise against σ² = (3 %)² + the fit's (1 % floor)²: χ²/dof ≈ 0.9.
        EXPECT_NEAR(r.summary.reduced_chi_square, 0.9, 0.2);
        for (int i = 0; i < analysis::kHuang2022ParameterCount; ++i) {
            const auto& p = r.summary.parameters[static_cast<std::size_t>(i)];
            if (p.fixed) continue;
            const double pull = (p.value - expected[i]) / p.sigma;
            RecordProperty(fmt::format("{}_seed{}", p.name, seed),
                           fmt::format("{:.5f} ± {:.5f} (truth {:.5f}, {:+.2f} σ)", p.value,
                                       p.sigma, expected[i], pull));
            EXPECT_LT(std::abs(pull), 3.0) << p.name << " = " << p.value << " ± " << p.sigma;
            pull_sum2 += pull * pull;
            ++pulls;
        }
        EXPECT_TRUE(fs::exists(r.output_dir / "parameters.json"));
    }
    // 3 seeds × 5 parameters: honest σ give an RMS pull of 1 within ~±0.2.
    const double rms = std::sqrt(pull_sum2 / pulls);
    RecordProperty("rms_pull", fmt::format("{:.3f} over {} pulls", rms, pulls));
    EXPECT_GT(rms, 0.4);
    EXPECT_LT(rms, 2.0);
    fs::remove_all(dir);
}

TEST(FitCommand, BadDataIsRefusedNamingTheLineAndNothingIsWritten) {
    const fs::path dir = scratch("bad");
    const auto message = [&](const std::string& text, const std::string& model = "filip2024") {
        std::ofstream(dir / "bad.csv") << text;
        FitCommand c;
        c.model = model;
        c.data = dir / "bad.csv";
        return testing::input_error_message([&] { run_fit_command(c, dir / "results"); });
    };
    const std::string header =
        "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,wavelength_nm,value_per_sr\n";
    EXPECT_NE(message("theta_i_deg,phi_i_deg,theta_o,phi_o_deg,wavelength_nm,value_per_sr\n")
                  .find("bad.csv:1:3: column 'theta_o': unknown"),
              std::string::npos);
    EXPECT_NE(message(header + "10,0,95,180,550,0.3\n").find("bad.csv:2:3: theta_o_deg = 95"),
              std::string::npos);
    EXPECT_NE(message(header + "10,0,20,180,550,abc\n").find("bad.csv:2:6: value_per_sr = 'abc'"),
              std::string::npos);
    EXPECT_NE(message("# only a comment\n" + header).find("no data rows"), std::string::npos);
    EXPECT_NE(
        message(header + "10,0,20,180,550,0.3\n", "huang2022").find("expected a scatterogram"),
        std::string::npos);
    EXPECT_FALSE(fs::exists(dir / "results"));
    fs::remove_all(dir);
}

// A goniometer record (the instrument's own writer) read back as observations: every cell with a
// standard error, in pair-major order, directions and values to the bit; cells without one
// (σ = 0: no quantum counted) left out and counted.
// Issue 43: the residual map has at most 1024 rows and columns whatever the data (one per distinct
// direction was N² cells: 20 000 CSV rows of distinct directions needed 6.3 GB); 1100 distinct
// light and view directions share 1024 rows and columns, a cell showing its largest residual.
// Peak memory on 10⁵ rows: bench/fit_memory_bench.cpp.
TEST(FitCommand, ResidualMapOfManyDistinctDirectionsIsBounded) {
    const fs::path dir = scratch("map");
    std::vector<gonio::DirectionPair> pairs;
    Rng rng(derive_seed(kDefaultSeed, "test/fit/map"), 0);
    auto direction = [&rng] {
        const double z = 0.1 + 0.9 * rng.uniform(), phi = 2.0 * std::numbers::pi * rng.uniform();
        const double s = std::sqrt(1.0 - z * z);
        return Vec3d(s * std::cos(phi), s * std::sin(phi), z);
    };
    for (int p = 0; p < 1100; ++p) pairs.push_back({direction(), direction()});
    write_filip_csv(dir / "distinct.csv", analysis::filip2024_preset("parrot"), 1, pairs);
    FitCommand c;
    c.model = "filip2024";
    c.data = dir / "distinct.csv";
    const FitCommandResult r = run_fit_command(c, dir);
    const record::Dataset map = record::read_dataset(r.output_dir / "residuals.h5", "residual");
    EXPECT_EQ(map.dims, (std::vector<std::uint64_t>{3, 1024, 1024}));
    EXPECT_NE(record::read_string_attribute(r.output_dir / "residuals.h5", "/", "title")
                  .find("1100 light x 1100 view directions (in 1024 x 1024 cells"),
              std::string::npos);
    const std::size_t filled = static_cast<std::size_t>(std::count_if(
        map.values.begin(), map.values.end(), [](double v) { return std::isfinite(v); }));
    EXPECT_GE(filled, 3u * 1024u);  // every pair in some cell of each wavelength's panel
    EXPECT_LE(filled, 3u * 1100u);
    fs::remove_all(dir);
}

TEST(FitCommand, GoniometerRecordIsReadAsObservations) {
    const fs::path dir = scratch("record");
    gonio::BrdfRecord r;
    r.config.pairs = gonio::filip2024_in_plane_pairs();
    r.config.wavelengths_nm = {450.0, 650.0};
    r.scatterer = "synthetic";
    const std::size_t cells = r.config.pairs.size() * 2;
    for (std::size_t k = 0; k < cells; ++k) {
        r.value.push_back(0.1 + 0.001 * static_cast<double>(k));
        r.standard_error.push_back(k % 10 == 3 ? 0.0 : 0.01);
    }
    gonio::write_brdf_record(r, dir / "brdf.h5");
    const analysis::BrdfData data = analysis::read_brdf_data(dir / "brdf.h5");
    EXPECT_EQ(data.format, "brdf_record");
    EXPECT_EQ(data.left_out, cells / 10 + (cells % 10 > 3 ? 1 : 0));
    ASSERT_EQ(data.observations.size(), cells - data.left_out);
    std::size_t next = 0;
    for (std::size_t k = 0; k < cells; ++k) {
        if (r.standard_error[k] == 0.0) continue;
        const analysis::BrdfObservation& o = data.observations[next++];
        const auto& pair = r.config.pairs[k / 2];
        EXPECT_EQ(o.value, r.value[k]);
        EXPECT_EQ(*o.standard_error, 0.01);
        EXPECT_EQ(*o.lambda_nm, r.config.wavelengths_nm[k % 2]);
        EXPECT_LT((o.wi - pair.wi).norm(), 1e-15);
        EXPECT_LT((o.wo - pair.wo).norm(), 1e-15);
    }
    fs::remove_all(dir);
}

}  // namespace
}  // namespace plumage::studies
