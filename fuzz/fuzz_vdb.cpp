// OpenVDB level sets as `plumage geometry` reads them (geometry/spongy_volume.h,
// load_level_set): the file, the grid lookup and the checks on class and voxel shape.
#include <cstddef>
#include <cstdint>
#include <mutex>

#include <openvdb/openvdb.h>

#include "fuzz/fuzz_input.h"
#include "geometry/spongy_volume.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
    const plumage::fuzz::InputFile file(data, size, ".vdb");
    plumage::fuzz::expect_clean_rejection(
        [&] { plumage::geometry::load_level_set(file.path(), "keratin"); });
    return 0;
}
