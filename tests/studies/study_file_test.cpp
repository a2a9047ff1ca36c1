// Issue 41: what the study-file reader says about a wrong value, in the style of every reader
// error (file:line:column, the full key, what was expected):
//  - a length or wavelength in the other unit (590 for a 0.59 µm film, 0.45 for 450 nm) gets a
//    unit hint, for a key's own suffix and for the keys of a table named after a quantity;
//  - a film thickness is refused at read time above the shared film range, in every study that
//    reads one (geometry.cell, species cortex, measure film, ablation sweep);
//  - a bad wavelength grid names the grid the file gives, as written;
//  - an unknown key suggests the nearest key of its table, or the same key in another table.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "common/spelling.h"
#include "studies/sections.h"
#include "studies/study.h"
#include "studies/study_file.h"
#include "tests/test_util.h"

namespace plumage::studies {
namespace {

// The InputError of reading `key` of [table] in `text` with `read`.
template <typename Read>
std::string message_of(const std::string& text, Read read) {
    auto file = StudyFile::parse(text, "s.toml");
    return testing::input_error_message([&] {
        ParameterTable root = file->root();
        read(root);
        root.reject_unused();
    });
}

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

TEST(StudyFile, FilmInNanometresIsRefusedWithAUnitHint) {
    const std::string m =
        message_of("[geometry.cell]\nfilm_thickness_um = 590\n", [](ParameterTable& root) {
            ParameterTable geometry = root.table("geometry");
            read_barbule_row_params(geometry);
        });
    EXPECT_TRUE(contains(m,
                         "s.toml:2:21: geometry.cell.film_thickness_um = 590: expected a "
                         "number in [0, 5]"))
        << m;
    EXPECT_TRUE(contains(m, "590 looks like nanometres; the key is in µm (590 nm = 0.59 µm)")) << m;
}

TEST(StudyFile, FilmAboveTheRangeWithoutAnotherUnitGetsNoHint) {
    // 7000 is out of range in either unit (7 µm): no hint.
    const std::string m =
        message_of("[geometry.cell]\nfilm_thickness_um = 7000\n", [](ParameterTable& root) {
            ParameterTable geometry = root.table("geometry");
            read_barbule_row_params(geometry);
        });
    EXPECT_TRUE(contains(m, "geometry.cell.film_thickness_um = 7000: expected")) << m;
    EXPECT_FALSE(contains(m, "looks like")) << m;
    EXPECT_EQ(message_of("f_um = 0.59\n",
                         [](ParameterTable& root) {
                             read_required_film_thickness_um(root, "f_um", "film");
                         }),
              "no InputError");
}

TEST(StudyFile, EveryStudyReadsFilmsWithTheSharedRange) {
    const std::filesystem::path root = std::filesystem::path(PLUMAGE_SOURCE_DIR) / "studies";
    const auto refused = [&](const std::string& study, const std::string& from,
                             const std::string& to) {
        std::string text = testing::read_text_file(root / study);
        const auto at = text.find(from);
        if (at == std::string::npos) return "no '" + from + "' in " + study;
        text.replace(at, from.size(), to);
        return testing::input_error_message([&] { check_study(text, root / study); });
    };
    const std::string hint = "590 looks like nanometres; the key is in µm";
    EXPECT_TRUE(contains(refused("rock_dove_quick.toml", "[geometry.row]",
                                 "[geometry.cell]\nfilm_thickness_um = 590\n[geometry.row]"),
                         hint));
    EXPECT_TRUE(
        contains(refused("species_quick.toml", "cortex_film_um = 0.174", "cortex_film_um = 174"),
                 "174 looks like nanometres"));
    EXPECT_TRUE(contains(
        refused("measure_example.toml", "thickness_um = 0.59", "thickness_um = 590"), hint));
    const std::string sweep = refused("ablation_quick.toml", "to = 0.69", "to = 790");
    EXPECT_TRUE(contains(sweep, "sweep.film_thickness_um.to = 790: expected a number in [0, 5]"))
        << sweep;
    EXPECT_TRUE(contains(sweep, "790 looks like nanometres")) << sweep;
}

TEST(StudyFile, WavelengthInMicrometresGetsAUnitHint) {
    const std::string m = message_of("[spectrum]\nfirst_nm = 0.45\n", [](ParameterTable& root) {
        ParameterTable spectrum = root.table("spectrum");
        read_wavelengths(spectrum, WavelengthRule{});
    });
    EXPECT_TRUE(contains(m,
                         "s.toml:2:12: spectrum.first_nm = 0.45: expected a number in "
                         "[300, 800] (first wavelength, nm; 300-800 nm: "))
        << m;
    EXPECT_TRUE(contains(m, "0.45 looks like micrometres; the key is in nm (0.45 µm = 450 nm)"))
        << m;
}

TEST(StudyFile, BadWavelengthGridNamesTheGridAsWritten) {
    const auto read = [](ParameterTable& root) {
        ParameterTable spectrum = root.table("spectrum");
        read_wavelengths(spectrum, WavelengthRule{});
    };
    const std::string empty =
        message_of("[spectrum]\nfirst_nm = 300\nlast_nm = 3e2\nstep_nm = 20\n", read);
    EXPECT_TRUE(contains(empty,
                         "s.toml:3:11: spectrum.last_nm = 300 is not above first_nm = 300 "
                         "(the grid given: first_nm = 300, last_nm = 3e2, step_nm = 20)"))
        << empty;
    EXPECT_FALSE(contains(empty, "300-300")) << empty;
    const std::string low = message_of("[spectrum]\nfirst_nm = 250\nlast_nm = 700\n", read);
    EXPECT_TRUE(contains(low, "(first wavelength, nm; 300-800 nm: ")) << low;
    EXPECT_TRUE(contains(low,
                         "the grid given: first_nm = 250, last_nm = 700, step_nm = 50 "
                         "(default)"))
        << low;
    const std::string one =
        message_of("[spectrum]\nfirst_nm = 400\nlast_nm = 410\nstep_nm = 50\n", read);
    EXPECT_TRUE(contains(one, "gives 1 wavelength")) << one;
    EXPECT_TRUE(contains(one, "the grid given: first_nm = 400, last_nm = 410, step_nm = 50"))
        << one;
}

TEST(StudyFile, UnknownKeySuggestsTheNearestKeyOfItsTable) {
    const auto read = [](ParameterTable& root) {
        ParameterTable sc = root.table("scatterometer");
        sc.integer("image_size", 65, 17, 1025, "pixels");
        sc.integer("passes", 1, 1, 10, "passes");
        ParameterTable geometry = root.table("geometry");
        read_barbule_row_params(geometry);
    };
    const std::string m = message_of(
        "[scatterometer]\nimage_sise = 64\npasess = 2\nnothing_like_it = 1\n"
        "[geometry.row]\nfilm_thickness_um = 0.5\n[scaterometer]\n",
        read);
    EXPECT_TRUE(contains(m,
                         "s.toml:2:1: unknown key 'scatterometer.image_sise'; did you mean "
                         "'scatterometer.image_size'?"))
        << m;
    // A swap of two neighbouring letters is one edit.
    EXPECT_TRUE(contains(m,
                         "unknown key 'scatterometer.pasess'; did you mean "
                         "'scatterometer.passes'?"))
        << m;
    EXPECT_TRUE(contains(m, "unknown key 'scatterometer.nothing_like_it'\n")) << m;
    // The right key in the wrong table, and a misspelt table.
    EXPECT_TRUE(contains(m,
                         "s.toml:6:1: unknown key 'geometry.row.film_thickness_um'; did you "
                         "mean 'geometry.cell.film_thickness_um'? (it belongs in "
                         "[geometry.cell])"))
        << m;
    EXPECT_TRUE(contains(m, "unknown key 'scaterometer'; did you mean 'scatterometer'?")) << m;
}

TEST(StudyFile, KeyInTheWrongTableSuggestsTheNearestTableThatHasIt) {
    const auto read = [](ParameterTable& root) {
        for (const char* name : {"a", "b"}) {
            ParameterTable entry = root.table("species").table(name);
            entry.table("materials").number("cortex_film_um", 0.0, {}, "cortex");
            entry.table("patch").number("length_um", 1.0, {}, "length");
        }
    };
    const std::string m = message_of("[species.b.patch]\ncortex_film_um = 1\n", read);
    EXPECT_TRUE(contains(m,
                         "unknown key 'species.b.patch.cortex_film_um'; did you mean "
                         "'species.b.materials.cortex_film_um'? (it belongs in "
                         "[species.b.materials])"))
        << m;
}

TEST(StudyFile, SpellingDistanceCountsSwapsAsOneEdit) {
    EXPECT_EQ(edit_distance("lenght", "length"), 1u);
    EXPECT_EQ(edit_distance("image_sise", "image_size"), 1u);
    EXPECT_EQ(edit_distance("", "abc"), 3u);
    EXPECT_EQ(nearest_name("runn", {"run", "fit", "geometry"}), "run");
    EXPECT_EQ(nearest_name("export", {"run", "fit", "geometry"}), "");
    EXPECT_EQ(nearest_name("run", {"run", "fit"}), "");
}

}  // namespace
}  // namespace plumage::studies
