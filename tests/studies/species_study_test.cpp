// The species study in its quick form. Its numbers are checked against what each patch is
// built to do, independently of the fit:
//  - colour by construction, from the albedo at normal incidence (period-averaged): the
//    flamingo's carotenoid band absorbs blue (albedo rises with λ), the stork's clear keratin
//    and white medulla are neutral (flat within Monte Carlo error), the parrot's spongy
//    medulla — a first-Born medium computed from its structure, no colour parameter — reflects
//    blue (450 nm above 650 nm; tests/studies/spongy_medulla_test.cpp measures its hue and
//    chroma on a finer spectrum), the rooster's 0.174 µm cortex over melanin
//    has its first-order film maximum in the green (550 nm above 450 and 650 nm);
//  - the fit: Filip's anisotropy axis U(φa) must come out along the parrot's barbs (the patch
//    whose highlight is built from cylinders), and the fitted parameters must describe the
//    simulation at least as well as Table 1's;
//  - reciprocity of the simulated BRDF over the pairs the set holds both ways;
//  - the records: species.h5 holds what the run returned.
#include "studies/species_study.h"
#include "common/constants.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/metrics/statistics.h"
#include "common/error.h"
#include "sim/scatterer/random.h"
#include "tests/studies/measurement_streams.h"
#include "tests/test_util.h"
#include "tests/virtual_gonio/exr_test_util.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

