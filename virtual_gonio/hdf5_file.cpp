#include "virtual_gonio/hdf5_file.h"

#include <unistd.h>

#include <functional>
#include <numeric>

#include <fmt/format.h>
#include <hdf5.h>

#include "common/error.h"

namespace plumage::record {
namespace {

// Closes an HDF5 identifier when it leaves scope.
class Handle {
public:
    Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
    ~Handle() {
        if (id_ >= 0) close_(id_);
    }
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;
    hid_t get() const { return id_; }
    bool valid() const { return id_ >= 0; }

private:
    hid_t id_;
    herr_t (*close_)(hid_t);
};

[[noreturn]] void fail(const std::filesystem::path& file, const std::string& what) {
    throw IoError(fmt::format("HDF5 file '{}': {}", file.string(), what));
}

void check(herr_t status, const std::filesystem::path& file, const std::string& what) {
    if (status < 0) fail(file, what);
}

struct SilenceHdf5Errors {
    // HDF5 prints its own error stack to stderr by default; we report errors ourselves.
    SilenceHdf5Errors() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }
};
const SilenceHdf5Errors silence_hdf5_errors;

}  // namespace

Hdf5Writer::Hdf5Writer(std::filesystem::path final_path) : final_path_(std::move(final_path)) {
    temporary_path_ = final_path_;
    temporary_path_ += fmt::format(".partial-{}", ::getpid());
    file_ = H5Fcreate(temporary_path_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (file_ < 0)
        fail(temporary_path_, "cannot create (does the directory exist and is it writable?)");
}

Hdf5Writer::~Hdf5Writer() {
    if (file_ >= 0) {
        close();
        std::error_code ignored;
        std::filesystem::remove(temporary_path_, ignored);
    }
}

void Hdf5Writer::close() {
    if (file_ >= 0) {
        H5Fclose(file_);
        file_ = -1;
    }
}

void Hdf5Writer::commit() {
    if (file_ < 0) fail(final_path_, "commit() called twice");
    check(H5Fflush(file_, H5F_SCOPE_GLOBAL), temporary_path_, "flush failed");
    close();
    std::error_code error;
    std::filesystem::rename(temporary_path_, final_path_, error);
    if (error) {
        std::filesystem::remove(temporary_path_, error);
        fail(final_path_, "cannot rename the completed temporary file into place");
    }
}

void Hdf5Writer::ensure_parent_groups(const std::string& dataset_path) {
    std::size_t position = 0;
    while ((position = dataset_path.find('/', position + 1)) != std::string::npos) {
        const std::string group = dataset_path.substr(0, position);
        if (group.empty() || group == "/") continue;
        if (H5Lexists(file_, group.c_str(), H5P_DEFAULT) > 0) continue;
        Handle g(H5Gcreate2(file_, group.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
        if (!g.valid()) fail(temporary_path_, "cannot create group " + group);
    }
}

void Hdf5Writer::create_group(const std::string& group_path) {
    if (file_ < 0) fail(final_path_, "write after commit()");
    ensure_parent_groups(group_path + "/x");
}

template <typename T>
void Hdf5Writer::write_typed(const std::string& dataset_path, std::span<const T> data,
                             const std::vector<std::uint64_t>& dims, const Attributes& attributes,
                             std::int64_t memory_type, std::int64_t file_type) {
    if (file_ < 0) fail(final_path_, "write after commit()");
    const std::uint64_t count =
        std::accumulate(dims.begin(), dims.end(), std::uint64_t{1}, std::multiplies<>());
    PLUMAGE_CHECK(count == data.size(), fmt::format("dataset {}: dims give {} values, data has {}",
                                                    dataset_path, count, data.size()));
    ensure_parent_groups(dataset_path);
    std::vector<hsize_t> h5dims(dims.begin(), dims.end());
    Handle space(H5Screate_simple(static_cast<int>(h5dims.size()), h5dims.data(), nullptr),
                 H5Sclose);
    Handle properties(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
    if (count * sizeof(T) > 64 * 1024 && !dims.empty() && H5Zfilter_avail(H5Z_FILTER_DEFLATE) > 0) {
        // Chunk along the leading dimension only: whole trailing rows stay together.
        std::vector<hsize_t> chunk = h5dims;
        const hsize_t row = count / std::max<hsize_t>(1, h5dims[0]);
        chunk[0] = std::max<hsize_t>(
            1, std::min<hsize_t>(h5dims[0], (256 * 1024 / sizeof(T)) / std::max<hsize_t>(1, row)));
        check(H5Pset_chunk(properties.get(), static_cast<int>(chunk.size()), chunk.data()),
              temporary_path_, "chunking " + dataset_path);
        check(H5Pset_deflate(properties.get(), 4), temporary_path_, "compression " + dataset_path);
    }
    Handle dataset(H5Dcreate2(file_, dataset_path.c_str(), file_type, space.get(), H5P_DEFAULT,
                              properties.get(), H5P_DEFAULT),
                   H5Dclose);
    if (!dataset.valid()) fail(temporary_path_, "cannot create dataset " + dataset_path);
    check(H5Dwrite(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()),
          temporary_path_, "cannot write dataset " + dataset_path);
    for (const auto& [name, value] : attributes) set_attribute(dataset_path, name, value);
}

void Hdf5Writer::write(const std::string& path, std::span<const double> data,
                       const std::vector<std::uint64_t>& dims, const Attributes& attributes) {
    write_typed(path, data, dims, attributes, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE);
}
void Hdf5Writer::write(const std::string& path, std::span<const float> data,
                       const std::vector<std::uint64_t>& dims, const Attributes& attributes) {
    write_typed(path, data, dims, attributes, H5T_NATIVE_FLOAT, H5T_IEEE_F32LE);
}
void Hdf5Writer::write(const std::string& path, std::span<const std::uint8_t> data,
                       const std::vector<std::uint64_t>& dims, const Attributes& attributes) {
    write_typed(path, data, dims, attributes, H5T_NATIVE_UINT8, H5T_STD_U8LE);
}

void Hdf5Writer::set_attribute(const std::string& object_path, const std::string& name,
                               const std::string& value) {
    if (file_ < 0) fail(final_path_, "write after commit()");
    // Variable-length UTF-8 strings: h5py reads them as str, MATLAB's h5readatt as char.
    Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
    check(H5Tset_size(type.get(), H5T_VARIABLE), temporary_path_, "string type");
    check(H5Tset_cset(type.get(), H5T_CSET_UTF8), temporary_path_, "string type");
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle attribute(H5Acreate_by_name(file_, object_path.c_str(), name.c_str(), type.get(),
                                       space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                     H5Aclose);
    if (!attribute.valid())
        fail(temporary_path_, "cannot create attribute " + object_path + "@" + name);
    const char* text = value.c_str();
    check(H5Awrite(attribute.get(), type.get(), &text), temporary_path_,
          "cannot write attribute " + name);
}

void Hdf5Writer::set_attribute(const std::string& object_path, const std::string& name,
                               double value) {
    if (file_ < 0) fail(final_path_, "write after commit()");
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle attribute(H5Acreate_by_name(file_, object_path.c_str(), name.c_str(), H5T_IEEE_F64LE,
                                       space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                     H5Aclose);
    if (!attribute.valid())
        fail(temporary_path_, "cannot create attribute " + object_path + "@" + name);
    check(H5Awrite(attribute.get(), H5T_NATIVE_DOUBLE, &value), temporary_path_,
          "cannot write attribute " + name);
}

namespace {

template <typename T>
void write_scalar_attribute(std::int64_t file, const std::filesystem::path& temporary_path,
                            const std::string& object_path, const std::string& name, T value,
                            hid_t file_type, hid_t memory_type) {
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle attribute(H5Acreate_by_name(file, object_path.c_str(), name.c_str(), file_type,
                                       space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                     H5Aclose);
    if (!attribute.valid())
        fail(temporary_path, "cannot create attribute " + object_path + "@" + name);
    check(H5Awrite(attribute.get(), memory_type, &value), temporary_path,
          "cannot write attribute " + name);
}

}  // namespace

void Hdf5Writer::set_unsigned_attribute(const std::string& object_path, const std::string& name,
                                        std::uint64_t value) {
    if (file_ < 0) fail(final_path_, "write after commit()");
    write_scalar_attribute(file_, temporary_path_, object_path, name, value, H5T_STD_U64LE,
                           H5T_NATIVE_UINT64);
}

void Hdf5Writer::set_integer_attribute(const std::string& object_path, const std::string& name,
                                       std::int64_t value) {
    if (file_ < 0) fail(final_path_, "write after commit()");
    write_scalar_attribute(file_, temporary_path_, object_path, name, value, H5T_STD_I64LE,
                           H5T_NATIVE_INT64);
}

Dataset read_dataset(const std::filesystem::path& file, const std::string& dataset_path) {
    Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!f.valid()) fail(file, "cannot open for reading");
    Handle dataset(H5Dopen2(f.get(), dataset_path.c_str(), H5P_DEFAULT), H5Dclose);
    if (!dataset.valid()) fail(file, "no dataset " + dataset_path);
    Handle space(H5Dget_space(dataset.get()), H5Sclose);
    const int rank = space.valid() ? H5Sget_simple_extent_ndims(space.get()) : -1;
    // A damaged file can fail here: reading "all" of an unknown extent into a one-value buffer
    // would overflow it.
    if (rank < 0) fail(file, "cannot read the shape of dataset " + dataset_path);
    std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
    if (H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr) != rank) {
        fail(file, "cannot read the shape of dataset " + dataset_path);
    }
    Dataset result;
    result.dims.assign(dims.begin(), dims.end());
    const hsize_t count =
        std::accumulate(dims.begin(), dims.end(), hsize_t{1}, std::multiplies<>());
    // HDF5 1.10 trusts a damaged file's layout: a contiguous or compact dataset that stores
    // fewer bytes than its shape needs is refused here, before H5Dread copies past its buffers.
    // A damaged chunked, compressed dataset still crashes HDF5 itself (heap over-read in
    // H5VM_memcpyvv under H5Dread; fuzz/unfixed/record/, docs/reliability.md); plumage reads back
    // only the records and checkpoints it wrote.
    Handle plist(H5Dget_create_plist(dataset.get()), H5Pclose);
    Handle file_type(H5Dget_type(dataset.get()), H5Tclose);
    const H5D_layout_t layout = plist.valid() ? H5Pget_layout(plist.get()) : H5D_LAYOUT_ERROR;
    const std::size_t element = file_type.valid() ? H5Tget_size(file_type.get()) : 0;
    if (layout == H5D_LAYOUT_ERROR || element == 0 ||
        ((layout == H5D_CONTIGUOUS || layout == H5D_COMPACT) && count > 0 &&
         H5Dget_storage_size(dataset.get()) < count * element)) {
        fail(file,
             "damaged dataset " + dataset_path + ": its stored size does not match its shape");
    }
    result.values.resize(count);
    check(H5Dread(dataset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                  result.values.data()),
          file, "cannot read dataset " + dataset_path);
    return result;
}

std::string read_string_attribute(const std::filesystem::path& file, const std::string& object_path,
                                  const std::string& name) {
    Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!f.valid()) fail(file, "cannot open for reading");
    Handle attribute(
        H5Aopen_by_name(f.get(), object_path.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
        H5Aclose);
    if (!attribute.valid()) fail(file, "no attribute " + object_path + "@" + name);
    Handle type(H5Aget_type(attribute.get()), H5Tclose);
    if (H5Tis_variable_str(type.get()) > 0) {
        Handle memory_type(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(memory_type.get(), H5T_VARIABLE);
        H5Tset_cset(memory_type.get(), H5T_CSET_UTF8);
        char* text = nullptr;
        check(H5Aread(attribute.get(), memory_type.get(), &text), file,
              "cannot read attribute " + name);
        std::string value = text != nullptr ? text : "";
        H5free_memory(text);
        return value;
    }
    std::string value(H5Tget_size(type.get()), '\0');
    check(H5Aread(attribute.get(), type.get(), value.data()), file,
          "cannot read attribute " + name);
    value.erase(value.find_last_not_of('\0') + 1);
    return value;
}

double read_number_attribute(const std::filesystem::path& file, const std::string& object_path,
                             const std::string& name) {
    Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!f.valid()) fail(file, "cannot open for reading");
    Handle attribute(
        H5Aopen_by_name(f.get(), object_path.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
        H5Aclose);
    if (!attribute.valid()) fail(file, "no attribute " + object_path + "@" + name);
    double value = 0.0;
    check(H5Aread(attribute.get(), H5T_NATIVE_DOUBLE, &value), file,
          "cannot read attribute " + name);
    return value;
}

std::uint64_t read_unsigned_attribute(const std::filesystem::path& file,
                                      const std::string& object_path, const std::string& name) {
    Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!f.valid()) fail(file, "cannot open for reading");
    Handle attribute(
        H5Aopen_by_name(f.get(), object_path.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
        H5Aclose);
    if (!attribute.valid()) fail(file, "no attribute " + object_path + "@" + name);
    Handle type(H5Aget_type(attribute.get()), H5Tclose);
    if (!type.valid() || H5Tget_class(type.get()) != H5T_INTEGER)
        fail(file, "attribute " + object_path + "@" + name + " is not an integer");
    std::uint64_t value = 0;
    check(H5Aread(attribute.get(), H5T_NATIVE_UINT64, &value), file,
          "cannot read attribute " + name);
    return value;
}

bool has_attribute(const std::filesystem::path& file, const std::string& object_path,
                   const std::string& name) {
    Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!f.valid()) fail(file, "cannot open for reading");
    const htri_t exists =
        H5Aexists_by_name(f.get(), object_path.c_str(), name.c_str(), H5P_DEFAULT);
    if (exists < 0) fail(file, "cannot open " + object_path);
    return exists > 0;
}

AttributeType attribute_type(const std::filesystem::path& file, const std::string& object_path,
                             const std::string& name) {
    Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!f.valid()) fail(file, "cannot open for reading");
    Handle attribute(
        H5Aopen_by_name(f.get(), object_path.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
        H5Aclose);
    if (!attribute.valid()) fail(file, "no attribute " + object_path + "@" + name);
    Handle type(H5Aget_type(attribute.get()), H5Tclose);
    switch (type.valid() ? H5Tget_class(type.get()) : H5T_NO_CLASS) {
        case H5T_STRING:
            return AttributeType::string;
        case H5T_FLOAT:
            return AttributeType::floating_point;
        case H5T_INTEGER:
            return H5Tget_sign(type.get()) == H5T_SGN_NONE ? AttributeType::unsigned_integer
                                                           : AttributeType::signed_integer;
        default:
            return AttributeType::other;
    }
}

namespace {

struct DatasetVisit {
    std::vector<std::string> paths;
};

herr_t collect_dataset(hid_t group, const char* name, const H5L_info_t* /*info*/, void* data) {
    Handle object(H5Oopen(group, name, H5P_DEFAULT), H5Oclose);
    if (object.valid() && H5Iget_type(object.get()) == H5I_DATASET)
        static_cast<DatasetVisit*>(data)->paths.emplace_back(name);
    return 0;
}

}  // namespace

std::vector<std::string> dataset_paths(const std::filesystem::path& file) {
    Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!f.valid()) fail(file, "cannot open for reading");
    DatasetVisit visit;
    check(H5Lvisit(f.get(), H5_INDEX_NAME, H5_ITER_INC, collect_dataset, &visit), file,
          "cannot list the datasets");
    return visit.paths;
}

}  // namespace plumage::record
