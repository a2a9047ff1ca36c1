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
#include "virtual_gonio/hdf5_file.h"

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
