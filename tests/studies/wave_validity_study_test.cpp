// The wave-validity study in its quick form: the records hold the numbers the study returns
// (HDF5 with units on every dataset and /provenance, CSV, report), every L1 sits beside a finite
// noise floor, the verdicts follow the stated rule, the base point is one measurement shared by
// the maps, and bad study files fail with file:line:column before anything is written.
#include "studies/wave_validity_study.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/error.h"
#include "tests/test_util.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

fs::path quick_study() {
    return fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "wave_validity_quick.toml";
}

fs::path temporary_root(const std::string& tag) {
    const auto root = fs::temp_directory_path() /
                      ("plumage_wave_validity_" + tag + "_" + std::to_string(::getpid()));
    fs::remove_all(root);
    return root;
}

std::string error_of(const std::string& text) {
    try {
        check_wave_validity_study(text, "bad.toml");
    } catch (const InputError& e) {
        return e.what();
    }
    return "(accepted)";
}

// Every point of a map: a finite L1 beside a finite, positive noise floor, the verdict the
// stated rule gives, and the cost of each level.
void check_map_point(const WaveValidityPoint& p, std::size_t n_inc, double threshold) {
    for (std::size_t i = 0; i < n_inc; ++i) {
        EXPECT_TRUE(std::isfinite(p.relative_l1[i]) && p.relative_l1[i] > 0.0);
        // Jittered rows over 3 realisations: a finite, positive floor.
        EXPECT_GT(p.noise_floor[i], 0.0);
        EXPECT_LT(p.noise_floor[i], p.relative_l1[i]);
        const double l1 = p.relative_l1[i], f = p.noise_floor[i];
        const std::string expected = l1 - 2.0 * f > threshold    ? "PO needed"
                                     : l1 + 2.0 * f <= threshold ? "GO suffices"
                                                                 : "undecided";
        EXPECT_EQ(p.verdict[i], expected);
    }
    EXPECT_GT(p.po_wall_s, 0.0);
    EXPECT_GT(p.go_wall_s, 0.0);
    // PO's sums over every angle cost more than GO's mirror rays.
    EXPECT_GT(p.po_cpu_s, p.go_cpu_s);
}

// The three maps as returned: their shapes, every point, and the base point shared by all.
void check_maps(const WaveValidityResult& r) {
    ASSERT_EQ(r.maps.size(), 3u);
    const std::size_t n_w = r.widths_um.size(), n_inc = r.incidence_deg.size();
    EXPECT_EQ(n_inc, 2u);
    for (const WaveValidityMap& m : r.maps) {
        ASSERT_EQ(m.points.size(), m.values.size() * n_w) << m.axis;
        for (const WaveValidityPoint& p : m.points) check_map_point(p, n_inc, r.threshold);
    }
    // The base row (b 0.25, d 0.59, H 1.25) is in every map: measured once, the same numbers.
    const WaveValidityPoint& film_base = r.maps[0].points[1 * n_w + 1];  // d = 0.59, width 8
    const WaveValidityPoint& b_base = r.maps[1].points[0 * n_w + 1];     // b = 0.25
    const WaveValidityPoint& h_base = r.maps[2].points[0 * n_w + 1];     // H = 1.25
    EXPECT_EQ(film_base.relative_l1, b_base.relative_l1);
    EXPECT_EQ(film_base.relative_l1, h_base.relative_l1);
}

// The HDF5 record: the numbers returned, units on every dataset, provenance.
void check_map_records(const fs::path& h5, const WaveValidityResult& r, const std::string& text) {
    const std::size_t n_w = r.widths_um.size(), n_inc = r.incidence_deg.size();
    for (const WaveValidityMap& m : r.maps) {
        const std::string g = "maps/" + m.axis + "/";
        const record::Dataset l1 = record::read_dataset(h5, g + "relative_l1");
        ASSERT_EQ(l1.dims, (std::vector<std::uint64_t>{n_inc, m.values.size(), n_w}));
        for (std::size_t i = 0; i < n_inc; ++i)
            for (std::size_t k = 0; k < m.points.size(); ++k)
                EXPECT_EQ(l1.values[i * m.points.size() + k], m.points[k].relative_l1[i]);
        for (const char* name :
             {"values", "relative_l1", "relative_l1_noise_floor", "wavelength_at_max_nm",
              "power_error", "po_wall_s", "go_cpu_s", "barbules_per_row", "boundary_width_um",
              "extrapolated_boundary_um"}) {
            EXPECT_FALSE(record::read_string_attribute(h5, g + name, "units").empty()) << name;
            EXPECT_FALSE(record::read_string_attribute(h5, g + name, "description").empty());
        }
    }
    EXPECT_EQ(record::read_string_attribute(h5, "/provenance", "config"), text);
    EXPECT_EQ(record::read_dataset(h5, "wavelengths_nm").values, r.wavelengths_nm);
}

