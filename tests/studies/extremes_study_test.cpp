// The extremes study in its quick form: no scatterer produces NaN, Inf, a negative value
// or a malformed event in any case, none creates energy beyond Monte Carlo error — except
// the Filip 2024 presets whose published parameters do so by construction, which must be
// flagged as such (and only they) — and the inputs the geometry refuses are listed as
// rejected, not failed.
#include "studies/extremes_study.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "tests/test_util.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

std::string read(const std::filesystem::path& p) {
    std::ifstream in(p);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

const ExtremesRow* find(const ExtremesResult& r, const std::string& case_name,
                        const std::string& scatterer) {
    for (const auto& row : r.rows)
        if (row.case_name == case_name && row.scatterer == scatterer) return &row;
    return nullptr;
}

// Zero numerical violations and zero unexplained energy excesses, row by row; every kind of
// scatterer present.
void check_no_violations(const ExtremesResult& r) {
    // Zero numerical violations and zero unexplained energy excesses, row by row.
    EXPECT_EQ(r.numerical_violations, 0);
    EXPECT_EQ(r.energy_violations, 0);
    ASSERT_GT(r.rows.size(), 50u);
    std::set<std::string> scatterers;
    for (const auto& row : r.rows) {
        const std::string where = row.case_name + " / " + row.scatterer;
        EXPECT_EQ(row.nan, 0) << where;
        EXPECT_EQ(row.inf, 0) << where;
        EXPECT_EQ(row.negative, 0) << where;
        EXPECT_EQ(row.malformed, 0) << where;
        EXPECT_EQ(row.failure, "") << where;
        if (row.rejected) continue;
        scatterers.insert(row.scatterer);
        EXPECT_GT(row.samples, 0u) << where;
        EXPECT_TRUE(std::isfinite(row.energy)) << where;
        // Energy above 1 beyond 4σ only where the published model puts it.
        if (!row.by_construction) {
            EXPECT_LE(row.energy - 4.0 * row.energy_error, 1.0 + 1e-9) << where;
        }
        if (row.scatterer.rfind("explicit", 0) == 0) {
            EXPECT_EQ(row.reached_max_events, 0) << where;
        }
    }
    for (const char* s :
         {"Huang 2022", "Filip 2024 parrot", "Filip 2024 rooster", "Filip 2024 flamingo",
          "Filip 2024 stork", "Lambertian ρ = 1", "explicit barbules"}) {
        EXPECT_TRUE(scatterers.contains(s)) << s;
    }
}

// The published Filip parameters' known energy excesses, and only they, flagged "by
// construction".
void check_published_excesses(const ExtremesResult& r) {
    // The known excesses of the published Filip parameters (analysis/models/filip2024.h):
    // flamingo and stork at moderate incidence, rooster only at grazing light; the
    // parrot never. They, and nothing else, are flagged "by construction".
    std::set<std::string> flagged;
    for (const auto& row : r.rows) {
        if (row.by_construction) {
            flagged.insert(row.case_name + " / " + row.scatterer);
            EXPECT_EQ(row.scatterer.rfind("Filip 2024 ", 0), 0u) << row.scatterer;
        }
    }
    for (const char* c : {"reference", "grazing 89°", "grazing 89.9°"}) {
        EXPECT_TRUE(flagged.contains(std::string(c) + " / Filip 2024 flamingo")) << c;
        EXPECT_TRUE(flagged.contains(std::string(c) + " / Filip 2024 stork")) << c;
        EXPECT_FALSE(flagged.contains(std::string(c) + " / Filip 2024 parrot")) << c;
    }
    EXPECT_FALSE(flagged.contains("reference / Filip 2024 rooster"));
    EXPECT_TRUE(flagged.contains("grazing 89° / Filip 2024 rooster"));
    EXPECT_EQ(r.by_construction, static_cast<int>(flagged.size()));
    // The rooster at 89°: 1.11 by quadrature (analysis/models/filip2024.h's figure).
    const ExtremesRow* rooster = find(r, "grazing 89°", "Filip 2024 rooster");
    ASSERT_NE(rooster, nullptr);
    EXPECT_NEAR(rooster->eval_energy, 1.11, 0.03);
}

// Rows whose energy is known exactly or physically.
void check_exact_values(const ExtremesResult& r) {
    // Exact and physical values: a white Lambertian reflector returns every quantum with
    // weight 1 (energy exactly 1, not above), a black one nothing; the Huang model
    // with a sliver of arc lets everything pass; far-apart barbules pass most light in
    // the model and the simulation alike; with no film, no film reflection: little is left.
    const ExtremesRow* white = find(r, "grazing 89.9°", "Lambertian ρ = 1");
    ASSERT_NE(white, nullptr);
    EXPECT_DOUBLE_EQ(white->energy, 1.0);
    EXPECT_FALSE(white->energy_excess);
    EXPECT_EQ(find(r, "strong absorption", "Lambertian ρ = 0")->energy, 0.0);
    EXPECT_NEAR(find(r, "φ1 − φ0 = 1e-4 rad", "Huang 2022")->energy, 1.0, 1e-3);
    const ExtremesRow* gaps_model = find(r, "H = 20 (gaps)", "Huang 2022");
    const ExtremesRow* gaps_sim = find(r, "H = 20 (gaps)", "explicit barbules");
    EXPECT_GT(gaps_model->energy, 0.9);
    EXPECT_NEAR(gaps_sim->energy, gaps_model->energy, 0.03);
    const ExtremesRow* bare_model = find(r, "film d = 0", "Huang 2022");
    const ExtremesRow* bare_sim = find(r, "film d = 0", "explicit barbules");
    EXPECT_LT(bare_model->energy, 0.25);
    EXPECT_LT(bare_sim->energy, 0.25);
}

TEST(ExtremesStudy, QuickVariantFindsNoViolationsAndFlagsThePublishedExcesses) {
    const auto root =
        std::filesystem::temp_directory_path() / ("plumage_extremes_" + std::to_string(::getpid()));
    const std::filesystem::path study =
        std::filesystem::path(PLUMAGE_SOURCE_DIR) / "studies" / "extremes_quick.toml";
    const ExtremesResult r = run_extremes_study(read(study), study, root, false);
    const auto dir = root / "extremes_quick";
    ASSERT_EQ(r.output_dir, dir);

    check_no_violations(r);

    check_published_excesses(r);

    check_exact_values(r);

    // sample() and eval() describe the same scatterer: where the albedo quadrature
    // resolves f, it agrees with the sampled energy (smooth models: everywhere).
    for (const auto& row : r.rows) {
        if (row.rejected || !row.evaluated) continue;
        if (row.scatterer.rfind("Filip", 0) == 0 || row.scatterer.rfind("Lambertian", 0) == 0) {
            EXPECT_EQ(row.eval_unresolved, 0) << row.case_name << " / " << row.scatterer;
            EXPECT_EQ(row.eval_agreeing, row.eval_items) << row.case_name << " / " << row.scatterer;
        }
    }

    // Rejected, not failed: the explicit row with interpenetrating barbules (H = 0.3).
    EXPECT_EQ(r.rejected, 1);
    const ExtremesRow* overlap = find(r, "H = 0.3 (overlap)", "explicit barbules");
    ASSERT_NE(overlap, nullptr);
    EXPECT_TRUE(overlap->rejected);
    EXPECT_NE(overlap->rejection.find("interpenetrate"), std::string::npos) << overlap->rejection;
    EXPECT_FALSE(find(r, "H = 0.3 (overlap)", "Huang 2022")->rejected);

    // The report says "none" for both kinds of violation, and lists the excesses apart.
    const std::string report = read(dir / "report.md");
    EXPECT_NE(report.find("unexpected exceptions): none."), std::string::npos);
    EXPECT_NE(report.find("other than by a published model's construction: none."),
              std::string::npos);
    EXPECT_NE(report.find("- Filip 2024 rooster, grazing 89°: sampled"), std::string::npos);
    EXPECT_TRUE(std::filesystem::exists(dir / "energy.png"));
    const auto status = record::read_dataset(dir / "extremes.h5", "status");
    ASSERT_EQ(status.dims[0], r.rows.size());
    for (std::size_t i = 0; i < r.rows.size(); ++i) EXPECT_NE(status.values[i], 1.0) << i;
    std::filesystem::remove_all(root);
}

TEST(ExtremesStudy, BadStudyFileWritesNothing) {
    const auto root = std::filesystem::temp_directory_path() /
                      ("plumage_extremes_bad_" + std::to_string(::getpid()));
    const std::string unknown = plumage::testing::input_error_message([&] {
        run_extremes_study("study = \"extremes\"\n[sampling]\nquantas = 100\n", "bad.toml", root,
                           false);
    });
    EXPECT_NE(unknown.find("bad.toml:3:1: unknown key 'sampling.quantas'"), std::string::npos)
        << unknown;
    const std::string range = plumage::testing::input_error_message([&] {
        run_extremes_study("study = \"extremes\"\n[spectrum]\nlast_nm = 800\n", "range.toml", root,
                           false);
    });
    EXPECT_NE(
        range.find("range.toml:3:11: spectrum.last_nm = 800: expected a number in [380, 780]"),
        std::string::npos)
        << range;
    EXPECT_FALSE(std::filesystem::exists(root / "bad"));
    EXPECT_FALSE(std::filesystem::exists(root / "range"));
    std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace plumage::studies
