// PLY (ascii and binary_little_endian) → polygon soup (mesh_import.h describes the subset
// read).
//
// Kept, not replaced by CGAL::IO::read_PLY (CGAL 5.5), because its errors are clearer and it
// accepts files we must refuse: measured on the malformed-mesh corpus by
// tests/geometry/mesh_reader_errors_test.cpp (issue 18; it prints the full table).
//
//   file                         ours                                  CGAL read_PLY (verbose)
//   empty                        rejects: "the file is empty"          rejects, no message
//   PNG bytes / "hello world"    rejects: "starts with "...": expected rejects: "incorrect file
//                                a PLY file, whose first line is 'ply'" format line 1 of file"
//   x = "0..0" (ascii)           rejects: "vertex 0 (line 10): '0..0'  ACCEPTS (reads a number)
//                                is not a valid float ..."
//   face index 9 of 4 vertices   rejects: "face 3 (line 17): vertex    ACCEPTS (invalid soup)
//                                index 9 is out of range: 0..3"
//   ascii body one face short    rejects: "the file ends before face 3" rejects, no message
//   x = nan (ascii)              rejects: "vertex 0 (line 10) has x =  rejects, no message
//                                nan: expected finite coordinates"
//   no vertex_indices list       rejects: "element 'face' (line 7) has rejects: "can't find vertex
//                                no 'vertex_indices' list ..."         indices in PLY input"
//   fuzz/corpus/ply/             rejects: "element 'vertex' (line 4)   rejects, no message
//   truncated_interface.ply      declares 562 instances ... only 2782
//                                bytes are left"
//
// 9 files: ours rejects 9 and names file 9/9, line or element 8/8 where one applies; CGAL
// rejects 7 (4 of them silently), names the file 0 times, a line 2 times (the magic line).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "common/error.h"
#include "geometry/mesh_import_detail.h"

