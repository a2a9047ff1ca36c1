// Mesh import (geometry/mesh_import.h): parsing, the defect checks and the repairs, for the
// format named by PLUMAGE_FUZZ_EXTENSION (".ply" or ".obj"; one executable per format so
// each has its own corpus).
#include <cstddef>
#include <cstdint>

#include "fuzz/fuzz_input.h"
#include "geometry/mesh_import.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const plumage::fuzz::InputFile file(data, size, PLUMAGE_FUZZ_EXTENSION);
    plumage::fuzz::expect_clean_rejection([&] {
        plumage::geometry::MeshImportOptions options;
        options.require_closed = false;  // reach the repairs and checks of open meshes too
        plumage::geometry::import_mesh(file.path(), options);
    });
    return 0;
}
