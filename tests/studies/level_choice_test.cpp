// `[level]` (studies/level_choice.h): the decision follows full wave's certificate of the row —
// ray optics certified within the tolerance measures without a warning; a row that needs more
// warns with ray optics' measured error whether "auto" or "ray optics" was asked; no certificate
// (none, or an unconverged one) warns under "auto" only — and a level no instrument measures with
// is refused when the file is read.
#include "studies/level_choice.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/error.h"
#include "studies/study_common.h"
#include "studies/study_file.h"

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
        EXPECT_EQ(po.measured_with, kRayOptics);  // the instruments' only level
        EXPECT_TRUE(has(po.warning, "needs physical optics")) << po.warning;
        EXPECT_TRUE(has(po.warning, "+10.0 %")) << po.warning;
        const LevelDecision fw = decide_level(s, certificate(-0.2, 0.08, 0.01));
        EXPECT_EQ(fw.needed, "full wave");
        EXPECT_TRUE(has(fw.warning, "-20.0 %")) << fw.warning;
        EXPECT_TRUE(has(fw.summary, "below what this row needs: full wave")) << fw.summary;
    }
    LevelSettings loose;
    loose.tolerance = 0.15;  // the tolerance is the user's
    EXPECT_EQ(decide_level(loose, certificate(0.10, -0.03, 0.01)).needed, kRayOptics);
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

TEST(LevelChoice, ALevelNoInstrumentMeasuresWithIsRefusedWhenRead) {
    auto file = StudyFile::parse("[level]\nmeasure = \"physical optics\"\n", "bad.toml");
    try {
        read_level(file->root().table("level"));
        FAIL() << "accepted";
    } catch (const InputError& e) {
        EXPECT_TRUE(has(e.what(), "bad.toml:2")) << e.what();
        EXPECT_TRUE(has(e.what(), "level.measure")) << e.what();
    }
}

}  // namespace
}  // namespace plumage::studies
