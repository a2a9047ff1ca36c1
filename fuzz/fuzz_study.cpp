// Study files (TOML) through the whole validation `plumage run` applies before any work:
// toml++'s parser, then every key, type, range and cross-key rule of the study kind the file
// names (studies/study.h, check_study). Nothing is built or written.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz/fuzz_input.h"
#include "studies/study.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    plumage::fuzz::expect_clean_rejection(
        [&] { plumage::studies::check_study(text, "fuzz.toml"); });
    return 0;
}
