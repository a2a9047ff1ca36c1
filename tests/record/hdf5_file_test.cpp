#include "virtual_gonio/record/hdf5_file.h"

#include <unistd.h>

#include <filesystem>
#include <limits>

#include <gtest/gtest.h>

#include "common/error.h"

namespace plumage::record {
namespace {

std::filesystem::path scratch(const std::string& name) {
    const auto dir =
        std::filesystem::temp_directory_path() / ("plumage_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return dir / name;
}

bool any_partial_file(const std::filesystem::path& dir) {
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        if (entry.path().string().find(".partial-") != std::string::npos) return true;
    }
    return false;
}

TEST(Hdf5Record, RoundTripsDatasetsAndAttributes) {
    const auto path = scratch("roundtrip.h5");
    const std::vector<double> values = {1.0, 2.5, -3.0, 1e-300, 6.0, 7.0};
    {
        Hdf5Writer w(path);
        w.write("group/sub/values", std::span<const double>(values), {2, 3}, {{"units", "1/sr"}});
        w.set_attribute("/", "seed", 42.0);
        w.set_attribute("/group", "note", "ünïcode ok");
        w.commit();
    }
    const Dataset d = read_dataset(path, "group/sub/values");
    EXPECT_EQ(d.dims, (std::vector<std::uint64_t>{2, 3}));
    EXPECT_EQ(d.values, values);
    EXPECT_EQ(read_string_attribute(path, "group/sub/values", "units"), "1/sr");
    EXPECT_EQ(read_string_attribute(path, "/group", "note"), "ünïcode ok");
    EXPECT_FALSE(any_partial_file(path.parent_path()));
}

TEST(Hdf5Record, IntegerAttributesAreExactAndTyped) {
    const auto path = scratch("integers.h5");
    const std::uint64_t largest = std::numeric_limits<std::uint64_t>::max();  // no double holds it
    {
        Hdf5Writer w(path);
        w.write("values", std::span<const double>(std::vector<double>{1.0}), {1});
        w.set_unsigned_attribute("/", "seed", largest);
        w.set_integer_attribute("/", "threads", -3);
        w.set_attribute("/", "time", 0.5);
        w.set_attribute("/values", "units", "1");
        w.commit();
    }
    EXPECT_EQ(read_unsigned_attribute(path, "/", "seed"), largest);
    EXPECT_EQ(read_number_attribute(path, "/", "threads"), -3.0);
    EXPECT_EQ(attribute_type(path, "/", "seed"), AttributeType::unsigned_integer);
    EXPECT_EQ(attribute_type(path, "/", "threads"), AttributeType::signed_integer);
    EXPECT_EQ(attribute_type(path, "/", "time"), AttributeType::floating_point);
    EXPECT_EQ(attribute_type(path, "/values", "units"), AttributeType::string);
    EXPECT_THROW(read_unsigned_attribute(path, "/", "time"), InputError);
}

TEST(Hdf5Record, ListsEveryDatasetButNotGroups) {
    const auto path = scratch("listing.h5");
    const std::vector<double> one = {1.0};
    {
        Hdf5Writer w(path);
        w.write("b/deep/x", std::span<const double>(one), {1});
        w.write("a", std::span<const double>(one), {1});
        w.create_group("empty");
        w.commit();
    }
    EXPECT_EQ(dataset_paths(path), (std::vector<std::string>{"a", "b/deep/x"}));
}

TEST(Hdf5Record, LargeDatasetsAreCompressedAndExact) {
    const auto path = scratch("large.h5");
    std::vector<float> values(200 * 300);
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<float>(i % 97) * 0.25f;
    {
        Hdf5Writer w(path);
        w.write("big", std::span<const float>(values), {200, 300});
        w.commit();
    }
    const Dataset d = read_dataset(path, "big");
    ASSERT_EQ(d.values.size(), values.size());
    for (std::size_t i = 0; i < values.size(); ++i) ASSERT_EQ(d.values[i], values[i]);
    EXPECT_LT(std::filesystem::file_size(path), values.size() * sizeof(float) / 2);
}

TEST(Hdf5Record, UncommittedWriterLeavesNothingBehind) {
    const auto path = scratch("abandoned.h5");
    std::filesystem::remove(path);
    {
        Hdf5Writer w(path);
        const std::vector<double> v = {1.0};
        w.write("x", std::span<const double>(v), {1});
        // An exception would unwind here without commit().
    }
    EXPECT_FALSE(std::filesystem::exists(path));
    EXPECT_FALSE(any_partial_file(path.parent_path()));
}

}  // namespace
}  // namespace plumage::record