namespace plumage::geometry::mesh_import_detail {
namespace {

// Binary PLY is read by copying bytes into host scalars.
static_assert(std::endian::native == std::endian::little,
              "binary_little_endian PLY reading assumes a little-endian host");

// ---------------------------------------------------------------------------------------
// PLY.

enum class PlyType { int8, uint8, int16, uint16, int32, uint32, float32, float64 };

std::optional<PlyType> ply_type(std::string_view name) {
    if (name == "char" || name == "int8") return PlyType::int8;
    if (name == "uchar" || name == "uint8") return PlyType::uint8;
    if (name == "short" || name == "int16") return PlyType::int16;
    if (name == "ushort" || name == "uint16") return PlyType::uint16;
    if (name == "int" || name == "int32") return PlyType::int32;
    if (name == "uint" || name == "uint32") return PlyType::uint32;
    if (name == "float" || name == "float32") return PlyType::float32;
    if (name == "double" || name == "float64") return PlyType::float64;
    return std::nullopt;
}

const char* ply_type_name(PlyType type) {
    switch (type) {
        case PlyType::int8:
            return "char";
        case PlyType::uint8:
            return "uchar";
        case PlyType::int16:
            return "short";
        case PlyType::uint16:
            return "ushort";
        case PlyType::int32:
            return "int";
        case PlyType::uint32:
            return "uint";
        case PlyType::float32:
            return "float";
        case PlyType::float64:
            return "double";
    }
    return "?";
}

std::size_t ply_size(PlyType type) {
    switch (type) {
        case PlyType::int8:
        case PlyType::uint8:
            return 1;
        case PlyType::int16:
        case PlyType::uint16:
            return 2;
        case PlyType::int32:
        case PlyType::uint32:
        case PlyType::float32:
            return 4;
        case PlyType::float64:
            return 8;
    }
    return 0;
}

bool ply_is_float(PlyType type) { return type == PlyType::float32 || type == PlyType::float64; }

struct PlyProperty {
    std::string name;
    PlyType type = PlyType::float32;  // the item type, for lists
    bool is_list = false;
    PlyType count_type = PlyType::uint8;
    std::size_t header_line = 0;  // where the header declares it, for messages
};

struct PlyElement {
    std::string name;
    std::size_t count = 0;
    std::size_t header_line = 0;
    std::vector<PlyProperty> properties;
};

struct PlyHeader {
    bool binary = false;
    std::vector<PlyElement> elements;
    std::size_t body_offset = 0;
    std::size_t body_first_line = 0;
};

// A 'property <type> <name>' or 'property list <count type> <item type> <name>' line (line n).
PlyProperty parse_ply_property(const std::vector<std::string_view>& words, std::string_view line,
                               std::size_t n, const Names& names) {
    PlyProperty property;
    const bool list = words.size() >= 2 && words[1] == "list";
    if (words.size() != (list ? 5u : 3u)) {
        throw InputError(
            fmt::format("{}: line {}: '{}': expected 'property <type> <name>' or 'property list "
                        "<count type> <item type> <name>'",
                        names.file(), n, printable(line, 60)));
    }
    const std::size_t type_word = list ? 3 : 1;
    const auto type = ply_type(words[type_word]);
    const auto count_type = list ? ply_type(words[2]) : PlyType::uint8;
    if (!type || !count_type) {
        throw InputError(fmt::format(
            "{}: line {}: unknown PLY type in '{}': expected char, uchar, short, ushort, "
            "int, uint, float or double",
            names.file(), n, printable(line, 60)));
    }
    if (list && ply_is_float(*count_type)) {
        throw InputError(
            fmt::format("{}: line {}: list count type {}: expected an "
                        "integer type",
                        names.file(), n, ply_type_name(*count_type)));
    }
    property.name = std::string(words[type_word + 1]);
    property.type = *type;
    property.is_list = list;
    property.count_type = *count_type;
    property.header_line = n;
    return property;
}

PlyHeader parse_ply_header(std::string_view bytes, const Names& names) {
    LineReader lines(bytes);
    std::string_view line;
    if (!lines.next(line) || line != "ply") {
        throw InputError(
            fmt::format("{}: starts with \"{}\": expected a PLY file, whose first "
                        "line is 'ply'",
                        names.file(), printable(bytes.substr(0, 16))));
    }
    PlyHeader header;
    bool have_format = false;
    std::vector<std::string_view> words;
    while (true) {
        if (!lines.next(line)) {
            throw InputError(
                fmt::format("{}: the PLY header has no 'end_header' line: expected "
                            "one before the data",
                            names.file()));
        }
        const std::size_t n = lines.number();
        split_words(line, words);
        if (words.empty()) continue;
        const std::string_view keyword = words[0];
        if (keyword == "end_header") break;
        if (keyword == "comment" || keyword == "obj_info") continue;
        if (keyword == "format") {
            if (words.size() != 3 || words[2] != "1.0" ||
                (words[1] != "ascii" && words[1] != "binary_little_endian")) {
                throw InputError(
                    fmt::format("{}: line {}: '{}': expected 'format ascii 1.0' or 'format "
                                "binary_little_endian 1.0'",
                                names.file(), n, printable(line, 60)));
            }
            header.binary = words[1] == "binary_little_endian";
            have_format = true;
        } else if (keyword == "element") {
            const auto count = words.size() == 3 ? parse_integer(words[2]) : std::nullopt;
            if (!count || *count < 0) {
                throw InputError(fmt::format("{}: line {}: '{}': expected 'element <name> <count>'",
                                             names.file(), n, printable(line, 60)));
            }
            header.elements.push_back(
                {std::string(words[1]), static_cast<std::size_t>(*count), n, {}});
        } else if (keyword == "property") {
            if (header.elements.empty()) {
                throw InputError(fmt::format(
                    "{}: line {}: property before any element: expected 'element' first",
                    names.file(), n));
            }
            header.elements.back().properties.push_back(parse_ply_property(words, line, n, names));
        } else {
            throw InputError(fmt::format(
                "{}: line {}: unknown PLY header line '{}': expected format, element, property, "
                "comment or end_header",
                names.file(), n, printable(line, 60)));
        }
    }
    if (!have_format) {
        throw InputError(
            fmt::format("{}: the PLY header has no 'format' line: expected 'format "
                        "ascii 1.0' or 'format binary_little_endian 1.0'",
                        names.file()));
    }
    header.body_offset = lines.offset();
    header.body_first_line = lines.number() + 1;
    return header;
}

// Reads element instances from a binary_little_endian body.
class PlyBinaryReader final {
public:
    PlyBinaryReader(std::string_view body, const Names& names) : body_(body), names_(names) {}

