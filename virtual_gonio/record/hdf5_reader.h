// Reading HDF5 files that plumage did not write itself (a user's records, made with h5py or
// MATLAB) and its own records and checkpoints, through one typed reader.
//
// Every object is checked before a byte of it is read: its class (string, integer, float), its
// dataspace (scalar, a one-element array, or an array of the expected rank), for strings whether
// they are fixed- or variable-length and how long, for datasets their shape and size against a
// stated limit and against the storage the file holds. Anything else is refused with an
// InputError naming the file, the object's path and what was found and expected, e.g.
//   HDF5 file 'dove.h5': /instrument@kind: found a variable-length string array [1000];
//   expected one string
// so a well-formed file with a field of the wrong type, shape or size can neither crash the
// reader (HDF5 copies whole arrays into the caller's buffer) nor make it allocate without
// bound. External links and datasets whose data lie in other files are refused: a record
// names no file but itself.
//
// What the reader does not check: the values themselves (ranges are the caller's, who knows
// what the numbers mean) and damage below the object level (a corrupted chunk inside a
// compressed dataset is HDF5's to detect; docs/reliability.md, "Fuzzing").
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace plumage::record {

// The most values one dataset may hold when read (8 bytes each in memory): 2^25, 256 MiB,
// eight times the largest record the suite writes (a 61 × 60 BTF). Callers may state less.
inline constexpr std::uint64_t kMaxDatasetValues = std::uint64_t{1} << 25;
// The longest string attribute read, in bytes (a study file kept in provenance is a few kB).
inline constexpr std::size_t kMaxStringBytes = std::size_t{1} << 20;

// A dataset read as doubles (any integer or floating-point type), with its dimensions.
struct Dataset {
    std::vector<double> values;
    std::vector<std::uint64_t> dims;
};

// What a dataset must be: its rank (-1: any) and the most values it may hold.
struct DatasetShape {
    int rank = -1;
    std::uint64_t max_values = kMaxDatasetValues;
};

// How an attribute is stored: what a reader in h5py or MATLAB gets back.
enum class AttributeType { string, signed_integer, unsigned_integer, floating_point, other };

class Hdf5Reader final {
public:
    // Opens the file read-only; InputError naming it if it is missing or not HDF5.
    explicit Hdf5Reader(std::filesystem::path file);
    ~Hdf5Reader();
    Hdf5Reader(const Hdf5Reader&) = delete;
    Hdf5Reader& operator=(const Hdf5Reader&) = delete;

    const std::filesystem::path& file() const { return file_; }

    // Whether a group or dataset exists at `path` ("/instrument"); false for a dangling or
    // external link and for any path the file cannot resolve.
    bool has_object(const std::string& path) const;
    // Whether `object_path` (a group or dataset, "/" the root) has the attribute; InputError if
    // the object itself is missing.
    bool has_attribute(const std::string& object_path, const std::string& name) const;

    // One string (scalar or a one-element array, fixed- or variable-length, ASCII or UTF-8) of
    // at most max_bytes bytes; trailing NULs of a fixed-length string are dropped.
    std::string string_attribute(const std::string& object_path, const std::string& name,
                                 std::size_t max_bytes = kMaxStringBytes) const;
    // One number, stored as any integer or floating-point type (converted to double).
    double number_attribute(const std::string& object_path, const std::string& name) const;
    // One non-negative integer, exact (a float or a negative value is refused).
    std::uint64_t unsigned_attribute(const std::string& object_path, const std::string& name) const;

    // How the attribute is stored (for tests of the suite's own records).
    AttributeType attribute_type(const std::string& object_path, const std::string& name) const;

    // A numeric dataset's dimensions, read without its data; its class and shape checked.
    std::vector<std::uint64_t> shape(const std::string& dataset_path,
                                     const DatasetShape& expected = {}) const;
    // A numeric dataset's values as doubles, row-major, its shape checked before reading.
    Dataset dataset(const std::string& dataset_path, const DatasetShape& expected = {}) const;
    // Every dataset of the file by path without the leading '/', in name order (external links
    // are not followed).
    std::vector<std::string> dataset_paths() const;

private:
    struct OpenAttribute;  // an attribute with its type and dataspace (hdf5_reader.cpp)
    OpenAttribute open_attribute(const std::string& object_path, const std::string& name) const;
    [[noreturn]] void refuse(const std::string& object, const std::string& what) const;

    std::filesystem::path file_;
    std::int64_t id_ = -1;
    std::int64_t link_access_ = -1;  // refuses external links
};

// One-call forms for a single object (each opens the file): the same checks and errors.
Dataset read_dataset(const std::filesystem::path& file, const std::string& dataset_path,
                     const DatasetShape& expected = {});
std::string read_string_attribute(const std::filesystem::path& file, const std::string& object_path,
                                  const std::string& name);
double read_number_attribute(const std::filesystem::path& file, const std::string& object_path,
                             const std::string& name);
std::uint64_t read_unsigned_attribute(const std::filesystem::path& file,
                                      const std::string& object_path, const std::string& name);
bool has_attribute(const std::filesystem::path& file, const std::string& object_path,
                   const std::string& name);
std::vector<std::string> dataset_paths(const std::filesystem::path& file);

AttributeType attribute_type(const std::filesystem::path& file, const std::string& object_path,
                             const std::string& name);

}  // namespace plumage::record
