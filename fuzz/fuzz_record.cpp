// HDF5 records as plumage reads them back (virtual_gonio/record/hdf5_file.h; the goniometer resumes
// from them): datasets of every record kind and their attributes (virtual_gonio/RECORD.md).
#include <cstddef>
#include <cstdint>

#include <hdf5.h>

#include "fuzz/fuzz_input.h"
#include "virtual_gonio/record/hdf5_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    // HDF5 prints its whole error stack for every rejected file: silence it (the readers turn
    // the failure into an IoError naming the file), or printing is all the fuzzer measures.
    static const bool quiet = H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr) >= 0;
    (void)quiet;
    const plumage::fuzz::InputFile file(data, size, ".h5");
    for (const char* dataset : {"/brdf/value", "/brdf/standard_error", "/wavelength_nm",
                                "/convergence", "/image/intensity"}) {
        plumage::fuzz::expect_clean_rejection(
            [&] { plumage::record::read_dataset(file.path(), dataset); });
    }
    plumage::fuzz::expect_clean_rejection(
        [&] { plumage::record::read_string_attribute(file.path(), "/provenance", "config"); });
    plumage::fuzz::expect_clean_rejection(
        [&] { plumage::record::read_number_attribute(file.path(), "/provenance", "seed"); });
    return 0;
}
