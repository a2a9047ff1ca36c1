// What every fuzz target shares: the input as a file where a reader wants a path, and the rule
// for what a reader may throw.
//
// A reader fed arbitrary bytes may reject them only with plumage::InputError or IoError (a
// message naming the file and what was expected). Anything else — another exception (an
// InvariantError, std::bad_alloc from a size read out of the file, a third-party library's
// exception type leaking out), a crash, undefined behaviour, a leak or a hang — is a finding:
// the exception escapes LLVMFuzzerTestOneInput and the process aborts.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "common/error.h"

namespace plumage::fuzz {

// The input written to a file of this process (one per target and extension), removed when
// the holder goes. Readers that dispatch on the extension get the one they are fuzzed for.
class InputFile {
public:
    InputFile(const std::uint8_t* data, std::size_t size, std::string_view extension)
        : path_(std::filesystem::temp_directory_path() /
                ("plumage_fuzz_" + std::to_string(::getpid()) + std::string(extension))) {
        std::ofstream out(path_, std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    }
    ~InputFile() {
        std::error_code ignored;
        std::filesystem::remove(path_, ignored);
    }
    InputFile(const InputFile&) = delete;
    InputFile& operator=(const InputFile&) = delete;
    const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
};

// Runs f; a rejection by InputError or IoError is an answer, not a finding.
template <typename F>
void expect_clean_rejection(F&& f) {
    try {
        f();
    } catch (const InputError&) {
    } catch (const IoError&) {
    }
}

}  // namespace plumage::fuzz