// CSV: a header and one row per (map point, incidence); the report's sections.
void check_map_csv_and_report(const fs::path& dir, const WaveValidityResult& r,
                              const std::string& report) {
    std::size_t rows = 0;
    for (const WaveValidityMap& m : r.maps) rows += m.points.size() * r.incidence_deg.size();
    std::ifstream csv(dir / "wave_validity.csv");
    std::size_t lines = 0;
    for (std::string line; std::getline(csv, line);) ++lines;
    EXPECT_EQ(lines, rows + 1);
    for (const char* section : {"## Maps", "5 % boundary at θ_i = 0°", "extrapolated ≈",
                                "## Cost of each level", "## Statistical verdict",
                                "largest over the wavelengths", "width_x_film_thickness_um.png"})
        EXPECT_NE(report.find(section), std::string::npos) << section;
}

// The full-wave check: the 24 Meep curves as 12 unpolarised rows (single: θ_i 0° and 30°).
void check_full_wave_rows(const WaveValidityResult& r) {
    ASSERT_EQ(r.full_wave.size(), 12u);
    for (const WaveValidityFullWaveRow& f : r.full_wave) {
        EXPECT_EQ(f.polarisations, "TE+TM") << f.shape;
        for (double l1 : {f.go_vs_full_wave, f.po_vs_full_wave, f.po_vs_go})
            EXPECT_TRUE(std::isfinite(l1) && l1 > 0.0) << f.shape << " " << f.lambda_nm;
        EXPECT_GT(f.full_wave_floor, 0.0);
        EXPECT_GE(f.shadow_share, 0.0);
        EXPECT_LT(f.shadow_share, 0.1) << f.shape << ": the shadow part over |θ_s| < 90°";
        if (f.shape == "small") {
            EXPECT_GT(f.go_vs_full_wave, 0.4) << "the 2.6 µm shell diffracts";
        }
        if (f.shape == "single") {
            EXPECT_LT(f.po_vs_full_wave, 0.2) << f.theta_i_deg << " " << f.lambda_nm;
            EXPECT_LT(f.go_vs_full_wave, 0.3) << f.theta_i_deg << " " << f.lambda_nm;
        }
    }
}

// Each full-wave row's numbers in the report, the record (units, descriptions) and the CSV.
void check_full_wave_records(const fs::path& dir, const WaveValidityResult& r,
                             const std::string& report) {
    EXPECT_NE(report.find("## Against full wave"), std::string::npos);
    EXPECT_NE(report.find("| single | TE+TM | 30 | 650 |"), std::string::npos);
    EXPECT_NE(report.find("**Verdict.**"), std::string::npos);
    EXPECT_NE(report.find(r.full_wave_verdict), std::string::npos);
    EXPECT_NE(r.full_wave_verdict.find("The map's headline"), std::string::npos);
    const fs::path h5 = dir / "wave_validity.h5";
    for (const char* name : {"go_vs_full_wave", "po_vs_full_wave", "po_vs_go", "full_wave_floor",
                             "shadow_share", "theta_i_deg", "lambda_nm", "projected_width_um"}) {
        const std::string path = std::string("full_wave/") + name;
        EXPECT_EQ(record::read_dataset(h5, path).dims,
                  (std::vector<std::uint64_t>{r.full_wave.size()}))
            << name;
        EXPECT_FALSE(record::read_string_attribute(h5, path, "units").empty()) << name;
        EXPECT_FALSE(record::read_string_attribute(h5, path, "description").empty()) << name;
    }
    const record::Dataset go = record::read_dataset(h5, "full_wave/go_vs_full_wave");
    for (std::size_t k = 0; k < r.full_wave.size(); ++k)
        EXPECT_EQ(go.values[k], r.full_wave[k].go_vs_full_wave);
    EXPECT_EQ(record::read_string_attribute(h5, "full_wave", "verdict"), r.full_wave_verdict);
    std::ifstream fw_csv(dir / "full_wave_check.csv");
    int fw_lines = 0;
    for (std::string line; std::getline(fw_csv, line);) ++fw_lines;
    EXPECT_EQ(fw_lines, 13);
}

