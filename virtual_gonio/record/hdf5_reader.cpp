#include "virtual_gonio/record/hdf5_reader.h"

#include <cstring>
#include <limits>
#include <optional>

#include <fmt/format.h>
#include <hdf5.h>

#include "common/error.h"
#include "virtual_gonio/record/hdf5_handle.h"

namespace plumage::record {
namespace {

// A record names no file but itself: links into other files are not followed.
herr_t refuse_external_link(const char* /*parent_file*/, const char* /*parent_group*/,
                            const char* /*child_file*/, const char* /*child_object*/,
                            unsigned* /*access_flags*/, hid_t /*fapl*/, void* /*data*/) {
    return -1;
}

std::string describe_type(hid_t type) {
    const std::size_t bits = 8 * H5Tget_size(type);
    switch (H5Tget_class(type)) {
        case H5T_INTEGER:
            return fmt::format("a {}-bit {} integer", bits,
                               H5Tget_sign(type) == H5T_SGN_NONE ? "unsigned" : "signed");
        case H5T_FLOAT:
            return fmt::format("a {}-bit float", bits);
        case H5T_STRING:
            return H5Tis_variable_str(type) > 0
                       ? std::string("a variable-length string")
                       : fmt::format("a fixed-length string of {} bytes", bits / 8);
        case H5T_COMPOUND:
            return "a compound type";
        case H5T_ENUM:
            return "an enumeration (h5py stores bool as one)";
        case H5T_BITFIELD:
            return "a bit field";
        case H5T_OPAQUE:
            return "opaque bytes";
        case H5T_REFERENCE:
            return "an object reference";
        case H5T_VLEN:
            return "a variable-length sequence";
        case H5T_ARRAY:
            return "an array type";
        case H5T_TIME:
            return "a time type";
        default:
            return "an unknown type";
    }
}

// The dimensions of a simple dataspace ({} for a scalar); nullopt for a null dataspace (no
// data at all) or one HDF5 cannot read.
std::optional<std::vector<std::uint64_t>> extent(hid_t space) {
    const H5S_class_t kind = H5Sget_simple_extent_type(space);
    if (kind == H5S_SCALAR) return std::vector<std::uint64_t>{};
    if (kind != H5S_SIMPLE) return std::nullopt;
    const int rank = H5Sget_simple_extent_ndims(space);
    if (rank < 0) return std::nullopt;
    std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
    if (H5Sget_simple_extent_dims(space, dims.data(), nullptr) != rank) return std::nullopt;
    return std::vector<std::uint64_t>(dims.begin(), dims.end());
}

// The number of values of `dims`, or nullopt when the product does not fit in 64 bits.
std::optional<std::uint64_t> count_of(const std::vector<std::uint64_t>& dims) {
    std::uint64_t count = 1;
    for (std::uint64_t d : dims) {
        if (d != 0 && count > std::numeric_limits<std::uint64_t>::max() / d) return std::nullopt;
        count *= d;
    }
    return count;
}

std::string describe_extent(const std::optional<std::vector<std::uint64_t>>& dims) {
    if (!dims) return " with no data (a null dataspace)";
    if (dims->empty()) return "";
    return fmt::format(" array [{}]", fmt::join(*dims, " x "));
}

std::string describe(hid_t type, hid_t space) {
    return describe_type(type) + describe_extent(extent(space));
}

bool numeric(hid_t type) {
    const H5T_class_t c = H5Tget_class(type);
    return c == H5T_INTEGER || c == H5T_FLOAT;
}

}  // namespace

Hdf5Reader::Hdf5Reader(std::filesystem::path file) : file_(std::move(file)) {
    // HDF5 prints its own error stack to stderr by default; the reader reports errors itself.
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    std::error_code error;
    if (!std::filesystem::is_regular_file(file_, error))
        throw InputError(fmt::format("HDF5 file '{}': no such file", file_.string()));
    id_ = H5Fopen(file_.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (id_ < 0) {
        throw InputError(fmt::format(
            "HDF5 file '{}': cannot be opened as HDF5 (not an HDF5 file, damaged, or open for "
            "writing by another program)",
            file_.string()));
    }
    link_access_ = H5Pcreate(H5P_LINK_ACCESS);
    if (link_access_ < 0 || H5Pset_elink_cb(link_access_, refuse_external_link, nullptr) < 0) {
        if (link_access_ >= 0) H5Pclose(link_access_);
        H5Fclose(id_);
        throw IoError(fmt::format("HDF5 file '{}': cannot set up link access", file_.string()));
    }
}

Hdf5Reader::~Hdf5Reader() {
    H5Pclose(link_access_);
    H5Fclose(id_);
}

void Hdf5Reader::refuse(const std::string& object, const std::string& what) const {
    throw InputError(fmt::format("HDF5 file '{}': {}: {}", file_.string(), object, what));
}

bool Hdf5Reader::has_object(const std::string& path) const {
    if (path.empty() || path == "/") return true;
    // Every link along the path must exist before the next is asked for (HDF5 fails rather than
    // answering "no" past a missing group), then the object it names (a soft link may dangle).
    for (std::size_t slash = path.find('/', 1); slash != std::string::npos;
         slash = path.find('/', slash + 1)) {
        if (H5Lexists(id_, path.substr(0, slash).c_str(), link_access_) <= 0) return false;
    }
    return H5Lexists(id_, path.c_str(), link_access_) > 0 &&
           H5Oexists_by_name(id_, path.c_str(), link_access_) > 0;
}

bool Hdf5Reader::has_attribute(const std::string& object_path, const std::string& name) const {
    if (!has_object(object_path)) refuse(object_path, "missing (expected a group or dataset)");
    return H5Aexists_by_name(id_, object_path.c_str(), name.c_str(), link_access_) > 0;
}

struct Hdf5Reader::OpenAttribute {
    std::string where;  // "object@name", for messages
    Handle attribute, type, space;
};

Hdf5Reader::OpenAttribute Hdf5Reader::open_attribute(const std::string& object_path,
                                                     const std::string& name) const {
    std::string where = object_path + "@" + name;
    if (!has_attribute(object_path, name)) refuse(where, "missing");
    Handle attribute(
        H5Aopen_by_name(id_, object_path.c_str(), name.c_str(), H5P_DEFAULT, link_access_),
        H5Aclose);
    if (!attribute.valid()) refuse(where, "cannot be opened");
    Handle type(H5Aget_type(attribute.get()), H5Tclose);
    Handle space(H5Aget_space(attribute.get()), H5Sclose);
    if (!type.valid() || !space.valid()) refuse(where, "unreadable type or shape");
    return {std::move(where), std::move(attribute), std::move(type), std::move(space)};
}

std::string Hdf5Reader::string_attribute(const std::string& object_path, const std::string& name,
                                         std::size_t max_bytes) const {
    const OpenAttribute a = open_attribute(object_path, name);
    const std::string& where = a.where;
    const auto dims = extent(a.space.get());
    const auto count = dims ? count_of(*dims) : std::nullopt;
    if (H5Tget_class(a.type.get()) != H5T_STRING || count != std::uint64_t{1})
        refuse(where, "found " + describe(a.type.get(), a.space.get()) + "; expected one string");
    if (H5Tis_variable_str(a.type.get()) > 0) {
        Handle memory_type(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(memory_type.get(), H5T_VARIABLE);
        H5Tset_cset(memory_type.get(), H5Tget_cset(a.type.get()));
        char* text = nullptr;
        if (H5Aread(a.attribute.get(), memory_type.get(), &text) < 0)
            refuse(where, "cannot read the variable-length string");
        const std::size_t length = text != nullptr ? std::strlen(text) : 0;
        std::string value = length <= max_bytes ? std::string(text != nullptr ? text : "") : "";
        H5free_memory(text);
        if (length > max_bytes)
            refuse(where,
                   fmt::format("a string of {} bytes; expected at most {}", length, max_bytes));
        return value;
    }
    const std::size_t size = H5Tget_size(a.type.get());
    if (size > max_bytes)
        refuse(where, fmt::format("a string of {} bytes; expected at most {}", size, max_bytes));
    std::string value(size, '\0');
    if (H5Aread(a.attribute.get(), a.type.get(), value.data()) < 0)
        refuse(where, "cannot read the fixed-length string");
    value.erase(value.find_last_not_of('\0') + 1);
    return value;
}

double Hdf5Reader::number_attribute(const std::string& object_path, const std::string& name) const {
    const OpenAttribute a = open_attribute(object_path, name);
    const std::string& where = a.where;
    const auto dims = extent(a.space.get());
    if (!numeric(a.type.get()) || (dims ? count_of(*dims) : std::nullopt) != std::uint64_t{1})
        refuse(where, "found " + describe(a.type.get(), a.space.get()) + "; expected one number");
    double value = 0.0;
    if (H5Aread(a.attribute.get(), H5T_NATIVE_DOUBLE, &value) < 0)
        refuse(where, "cannot convert to a double");
    return value;
}

std::uint64_t Hdf5Reader::unsigned_attribute(const std::string& object_path,
                                             const std::string& name) const {
    const OpenAttribute a = open_attribute(object_path, name);
    const std::string& where = a.where;
    const auto dims = extent(a.space.get());
    if (H5Tget_class(a.type.get()) != H5T_INTEGER ||
        (dims ? count_of(*dims) : std::nullopt) != std::uint64_t{1}) {
        refuse(where, "found " + describe(a.type.get(), a.space.get()) +
                          "; expected one non-negative integer");
    }
    if (H5Tget_sign(a.type.get()) != H5T_SGN_NONE) {
        std::int64_t value = 0;
        if (H5Aread(a.attribute.get(), H5T_NATIVE_INT64, &value) < 0 || value < 0)
            refuse(where, fmt::format("{}: expected a non-negative integer", value));
        return static_cast<std::uint64_t>(value);
    }
    std::uint64_t value = 0;
    if (H5Aread(a.attribute.get(), H5T_NATIVE_UINT64, &value) < 0)
        refuse(where, "cannot read as a 64-bit integer");
    return value;
}

AttributeType Hdf5Reader::attribute_type(const std::string& object_path,
                                         const std::string& name) const {
    const OpenAttribute a = open_attribute(object_path, name);
    const std::string& where = a.where;
    switch (H5Tget_class(a.type.get())) {
        case H5T_STRING:
            return AttributeType::string;
        case H5T_FLOAT:
            return AttributeType::floating_point;
        case H5T_INTEGER:
            return H5Tget_sign(a.type.get()) == H5T_SGN_NONE ? AttributeType::unsigned_integer
                                                             : AttributeType::signed_integer;
        default:
            return AttributeType::other;
    }
}

std::vector<std::uint64_t> Hdf5Reader::shape(const std::string& dataset_path,
                                             const DatasetShape& expected) const {
    const std::string where = dataset_path.front() == '/' ? dataset_path : "/" + dataset_path;
    if (!has_object(where)) refuse(where, "missing (expected a dataset)");
    Handle object(H5Oopen(id_, where.c_str(), link_access_), H5Oclose);
    if (!object.valid()) refuse(where, "cannot be opened");
    if (H5Iget_type(object.get()) != H5I_DATASET)
        refuse(where, "found a group; expected a dataset");
    Handle type(H5Dget_type(object.get()), H5Tclose);
    Handle space(H5Dget_space(object.get()), H5Sclose);
    if (!type.valid() || !space.valid()) refuse(where, "unreadable type or shape");
    const auto dims = extent(space.get());
    const std::string found = describe(type.get(), space.get());
    if (!numeric(type.get()) || !dims)
        refuse(where, "found " + found + "; expected an array of numbers");
    if (expected.rank >= 0 && dims->size() != static_cast<std::size_t>(expected.rank)) {
        refuse(where, fmt::format("found {}; expected an array of {} dimension{}", found,
                                  expected.rank, expected.rank == 1 ? "" : "s"));
    }
    const auto count = count_of(*dims);
    if (!count || *count > expected.max_values) {
        refuse(where,
               fmt::format("found {}{}; expected at most {} values", found,
                           count ? fmt::format(", {} values", *count) : "", expected.max_values));
    }
    return *dims;
}

Dataset Hdf5Reader::dataset(const std::string& dataset_path, const DatasetShape& expected) const {
    const std::string where = dataset_path.front() == '/' ? dataset_path : "/" + dataset_path;
    Dataset result;
    result.dims = shape(where, expected);
    const std::uint64_t count = *count_of(result.dims);
    Handle dataset(H5Dopen2(id_, where.c_str(), H5P_DEFAULT), H5Dclose);
    Handle plist(H5Dget_create_plist(dataset.get()), H5Pclose);
    Handle file_type(H5Dget_type(dataset.get()), H5Tclose);
    if (!dataset.valid() || !plist.valid() || !file_type.valid()) refuse(where, "cannot be opened");
    const H5D_layout_t layout = H5Pget_layout(plist.get());
    if (layout == H5D_VIRTUAL || H5Pget_external_count(plist.get()) != 0)
        refuse(where, "its data lie in other files; expected them in this file");
    // HDF5 1.10 trusts a damaged file's layout: a contiguous or compact dataset that stores
    // fewer bytes than its shape needs is refused here, before H5Dread copies past its buffers.
    // A damaged chunked, compressed dataset can still crash HDF5 itself (heap over-read in
    // H5VM_memcpyvv under H5Dread; fuzz/unfixed/record/, docs/reliability.md).
    const std::size_t element = H5Tget_size(file_type.get());
    if (layout == H5D_LAYOUT_ERROR || element == 0 ||
        ((layout == H5D_CONTIGUOUS || layout == H5D_COMPACT) && count > 0 &&
         H5Dget_storage_size(dataset.get()) < count * element)) {
        refuse(where, "damaged: its stored size does not match its shape");
    }
    const int filters = H5Pget_nfilters(plist.get());
    for (int i = 0; i < filters; ++i) {
        unsigned flags = 0, config = 0;
        std::size_t elements = 0;
        char name[64] = {};
        const H5Z_filter_t filter = H5Pget_filter2(plist.get(), static_cast<unsigned>(i), &flags,
                                                   &elements, nullptr, sizeof name, name, &config);
        if (filter < 0 || H5Zfilter_avail(filter) <= 0) {
            refuse(where, fmt::format("compressed with filter {} ('{}'), which this HDF5 library "
                                      "lacks; expected deflate (gzip) or none",
                                      static_cast<int>(filter), name));
        }
    }
    result.values.resize(count);
    if (count > 0 && H5Dread(dataset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                             result.values.data()) < 0) {
        refuse(where, "cannot read its values as doubles");
    }
    return result;
}

namespace {

struct DatasetVisit {
    hid_t link_access;
    std::vector<std::string> paths;
};

herr_t collect_dataset(hid_t group, const char* name, const H5L_info_t* info, void* data) {
    auto* visit = static_cast<DatasetVisit*>(data);
    if (info->type == H5L_TYPE_EXTERNAL) return 0;
    if (H5Oexists_by_name(group, name, visit->link_access) <= 0) return 0;  // dangling
    Handle object(H5Oopen(group, name, visit->link_access), H5Oclose);
    if (object.valid() && H5Iget_type(object.get()) == H5I_DATASET) visit->paths.emplace_back(name);
    return 0;
}

}  // namespace

std::vector<std::string> Hdf5Reader::dataset_paths() const {
    DatasetVisit visit{link_access_, {}};
    if (H5Lvisit(id_, H5_INDEX_NAME, H5_ITER_INC, collect_dataset, &visit) < 0)
        refuse("/", "cannot list the datasets");
    return visit.paths;
}

Dataset read_dataset(const std::filesystem::path& file, const std::string& dataset_path,
                     const DatasetShape& expected) {
    return Hdf5Reader(file).dataset(dataset_path, expected);
}

std::string read_string_attribute(const std::filesystem::path& file, const std::string& object_path,
                                  const std::string& name) {
    return Hdf5Reader(file).string_attribute(object_path, name);
}

double read_number_attribute(const std::filesystem::path& file, const std::string& object_path,
                             const std::string& name) {
    return Hdf5Reader(file).number_attribute(object_path, name);
}

std::uint64_t read_unsigned_attribute(const std::filesystem::path& file,
                                      const std::string& object_path, const std::string& name) {
    return Hdf5Reader(file).unsigned_attribute(object_path, name);
}

bool has_attribute(const std::filesystem::path& file, const std::string& object_path,
                   const std::string& name) {
    return Hdf5Reader(file).has_attribute(object_path, name);
}

std::vector<std::string> dataset_paths(const std::filesystem::path& file) {
    return Hdf5Reader(file).dataset_paths();
}

AttributeType attribute_type(const std::filesystem::path& file, const std::string& object_path,
                             const std::string& name) {
    return Hdf5Reader(file).attribute_type(object_path, name);
}

}  // namespace plumage::record