std::string read(const std::filesystem::path& p) {
    std::ifstream in(p);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

const SpeciesOutcome& find(const SpeciesResult& r, const std::string& name) {
    for (const auto& o : r.species)
        if (o.species == name) return o;
    throw std::runtime_error("no species " + name);
}

// Filip's Table 1 parameters of the flamingo and the stork reflect more than they receive at
// oblique light (directional albedo up to 1.43 and 1.48, as their exports also say); the parrot's
// and rooster's, and the fits to the simulation (which conserves energy), do not. The report
// warns where it happens.
void check_energy_warnings(const SpeciesResult& r, const std::filesystem::path& dir) {
    for (const auto& o : r.species) {
        SCOPED_TRACE(o.species);
        EXPECT_EQ(o.table1_energy.directions, 21);
        const bool published_gain = o.species == "flamingo" || o.species == "stork";
        EXPECT_EQ(o.table1_energy.directions_above_one > 0, published_gain);
        EXPECT_EQ(o.fit_energy.directions_above_one, 0);
        EXPECT_LT(o.fit_energy.max_albedo, 1.0);
    }
    std::ifstream in(dir / "report.md");
    const std::string report((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
    std::size_t warnings = 0;
    for (std::size_t at = report.find("do not conserve energy"); at != std::string::npos;
         at = report.find("do not conserve energy", at + 1))
        ++warnings;
    EXPECT_EQ(warnings, 2u);
}

// a − b in units of their combined standard error.
double z(const SpeciesOutcome& o, std::size_t a, std::size_t b) {
    return (o.albedo[a] - o.albedo[b]) / std::hypot(o.albedo_error[a], o.albedo_error[b]);
}

// What holds for every patch: passive albedo, the fitted axis a direction, a reciprocal
// simulated BRDF, a fit no worse than Table 1's start, finite in-plane L*.
void check_patch(const SpeciesOutcome& o) {
    for (std::size_t k = 0; k < o.albedo.size(); ++k) {
        EXPECT_GE(o.albedo[k], 0.0);
        EXPECT_LE(o.albedo[k], 1.0 + 4.0 * o.albedo_error[k]);  // a passive scene
    }
    // The fitted axis is reported against both fibre families; it must be a direction.
    EXPECT_GE(o.fit_axis_from_barbs_deg, 0.0);
    EXPECT_LE(o.fit_axis_from_barbs_deg, 90.0 + 1e-9);
    EXPECT_NEAR(o.fit_axis_from_barbs_deg + o.fit_axis_from_barbules_deg, 90.0, 1e-9);
    // Reciprocity of the simulated BRDF (the tracer's physics is reciprocal; the patch
    // average over a beam covering a barb period is then too): the largest |z| over the
    // cells held both ways stays below the Šidák bound for a 1 % family-wise error.
    // (800: the tracer's low-weight roulette, sim/tracer.h, empties the quick rooster's cells
    // that only light below 1 % of its power reached; 898 remain, 1481 before.)
    ASSERT_GT(o.reciprocity_dof, 800);
    const double bound =
        analysis::two_sided_normal_quantile(analysis::sidak_significance(0.01, o.reciprocity_dof));
    EXPECT_LT(o.reciprocity_max_z, bound) << "over " << o.reciprocity_dof << " cells";
    // And χ² over those cells consistent with the Monte Carlo errors. With each cell's own
    // standard error (the Wald z) the quick stork read χ²/dof 1.13, p = 3e-9, on reciprocal
    // pairs: few hits of unequal size at grazing views (reciprocity_z); the score test reads
    // 0.97-1.02 on the four patches.
    EXPECT_GT(analysis::chi_square_p_value(o.reciprocity_chi_square, o.reciprocity_dof), 1e-3)
        << "chi2/dof " << o.reciprocity_chi_square / o.reciprocity_dof;
    // Least squares from Table 1's start cannot end worse than its start by much: the
    // final (variance-weighted) fit is compared by the unweighted RMS, hence the 5 % slack.
    EXPECT_LT(o.fit_relative_rms, 1.05 * o.table1_relative_rms);
    EXPECT_TRUE(std::isfinite(o.reduced_chi_square));
    EXPECT_EQ(o.in_plane_lstar.size(), 55u);
    for (double l : o.in_plane_lstar) EXPECT_TRUE(std::isfinite(l) && l >= 0.0);
}

// Colour by construction; 4σ one-sided (family of 6 comparisons: p < 2e-4).
void check_colour_by_construction(const SpeciesResult& r) {
    const auto& flamingo = find(r, "flamingo");
    EXPECT_GT(z(flamingo, 2, 0), 4.0)
        << "flamingo albedo " << flamingo.albedo[0] << " -> " << flamingo.albedo[2];
    const auto& stork = find(r, "stork");
    EXPECT_LT(std::abs(z(stork, 2, 0)), 4.0)
        << "stork albedo " << stork.albedo[0] << " -> " << stork.albedo[2];
    EXPECT_GT(stork.albedo[1], 2.0 * flamingo.albedo[0]);  // white against pink's blue
    const auto& parrot = find(r, "parrot");
    EXPECT_GT(z(parrot, 0, 2), 4.0)
        << "parrot albedo " << parrot.albedo[0] << " -> " << parrot.albedo[2];
    const auto& rooster = find(r, "rooster");
    EXPECT_GT(z(rooster, 1, 0), 4.0)
        << "rooster albedo " << rooster.albedo[0] << ", " << rooster.albedo[1];
    EXPECT_GT(z(rooster, 1, 2), 4.0)
        << "rooster albedo " << rooster.albedo[1] << ", " << rooster.albedo[2];
}

// The parrot is built so that its highlight comes from cylinders: round, protruding barbs
// over dark barbules. Filip's U must come out along its barb axis (modulo 180°: |H·U|
// does not see the sign), within 4σ of the fit plus 5° (the barbs' highlight is a cone of
// finite width). The other patches offer two fibre families; which one the fit picks is
// a finding the report states, not a property to test.
void check_parrot_axis_along_barbs(const SpeciesResult& r) {
    const auto& parrot = find(r, "parrot");
    const double parrot_sigma_deg = std::isfinite(parrot.fitted_error[analysis::kFilipPhiA])
                                        ? parrot.fitted_error[analysis::kFilipPhiA] / kDeg
                                        : 0.0;
    EXPECT_LT(parrot.fit_axis_from_barbs_deg, 4.0 * parrot_sigma_deg + 5.0)
        << "parrot phi_a fitted " << parrot.fitted[analysis::kFilipPhiA] / kDeg << " deg";
}

// Records: what the run returned for a patch, read back, and its files.
void check_patch_records(const std::filesystem::path& dir, const SpeciesOutcome& o) {
    const auto fit = record::read_dataset(dir / "species.h5", o.species + "/fit/values");
    ASSERT_EQ(fit.values.size(), static_cast<std::size_t>(analysis::kFilip2024ParameterCount));
    for (int p = 0; p < analysis::kFilip2024ParameterCount; ++p)
        EXPECT_DOUBLE_EQ(fit.values[p], o.fitted[p]);
    const auto albedo = record::read_dataset(dir / "species.h5", o.species + "/albedo");
    EXPECT_EQ(albedo.values, o.albedo);
    for (const char* f :
         {"brdf.h5", "fit.h5", "in_plane.h5", "btf.h5", "btf.png", "fingerprints.png"}) {
        EXPECT_TRUE(std::filesystem::exists(dir / o.species / f)) << o.species << "/" << f;
    }
}

// Beside the PNGs, their spectra as OpenEXR, opened by OpenEXR: the fingerprints of
// simulation and both models (61 lights x 60 views), the BTF tiles.
void check_patch_exr(const std::filesystem::path& dir, const SpeciesOutcome& o) {
    Imf::MultiPartInputFile fingerprints((dir / o.species / "fingerprints.exr").c_str());
    ASSERT_EQ(fingerprints.parts(), 3);
    EXPECT_EQ(fingerprints.header(0).name(), "simulation");
    const auto window = fingerprints.header(0).dataWindow();
    EXPECT_EQ(window.max.x - window.min.x + 1, 60);
    EXPECT_EQ(window.max.y - window.min.y + 1, 61);
    const auto names = testing::exr_channel_names(fingerprints.header(0));
    for (const char* c : {"R", "G", "B"})
        EXPECT_NE(std::find(names.begin(), names.end(), c), names.end()) << c;
    auto starting = [&names](const std::string& prefix) {
        return std::count_if(names.begin(), names.end(),
                             [&](const std::string& n) { return n.rfind(prefix, 0) == 0; });
    };
    EXPECT_GT(starting("S0."), 1);
    EXPECT_EQ(starting("stderr.S0."), starting("S0."));
    Imf::MultiPartInputFile btf((dir / o.species / "btf.exr").c_str());
    EXPECT_GE(btf.parts(), 1);
    EXPECT_NE(testing::exr_channel_names(btf.header(0)).size(), 0u);
}

// The report's sections and the study's tables beside it.
// The report opens with the verdicts (analysis/metrics/verdict.h): per species, against the fit and
// against Table 1, each following its p.
void check_verdicts(const SpeciesResult& r, const std::filesystem::path& dir) {
    const std::string report = read(dir / "report.md");
    const std::size_t block = report.find("## Verdicts");
    ASSERT_NE(block, std::string::npos);
    EXPECT_EQ(report.find("## "), block);  // the first section
    for (const auto& o : r.species)
        for (const analysis::AgreementVerdict* v : {&o.fit_verdict, &o.table1_verdict}) {
            EXPECT_GT(v->cells, 0u) << o.species;
            EXPECT_EQ(v->verdict, v->p_value < 1e-3    ? "differs"
                                  : v->p_value >= 0.01 ? "agrees"
                                                       : "undecided")
                << o.species;
            EXPECT_NE(report.find(fmt::format("| {} | {} | **{}** | {} |", o.species,
                                              v == &o.fit_verdict ? "fit" : "Table 1", v->verdict,
                                              v->cells)),
                      std::string::npos)
                << o.species;
        }
    // The BTF's noise against its target, per tile: the quick study sets no target, and the
    // median over all tiles' lit pixels lies between the tiles' own medians.
    EXPECT_NE(report.find("| species | median σ/f | target | passes, time | per tile (%) |"),
              std::string::npos);
    for (const auto& o : r.species) {
        ASSERT_EQ(o.btf_tile_pixel_errors.size(), 12u) << o.species;
        EXPECT_NE(report.find(fmt::format("| {} | {:.1f} % | none set | {}, ", o.species,
                                          100.0 * o.btf_median_pixel_error, o.btf_passes)),
                  std::string::npos)
            << o.species;
        const auto [low, high] =
            std::minmax_element(o.btf_tile_pixel_errors.begin(), o.btf_tile_pixel_errors.end());
        EXPECT_LE(*low, o.btf_median_pixel_error) << o.species;
        EXPECT_GE(*high, o.btf_median_pixel_error) << o.species;
    }
}

void check_report_and_tables(const std::filesystem::path& dir) {
    const std::string report = read(dir / "report.md");
    EXPECT_NE(report.find("## Fitted parameters beside Table 1"), std::string::npos);
    EXPECT_NE(report.find("**Reading.**"), std::string::npos);
    // Every species' fit verdict is a χ² test with its p-value and effect size, and the quick
    // study's 80–90 % Monte Carlo error makes each one indicative only.
    auto count = [&](const std::string& what) {
        std::size_t n = 0;
        for (auto at = report.find(what); at != std::string::npos; at = report.find(what, at + 1))
            ++n;
        return n;
    };
    EXPECT_EQ(count("degrees of freedom (reduced "), 4u) << report;
    EXPECT_EQ(count("the typical residual is "), 4u);
    EXPECT_EQ(count(" — indicative only: the simulated BRDF's estimated relative error is "), 4u);
    EXPECT_EQ(count("the set holds both ways: χ²/dof = "), 4u);
    EXPECT_NE(report.find("in_plane_luminance.png"), std::string::npos);
    EXPECT_TRUE(std::filesystem::exists(dir / "in_plane_luminance.png"));
    EXPECT_TRUE(std::filesystem::exists(dir / "fits.csv"));
    // Issue 18: the species' mirror-pair spectra in pavo's layout, and their avian ΔS matrices.
    const std::string pavo = read(dir / "spectra_pavo.csv");
    EXPECT_EQ(pavo.rfind("wl,", 0), 0u) << pavo;
    EXPECT_NE(read(dir / "avian_catches.csv").find("\nbluetit,"), std::string::npos);
    EXPECT_NE(report.find("## Avian vision"), std::string::npos);
    EXPECT_NE(report.find("| UVS (blue tit) |"), std::string::npos);
}

// Runs the quick study once and checks each part of what it returned and wrote. A fatal
// failure in a record check stops the test, as when the checks were inline.
TEST(SpeciesStudy, QuickVariantReproducesEachPatchsColourAndOrientation) {
    const auto root =
        std::filesystem::temp_directory_path() / ("plumage_species_" + std::to_string(::getpid()));
    const std::filesystem::path study =
        std::filesystem::path(PLUMAGE_SOURCE_DIR) / "studies" / "species_quick.toml";
    clear_recorded_measurement_seeds();
    const SpeciesResult r = run_species_study(read(study), study, root, false);
    // Measurements the report compares must not share their noise (issue 39).
    test::expect_each_measurement_its_own_streams();
    const auto dir = root / "species_quick";
    ASSERT_EQ(r.output_dir, dir);
    ASSERT_EQ(r.species.size(), 4u);
    ASSERT_EQ(r.wavelengths_nm, (std::vector<double>{450.0, 550.0, 650.0}));
    ASSERT_EQ(r.in_plane_angles_deg.size(), 55u);
    check_colour_by_construction(r);
    check_parrot_axis_along_barbs(r);
    for (const auto& o : r.species) {
        SCOPED_TRACE(o.species);
        ASSERT_NO_FATAL_FAILURE(check_patch(o));
    }
    for (const auto& o : r.species) {
        ASSERT_NO_FATAL_FAILURE(check_patch_records(dir, o));
        ASSERT_NO_FATAL_FAILURE(check_patch_exr(dir, o));
    }
    check_report_and_tables(dir);
    check_verdicts(r, dir);
    check_energy_warnings(r, dir);
    EXPECT_FALSE(std::filesystem::exists(root / ".checkpoints"));
    std::filesystem::remove_all(root);
}

// Synthetic reciprocal couples measured like the goniometer's photon cells: N quanta, each a
// hit with probability ∝ the view cosine c (the detector's projected solid angle), carrying
// x = w / (P c) with w from one weight distribution for both cells, so both cells have the mean
// p̄ E[w] / P exactly; cell a views at 15°, cell b at 75° (hit sizes 3.7 apart), or the reverse.
// `hits` is the expected hits per unit view cosine, log-uniform in [lo, hi] over the couples;
// cell a's hit probability is scaled by `ratio` (1: reciprocal).
struct SyntheticChi2 {
    double score = 0.0, wald = 0.0;
    int dof = 0;
};
SyntheticChi2 synthetic_reciprocity(double lo, double hi, double ratio, std::uint64_t seed) {
    constexpr std::uint64_t kQuanta = 3000;
    constexpr int kCouples = 3000;
    const double projected = kPi * std::pow(std::sin(8.0 * kDeg), 2);
    const double c15 = std::cos(15.0 * kDeg), c75 = std::cos(75.0 * kDeg);
    auto cell = [&](Rng& rng, double hit_probability, double c) {
        double s1 = 0.0, s2 = 0.0;
        for (std::uint64_t q = 0; q < kQuanta; ++q) {
            if (!(rng.uniform() < hit_probability)) continue;
            const double x = (0.2 + 0.8 * rng.uniform()) / (projected * c);
            s1 += x;
            s2 += x * x;
        }
        const double n = static_cast<double>(kQuanta), mean = s1 / n;
        // The goniometer's estimator (virtual_gonio/goniometer.cpp, estimate_from_sums).
        return analysis::ReciprocityCell{
            mean, std::sqrt(std::max(0.0, s2 / n - mean * mean) / (n - 1.0)), c};
    };
    SyntheticChi2 out;
    for (int i = 0; i < kCouples; ++i) {
        Rng rng(seed, static_cast<std::uint64_t>(i));
        const double ca = i % 2 == 0 ? c15 : c75, cb = i % 2 == 0 ? c75 : c15;
        const double hits = lo * std::exp(rng.uniform() * std::log(hi / lo));
        const analysis::ReciprocityCell a = cell(rng, ratio * hits * ca / kQuanta, ca);
        const analysis::ReciprocityCell b = cell(rng, hits * cb / kQuanta, cb);
        const double z = analysis::reciprocity_z(a, b, kQuanta);
        if (std::isnan(z)) continue;
        out.score += z * z;
        const double wald = (a.value - b.value) / std::hypot(a.standard_error, b.standard_error);
        out.wald += wald * wald;  // both cells empty only when z is NaN
        ++out.dof;
    }
    return out;
}

// The reciprocity test keeps its size when the two cells of a couple have few hits of
// different sizes (grazing views), where each cell's own standard error (the Wald z) inflates
// χ² — the excess the species reports showed before this test existed — and still finds a
// 20 % non-reciprocity.
TEST(SpeciesStudy, ReciprocityScoreTestKeepsItsSizeWithFewUnequalHits) {
    for (const auto& [lo, hi] : {std::pair{1.0, 20.0}, std::pair{4.0, 80.0}}) {
        const SyntheticChi2 r = synthetic_reciprocity(lo, hi, 1.0, 2024);
        ASSERT_GT(r.dof, 2800);
        // χ²/dof of a calibrated test: 1 ± √(2/dof) ≈ 0.026; four standard deviations.
        const double band = 4.0 * std::sqrt(2.0 / r.dof);
        RecordProperty(fmt::format("score_chi2_per_dof_{}_{}", lo, hi),
                       fmt::format("{:.4f}", r.score / r.dof));
        RecordProperty(fmt::format("wald_chi2_per_dof_{}_{}", lo, hi),
                       fmt::format("{:.4f}", r.wald / r.dof));
        EXPECT_NEAR(r.score / r.dof, 1.0, band) << "hits per unit cosine " << lo << "-" << hi;
        EXPECT_GT(analysis::chi_square_p_value(r.score, r.dof), 1e-3);
        // The Wald z on the same cells: far outside the band (measured 1.51 and 1.40).
        EXPECT_GT(r.wald / r.dof, 1.0 + 2.0 * band) << "hits per unit cosine " << lo << "-" << hi;
    }
    const SyntheticChi2 unequal = synthetic_reciprocity(40.0, 400.0, 1.2, 2025);
    EXPECT_LT(analysis::chi_square_p_value(unequal.score, unequal.dof), 1e-6)
        << "chi2/dof " << unequal.score / unequal.dof;
}

TEST(SpeciesStudy, BadFilesNameTheKeyAndWriteNothing) {
    const auto root = std::filesystem::temp_directory_path() /
                      ("plumage_species_bad_" + std::to_string(::getpid()));
    const std::string base =
        read(std::filesystem::path(PLUMAGE_SOURCE_DIR) / "studies" / "species_quick.toml");
    auto message = [&](const std::string& text) {
        return testing::input_error_message(
            [&] { run_species_study(text, "bad.toml", root, false); });
    };
    // Unknown key, with its line.
    std::string typo = base;
    typo.replace(typo.find("layers = 2"), 10, "layer = 2");
    EXPECT_NE(message(typo).find("unknown key 'species.flamingo.layer'"), std::string::npos)
        << message(typo);
    EXPECT_NE(message(typo).find("bad.toml:"), std::string::npos);
    // A species Filip did not capture.
    std::string unknown = base;
    unknown.replace(unknown.find("parrot, rooster"), 15, "parrot, peacock");
    EXPECT_NE(message(unknown).find("peacock"), std::string::npos) << message(unknown);
    // A patch too small for light crossing the stack at 75°.
    std::string small = base;
    small.replace(small.find("length_um = 3200"), 16, "length_um = 500");
    EXPECT_NE(message(small).find("expected a larger length_um or more barbs"), std::string::npos)
        << message(small);
    EXPECT_NE(message(small).find("bad.toml:55:1: [species.parrot.patch] gives a patch"),
              std::string::npos)
        << message(small);
    // Out of range.
    std::string range = base;
    range.replace(range.find("pigment_k = 0.002"), 17, "pigment_k = -0.01");
    EXPECT_NE(message(range).find("pigment_k"), std::string::npos) << message(range);
    // A walk from the detector cannot reach a collimated light.
    std::string collimated = base;
    collimated.replace(collimated.find("aperture = \"both_cones\"\nestimator"), 23,
                       "aperture = \"view_cone\"");
    EXPECT_NE(message(collimated).find("[btf] estimator = \"detector\" needs aperture"),
              std::string::npos)
        << message(collimated);
    EXPECT_FALSE(std::filesystem::exists(root / "species_quick"));
    std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace plumage::studies
