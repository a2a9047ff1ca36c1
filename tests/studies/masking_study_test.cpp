// The masking study in its quick form: the analytic masking term of Padrón-Griffe 2024 agrees with
// Monte Carlo on the explicit cross-section (opaque rows) within a family-wise bound on every
// comparison, and with the explicit 3D patch (see-through rows) within that bound's σ plus the
// strip picture's model allowance; the records (HDF5, CSVs, report) hold exactly the numbers the
// study returns, the numbers do not depend on the thread count, and bad study files (old keys
// included) fail with file:line:column before anything is written.
#include "studies/masking_study.h"
#include "common/constants.h"

#include <omp.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/models/padrongriffe2024_masking.h"
#include "tests/test_util.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

std::string read(const fs::path& p) { return testing::read_text_file(p); }

fs::path quick_study() { return fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "masking_quick.toml"; }

fs::path temporary_root(const std::string& tag) {
    const auto root =
        fs::temp_directory_path() / ("plumage_masking_" + tag + "_" + std::to_string(::getpid()));
    fs::remove_all(root);
    return root;
}

// The two-sided standard-normal quantile of the Šidák per-comparison significance for m
// comparisons at family-wise 0.01, computed here independently of the study (bisection on erfc).
double sidak_z_bound(int m) {
    const double per_test = 1.0 - std::pow(1.0 - 0.01, 1.0 / m);
    double lo = 0.0, hi = 40.0;
    for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        (std::erfc(mid / std::sqrt(2.0)) > per_test ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

std::vector<std::string> split(const std::string& line, char separator) {
    std::vector<std::string> out;
    std::stringstream s(line);
    std::string field;
    while (std::getline(s, field, separator)) out.push_back(field);
    return out;
}

// Every value of the result's per-angle triples, in [configuration][angle][component] order.
std::vector<double> flatten(const MaskingStudyResult& r,
                            std::vector<MaskingTriple> MaskingConfigurationResult::*member) {
    std::vector<double> out;
    for (const auto& c : r.configurations)
        for (const auto& t : c.*member) out.insert(out.end(), t.begin(), t.end());
    return out;
}

// One configuration of the quick study: the analytic column is the term's opaque cross-section,
// every Monte Carlo value within the Šidák bound and the stratified bound, fractions summing to
// one, and the 3D check on the explicit patch. Updates the largest |difference| and |z| seen.
void check_configuration(const MaskingConfigurationResult& c, const MaskingStudyResult& r,
                         double z_bound, double& max_difference, double& max_z) {
    const analysis::PadronGriffe2024Masking masking(c.params,
                                                    analysis::BarbuleStrips::kFibreThickness);
    ASSERT_EQ(c.analytic.size(), r.angles_deg.size());
    EXPECT_EQ(c.degrees_of_freedom, static_cast<int>(r.angles_deg.size()));
    EXPECT_NEAR(c.period_um, masking.period_um(), 1e-12 * c.period_um);
    for (std::size_t i = 0; i < r.angles_deg.size(); ++i) {
        const std::string where = c.name + " at " + std::to_string(r.angles_deg[i]) + " deg";
        // The analytic column is the term's cross-section with opaque rows (the polygons are
        // opaque), with distal and proximal summed.
        const auto f = masking.fractions(r.angles_deg[i] * kDeg, analysis::RowTransmittance{});
        EXPECT_EQ(c.analytic[i][0], f.barb) << where;
        EXPECT_EQ(c.analytic[i][1], f.barbule()) << where;
        EXPECT_EQ(c.analytic[i][2], f.gap) << where;
        double mc_sum = 0.0;
        for (std::size_t k = 0; k < 3; ++k) {
            const double difference = c.mc[i][k] - c.analytic[i][k];
            EXPECT_GE(c.mc_standard_error[i][k], 1.0 / static_cast<double>(r.rays)) << where;
            EXPECT_DOUBLE_EQ(c.z[i][k], difference / c.mc_standard_error[i][k]) << where;
            EXPECT_LT(std::abs(c.z[i][k]), z_bound) << where << " component " << k;
            // The deterministic bound of stratified sampling (plus the polygons' offset).
            EXPECT_LE(std::abs(difference), c.stratified_bound[i]) << where;
            max_difference = std::max(max_difference, std::abs(difference));
            max_z = std::max(max_z, std::abs(c.z[i][k]));
            mc_sum += c.mc[i][k];
        }
        EXPECT_NEAR(mc_sum, 1.0, 1e-12) << where;
    }
    EXPECT_EQ(c.above_stratified_bound, 0) << c.name;
    EXPECT_LE(c.max_bound_ratio, 1.0) << c.name;
    for (std::size_t k = 0; k < 3; ++k) {
        EXPECT_GE(c.chi_square_p_value[k], r.chi_square_significance) << c.name;
    }
    // The 3D check: the term with see-through rows at ω against the explicit patch.
    ASSERT_EQ(c.directions.size(), kMaskingCheckDirections.size());
    for (const auto& d : c.directions) {
        const std::string where = fmt::format("{} at ({:.3f}, {:.3f}, {:.3f})", c.name,
                                              d.direction.x(), d.direction.y(), d.direction.z());
        EXPECT_NEAR(d.direction.norm(), 1.0, 1e-12);
        EXPECT_DOUBLE_EQ(d.projected_angle_deg,
                         std::atan2(d.direction.y(), d.direction.z()) / kDeg);
        const auto f = masking(d.direction);
        EXPECT_EQ(d.model, (PatchQuad{f.barb, f.distal_barbule, f.proximal_barbule, f.gap}))
            << where;
        const auto rows = masking.row_transmittance(d.direction);
        EXPECT_EQ(d.transmittance_distal, rows.distal) << where;
        EXPECT_EQ(d.transmittance_proximal, rows.proximal) << where;
        EXPECT_GT(d.allowance, 0.0) << where;
        EXPECT_GE(d.rays, r.patch_rays * 9 / 10) << where;
        EXPECT_LE(d.rays, r.patch_rays) << where;
        double mc_sum = 0.0;
        for (std::size_t k = 0; k < kPatchComponentCount; ++k) {
            const double difference = d.mc[k] - d.model[k];
            EXPECT_DOUBLE_EQ(d.z[k], difference / d.mc_standard_error[k]) << where;
            EXPECT_LE(std::abs(difference), z_bound * d.mc_standard_error[k] + d.allowance)
                << where << " component " << k;
            mc_sum += d.mc[k];
        }
        EXPECT_NEAR(mc_sum, 1.0, 1e-12) << where;
    }
    EXPECT_EQ(c.patch_beyond, 0) << c.name;
    EXPECT_LE(c.patch_max_excess, 1.0) << c.name;
}

// The HDF5 record: the same numbers, exactly, with their layout and units.
void check_record(const fs::path& dir, const MaskingStudyResult& r) {
    const fs::path h5 = dir / "masking.h5";
    const auto angles = record::read_dataset(h5, "angles_deg");
    EXPECT_EQ(angles.values, r.angles_deg);
    EXPECT_EQ(record::read_string_attribute(h5, "angles_deg", "units"), "deg");
    using R = MaskingConfigurationResult;
    for (const auto& [name, member] :
         std::vector<std::pair<std::string, std::vector<MaskingTriple> R::*>>{
             {"analytic", &R::analytic},
             {"mc", &R::mc},
             {"mc_standard_error", &R::mc_standard_error},
             {"z", &R::z}}) {
        const auto data = record::read_dataset(h5, name);
        EXPECT_EQ(data.dims, (std::vector<std::uint64_t>{4, 11, 3})) << name;
        EXPECT_EQ(data.values, flatten(r, member)) << name;
    }
    EXPECT_EQ(record::read_string_attribute(h5, "/", "configurations"),
              "default,opaque_rows,authors_barb_figure,sparse");
    EXPECT_EQ(record::read_number_attribute(h5, "/", "rays_per_angle"), 20000.0);
    EXPECT_EQ(record::read_number_attribute(h5, "/", "patch_rays_per_direction"), 40000.0);
    EXPECT_NEAR(record::read_number_attribute(h5, "/configuration/authors_barb_figure",
                                              "barbule_inclination_deg"),
                45.0, 1e-12);
    EXPECT_EQ(record::read_number_attribute(h5, "/configuration/opaque_rows",
                                            "barbule_separation_barbule_widths"),
              0.0);
    const std::uint64_t n_dir = kMaskingCheckDirections.size();
    for (const auto& [name, member] :
         std::vector<std::pair<std::string, PatchQuad MaskingDirectionCheck::*>>{
             {"patch_3d/model", &MaskingDirectionCheck::model},
             {"patch_3d/mc", &MaskingDirectionCheck::mc},
             {"patch_3d/mc_standard_error", &MaskingDirectionCheck::mc_standard_error},
             {"patch_3d/z", &MaskingDirectionCheck::z}}) {
        const auto data = record::read_dataset(h5, name);
        EXPECT_EQ(data.dims, (std::vector<std::uint64_t>{4, n_dir, 4})) << name;
        std::vector<double> expected;
        for (const auto& c : r.configurations)
            for (const auto& d : c.directions)
                expected.insert(expected.end(), (d.*member).begin(), (d.*member).end());
        EXPECT_EQ(data.values, expected) << name;
    }
    const auto allowance = record::read_dataset(h5, "patch_3d/allowance");
    EXPECT_EQ(allowance.dims, (std::vector<std::uint64_t>{4, n_dir}));
    EXPECT_EQ(allowance.values[1], r.configurations[0].directions[1].allowance);
}

// The CSV: one row per configuration and angle, the same numbers to the last bit.
void check_csv(const fs::path& dir, const MaskingStudyResult& r) {
    std::ifstream csv(dir / "masking.csv");
    std::string line;
    ASSERT_TRUE(std::getline(csv, line));
    const auto header = split(line, ',');
    ASSERT_EQ(header.size(), 2u + 4u * 3u + 1u);
    EXPECT_EQ(header[2], "analytic_barb");
    EXPECT_EQ(header[7], "mc_gap");
    EXPECT_EQ(header.back(), "stratified_bound");
    std::size_t rows = 0;
    while (std::getline(csv, line)) {
        const auto fields = split(line, ',');
        ASSERT_EQ(fields.size(), header.size()) << line;
        const std::size_t c = rows / r.angles_deg.size(), i = rows % r.angles_deg.size();
        ASSERT_LT(c, r.configurations.size());
        const auto& config = r.configurations[c];
        EXPECT_EQ(fields[0], config.name);
        EXPECT_EQ(std::stod(fields[1]), r.angles_deg[i]);
        for (std::size_t k = 0; k < 3; ++k) {
            EXPECT_EQ(std::stod(fields[2 + k]), config.analytic[i][k]);
            EXPECT_EQ(std::stod(fields[5 + k]), config.mc[i][k]);
            EXPECT_EQ(std::stod(fields[8 + k]), config.mc_standard_error[i][k]);
            EXPECT_EQ(std::stod(fields[11 + k]), config.z[i][k]);
        }
        EXPECT_EQ(std::stod(fields[14]), config.stratified_bound[i]);
        ++rows;
    }
    EXPECT_EQ(rows, r.configurations.size() * r.angles_deg.size());
}

// The 3D CSV: one row per configuration and direction, the same numbers to the last bit.
void check_patch_csv(const fs::path& dir, const MaskingStudyResult& r) {
    std::ifstream csv(dir / "masking_3d.csv");
    std::string line;
    ASSERT_TRUE(std::getline(csv, line));
    const auto header = split(line, ',');
    ASSERT_EQ(header.size(), 10u + 4u * 4u + 1u);
    EXPECT_EQ(header[10], "model_barb");
    EXPECT_EQ(header[15], "mc_distal_barbule");
    EXPECT_EQ(header.back(), "allowance");
    std::size_t rows = 0;
    const std::size_t n_dir = kMaskingCheckDirections.size();
    while (std::getline(csv, line)) {
        const auto fields = split(line, ',');
        ASSERT_EQ(fields.size(), header.size()) << line;
        const std::size_t c = rows / n_dir, j = rows % n_dir;
        ASSERT_LT(c, r.configurations.size());
        const auto& d = r.configurations[c].directions[j];
        EXPECT_EQ(fields[0], r.configurations[c].name);
        EXPECT_EQ(std::stod(fields[1]), kMaskingCheckDirections[j][0]);
        EXPECT_EQ(std::stod(fields[3]), d.direction.x());
        EXPECT_EQ(std::stoll(fields[9]), d.rays);
        for (std::size_t k = 0; k < kPatchComponentCount; ++k) {
            EXPECT_EQ(std::stod(fields[10 + k]), d.model[k]);
            EXPECT_EQ(std::stod(fields[14 + k]), d.mc[k]);
            EXPECT_EQ(std::stod(fields[18 + k]), d.mc_standard_error[k]);
            EXPECT_EQ(std::stod(fields[22 + k]), d.z[k]);
        }
        EXPECT_EQ(std::stod(fields[26]), d.allowance);
        ++rows;
    }
    EXPECT_EQ(rows, r.configurations.size() * n_dir);
}

TEST(MaskingStudy, QuickStudyAgreesWithMonteCarloWithinTheFamilyWiseBound) {
    const auto root = temporary_root("quick");
    const MaskingStudyResult r = run_masking_study(read(quick_study()), quick_study(), root, false);
    const fs::path dir = root / "masking_quick";
    ASSERT_EQ(r.output_dir, dir);
    ASSERT_EQ(r.configurations.size(), 4u);
    ASSERT_EQ(r.angles_deg.size(), 11u);  // −85..85 by 17
    EXPECT_DOUBLE_EQ(r.angles_deg.front(), -85.0);
    EXPECT_DOUBLE_EQ(r.angles_deg.back(), 85.0);
    EXPECT_EQ(r.rays, 20000);
    EXPECT_EQ(r.patch_rays, 40000);
    EXPECT_EQ(r.configurations[0].name, "default");
    EXPECT_EQ(r.configurations[1].name, "opaque_rows");  // the file's order, not alphabetical
    EXPECT_EQ(r.configurations[2].name, "authors_barb_figure");
    EXPECT_EQ(r.configurations[3].name, "sparse");

    // Every comparison (angles × 3 components, 3D directions × 4) in the Šidák family.
    const int m = static_cast<int>(r.configurations.size() *
                                   (r.angles_deg.size() * 3 + kMaskingCheckDirections.size() * 4));
    ASSERT_EQ(r.comparisons, m);
    const double z_bound = sidak_z_bound(m);
    EXPECT_NEAR(r.z_bound, z_bound, 1e-9);
    double max_difference = 0.0, max_z = 0.0;
    for (const auto& c : r.configurations)
        check_configuration(c, r, z_bound, max_difference, max_z);
    EXPECT_DOUBLE_EQ(r.max_abs_difference, max_difference);
    EXPECT_GE(r.max_abs_z, max_z);
    // 20 000 stratified rays: the bound is ~(10 + 2)/N + geometry, ~1e-3 at 85°.
    EXPECT_LT(r.max_abs_difference, 2e-3);
    EXPECT_TRUE(r.agrees) << r.verdict;
    // With opaque rows the sparse vane lets light through at normal incidence and the default one
    // (barbule tips meet) does not: the 2D comparison covers all three components.
    EXPECT_GT(r.configurations[3].analytic[5][2], 0.2);
    EXPECT_EQ(r.configurations[0].analytic[5][2], 0.0);
    // In 3D the default rows are see-through (a third of each row open): the term and the explicit
    // patch both pass light at normal view; opaque rows pass none in the term.
    ASSERT_EQ(kMaskingCheckDirections[0][0], 0.0);
    EXPECT_GT(r.configurations[0].directions[0].model[3], 0.2);
    EXPECT_GT(r.configurations[0].directions[0].mc[3], 0.2);
    EXPECT_EQ(r.configurations[1].directions[0].model[3], 0.0);
    EXPECT_LT(r.configurations[1].directions[0].mc[3], 0.005);  // the roots' clearance only

    check_record(dir, r);
    check_csv(dir, r);
    check_patch_csv(dir, r);

    // The report: the verdict, the table with a row per configuration, the 3D check, the plot.
    const std::string report = read(dir / "report.md");
    EXPECT_NE(report.find("**Agrees.**"), std::string::npos);
    EXPECT_NE(report.find("| configuration | period (µm) |"), std::string::npos);
    EXPECT_NE(report.find("upper bound"), std::string::npos);
    for (const auto& c : r.configurations) {
        EXPECT_NE(report.find("| " + c.name + " | " + fmt::format("{:.2f}", c.period_um)),
                  std::string::npos)
            << c.name;
    }
    EXPECT_NE(report.find("## 3D directions: the term against the explicit 3D patch"),
              std::string::npos);
    EXPECT_NE(report.find("## What changed in the parameters"), std::string::npos);
    EXPECT_NE(report.find("**Model allowance.**"), std::string::npos);
    EXPECT_NE(report.find("![fractions against angle"), std::string::npos);
    EXPECT_GT(fs::file_size(dir / "masking.png"), 10000u);
    // Nothing but the committed folder is left in the results root.
    std::size_t entries = 0;
    for (const auto& e : fs::directory_iterator(root)) {
        EXPECT_EQ(e.path().filename(), "masking_quick");
        ++entries;
    }
    EXPECT_EQ(entries, 1u);
    fs::remove_all(root);
}

TEST(MaskingStudy, NumbersDoNotDependOnTheThreadCount) {
    const std::string text = read(quick_study());
    const int threads = omp_get_max_threads();
    const auto root = temporary_root("threads");
    omp_set_num_threads(1);
    const MaskingStudyResult one = run_masking_study(text, quick_study(), root / "one", false);
    omp_set_num_threads(std::max(2, threads));
    const MaskingStudyResult many = run_masking_study(text, quick_study(), root / "many", false);
    omp_set_num_threads(threads);
    ASSERT_EQ(one.configurations.size(), many.configurations.size());
    for (std::size_t c = 0; c < one.configurations.size(); ++c) {
        EXPECT_EQ(one.configurations[c].mc, many.configurations[c].mc);
        EXPECT_EQ(one.configurations[c].directions[0].mc, many.configurations[c].directions[0].mc);
    }
    fs::remove_all(root);
}

class MaskingStudyInput : public ::testing::Test {
protected:
    void SetUp() override { root_ = temporary_root("input"); }
    void TearDown() override { fs::remove_all(root_); }
    // The InputError message for a study text named bad_masking.toml; nothing may be written.
    std::string error_of(const std::string& text) {
        const std::string message = plumage::testing::input_error_message(
            [&] { run_masking_study(text, "bad_masking.toml", root_, false); });
        EXPECT_FALSE(fs::exists(root_) && !fs::is_empty(root_)) << "results left behind";
        return message;
    }
    fs::path root_;
};

constexpr const char* kHead = "study = \"masking\"\n[monte_carlo]\nrays = 1000\n";

TEST_F(MaskingStudyInput, UnknownKeyNamesFileLineAndColumn) {
    const std::string m =
        error_of(std::string(kHead) + "[configurations.default.vane]\nbarb_widht_um = 3\n");
    EXPECT_NE(
        m.find("bad_masking.toml:5:1: unknown key 'configurations.default.vane.barb_widht_um'"),
        std::string::npos)
        << m;
    const std::string top = error_of(std::string(kHead) + "rayz = 4\n[configurations.default]\n");
    EXPECT_NE(top.find("bad_masking.toml:4:1: unknown key 'monte_carlo.rayz'"), std::string::npos)
        << top;
}

TEST_F(MaskingStudyInput, OutOfRangeValuesNameTheKeyAndTheRange) {
    const std::string base = std::string(kHead) + "[configurations.default]\n";
    std::string m = error_of(base + "[angles]\nfrom_deg = -95\n");
    EXPECT_NE(m.find("bad_masking.toml:6:12: angles.from_deg = -95: expected a number in [-89.9, "
                     "89.9]"),
              std::string::npos)
        << m;
    m = error_of(base + "[angles]\nfrom_deg = 10\nto_deg = -10\n");
    EXPECT_NE(m.find("angles.to_deg = -10: expected a number >= from_deg = 10"), std::string::npos)
        << m;
    m = error_of(base + "[angles]\nstep_deg = 0\n");
    EXPECT_NE(m.find("angles.step_deg = 0: expected a number in (0, 179.8]"), std::string::npos)
        << m;
    m = error_of("study = \"masking\"\n[monte_carlo]\nrays = 5\n[configurations.default]\n");
    EXPECT_NE(m.find("monte_carlo.rays = 5: expected an integer in [100, 1000000000]"),
              std::string::npos)
        << m;
    m = error_of(std::string(kHead) + "[configurations.a.vane]\nbarbule_inclination_deg = 90\n");
    EXPECT_NE(m.find("configurations.a.vane.barbule_inclination_deg = 90: expected a number in "
                     "(-90, 90)"),
              std::string::npos)
        << m;
    m = error_of(base + "[patch_monte_carlo]\nrays = 5\n");
    EXPECT_NE(m.find("patch_monte_carlo.rays = 5: expected an integer in [100, 1000000000]"),
              std::string::npos)
        << m;
}

TEST_F(MaskingStudyInput, ConfigurationsMustExistBeTablesAndBuild) {
    std::string m = error_of(kHead);
    EXPECT_NE(m.find("configurations: expected at least one [configurations.NAME] table"),
              std::string::npos)
        << m;
    m = error_of(std::string(kHead) + "[configurations]\nplain = 3\n");
    EXPECT_NE(m.find("bad_masking.toml:5:9: configurations.plain is an integer: expected a table"),
              std::string::npos)
        << m;
    m = error_of(std::string(kHead) + "[configurations.\"a b\"]\n");
    EXPECT_NE(m.find("configurations.\"a b\": expected a name of letters, digits"),
              std::string::npos)
        << m;
    // A medulla that leaves the cortex: the geometry refuses it, named with the configuration.
    m = error_of(std::string(kHead) +
                 "[configurations.leaky.vane]\nmedulla_scale = 0.9\nmedulla_offset_y_um = 10\n");
    EXPECT_NE(m.find("bad_masking.toml:4:"), std::string::npos) << m;
    EXPECT_NE(m.find("configurations.leaky: "), std::string::npos) << m;
    EXPECT_NE(m.find("medulla_offset"), std::string::npos) << m;
    // Barbules not perpendicular to the barb: the term has them, the explicit patch does not.
    m = error_of(std::string(kHead) + "[configurations.turned.vane]\nbarbule_rotation_deg = 45\n");
    EXPECT_NE(m.find("configurations.turned: "), std::string::npos) << m;
    EXPECT_NE(m.find("barbule_rotation"), std::string::npos) << m;
}

// The tables of the earlier meanings are refused, never reinterpreted (issue 20).
TEST_F(MaskingStudyInput, OldBarbAndBarbuleTablesAreRefused) {
    for (const char* old : {"barb", "barbules"}) {
        const std::string m = error_of(std::string(kHead) + "[configurations.old." + old +
                                       "]\ninclination_deg = 30\n");
        EXPECT_NE(m.find(fmt::format("configurations.old.{}: the barb and barbule keys moved to "
                                     "[configurations.old.vane]",
                                     old)),
                  std::string::npos)
            << m;
        EXPECT_NE(m.find("studies/README.md"), std::string::npos) << m;
    }
}

}  // namespace
}  // namespace plumage::studies