    void check_count(const PlyElement& element) const {
        // Smallest instance: lists empty. Guards the reservations below against a count
        // that the file cannot hold.
        std::size_t min_size = 0;
        for (const PlyProperty& p : element.properties) {
            min_size += ply_size(p.is_list ? p.count_type : p.type);
        }
        const std::size_t left = body_.size() - pos_;
        if (min_size > 0 && element.count > left / min_size) {
            throw InputError(fmt::format(
                "{}: element '{}' (line {}) declares {} instances of at least {} bytes, but only "
                "{} bytes are left: expected a count that matches the data",
                names_.file(), element.name, element.header_line, element.count, min_size, left));
        }
    }
    // check_count has bounded the count by the bytes left.
    std::size_t reservable(const PlyElement& element) const { return element.count; }
    void begin(const char* what, std::size_t index) {
        what_ = what;
        index_ = index;
    }
    double scalar(PlyType type, const PlyProperty& property) {
        const std::size_t size = ply_size(type);
        if (body_.size() - pos_ < size) {
            throw InputError(fmt::format(
                "{}: {} {}: the file ends inside property '{}': expected {} more bytes",
                names_.file(), what_, index_, property.name, size - (body_.size() - pos_)));
        }
        const char* p = body_.data() + pos_;
        pos_ += size;
        switch (type) {
            case PlyType::int8:
                return load<std::int8_t>(p);
            case PlyType::uint8:
                return load<std::uint8_t>(p);
            case PlyType::int16:
                return load<std::int16_t>(p);
            case PlyType::uint16:
                return load<std::uint16_t>(p);
            case PlyType::int32:
                return load<std::int32_t>(p);
            case PlyType::uint32:
                return load<std::uint32_t>(p);
            case PlyType::float32:
                return load<float>(p);
            case PlyType::float64:
                return load<double>(p);
        }
        return 0.0;
    }
    void end() {}
    std::size_t line() const { return 0; }
    void finish() const {
        if (pos_ != body_.size()) {
            throw InputError(fmt::format(
                "{}: {} bytes follow the last element: expected the file to end there (do the "
                "element counts match the data?)",
                names_.file(), body_.size() - pos_));
        }
    }

private:
    template <typename T>
    static double load(const char* p) {
        T value;
        std::memcpy(&value, p, sizeof(T));
        return static_cast<double>(value);
    }

    std::string_view body_;
    const Names& names_;
    std::size_t pos_ = 0;
    const char* what_ = "";
    std::size_t index_ = 0;
};

// Reads element instances from an ASCII body: one instance per line.
class PlyAsciiReader final {
public:
    PlyAsciiReader(std::string_view body, std::size_t first_line, const Names& names)
        : lines_(body, first_line), names_(names), text_size_(body.size()) {}

