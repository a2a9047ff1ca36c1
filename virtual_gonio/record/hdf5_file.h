// Writing records in HDF5 that h5py and MATLAB open directly.
//
// A record is written under a temporary name beside its final path and renamed when
// commit() is called, so a crash or an exception never leaves a half-written record:
// a Hdf5Writer destroyed without commit() deletes its temporary file.
//
// Datasets are row-major (C order) as h5py reads them; MATLAB's h5read shows the
// dimensions reversed, as it does for every C-written file. Each dataset may carry
// string attributes such as "units" and "description".
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "virtual_gonio/record/hdf5_reader.h"

namespace plumage::record {

using Attributes = std::vector<std::pair<std::string, std::string>>;

class Hdf5Writer {
public:
    explicit Hdf5Writer(std::filesystem::path final_path);
    ~Hdf5Writer();
    Hdf5Writer(const Hdf5Writer&) = delete;
    Hdf5Writer& operator=(const Hdf5Writer&) = delete;

    // dataset_path like "chart/xyz"; intermediate groups are created. The product of
    // dims must equal data.size(). Large datasets are chunked and deflate-compressed.
    void write(const std::string& dataset_path, std::span<const double> data,
               const std::vector<std::uint64_t>& dims, const Attributes& attributes = {});
    void write(const std::string& dataset_path, std::span<const float> data,
               const std::vector<std::uint64_t>& dims, const Attributes& attributes = {});
    void write(const std::string& dataset_path, std::span<const std::uint8_t> data,
               const std::vector<std::uint64_t>& dims, const Attributes& attributes = {});
    // Creates a group (and its parents) if missing, e.g. for attribute-only groups.
    void create_group(const std::string& group_path);
    // Attributes on a group or dataset ("/" is the file's root group).
    void set_attribute(const std::string& object_path, const std::string& name,
                       const std::string& value);
    void set_attribute(const std::string& object_path, const std::string& name, double value);
    // Integer attributes, stored as 64-bit HDF5 integers (h5py reads numpy.uint64 / int64):
    // seeds are exact to the last bit, counts read back as integers. Separate names, not
    // set_attribute overloads: an int argument would be ambiguous among double and the two.
    void set_unsigned_attribute(const std::string& object_path, const std::string& name,
                                std::uint64_t value);
    void set_integer_attribute(const std::string& object_path, const std::string& name,
                               std::int64_t value);

    // Flush, close and rename to the final path. After commit the writer is inert.
    void commit();

    const std::filesystem::path& final_path() const { return final_path_; }

private:
    template <typename T>
    void write_typed(const std::string& dataset_path, std::span<const T> data,
                     const std::vector<std::uint64_t>& dims, const Attributes& attributes,
                     std::int64_t memory_type, std::int64_t file_type);
    void ensure_parent_groups(const std::string& dataset_path);
    void close();

    std::filesystem::path final_path_;
    std::filesystem::path temporary_path_;
    std::int64_t file_ = -1;
};

}  // namespace plumage::record
