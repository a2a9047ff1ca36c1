// Measured BRDFs in the RGL tensor layout as plumage reads them (virtual_gonio/rgl_bsdf.h,
// RglBsdf::read): the tensor container, the fields' names, dtypes, shapes and values, the
// warps built on them, and one evaluation per hemisphere octant.
#include <cstddef>
#include <cstdint>

#include "fuzz/fuzz_input.h"
#include "virtual_gonio/rgl_bsdf.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const plumage::fuzz::InputFile file(data, size, ".bsdf");
    plumage::fuzz::expect_clean_rejection([&] {
        const auto bsdf = plumage::gonio::RglBsdf::read(file.path());
        for (int k = 0; k < 8; ++k) {
            const plumage::Vec3d wi((k & 1) ? 0.3 : -0.3, (k & 2) ? 0.4 : -0.4, 0.866);
            const plumage::Vec3d wo((k & 4) ? 0.5 : -0.1, -0.2, 0.84);
            (void)bsdf.eval(wi.normalized(), wo.normalized(), 550.0);
            (void)bsdf.pdf_mitsuba(wi.normalized(), wo.normalized());
        }
    });
    return 0;
}