    void check_count(const PlyElement&) const {}
    // An ASCII count is only checked as lines run out; reserve no more than the text holds.
    std::size_t reservable(const PlyElement& element) const {
        return std::min(element.count, text_size_ / 6);
    }
    void begin(const char* what, std::size_t index) {
        what_ = what;
        index_ = index;
        std::string_view line;
        do {
            if (!lines_.next(line)) {
                throw InputError(
                    fmt::format("{}: the file ends before {} {}: expected one line "
                                "per element",
                                names_.file(), what_, index_));
            }
            split_words(line, words_);
        } while (words_.empty());
        next_word_ = 0;
    }
    double scalar(PlyType type, const PlyProperty& property) {
        if (next_word_ >= words_.size()) {
            throw InputError(fmt::format(
                "{}: {} {} (line {}): too few values: expected property "
                "'{}' ({})",
                names_.file(), what_, index_, lines_.number(), property.name, ply_type_name(type)));
        }
        const std::string_view token = words_[next_word_++];
        if (ply_is_float(type)) {
            const auto value = parse_double(token);
            if (!value) throw not_a_number(token, type, property);
            return *value;
        }
        const auto value = parse_integer(token);
        const long long lo = type == PlyType::int8    ? INT8_MIN
                             : type == PlyType::int16 ? INT16_MIN
                             : type == PlyType::int32 ? INT32_MIN
                                                      : 0;
        const long long hi = type == PlyType::int8     ? INT8_MAX
                             : type == PlyType::uint8  ? UINT8_MAX
                             : type == PlyType::int16  ? INT16_MAX
                             : type == PlyType::uint16 ? UINT16_MAX
                             : type == PlyType::int32  ? INT32_MAX
                                                       : UINT32_MAX;
        if (!value || *value < lo || *value > hi) throw not_a_number(token, type, property);
        return static_cast<double>(*value);
    }
    void end() const {
        if (next_word_ != words_.size()) {
            throw InputError(fmt::format("{}: {} {} (line {}): {} values: expected {}",
                                         names_.file(), what_, index_, lines_.number(),
                                         words_.size(), next_word_));
        }
    }
    std::size_t line() const { return lines_.number(); }
    void finish() {
        std::string_view line;
        while (lines_.next(line)) {
            split_words(line, words_);
            if (!words_.empty()) {
                throw InputError(fmt::format(
                    "{}: line {}: data after the last element: expected the file to end (do the "
                    "element counts match the data?)",
                    names_.file(), lines_.number()));
            }
        }
    }

private:
    InputError not_a_number(std::string_view token, PlyType type,
                            const PlyProperty& property) const {
        return InputError(
            fmt::format("{}: {} {} (line {}): '{}' is not a valid {}: expected "
                        "property '{}'",
                        names_.file(), what_, index_, lines_.number(), printable(token),
                        ply_type_name(type), property.name));
    }

