// The typed reader (virtual_gonio/record/hdf5_reader.h) on well-formed files whose objects have the
// wrong class, shape, string kind or size, written with the HDF5 C API as h5py or MATLAB would:
// each is refused with an InputError naming the file, the object and what was found, and none is
// read past its buffer (the sanitized suite runs these).
#include "virtual_gonio/record/hdf5_reader.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <hdf5.h>

#include "common/error.h"
#include "tests/test_util.h"

namespace plumage::record {
namespace {

namespace fs = std::filesystem;

// A scratch file, created empty with a group /g; removed with the test's folder.
class Hdf5ReaderTest : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("plumage_reader_test_" + std::to_string(::getpid()));
        fs::create_directories(dir_);
        path_ =
            dir_ /
            (std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + ".h5");
        file_ = H5Fcreate(path_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
        ASSERT_GE(file_, 0);
        const hid_t g = H5Gcreate2(file_, "/g", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
        H5Gclose(g);
    }
    void TearDown() override {
        if (file_ >= 0) H5Fclose(file_);
        std::error_code ignored;
        fs::remove_all(dir_, ignored);
    }
    // Closes the file for reading.
    const fs::path& written() {
        H5Fclose(file_);
        file_ = -1;
        return path_;
    }
    // An attribute on /g of `type`, `count` elements (0: scalar), from `data`.
    void attribute(const char* name, hid_t type, hsize_t count, const void* data) {
        const hid_t space =
            count == 0 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &count, nullptr);
        const hid_t attr = H5Acreate_by_name(file_, "/g", name, type, space, H5P_DEFAULT,
                                             H5P_DEFAULT, H5P_DEFAULT);
        ASSERT_GE(attr, 0);
        ASSERT_GE(H5Awrite(attr, type, data), 0);
        H5Aclose(attr);
        H5Sclose(space);
    }
    static hid_t variable_string() {
        const hid_t t = H5Tcopy(H5T_C_S1);
        H5Tset_size(t, H5T_VARIABLE);
        H5Tset_cset(t, H5T_CSET_UTF8);
        return t;
    }
    static hid_t fixed_string(std::size_t size) {
        const hid_t t = H5Tcopy(H5T_C_S1);
        H5Tset_size(t, size);
        return t;
    }

