// The spongy-keratin study (studies/spongy_study.cpp): the quick study runs, its records read
// back, the base channel volume is blue from the computed medium alone, bad input is refused
// with file:line:col before anything is written, and the records do not depend on the thread
// count.
#include <omp.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "studies/study.h"
#include "tests/test_util.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

std::string read(const fs::path& p) { return testing::read_text_file(p); }

const fs::path kQuick = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "spongy_quick.toml";

fs::path temp_root(const std::string& tag) {
    const fs::path root =
        fs::temp_directory_path() / ("plumage_spongy_" + tag + "_" + std::to_string(::getpid()));
    fs::remove_all(root);
    return root;
}

record::Dataset dataset(const fs::path& h5, const std::string& name) {
    return record::read_dataset(h5, name);
}

TEST(SpongyStudy, QuickStudyIsBlueFromTheVolume) {
    const std::string text = read(kQuick);
    const StudyEntry& entry = study_of(text, kQuick);
    EXPECT_EQ(entry.kind, "spongy");
    const fs::path root = temp_root("quick");
    entry.run(text, kQuick, root, {});
    const fs::path dir = root / "spongy_quick";
    ASSERT_TRUE(fs::exists(dir / "report.md"));
    const fs::path h5 = dir / "spongy.h5";
    const auto wl = dataset(h5, "wavelength_nm");
    const auto r = dataset(h5, "reflectance");
    const auto se = dataset(h5, "reflectance_standard_error");
    const auto peak = dataset(h5, "peak_wavelength_nm");
    const auto hue = dataset(h5, "hue_deg");
    ASSERT_EQ(r.dims.size(), 3u);
    ASSERT_EQ(r.dims[2], wl.values.size());
    EXPECT_EQ(dataset(h5, "keratin_fraction").values.front(), 0.5);
    const double base_scale = dataset(h5, "length_scale_um").values.front();
    EXPECT_GE(base_scale, 0.18);
    EXPECT_LE(base_scale, 0.20);
    EXPECT_EQ(record::read_string_attribute(h5, "reflectance", "units"), "1");
    // Base (first) case: blue. Its peak lies below 500 nm and its hue is blue; R at the peak
    // exceeds R at 650 nm by more than 5 sigma. (The peak sits near the spectrum's short end,
    // well below 2 n_eff Lambda: see the study's report and studies/README.md.)
    const std::size_t w650 = static_cast<std::size_t>(
        std::find(wl.values.begin(), wl.values.end(), 650.0) - wl.values.begin());
    ASSERT_LT(w650, wl.values.size());
    std::size_t top = 0;
    for (std::size_t w = 0; w < wl.values.size(); ++w) top = r.values[w] > r.values[top] ? w : top;
    const double sigma = std::hypot(se.values[top], se.values[w650]);
    std::printf("base: peak %.1f nm, R %.4f +- %.4f at %g nm, R(650) %.4f, hue %.0f deg\n",
                peak.values[0], r.values[top], se.values[top], wl.values[top], r.values[w650],
                hue.values[0]);
    EXPECT_LT(peak.values[0], 500.0);
    // The single-scattering closed form of the same medium does peak in the blue, a little
    // short of 2 n_eff Lambda (the k0^4 of the Born cross-section).
    const double single = dataset(h5, "single_scattering_peak_wavelength_nm").values[0];
    const double bragg = dataset(h5, "bragg_wavelength_nm").values[0];
    std::printf("base: single-scattering peak %.1f nm, 2 n_eff Lambda %.1f nm\n", single, bragg);
    EXPECT_GT(single, 420.0);
    EXPECT_LT(single, 500.0);
    EXPECT_LT(single, bragg);
    EXPECT_GT(r.values[top] - r.values[w650], 5.0 * sigma);
    EXPECT_GT(hue.values[0], 225.0);
    EXPECT_LT(hue.values[0], 300.0);
    EXPECT_EQ(dataset(h5, "angles/reflectance").dims[0], 3u);
    // The geometric-optics baseline of the same volume (its mesh traced as interfaces) is not
    // blue: R(λ) is flat within its Monte Carlo noise (χ² test against a constant, p > 0.001,
    // a 1-in-1000 false alarm), and its chroma is below a tenth of the medium's.
    const auto baseline = dataset(h5, "baseline/reflectance");
    ASSERT_EQ(baseline.values.size(), wl.values.size());
    const double flat_p = record::read_number_attribute(h5, "baseline", "flatness_p_value");
    const double chroma = record::read_number_attribute(h5, "baseline", "chroma");
    const double medium_chroma = dataset(h5, "chroma").values[0];
    std::printf("baseline: R(%g nm) %.4f, flatness p %.3f, chroma %.2f (medium %.1f)\n",
                wl.values[0], baseline.values[0], flat_p, chroma, medium_chroma);
    EXPECT_GT(flat_p, 1e-3);
    EXPECT_LT(chroma, 0.1 * medium_chroma);
    // The report opens with its verdicts: the colour, the baseline's flatness test, and where
    // the route is trusted, with each case inside or outside that range.
    const std::string report = read(dir / "report.md");
    const auto verdicts = report.find("## Verdicts");
    EXPECT_LT(verdicts, report.find("Channel-type volumes"));
    EXPECT_NE(report.find("**Colour from the volume**", verdicts), std::string::npos);
    EXPECT_NE(report.find("p = ", verdicts), std::string::npos);
    EXPECT_NE(report.find("**Where the route is trusted**: this study's route, first Born"),
              std::string::npos);
    EXPECT_NE(report.find("  - f = 0.5, Λ = 0.19 µm: "), std::string::npos);
    for (const char* png : {"spectra.png", "peak_map.png", "angles.png"}) {
        if (!fs::exists(dir / png)) std::printf("note: %s not drawn (no matplotlib?)\n", png);
    }
    fs::remove_all(root);
}

