#include "geometry/mesh_import.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "common/error.h"
#include "geometry/mesh_import_detail.h"

// The readers (obj_reader.cpp, ply_reader.cpp), the polygon soup they fill (mesh_soup.cpp)
// and the checks (mesh_validation.cpp) share mesh_import_detail.h; this file holds the entry
// points.
namespace plumage::geometry {
namespace {

using mesh_import_detail::blocking_count;
using mesh_import_detail::check_soup;
using mesh_import_detail::checked_position;
using mesh_import_detail::drop_normals;
using mesh_import_detail::kMaxVertices;
using mesh_import_detail::Names;
using mesh_import_detail::ObjNormals;
using mesh_import_detail::parse_obj;
using mesh_import_detail::parse_ply;
using mesh_import_detail::reject;
using mesh_import_detail::Reporter;
using mesh_import_detail::Soup;
using mesh_import_detail::Source;

static_assert(static_cast<std::size_t>(MeshDefectKind::shading_normals_dropped) + 1 ==
                  kMeshDefectKinds,
              "kMeshDefectKinds counts MeshDefectKind");

std::string lower_extension(const std::filesystem::path& path) {
    std::string extension = path.extension().string();
    for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return extension;
}

std::string read_bytes(const std::filesystem::path& path) {
    std::error_code error;
    const auto status = std::filesystem::status(path, error);
    if (!std::filesystem::exists(status)) {
        throw InputError(fmt::format("mesh file '{}' does not exist", path.string()));
    }
    if (std::filesystem::is_directory(status)) {
        throw InputError(fmt::format("mesh file '{}' is a directory: expected a PLY or OBJ file",
                                     path.string()));
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(fmt::format("cannot open mesh file '{}'", path.string()));
    in.seekg(0, std::ios::end);
    const std::streamoff size = in.tellg();
    in.seekg(0, std::ios::beg);
    std::string bytes(static_cast<std::size_t>(std::max<std::streamoff>(size, 0)), '\0');
    in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!in) throw IoError(fmt::format("cannot read mesh file '{}'", path.string()));
    return bytes;
}

}  // namespace

void MeshImportOptions::validate() const {
    if (!std::isfinite(scale_to_um) || !(scale_to_um > 0.0)) {
        throw InputError(fmt::format(
            "mesh import: scale_to_um = {}: expected a finite length > 0 (µm per file unit)",
            scale_to_um));
    }
}

const char* to_string(MeshDefectKind kind) {
    switch (kind) {
        case MeshDefectKind::duplicate_vertex:
            return "duplicate vertex";
        case MeshDefectKind::degenerate_face:
            return "degenerate face";
        case MeshDefectKind::isolated_vertex:
            return "isolated vertex";
        case MeshDefectKind::border_edge:
            return "border edge";
        case MeshDefectKind::non_manifold_edge:
            return "non-manifold edge";
        case MeshDefectKind::non_manifold_vertex:
            return "non-manifold vertex";
        case MeshDefectKind::non_orientable:
            return "non-orientable surface";
        case MeshDefectKind::inconsistent_orientation:
            return "inconsistent orientation";
        case MeshDefectKind::self_intersection:
            return "self-intersection";
        case MeshDefectKind::inward_orientation:
            return "inward orientation";
        case MeshDefectKind::shading_normal_flipped:
            return "shading normal flipped";
        case MeshDefectKind::shading_normals_dropped:
            return "shading normals dropped";
    }
    return "?";
}

bool MeshReport::clean() const {
    return std::all_of(counts.begin(), counts.end(), [](std::size_t c) { return c == 0; });
}

std::string MeshReport::summary() const {
    std::string out;
    for (const MeshDefect& d : defects) {
        out += fmt::format("{}{}: {}\n", d.repaired ? "[repaired] " : "", to_string(d.kind),
                           d.message);
    }
    for (std::size_t k = 0; k < kMeshDefectKinds; ++k) {
        if (counts[k] > kMaxListedPerKind) {
            out += fmt::format("... {} {} defects in all\n", counts[k],
                               to_string(static_cast<MeshDefectKind>(k)));
        }
    }
    return out;
}

ImportedMesh import_mesh(const std::filesystem::path& path, const MeshImportOptions& options) {
    options.validate();
    const std::string extension = lower_extension(path);
    const Source source = extension == ".ply"   ? Source::ply
                          : extension == ".obj" ? Source::obj
                                                : Source::memory;
    if (source == Source::memory) {
        throw InputError(
            fmt::format("mesh file '{}': unknown format '{}': expected a .ply or "
                        ".obj file",
                        path.string(), extension));
    }
    const Names names(source, fmt::format("'{}'", path.string()));
    const std::string bytes = read_bytes(path);
    if (bytes.empty()) {
        throw InputError(fmt::format("{}: the file is empty: expected a {} mesh", names.file(),
                                     source == Source::ply ? "PLY" : "OBJ"));
    }
    ImportedMesh imported;
    Reporter reporter(imported.report);
    Soup soup;
    if (source == Source::ply) {
        soup = parse_ply(bytes, options.scale_to_um, names);
    } else {
        ObjNormals normals;
        soup = parse_obj(bytes, options.scale_to_um, names, normals);
        if (normals.dropped_because) drop_normals(soup, reporter, *normals.dropped_because);
    }
    check_soup(soup, names, options.repair, options.require_closed, imported.report);
    if (soup.triangles.empty()) {
        throw InputError(
            fmt::format("{}: every face is degenerate (zero area; {} read): expected a surface",
                        names.file(), soup.faces_read));
    }
    if (blocking_count(imported.report, options.repair) > 0) {
        reject(imported.report, names, options.repair);
    }
    imported.mesh.positions = std::move(soup.positions);
    imported.mesh.shading_normals = std::move(soup.normals);
    imported.mesh.triangles = std::move(soup.triangles);
    return imported;
}

TriangleMesh read_mesh(const std::filesystem::path& path, const MeshImportOptions& options) {
    return import_mesh(path, options).mesh;
}

MeshReport check_mesh(const TriangleMesh& mesh, bool require_closed) {
    const Names names(Source::memory, "in-memory mesh");
    if (!mesh.shading_normals.empty() && mesh.shading_normals.size() != mesh.positions.size()) {
        throw InputError(
            fmt::format("{}: {} shading normals for {} vertices: expected none or "
                        "one per vertex",
                        names.file(), mesh.shading_normals.size(), mesh.positions.size()));
    }
    if (mesh.positions.size() > kMaxVertices) {
        throw InputError(fmt::format("{}: {} vertices: expected at most {}", names.file(),
                                     mesh.positions.size(), kMaxVertices));
    }
    Soup soup;
    soup.positions = mesh.positions;
    soup.normals = mesh.shading_normals;
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
        checked_position(mesh.positions[v], 1.0, names, v, 0);
        soup.vertex_ordinal.push_back(v);
        soup.vertex_line.push_back(0);
    }
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        for (const std::uint32_t v : mesh.triangles[t]) {
            if (v >= mesh.positions.size()) {
                throw InputError(fmt::format(
                    "{}: triangle {}: vertex index {} is out of range: "
                    "expected 0..{}",
                    names.file(), t, v, static_cast<long long>(mesh.positions.size()) - 1));
            }
        }
        soup.add_triangle(mesh.triangles[t][0], mesh.triangles[t][1], mesh.triangles[t][2], t, 0);
    }
    soup.faces_read = mesh.triangles.size();
    MeshReport report;
    if (soup.triangles.empty()) return report;
    check_soup(soup, names, /*repair=*/false, require_closed, report);
    return report;
}

}  // namespace plumage::geometry
