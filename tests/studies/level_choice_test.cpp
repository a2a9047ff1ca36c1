// `[level]` (studies/level_choice.h): the decision follows full wave's certificate of the row —
// ray optics certified within the tolerance measures without a warning; a row that needs more
// warns with the measured error whatever was asked, and "auto" measures the BRDF at physical
// optics where the row needs it; "physical optics" measures there whatever full wave says; no
// certificate (none, or an unconverged one) warns under "auto" only — and an unknown level, or one
// no instrument measures with, is refused when the file is read.
#include "studies/level_choice.h"

#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/error.h"
#include "studies/study_file.h"
#include "studies/study_progress.h"

namespace plumage::studies {
namespace {

LevelCertificate certificate(double go_error, double po_error, double resolution_error) {
    LevelCertificate c;
    c.present = true;
    c.source = "a test reference";
    c.verdict.band_full_wave = 0.1;
    c.verdict.go_error = go_error;
    c.verdict.po_error = po_error;
    c.verdict.resolution_error = resolution_error;
    return c;
}

bool has(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

TEST(LevelChoice, RayOpticsCertifiedWithinTheToleranceMeasuresWithoutAWarning) {
    const LevelDecision d = decide_level({}, certificate(0.025, 0.05, -0.009));
    EXPECT_EQ(d.needed, kRayOptics);
    EXPECT_EQ(d.measured_with, kRayOptics);
    EXPECT_TRUE(d.warning.empty()) << d.warning;
    EXPECT_TRUE(has(d.summary, "**certified** within 5 %")) << d.summary;
    EXPECT_TRUE(has(d.summary, "ray optics +2.5 %")) << d.summary;
}

TEST(LevelChoice, ARowThatNeedsMoreWarnsWithTheMeasuredErrorWhateverWasAsked) {
    for (const char* asked : {"auto", "ray optics"}) {
        LevelSettings s;
        s.measure = asked;
        const LevelDecision po = decide_level(s, certificate(0.10, -0.03, 0.01));
        EXPECT_EQ(po.needed, "physical optics");
        // "auto" measures the BRDF at the level the row needs; "ray optics" keeps the user's.
        const bool automatic = std::string(asked) == "auto";
        EXPECT_EQ(po.measured_with, automatic ? kPhysicalOptics : kRayOptics);
        EXPECT_EQ(po.physical_optics, automatic);
        EXPECT_TRUE(has(po.warning, "needs physical optics")) << po.warning;
        EXPECT_TRUE(has(po.warning, "+10.0 %")) << po.warning;
        const LevelDecision fw = decide_level(s, certificate(-0.2, 0.08, 0.01));
        EXPECT_EQ(fw.needed, "full wave");
        EXPECT_EQ(fw.measured_with, kRayOptics);  // physical optics is not within it either
        EXPECT_FALSE(fw.physical_optics);
        EXPECT_TRUE(has(fw.warning, "-20.0 %")) << fw.warning;
        EXPECT_TRUE(has(fw.summary, "below what this row needs: full wave")) << fw.summary;
    }
    LevelSettings loose;
    loose.tolerance = 0.15;  // the tolerance is the user's
    const LevelDecision d = decide_level(loose, certificate(0.10, -0.03, 0.01));
    EXPECT_EQ(d.needed, kRayOptics);
    EXPECT_FALSE(d.physical_optics);
}

TEST(LevelChoice, PhysicalOpticsAskedMeasuresAtPhysicalOpticsWhateverTheCertificate) {
    LevelSettings s;
    s.measure = "physical optics";
    // Ray optics suffices and physical optics is within the tolerance too: no warning.
    const LevelDecision both = decide_level(s, certificate(0.025, 0.03, 0.01));
    EXPECT_EQ(both.needed, kRayOptics);
    EXPECT_EQ(both.measured_with, kPhysicalOptics);
    EXPECT_TRUE(both.physical_optics);
    EXPECT_TRUE(both.warning.empty()) << both.warning;
    EXPECT_TRUE(has(both.summary, "**certified** within the tolerance 5 %")) << both.summary;
    EXPECT_TRUE(has(both.summary, "other measurements are ray optics + thin film's, certified"))
        << both.summary;
    // Physical optics beyond the tolerance: measured as asked, with a warning giving its error.
    const LevelDecision beyond = decide_level(s, certificate(0.025, 0.0504, 0.01));
    EXPECT_TRUE(beyond.physical_optics);
    EXPECT_TRUE(has(beyond.warning, "physical optics is off by +5.04 %")) << beyond.warning;
    EXPECT_TRUE(has(beyond.summary, "**not within** the tolerance 5 %")) << beyond.summary;
    // "auto" on a row that needs physical optics: the measurements left at ray optics carry its
    // error, and the warning says so.
    const LevelDecision automatic = decide_level({}, certificate(0.10, -0.03, 0.01));
    EXPECT_TRUE(automatic.physical_optics);
    EXPECT_TRUE(has(automatic.warning, "other measurements are ray optics'")) << automatic.warning;
    // Without a certificate: measured as asked, a note, no warning (the user chose the level).
    LevelCertificate none;
    none.source = "no reference covers this row";
    const LevelDecision uncertified = decide_level(s, none);
    EXPECT_TRUE(uncertified.physical_optics);
    EXPECT_EQ(uncertified.measured_with, kPhysicalOptics);
    EXPECT_TRUE(uncertified.warning.empty()) << uncertified.warning;
    EXPECT_TRUE(has(uncertified.summary, "**not certified**")) << uncertified.summary;
}

TEST(LevelChoice, WithoutACertificateOnlyAutoWarns) {
    LevelCertificate none;
    none.source = "no reference covers this row";
    const LevelDecision automatic = decide_level({}, none);
    EXPECT_TRUE(automatic.needed.empty());
    EXPECT_TRUE(has(automatic.warning, "no reference covers this row")) << automatic.warning;
    EXPECT_TRUE(has(automatic.summary, "**not certified**")) << automatic.summary;
    LevelSettings forced;
    forced.measure = "ray optics";
    EXPECT_TRUE(decide_level(forced, none).warning.empty());
    // a reference whose grids differ by 3 % (> 2 %) certifies nothing
    const LevelDecision unconverged = decide_level({}, certificate(0.0, 0.0, 0.03));
    EXPECT_TRUE(unconverged.needed.empty());
    EXPECT_TRUE(has(unconverged.warning, "not converged")) << unconverged.warning;
}

TEST(LevelChoice, NoCertificateBeyondTheBudgetOrForANonBarbule) {
    const StudyProgress quiet(false);
    const std::vector<double> lambdas{450.0, 550.0, 650.0};
    LevelSettings s;  // budget 0
    const LiveRowReference rock_dove =
        live_row_reference({10.0, 0.25, 0.59, 0.3, 1.25, -0.35, 0.0}, lambdas, s, quiet);
    EXPECT_TRUE(rock_dove.reflectance.empty());
    EXPECT_TRUE(has(rock_dove.why_none, "predicted to take")) << rock_dove.why_none;
    EXPECT_TRUE(has(rock_dove.why_none, "full_wave_budget_minutes = 0")) << rock_dove.why_none;
    const LiveRowReference thin =
        live_row_reference({1.0, 0.25, 0.59, 0.3, 1.25, -0.35, 0.0}, lambdas, s, quiet);
    EXPECT_TRUE(has(thin.why_none, "cannot build")) << thin.why_none;
}

TEST(LevelChoice, AnUnknownLevelOrOneNoInstrumentMeasuresWithIsRefusedWhenRead) {
    for (const char* value : {"full wave", "physical_optics"}) {
        auto file = StudyFile::parse(
            fmt::format("[level]\ntolerance = 0.05\nmeasure = \"{}\"\n", value), "bad.toml");
        try {
            read_level(file->root().table("level"));
            FAIL() << "accepted " << value;
        } catch (const InputError& e) {
            EXPECT_TRUE(has(e.what(), "bad.toml:3")) << e.what();
            EXPECT_TRUE(has(e.what(), "level.measure")) << e.what();
            EXPECT_TRUE(
                has(e.what(), "expected one of \"auto\", \"ray optics\", \"physical optics\""))
                << e.what();
        }
    }
    auto file = StudyFile::parse("[level]\nmeasure = \"physical optics\"\n", "good.toml");
    EXPECT_EQ(read_level(file->root().table("level")).measure, kPhysicalOptics);
}

}  // namespace
}  // namespace plumage::studies