TEST(SpongyStudy, CoarseVoxelsAreRefusedAtReadTime) {
    std::string text = read(kQuick);
    text.replace(text.find("voxel_um = 0.025"), 16, "voxel_um = 0.08 ");
    text.replace(text.find("box_um = 1.6"), 12, "box_um = 1.92");
    const fs::path root = temp_root("coarse");
    const std::string message =
        testing::input_error_message([&] { study_of(text, kQuick).run(text, kQuick, root, {}); });
    EXPECT_NE(message.find("spongy_quick.toml:14:12: volume.voxel_um = 0.08: voxels coarser than "
                           "lambda/(4 n_keratin)"),
              std::string::npos)
        << message;
    EXPECT_NE(message.find("380 nm"), std::string::npos) << message;
    EXPECT_FALSE(fs::exists(root / "spongy_quick"));
    fs::remove_all(root);
}

TEST(SpongyStudy, SlabThinnerThanATransportLengthIsRefused) {
    // The base medium's shortest transport length 1/(μ_s (1 − g)) is about 0.9 µm (at 380
    // nm); a 0.3 µm slab shows the backing, not the medium: refused naming the key, the value
    // and the limit, and nothing is written.
    std::string text = read(kQuick);
    text.replace(text.find("thickness_um = 3.0"), 18, "thickness_um = 0.3");
    const fs::path root = temp_root("thin");
    const std::string message =
        testing::input_error_message([&] { study_of(text, kQuick).run(text, kQuick, root, {}); });
    EXPECT_NE(message.find("spongy_quick.toml:20:16: slab.thickness_um = 0.3: thinner than one "
                           "transport length"),
              std::string::npos)
        << message;
    EXPECT_NE(message.find("l* = 1/(mu_s (1 - g) + mu_a) = "), std::string::npos) << message;
    EXPECT_FALSE(fs::exists(root / "spongy_quick"));
    fs::remove_all(root);
}

TEST(SpongyStudy, UnknownKeysAndBadListsAreNamed) {
    std::string text = read(kQuick);
    std::string typo = text;
    typo.replace(typo.find("thickness_um = 3.0"), 18, "thicknes_um = 3.0");
    EXPECT_NE(testing::input_error_message([&] {
                  check_study(typo, kQuick);
              }).find("spongy_quick.toml:20:1: unknown key 'slab.thicknes_um'"),
              std::string::npos)
        << testing::input_error_message([&] { check_study(typo, kQuick); });
    std::string list = text;
    list.replace(list.find("\"0.5, 0.4\""), 10, "\"0.5, 1.4\"");
    EXPECT_NE(testing::input_error_message([&] {
                  check_study(list, kQuick);
              }).find("spongy_quick.toml:16:21: volume.keratin_fractions = \"0.5, 1.4\""),
              std::string::npos)
        << testing::input_error_message([&] { check_study(list, kQuick); });
    std::string step = text;
    step.replace(step.find("step_nm = 10"), 12, "step_nm = 20");
    EXPECT_NE(testing::input_error_message([&] {
                  check_study(step, kQuick);
              }).find("spectrum.step_nm = 20: expected at most 10 nm"),
              std::string::npos);
}