    fs::path dir_, path_;
    hid_t file_ = -1;
};

// The message of the InputError `f` throws.
template <typename F>
std::string refusal(F&& f) {
    return plumage::testing::input_error_message(std::forward<F>(f));
}

TEST_F(Hdf5ReaderTest, ReadsScalarAndOneElementStringsOfEitherKind) {
    const hid_t v = variable_string(), fx = fixed_string(6);
    const char* text = "beam";
    attribute("variable", v, 0, &text);
    attribute("one_element", v, 1, &text);
    attribute("fixed", fx, 0, "cone\0\0");
    H5Tclose(v);
    H5Tclose(fx);
    const Hdf5Reader r(written());
    EXPECT_EQ(r.string_attribute("/g", "variable"), "beam");
    EXPECT_EQ(r.string_attribute("/g", "one_element"), "beam");
    EXPECT_EQ(r.string_attribute("/g", "fixed"), "cone");
}

TEST_F(Hdf5ReaderTest, StringArraysAreRefusedByName) {
    const hid_t v = variable_string(), fx = fixed_string(21);
    std::vector<const char*> texts(1000, "imaging_scatterometer");
    std::string fixed;
    for (int i = 0; i < 1000; ++i) fixed += "imaging_scatterometer";
    attribute("variable_array", v, 1000, texts.data());
    attribute("fixed_array", fx, 1000, fixed.data());
    H5Tclose(v);
    H5Tclose(fx);
    const Hdf5Reader r(written());
    const std::string a = refusal([&] { r.string_attribute("/g", "variable_array"); });
    EXPECT_NE(a.find("/g@variable_array"), std::string::npos) << a;
    EXPECT_NE(a.find("variable-length string array [1000]"), std::string::npos) << a;
    EXPECT_NE(a.find(path_.string()), std::string::npos) << a;
    const std::string b = refusal([&] { r.string_attribute("/g", "fixed_array"); });
    EXPECT_NE(b.find("fixed-length string of 21 bytes array [1000]"), std::string::npos) << b;
    // Neither is a number either.
    EXPECT_NE(refusal([&] { r.number_attribute("/g", "fixed_array"); }).find("expected one number"),
              std::string::npos);
}

TEST_F(Hdf5ReaderTest, NumberArraysAndWrongClassesAreRefused) {
    const std::vector<double> values(4096, 16.0);
    attribute("aperture", H5T_NATIVE_DOUBLE, 4096, values.data());
    const double one = 16.0;
    attribute("scalar", H5T_NATIVE_DOUBLE, 0, &one);
    const std::int64_t negative = -3;
    attribute("negative", H5T_NATIVE_INT64, 0, &negative);
    const hid_t v = variable_string();
    const char* text = "16";
    attribute("text", v, 0, &text);
    H5Tclose(v);
    const Hdf5Reader r(written());
    EXPECT_EQ(r.number_attribute("/g", "scalar"), 16.0);
    const std::string a = refusal([&] { r.number_attribute("/g", "aperture"); });
    EXPECT_NE(a.find("64-bit float array [4096]; expected one number"), std::string::npos) << a;
    EXPECT_NE(refusal([&] { r.number_attribute("/g", "text"); }).find("variable-length string"),
              std::string::npos);
    EXPECT_NE(refusal([&] { r.unsigned_attribute("/g", "negative"); }).find("non-negative"),
              std::string::npos);
    EXPECT_NE(refusal([&] { r.unsigned_attribute("/g", "scalar"); }).find("64-bit float"),
              std::string::npos);
    EXPECT_NE(refusal([&] { r.number_attribute("/g", "absent"); }).find("/g@absent: missing"),
              std::string::npos);
    EXPECT_NE(refusal([&] { r.number_attribute("/nowhere", "x"); }).find("/nowhere"),
              std::string::npos);
}

TEST_F(Hdf5ReaderTest, HugeDeclaredDatasetsAreRefusedBeforeAllocation) {
    // 30 000 × 4096 values declared in 4096-value chunks, none written: 0 bytes on disk.
    const hsize_t dims[1] = {30000 * 4096ULL}, chunk[1] = {4096};
    const hid_t space = H5Screate_simple(1, dims, nullptr);
    const hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(plist, 1, chunk);
    const hid_t d =
        H5Dcreate2(file_, "/huge", H5T_IEEE_F64LE, space, H5P_DEFAULT, plist, H5P_DEFAULT);
    ASSERT_GE(d, 0);
    H5Dclose(d);
    H5Pclose(plist);
    H5Sclose(space);
    const Hdf5Reader r(written());
    const std::string a = refusal([&] { r.dataset("/huge"); });
    EXPECT_NE(a.find("/huge"), std::string::npos) << a;
    EXPECT_NE(a.find("122880000 values; expected at most"), std::string::npos) << a;
    // The caller's own, smaller limit and rank are named too.
    EXPECT_NE(refusal([&] {
                  r.shape("huge", {1, 4701});
              }).find("at most 4701 values"),
              std::string::npos);
    EXPECT_NE(refusal([&] { r.shape("huge", {2}); }).find("expected an array of 2 dimensions"),
              std::string::npos);
}

TEST_F(Hdf5ReaderTest, GroupsStringsAndExternalLinksAreNotDatasets) {
    const hsize_t two = 2;
    const hid_t space = H5Screate_simple(1, &two, nullptr);
    const hid_t v = variable_string();
    const hid_t d = H5Dcreate2(file_, "/names", v, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const char* texts[2] = {"500", "600"};
    ASSERT_GE(H5Dwrite(d, v, H5S_ALL, H5S_ALL, H5P_DEFAULT, texts), 0);
    H5Dclose(d);
    H5Tclose(v);
    H5Sclose(space);
    ASSERT_GE(H5Lcreate_external("/etc/elsewhere.h5", "/data", file_, "/linked", H5P_DEFAULT,
                                 H5P_DEFAULT),
              0);
    ASSERT_GE(H5Lcreate_soft("/no/such/object", file_, "/dangling", H5P_DEFAULT, H5P_DEFAULT), 0);
    const Hdf5Reader r(written());
    EXPECT_NE(refusal([&] { r.dataset("/g"); }).find("found a group"), std::string::npos);
    EXPECT_NE(refusal([&] { r.dataset("/names"); }).find("expected an array of numbers"),
              std::string::npos);
    EXPECT_NE(refusal([&] { r.dataset("/linked"); }).find("/linked: missing"), std::string::npos);
    EXPECT_NE(refusal([&] { r.dataset("/dangling"); }).find("/dangling: missing"),
              std::string::npos);
    EXPECT_FALSE(r.has_object("/linked"));
    EXPECT_EQ(r.dataset_paths(), std::vector<std::string>{"names"});
}

TEST_F(Hdf5ReaderTest, NotAnHdf5FileIsBadInput) {
    const fs::path text = dir_ / "text.h5";
    { std::ofstream(text) << "not hdf5\n"; }
    EXPECT_NE(refusal([&] { Hdf5Reader r(text); }).find("cannot be opened as HDF5"),
              std::string::npos);
    EXPECT_NE(refusal([&] { Hdf5Reader r(dir_ / "absent.h5"); }).find("no such file"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::record