// The spongy scenes: every structure of the 3D reference, its levels cheapest first (the
// strong-contrast forms after first Born), the cheapest level within the tolerance as the
// reference's verdicts give it (at keratin's n = 1.55: first Born on the channel network; on
// keratin spheres in air only the strong-contrast form with keratin as host; on air spheres in
// keratin none, every level there lies within floors (18–41 %) wider than the 15 % asked, so only
// full wave is validated), each level's cost measured (> 0) and the record's columns one per
// (structure, level).
void check_spongy(const fs::path& dir, const WaveValidityResult& r, const std::string& report) {
    ASSERT_GE(r.spongy.size(), 3u);  // the three structures at n = 1.55, and any other index run
    std::size_t rows = 0;
    for (const SpongyScene& s : r.spongy) {
        ASSERT_FALSE(s.levels.empty()) << s.structure;
        bool seen_strong = false;
        for (const SpongyLevelJudgement& l : s.levels) {
            EXPECT_GT(l.seconds, 0.0) << s.structure << " " << l.route;
            const bool strong = l.route.starts_with("strong_");
            EXPECT_TRUE(strong || !seen_strong)
                << s.structure << ": " << l.route << " after a strong-contrast form";
            seen_strong = seen_strong || strong;
            ++rows;
        }
        EXPECT_GT(s.full_wave_seconds, 0.0) << s.structure;
        if (s.keratin_index == "1.55") {
            const std::string expected = s.structure == "keratin_spheres"
                                             ? "strong contrast, keratin host"
                                         : s.structure == "air_spheres" ? "full wave"
                                                                        : "first Born";
            EXPECT_EQ(s.cheapest, expected) << s.structure;
        }
        EXPECT_NE(report.find(fmt::format("**{}** (keratin n = {}): cheapest level within the "
                                          "tolerance: **{}**",
                                          s.structure, s.keratin_index, s.cheapest)),
                  std::string::npos)
            << s.structure;
    }
    const record::Dataset seconds =
        record::read_dataset(dir / "wave_validity.h5", "spongy/seconds");
    EXPECT_EQ(seconds.dims, (std::vector<std::uint64_t>{rows}));
    EXPECT_NE(record::read_string_attribute(dir / "wave_validity.h5", "spongy", "cheapest_level")
                  .find("channel: first Born"),
              std::string::npos);
}

// Runs the quick study once and checks each part of what it returned and wrote. A fatal
// failure in a check stops the test, as when the checks were inline (later ones index
// what the failed one asserted).
TEST(WaveValidityStudy, QuickStudyRecordsWhatItReturns) {
    const fs::path root = temporary_root("quick");
    const std::string text = testing::read_text_file(quick_study());
    const WaveValidityResult r = run_wave_validity_study(text, quick_study(), root, false);
    const fs::path dir = root / "wave_validity_quick";
    ASSERT_EQ(r.output_dir, dir);
    ASSERT_NO_FATAL_FAILURE(check_maps(r));
    ASSERT_NO_FATAL_FAILURE(check_map_records(dir / "wave_validity.h5", r, text));
    const std::string report = testing::read_text_file(dir / "report.md");
    check_map_csv_and_report(dir, r, report);
    ASSERT_NO_FATAL_FAILURE(check_full_wave_rows(r));
    check_full_wave_records(dir, r, report);
    ASSERT_NO_FATAL_FAILURE(check_spongy(dir, r, report));
    fs::remove_all(root);
}

// A study of two small scenes (b = 1, widths 2 and 2.4 µm, film 0.3 µm over a 0.3 µm gap: melanin
// cores 0.4 and 0.6 µm across; periods 1.25 and 1.5 µm) at a coarse live grid: with no budget
// nothing runs and the prediction is stated; with a budget full wave judges it and every number of
// the verdict is in the record, the CSV and the report.
std::string live_study(double budget_minutes) {
    return fmt::format(R"(study = "wave_validity"
name = "live"
[barbule]
b = 1.0
film_thickness_um = 0.3
[row]
realisations = 2
[sweep]
widths_um = [2, 2.4]
b = [1.0]
film_thickness_um = [0.3]
H = [1.25]
[spectrum]
first_nm = 550
last_nm = 650
step_nm = 100
[illumination]
incidence_deg = [0]
[full_wave]
live = true
resolution_px_per_um = 32
decay = 1e-3
budget_minutes = {}
)",
                       budget_minutes);
}