// The quick study turned into one small sphere packing (f = 0.7: air spheres of a = 0.08 µm at
// φ = 0.3, disjoint), fewer paths, one angle; `route` is medium.route ("" for the default).
std::string sphere_study(const std::string& route) {
    std::string text = read(kQuick);
    text.replace(text.find("keratin_fractions = \"0.5, 0.4\""), 30,
                 "morphology = \"spheres\"\nkeratin_fractions = \"0.7\"");
    text.replace(text.find("length_scales_um = \"0.19, 0.23\""), 31, "sphere_radii_um = \"0.08\"");
    text.replace(text.find("shell_relative_width = 0.15"), 27, "");
    text.replace(text.find("incidence_deg = \"0, 30, 60\""), 27, "incidence_deg = \"30\"");
    for (std::size_t at = text.find("= 3000"); at != std::string::npos; at = text.find("= 3000")) {
        text.replace(at, 6, "= 1000");
    }
    text.replace(text.find("paths_per_wavelength = 1000\n", text.find("[baseline]")), 27,
                 "paths_per_wavelength = 200");
    if (!route.empty()) text += "\n[medium]\nroute = \"" + route + "\"\n";
    return text;
}

TEST(SpongyStudy, SpherePackingReportCarriesBothRoutes) {
    // Default route (born) on a hard-sphere packing: the report and the record carry the sphere
    // route beside it (μ_s, R, peak), and every reflectance is defined. μ_s(Born) / μ_s(sphere)
    // is the weak-contrast 1/(1 − φ)² = 2.04 (sim/wave/volume/born_medium.h) up to the O(Δn) terms
    // at keratin/air contrast: Bruggeman's second-order term, |2φδ/(3ε_h)| = 0.12 at δ = −1.4, ε_h
    // = 2.4, and Mie's departure from RGD; 25 % allows both.
    const std::string text = sphere_study("");
    const fs::path root = temp_root("spheres");
    study_of(text, kQuick).run(text, kQuick, root, {});
    const fs::path dir = root / "spongy_quick";
    const std::string report = read(dir / "report.md");
    for (const char* needle :
         {"## The two routes side by side", "is **first Born**",
          "## The routes against 3D full wave", "| channel | 1.55 | first Born (this study's) |",
          "| first Born |", "| sphere (Mie x S(q)) |", "ε_air − ε_eff",
          "## What each reflectance is", "specular reflection of the top face is included",
          "total-internal-reflection cone", "index-matched slab"}) {
        EXPECT_NE(report.find(needle), std::string::npos) << needle;
    }
    const fs::path h5 = dir / "spongy.h5";
    EXPECT_EQ(record::read_string_attribute(h5, "/", "medium_route"), "born");
    const auto born = dataset(h5, "mu_s_per_um").values;
    const auto sphere = dataset(h5, "other_route/mu_s_per_um").values;
    const double phi = dataset(h5, "sphere_fraction").values.at(0);
    ASSERT_EQ(born.size(), sphere.size());
    const std::size_t mid = born.size() / 2;
    const double limit = 1.0 / ((1.0 - phi) * (1.0 - phi));
    std::printf("phi %.3f: mu_s Born / sphere at the middle wavelength %.3f, limit %.3f\n", phi,
                born[mid] / sphere[mid], limit);
    EXPECT_NEAR(phi, 0.3, 0.01);  // the packing's N (4π/3) a³ / L³: within one sphere of 0.3
    EXPECT_NEAR(born[mid] / sphere[mid], limit, 0.25 * limit);
    EXPECT_EQ(dataset(h5, "other_route/reflectance").values.size(), born.size());
    EXPECT_GT(dataset(h5, "other_route/peak_wavelength_nm").values.at(0), 0.0);

    // medium.route = "sphere" makes the sphere route the study's: its μ_s is the Born run's
    // other_route, bit for bit (same volume, same centres), and Born goes beside it.
    const std::string swapped = sphere_study("sphere");
    const fs::path root2 = temp_root("sphere_route");
    study_of(swapped, kQuick).run(swapped, kQuick, root2, {});
    const fs::path h5b = root2 / "spongy_quick" / "spongy.h5";
    EXPECT_EQ(record::read_string_attribute(h5b, "/", "medium_route"), "sphere");
    EXPECT_EQ(dataset(h5b, "mu_s_per_um").values, sphere);
    EXPECT_EQ(dataset(h5b, "other_route/mu_s_per_um").values, born);
    EXPECT_NE(read(root2 / "spongy_quick" / "report.md").find("is **sphere route (Mie x S(q))**"),
              std::string::npos);
    fs::remove_all(root);
    fs::remove_all(root2);
}