    LineReader lines_;
    const Names& names_;
    std::size_t text_size_;
    std::vector<std::string_view> words_;
    std::size_t next_word_ = 0;
    const char* what_ = "";
    std::size_t index_ = 0;
};

// Where the mesh is in a PLY header: its vertex and face elements, which vertex property is x,
// y, z, nx, ny, nz (slot, -1 when absent), and which face property holds the vertex indices.
struct PlyLayout {
    const PlyElement* vertex = nullptr;
    const PlyElement* face = nullptr;
    std::array<int, 6> slot;
    int normal_slots = 0;
    int index_list = -1;
};

std::array<int, 6> vertex_slots(const PlyElement& vertex, const Names& names) {
    std::array<int, 6> slot;
    slot.fill(-1);
    static constexpr const char* kVertexNames[] = {"x", "y", "z", "nx", "ny", "nz"};
    for (std::size_t i = 0; i < vertex.properties.size(); ++i) {
        const PlyProperty& p = vertex.properties[i];
        for (std::size_t s = 0; s < 6; ++s) {
            if (p.name != kVertexNames[s]) continue;
            if (p.is_list || !ply_is_float(p.type)) {
                throw InputError(fmt::format(
                    "{}: line {}: vertex property '{}' is {}{}: expected float or double",
                    names.file(), p.header_line, p.name, p.is_list ? "a list of " : "",
                    ply_type_name(p.type)));
            }
            slot[s] = static_cast<int>(i);
        }
    }
    if (slot[0] < 0 || slot[1] < 0 || slot[2] < 0) {
        throw InputError(
            fmt::format("{}: element 'vertex' (line {}) lacks x, y or z: expected "
                        "all three",
                        names.file(), vertex.header_line));
    }
    return slot;
}

int face_index_list(const PlyElement& face, const Names& names) {
    int index_list = -1;
    for (std::size_t i = 0; i < face.properties.size(); ++i) {
        const PlyProperty& p = face.properties[i];
        if (p.name != "vertex_indices" && p.name != "vertex_index") continue;
        if (!p.is_list || ply_is_float(p.type)) {
            throw InputError(
                fmt::format("{}: line {}: face property '{}' is {}{}: expected a list of integers",
                            names.file(), p.header_line, p.name, p.is_list ? "a list of " : "",
                            ply_type_name(p.type)));
        }
        index_list = static_cast<int>(i);
    }
    if (index_list < 0) {
        throw InputError(
            fmt::format("{}: element 'face' (line {}) has no 'vertex_indices' list: "
                        "expected 'property list uchar int vertex_indices'",
                        names.file(), face.header_line));
    }
    return index_list;
}

PlyLayout ply_layout(const PlyHeader& header, const Names& names) {
    PlyLayout layout;
    for (const PlyElement& e : header.elements) {
        if (e.name == "vertex") layout.vertex = &e;
        if (e.name == "face") layout.face = &e;
    }
    if (layout.vertex == nullptr) {
        throw InputError(fmt::format("{}: no 'vertex' element: expected vertices", names.file()));
    }
    if (layout.face == nullptr) {
        throw InputError(fmt::format(
            "{}: no 'face' element: expected a surface mesh, not a point cloud", names.file()));
    }
    if (layout.vertex->count > kMaxVertices) {
        throw InputError(fmt::format(
            "{}: element 'vertex' (line {}) declares {} vertices: expected "
            "at most {}",
            names.file(), layout.vertex->header_line, layout.vertex->count, kMaxVertices));
    }
    layout.slot = vertex_slots(*layout.vertex, names);
    const std::array<int, 6>& slot = layout.slot;
    layout.normal_slots = (slot[3] >= 0) + (slot[4] >= 0) + (slot[5] >= 0);
    if (layout.normal_slots != 0 && layout.normal_slots != 3) {
        throw InputError(
            fmt::format("{}: element 'vertex' (line {}) has only some of nx, ny, "
                        "nz: expected all three or none",
                        names.file(), layout.vertex->header_line));
    }
    layout.index_list = face_index_list(*layout.face, names);
    return layout;
}

// The faces' vertex indices as read, kept raw until all vertices are known (the header may
// declare faces first): face f is indices[offsets[f] … offsets[f + 1]), from line lines[f].
struct RawFaces {
    std::vector<std::int64_t> indices;
    std::vector<std::size_t> offsets{0};
    std::vector<std::size_t> lines;
};

// Record i of an element: its scalar properties into values; the items of the face's index
// list (keep_list, that property's index) into faces; other lists read past.
template <typename Reader>
void read_ply_record(Reader& reader, const PlyElement& element, const char* what, std::size_t i,
                     int keep_list, const Names& names, std::vector<double>& values,
                     RawFaces& faces) {
    reader.begin(what, i);
    values.assign(element.properties.size(), 0.0);
    for (std::size_t pi = 0; pi < element.properties.size(); ++pi) {
        const PlyProperty& p = element.properties[pi];
        if (!p.is_list) {
            values[pi] = reader.scalar(p.type, p);
            continue;
        }
        const double count = reader.scalar(p.count_type, p);
        if (count < 0) {
            // Binary bodies have no lines: there the element index alone says where.
            const std::string line =
                reader.line() != 0 ? fmt::format(" (line {})", reader.line()) : std::string();
            throw InputError(
                fmt::format("{}: {} {}{}: list '{}' has {} items: expected a "
                            "count >= 0",
                            names.file(), what, i, line, p.name, count));
        }
        const auto items = static_cast<std::size_t>(count);
        const bool keep = static_cast<int>(pi) == keep_list;
        for (std::size_t j = 0; j < items; ++j) {
            const double item = reader.scalar(p.type, p);
            if (keep) faces.indices.push_back(static_cast<std::int64_t>(item));
        }
    }
    reader.end();
}

// Vertex i from its record's values.
void add_ply_vertex(Soup& soup, const PlyLayout& layout, const std::vector<double>& values,
                    double scale, const Names& names, std::size_t i, std::size_t line) {
    auto at = [&](std::size_t s) { return values[static_cast<std::size_t>(layout.slot[s])]; };
    const Vec3 raw(at(0), at(1), at(2));
    soup.positions.push_back(checked_position(raw, scale, names, i, line));
    soup.vertex_ordinal.push_back(i);
    soup.vertex_line.push_back(line);
    if (layout.normal_slots == 3) {
        soup.normals.push_back(
            checked_normal(Vec3(at(3), at(4), at(5)), names, names.vertex(i, line)));
    }
}

// The raw faces as polygons, once every vertex is known.
void add_ply_faces(Soup& soup, const RawFaces& faces, const Names& names) {
    const auto vertex_count = static_cast<std::int64_t>(soup.positions.size());
    std::vector<std::uint32_t> polygon;
    for (std::size_t f = 0; f + 1 < faces.offsets.size(); ++f) {
        polygon.clear();
        const std::size_t begin = faces.offsets[f], end = faces.offsets[f + 1];
        if (end - begin < 3) {
            throw InputError(fmt::format("{}: {} has {} vertices: expected at least 3",
                                         names.file(), names.face(f, faces.lines[f]), end - begin));
        }
        for (std::size_t j = begin; j < end; ++j) {
            if (faces.indices[j] < 0 || faces.indices[j] >= vertex_count) {
                throw InputError(fmt::format(
                    "{}: {}: vertex index {} is out of range: expected 0..{} ({} vertices)",
                    names.file(), names.face(f, faces.lines[f]), faces.indices[j], vertex_count - 1,
                    vertex_count));
            }
            polygon.push_back(static_cast<std::uint32_t>(faces.indices[j]));
        }
        add_polygon(soup, polygon, f, faces.lines[f], names);
    }
}

template <typename Reader>
Soup read_ply_body(Reader& reader, const PlyHeader& header, double scale, const Names& names) {
    const PlyLayout layout = ply_layout(header, names);
    Soup soup;
    RawFaces faces;
    std::vector<double> values;
    for (const PlyElement& element : header.elements) {
        reader.check_count(element);
        const bool is_vertex = &element == layout.vertex;
        const bool is_face = &element == layout.face;
        const char* what = is_vertex ? "vertex" : is_face ? "face" : element.name.c_str();
        // An element without properties has nothing to read (and its count bounds nothing).
        if (element.properties.empty()) continue;
        if (is_vertex) {
            const std::size_t expected = reader.reservable(element);
            soup.positions.reserve(expected);
            if (layout.normal_slots == 3) soup.normals.reserve(expected);
        }
        for (std::size_t i = 0; i < element.count; ++i) {
            read_ply_record(reader, element, what, i, is_face ? layout.index_list : -1, names,
                            values, faces);
            if (is_vertex) {
                add_ply_vertex(soup, layout, values, scale, names, i, reader.line());
            } else if (is_face) {
                faces.offsets.push_back(faces.indices.size());
                faces.lines.push_back(reader.line());
            }
        }
    }
    reader.finish();
    if (layout.face->count == 0) {
        throw InputError(
            fmt::format("{}: element 'face' (line {}) is empty: expected a surface mesh, not a "
                        "point cloud",
                        names.file(), layout.face->header_line));
    }
    add_ply_faces(soup, faces, names);
    return soup;
}

}  // namespace

Soup parse_ply(std::string_view bytes, double scale, const Names& names) {
    const PlyHeader header = parse_ply_header(bytes, names);
    const std::string_view body = bytes.substr(header.body_offset);
    if (header.binary) {
        PlyBinaryReader reader(body, names);
        return read_ply_body(reader, header, scale, names);
    }
    PlyAsciiReader reader(body, header.body_first_line, names);
    return read_ply_body(reader, header, scale, names);
}

}  // namespace plumage::geometry::mesh_import_detail
