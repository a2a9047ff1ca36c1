// `plumage geometry`: study files build geometry; bad study files fail with file:line
// and the expected value, and leave no results folder.
#include "studies/geometry_study.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "geometry/mesh_import.h"
#include "tests/test_util.h"

namespace plumage::studies {
namespace {

class GeometryStudy : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = std::filesystem::temp_directory_path() /
               ("plumage_geometry_study_" + std::to_string(::getpid()));
        std::filesystem::remove_all(dir_);
        std::filesystem::create_directories(dir_);
    }
    void TearDown() override { std::filesystem::remove_all(dir_); }

    std::filesystem::path write_study(const std::string& text) {
        const auto path = dir_ / "study.toml";
        std::ofstream(path) << text;
        return path;
    }
    std::string error_of(const std::string& text) {
        return plumage::testing::input_error_message(
            [&] { run_geometry_study(write_study(text), dir_ / "results"); });
    }
    bool results_left() const {
        if (!std::filesystem::exists(dir_ / "results")) return false;
        return !std::filesystem::is_empty(dir_ / "results");
    }
    std::filesystem::path dir_;
};

constexpr const char* kRow = R"(name = "row"
[geometry]
kind = "barbule_row"
[geometry.row]
barbules = 3
cells_per_barbule = 2
[geometry.tessellation]
max_chord_um = 0.05
)";

TEST_F(GeometryStudy, BuildsABarbuleRowWithPreviewAndReport) {
    const auto result = run_geometry_study(write_study(kRow), dir_ / "results");
    EXPECT_EQ(result.instances, 6u);
    for (const char* f :
         {"cell_film.ply", "cell_melanin.ply", "instances.csv", "preview.png", "report.md"}) {
        EXPECT_TRUE(std::filesystem::exists(result.output_dir / f)) << f;
    }
    // The PLY we wrote reads back through the validating importer (an open film sheet).
    geometry::MeshImportOptions open;
    open.require_closed = false;
    const auto mesh = geometry::read_mesh(result.output_dir / "cell_film.ply", open);
    EXPECT_EQ(mesh.triangles.size() * 2, result.triangles);  // film + melanin of equal size
}

TEST_F(GeometryStudy, UnknownKeyIsAnErrorWithItsLine) {
    const std::string message = error_of(std::string(kRow) + "[geometry.cell]\nbb = 0.3\n");
    EXPECT_NE(message.find("study.toml:10:1: unknown key 'geometry.cell.bb'"), std::string::npos)
        << message;
    EXPECT_FALSE(results_left());
}

// A barb patch written with the earlier parameter meanings ([geometry.barb], [geometry.barbules])
// is refused, never reinterpreted, with the way to the mapping; nothing is written.
TEST_F(GeometryStudy, OldBarbPatchTablesPointToTheParameterMapping) {
    const std::string message = error_of(
        "study = \"geometry\"\nname = \"g\"\n[geometry]\nkind = \"barb_patch\"\n"
        "[geometry.barb]\nwidth_um = 30\neccentricity = 0.6\n[geometry.patch]\nlength_um = 100\n");
    EXPECT_NE(message.find("study.toml:5:1: geometry.barb: the barb and barbule keys moved to "
                           "[geometry.vane] and now mean what Padrón-Griffe et al. 2024's code "
                           "means"),
              std::string::npos)
        << message;
    EXPECT_NE(message.find("studies/README.md, \"Padrón-Griffe parameters\""), std::string::npos)
        << message;
    EXPECT_FALSE(results_left());
}

TEST_F(GeometryStudy, WrongTypeNamesTheExpectedType) {
    const std::string message = error_of(std::string(kRow) + "[geometry.cell]\nb = \"flat\"\n");
    EXPECT_NE(message.find(
                  "study.toml:10:5: geometry.cell.b is a string: expected a number in [0.001, 1]"),
              std::string::npos)
        << message;
    EXPECT_FALSE(results_left());
}

TEST_F(GeometryStudy, OutOfRangeValueNamesTheRange) {
    std::string text = kRow;
    text.replace(text.find("barbules = 3"), 12, "barbules = 0");
    const std::string message = error_of(text);
    EXPECT_NE(message.find(
                  "study.toml:5:12: geometry.row.barbules = 0: expected an integer in [1, 100000]"),
              std::string::npos)
        << message;
    // A value whose validity depends on others is checked by the builder, still located.
    std::string tight = kRow;
    tight.replace(tight.find("barbules = 3"), 12, "barbules = 3\nH = 0.2");
    const std::string coupled = error_of(tight);
    EXPECT_NE(coupled.find("study.toml"), std::string::npos) << coupled;
    EXPECT_NE(coupled.find("interpenetrate"), std::string::npos) << coupled;
    EXPECT_FALSE(results_left());
}

TEST_F(GeometryStudy, MissingMeshFileIsNamed) {
    const std::string message =
        error_of("[geometry]\nkind = \"mesh\"\n[geometry.mesh]\nfile = \"nowhere.ply\"\n");
    EXPECT_NE(message.find("nowhere.ply"), std::string::npos) << message;
    EXPECT_FALSE(results_left());
}

// A mesh or volume file that exists but cannot be read: the reader's message (the file and
// its line) behind the study key that named the file.
TEST_F(GeometryStudy, BadMeshOrVolumeFileNamesTheStudyKey) {
    std::ofstream(dir_ / "bad.ply") << "hello world\n";
    std::ofstream(dir_ / "bad.vdb") << "not a volume\n";
    for (const std::string kind : {"mesh", "vdb"}) {
        const std::string message =
            error_of("[geometry]\nkind = \"" + kind + "\"\n[geometry.mesh]\nfile = \"bad." +
                     (kind == "mesh" ? "ply" : "vdb") + "\"\n");
        EXPECT_NE(message.find("study.toml:4:8: geometry.mesh.file: "), std::string::npos)
            << message;
        EXPECT_NE(message.find(kind == "mesh" ? "bad.ply" : "bad.vdb"), std::string::npos)
            << message;
    }
    EXPECT_FALSE(results_left());
}

TEST_F(GeometryStudy, SyntaxErrorsAndMissingKindAreLocated) {
    EXPECT_NE(error_of("[geometry\nkind = 1\n").find("study.toml:1:"), std::string::npos);
    EXPECT_NE(error_of("[geometry]\n").find("geometry.kind is missing"), std::string::npos);
    EXPECT_NE(error_of("[geometry]\nkind = \"cube\"\n").find("expected one of \"barbule_row\""),
              std::string::npos);
    EXPECT_FALSE(results_left());
}

}  // namespace
}  // namespace plumage::studies