TEST(SpongyStudy, ShippedSpherePackingStudyReadsWithEitherRoute) {
    const fs::path file = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "spongy_spheres_quick.toml";
    std::string text = read(file);
    EXPECT_NO_THROW(check_study(text, file));
    text.replace(text.find("route = \"born\""), 14, "route = \"sphere\"");
    EXPECT_NO_THROW(check_study(text, file));
}

TEST(SpongyStudy, SphereRouteRefusesWhatItCannotDescribe) {
    // Each refusal at read time, naming file:line:col, the key and the limit.
    const auto refusal = [](const std::string& text) {
        return testing::input_error_message([&] { check_study(text, kQuick); });
    };
    std::string channel = read(kQuick) + "\n[medium]\nroute = \"sphere\"\n";
    const std::string not_packing = refusal(channel);
    EXPECT_NE(not_packing.find("spongy_quick.toml:33:9: medium.route = \"sphere\" refused: "
                               "volume.morphology = \"channel\": a channel network is not a "
                               "sphere packing"),
              std::string::npos)
        << not_packing;
    std::string overlap = sphere_study("sphere");
    overlap.replace(overlap.find("morphology = \"spheres\""), 22,
                    "morphology = \"spheres\"\nmin_separation_diameters = 0.8");
    const std::string overlapping = refusal(overlap);
    EXPECT_NE(overlapping.find("volume.min_separation_diameters = 0.8: the spheres overlap"),
              std::string::npos)
        << overlapping;
    EXPECT_NE(overlapping.find("needs at least 1"), std::string::npos) << overlapping;
    std::string dense = sphere_study("sphere");
    dense.replace(dense.find("\"0.7\""), 5, "\"0.7, 0.6\"");
    const std::string too_dense = refusal(dense);
    EXPECT_NE(too_dense.find("volume.keratin_fractions lists 0.6 (air-sphere fraction phi = 0.4): "
                             "the sphere route needs phi in (0, 0.35]"),
              std::string::npos)
        << too_dense;
    std::string poly = sphere_study("sphere") + "polydispersity = 0.1\n";
    const std::string polydisperse = refusal(poly);
    EXPECT_NE(polydisperse.find("medium.polydispersity = 0.1: the sphere route accepts 0 only"),
              std::string::npos)
        << polydisperse;
    // The Born route has no polydispersity either: the generated volumes are monodisperse.
    std::string born_poly = sphere_study("born") + "polydispersity = 0.1\n";
    EXPECT_NE(refusal(born_poly).find("medium.polydispersity = 0.1: expected 0"), std::string::npos)
        << refusal(born_poly);
    // The same volumes are fine for the Born route, which takes any volume.
    overlap.replace(overlap.find("route = \"sphere\""), 16, "route = \"born\"  ");
    EXPECT_NO_THROW(check_study(overlap, kQuick));
    std::string unknown = sphere_study("spheres");
    EXPECT_NE(refusal(unknown).find("medium.route"), std::string::npos) << refusal(unknown);
}

TEST(SpongyStudy, RecordsDoNotDependOnThreads) {
    // One small case (the base), fewer paths: 1 and 2 threads give bit-identical spectra
    // (slab, angle and geometric-optics baseline).
    std::string text = read(kQuick);
    text.replace(text.find("\"0.5, 0.4\""), 10, "\"0.5\"     ");
    text.replace(text.find("\"0.19, 0.23\""), 12, "\"0.19\"      ");
    text.replace(text.find("incidence_deg = \"0, 30, 60\""), 27, "incidence_deg = \"30\"       ");
    std::vector<double> spectra[2];
    const int threads_before = omp_get_max_threads();
    for (int t = 0; t < 2; ++t) {
        omp_set_num_threads(t + 1);
        const fs::path root = temp_root("threads" + std::to_string(t));
        study_of(text, kQuick).run(text, kQuick, root, {});
        const fs::path h5 = root / "spongy_quick" / "spongy.h5";
        spectra[t] = dataset(h5, "reflectance").values;
        const auto angle = dataset(h5, "angles/reflectance").values;
        spectra[t].insert(spectra[t].end(), angle.begin(), angle.end());
        const auto baseline = dataset(h5, "baseline/reflectance").values;
        spectra[t].insert(spectra[t].end(), baseline.begin(), baseline.end());
        fs::remove_all(root);
    }
    omp_set_num_threads(threads_before);
    ASSERT_EQ(spectra[0].size(), spectra[1].size());
    for (std::size_t i = 0; i < spectra[0].size(); ++i) EXPECT_EQ(spectra[0][i], spectra[1][i]);
}

}  // namespace
}  // namespace plumage::studies
