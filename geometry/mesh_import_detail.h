// Internals of mesh_import.cpp shared by its parts, not an interface of the geometry
// library: the polygon soup that the readers fill and the checks take, and the functions that
// pass it between them.
//   mesh_soup.cpp        naming, text helpers, finite checks, polygon triangulation
//   obj_reader.cpp       OBJ statements → soup
//   ply_reader.cpp       PLY header and ascii/binary bodies → soup
//   mesh_validation.cpp  checks 1–9 and repairs (mesh_import.h), the only user of CGAL
//   mesh_import.cpp      the public entry points
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "geometry/mesh_import.h"
#include "geometry/triangle_mesh.h"

namespace plumage::geometry::mesh_import_detail {

inline constexpr std::size_t kMaxVertices = std::numeric_limits<std::uint32_t>::max();

// Naming vertices and faces the way the user will look for them in the file.

enum class Source { obj, ply, memory };

class Names final {
public:
    Names(Source source, std::string file) : source_(source), file_(std::move(file)) {}

    // OBJ vertices by the 1-based index that face statements use; PLY by element index.
    std::string vertex(std::size_t ordinal, std::size_t line) const {
        if (source_ == Source::obj) return fmt::format("vertex {} (line {})", ordinal + 1, line);
        if (line != 0) return fmt::format("vertex {} (line {})", ordinal, line);
        return fmt::format("vertex {}", ordinal);
    }
    std::string face(std::size_t ordinal, std::size_t line) const {
        if (source_ == Source::obj) return fmt::format("face on line {}", line);
        if (source_ == Source::memory) return fmt::format("triangle {}", ordinal);
        if (line != 0) return fmt::format("face {} (line {})", ordinal, line);
        return fmt::format("face {}", ordinal);
    }
    // Prefix of every InputError: the file, quoted.
    const std::string& file() const { return file_; }

private:
    Source source_;
    std::string file_;
};

// A triangle soup plus where each vertex and triangle came from, for messages. Triangles
// of one fan-triangulated polygon share their face ordinal and line.
struct Soup {
    std::vector<Vec3> positions;
    std::vector<Vec3> normals;  // empty or one per position
    std::vector<std::size_t> vertex_ordinal;
    std::vector<std::size_t> vertex_line;
    std::vector<Triangle> triangles;
    std::vector<std::size_t> face_ordinal;
    std::vector<std::size_t> face_line;
    std::size_t faces_read = 0;

    void add_triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::size_t ordinal,
                      std::size_t line) {
        triangles.push_back({a, b, c});
        face_ordinal.push_back(ordinal);
        face_line.push_back(line);
    }
    std::string vertex_name(const Names& names, std::uint32_t v) const {
        return names.vertex(vertex_ordinal[v], vertex_line[v]);
    }
    std::string face_name(const Names& names, std::size_t t) const {
        return names.face(face_ordinal[t], face_line[t]);
    }
};

// ---------------------------------------------------------------------------------------
// Text helpers (mesh_soup.cpp).

void split_words(std::string_view line, std::vector<std::string_view>& words);

// Lines of a text, numbered from 1, without their "\n" or "\r\n".
class LineReader final {
public:
    explicit LineReader(std::string_view text, std::size_t first_line = 1)
        : text_(text), next_line_(first_line) {}

    bool next(std::string_view& line) {
        if (pos_ >= text_.size()) return false;
        const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
        line = text_.substr(pos_, end - pos_);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        pos_ = end + 1;
        number_ = next_line_++;
        return true;
    }
    std::size_t number() const { return number_; }
    std::size_t offset() const { return std::min(pos_, text_.size()); }

private:
    std::string_view text_;
    std::size_t pos_ = 0;
    std::size_t next_line_;
    std::size_t number_ = 0;
};

// Bytes shown in a message: printable ASCII as is, the rest as \xNN (a PNG signature
// must not put control characters on a terminal).
std::string printable(std::string_view bytes, std::size_t max = 24);

// A decimal number, the whole token; nullopt if malformed. "nan" and "inf" parse (the
// caller names the vertex that has one); magnitudes beyond double become ±inf.
std::optional<double> parse_double(std::string_view token);
std::optional<long long> parse_integer(std::string_view token);

std::string format_vec(const Vec3& v);

// Throws unless the scaled position is finite; names the vertex and the raw values.
Vec3 checked_position(const Vec3& raw, double scale, const Names& names, std::size_t ordinal,
                      std::size_t line);

// Throws unless the normal is finite and non-zero; returns it normalised.
Vec3 checked_normal(const Vec3& raw, const Names& names, const std::string& owner);

// Adds one polygon of the file as a triangle fan, when that is the polygon's surface
// (mesh_import.h: convex and planar within kPolygonPlanarity); InputError otherwise.
void add_polygon(Soup& soup, const std::vector<std::uint32_t>& ids, std::size_t ordinal,
                 std::size_t line, const Names& names);

// ---------------------------------------------------------------------------------------
// Readers (obj_reader.cpp, ply_reader.cpp): the file's bytes → soup, positions times scale.

// Per-corner OBJ normals become per-vertex shading normals only when every corner of every
// face names one, and a vertex always gets the same vector.
struct ObjNormals {
    std::vector<Vec3> values;                 // vn statements
    std::vector<std::size_t> lines;           // their lines
    std::vector<std::int64_t> vertex_normal;  // per vertex: vn index, -1 none yet
    bool corner_with = false;
    bool corner_without = false;
    std::optional<std::string> dropped_because;  // first reason to drop, naming the place
};

Soup parse_obj(std::string_view text, double scale, const Names& names, ObjNormals& normals);

Soup parse_ply(std::string_view bytes, double scale, const Names& names);

// ---------------------------------------------------------------------------------------
// Checks and repairs (mesh_validation.cpp).

// Exact predicate (CGAL): the three vertices lie on one line.
bool collinear(const Soup& soup, std::uint32_t a, std::uint32_t b, std::uint32_t c);

// Counts every defect, lists the first kMaxListedPerKind of each kind; the message is only
// formatted for listed ones.
class Reporter final {
public:
    explicit Reporter(MeshReport& report) : report_(report) {}

    template <typename MakeMessage>
    void add(MeshDefectKind kind, std::size_t index, std::size_t other, std::size_t line,
             bool repaired, MakeMessage&& make_message) {
        std::size_t& count = report_.counts[static_cast<std::size_t>(kind)];
        if (++count <= MeshReport::kMaxListedPerKind) {
            report_.defects.push_back({kind, index, other, line, make_message(), repaired});
        }
    }

private:
    MeshReport& report_;
};

// Drops every shading normal and reports why.
void drop_normals(Soup& soup, Reporter& reporter, const std::string& reason);

// Defects in the report that reject the mesh.
std::size_t blocking_count(const MeshReport& report, bool repair);

// Runs checks 1–9 on the soup, repairing it in place where `repair` (and, so that later
// checks can see past them, removing degenerate faces and fixing windings even without;
// callers that do not repair do not use the soup afterwards).
void check_soup(Soup& soup, const Names& names, bool repair, bool require_closed,
                MeshReport& report);

// Throws the InputError that rejects a mesh, naming its first blocking defects.
[[noreturn]] void reject(const MeshReport& report, const Names& names, bool repair);

}  // namespace plumage::geometry::mesh_import_detail
