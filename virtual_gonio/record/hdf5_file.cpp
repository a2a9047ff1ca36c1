#include "virtual_gonio/record/hdf5_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <functional>
#include <numeric>

#include <fmt/format.h>
#include <hdf5.h>

#include "common/error.h"
#include "virtual_gonio/record/hdf5_handle.h"

namespace plumage::record {
namespace {

// A write that failed for want of space says so (HDF5 reports only that the write failed).
[[noreturn]] void fail(const std::filesystem::path& file, const std::string& what) {
    const int error = errno;
    const bool full = error == ENOSPC || error == EDQUOT;
    throw IoError(fmt::format("HDF5 file '{}': {}{}", file.string(), what,
                              full ? fmt::format(" ({})", std::strerror(error)) : ""));
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

}  // namespace plumage::record