TEST(WaveValidityStudy, LiveFullWaveJudgesWhatTheBudgetAffords) {
    const fs::path root = temporary_root("live");
    const WaveValidityResult none =
        run_wave_validity_study(live_study(0), "live.toml", root, false);
    ASSERT_EQ(none.live.size(), 2u);  // the three maps share their base points
    for (const WaveValidityLivePoint& p : none.live) {
        EXPECT_EQ(p.status, "not afforded");
        EXPECT_GT(p.predicted_s, 0.0);
        EXPECT_EQ(p.seconds, 0.0);
    }
    fs::remove_all(root);

    const WaveValidityResult r = run_wave_validity_study(live_study(5), "live.toml", root, false);
    ASSERT_EQ(r.live.size(), 2u);
    ASSERT_EQ(r.live[0].status, "judged") << r.live[0].reason;
    for (const WaveValidityLivePoint& p : r.live) {
        if (p.status != "judged") continue;
        EXPECT_LE(std::abs(p.resolution_error), 0.02);
        ASSERT_EQ(p.lambda_nm, (std::vector<double>{550.0, 650.0}));
        for (std::size_t k = 0; k < 2; ++k) {
            EXPECT_GT(p.full_wave[k], 0.0);
            EXPECT_LT(p.full_wave[k], 1.0);
        }
        // the verdict follows the rule: the cheapest level whose band error is within 5 %
        const std::string expected = std::abs(p.go_error) <= 0.05   ? "ray optics + thin film"
                                     : std::abs(p.po_error) <= 0.05 ? "physical optics"
                                                                    : "full wave";
        EXPECT_EQ(p.level, expected);
        EXPECT_GT(p.seconds, 0.0);
    }
    const WaveValidityLivePoint& p = r.live[0];
    EXPECT_GT(r.live_seconds_per_cell_run, 0.0);
    const fs::path dir = root / "live";
    const fs::path h5 = dir / "wave_validity.h5";
    EXPECT_EQ(record::read_dataset(h5, "full_wave_live/physical_optics_error").values[0],
              p.po_error);
    EXPECT_FALSE(
        record::read_string_attribute(h5, "full_wave_live/resolution_error", "units").empty());
    EXPECT_EQ(
        record::read_string_attribute(h5, "full_wave_live", "levels").substr(0, p.level.size()),
        p.level);
    EXPECT_EQ(record::read_string_attribute(h5, "full_wave_live", "verdict"), r.live_verdict);
    std::ifstream csv(dir / "full_wave_live.csv");
    int lines = 0;
    for (std::string line; std::getline(csv, line);) ++lines;
    EXPECT_EQ(lines, 5);  // header, two scenes of two wavelengths
    const std::string report = testing::read_text_file(dir / "report.md");
    EXPECT_NE(report.find("## Judged by full wave, live"), std::string::npos);
    EXPECT_NE(report.find(r.live_verdict), std::string::npos);
    if (std::abs(p.po_error) > 0.05 || std::abs(r.live[1].po_error) > 0.05) {
        EXPECT_NE(report.find("Where physical optics fails"), std::string::npos);
        EXPECT_TRUE(fs::exists(dir / "live_spectra.h5"));
    }
    fs::remove_all(root);
}

TEST(WaveValidityStudy, BadFilesNameTheKeyAndLine) {
    EXPECT_EQ(error_of("study = \"wave_validity\"\nname = \"x\"\n"), "(accepted)");
    const std::string unknown = error_of("study = \"wave_validity\"\n[sweep]\nwidth_um = [1, 2]\n");
    EXPECT_NE(unknown.find("bad.toml:3:1"), std::string::npos) << unknown;
    EXPECT_NE(unknown.find("sweep.width_um"), std::string::npos) << unknown;
    const std::string order = error_of("study = \"wave_validity\"\n[sweep]\nwidths_um = [2, 1]\n");
    EXPECT_NE(order.find("bad.toml:3"), std::string::npos) << order;
    EXPECT_NE(order.find("increasing"), std::string::npos) << order;
    const std::string range = error_of("study = \"wave_validity\"\n[sweep]\nb = [0.25, 2]\n");
    EXPECT_NE(range.find("sweep.b at [1] = 2"), std::string::npos) << range;
    const std::string type = error_of("study = \"wave_validity\"\n[sweep]\nH = 1.25\n");
    EXPECT_NE(type.find("expected a list of 1 to 64 numbers"), std::string::npos) << type;
    const std::string kernel =
        error_of("study = \"wave_validity\"\n[detector]\nkernel = \"cone\"\n");
    EXPECT_NE(kernel.find("detector.kernel"), std::string::npos) << kernel;
    // The full-wave folder is checked when the file is read, naming the key and the file.
    const std::string folder =
        error_of("study = \"wave_validity\"\n[full_wave]\nreference = \"no/such/folder\"\n");
    EXPECT_NE(folder.find("bad.toml:3"), std::string::npos) << folder;
    EXPECT_NE(folder.find("full_wave.reference = \"no/such/folder\""), std::string::npos) << folder;
    EXPECT_NE(folder.find("expected a folder"), std::string::npos) << folder;
    // A live full-wave grid coarser than λ/(10 n) is refused when the file is read.
    const std::string grid = error_of(
        "study = \"wave_validity\"\n[full_wave]\nlive = true\nresolution_px_per_um = 20\n");
    EXPECT_NE(grid.find("bad.toml:4"), std::string::npos) << grid;
    EXPECT_NE(grid.find("full_wave.resolution_px_per_um = 20"), std::string::npos) << grid;
    EXPECT_NE(grid.find("λ/(10 n)"), std::string::npos) << grid;
}

}  // namespace
}  // namespace plumage::studies
