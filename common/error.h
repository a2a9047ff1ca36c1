// Error kinds of Plumage, one type each (after OpenVDB's Exceptions.h and pbrt's
// util/check.h):
//  - InputError: something a user gave us is wrong (a value, a key, a file). The
//    message names the offending item and what was expected.
//  - InvariantError: a condition the code itself guarantees was broken (a bug);
//    raised by PLUMAGE_CHECK, which stays on in Release builds.
//  - IoError: the operating system or a file library refused (disk full, no such
//    directory, HDF5 failure).
#pragma once

#include <stdexcept>
#include <string>

namespace plumage {

class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

class InputError final : public Error {
public:
    using Error::Error;
};

class InvariantError final : public Error {
public:
    using Error::Error;
};

class IoError final : public Error {
public:
    using Error::Error;
};

[[noreturn]] void throw_invariant(const char* condition, const char* file, int line,
                                  const std::string& detail);

}  // namespace plumage

// Always-on invariant check: cheap conditions that guard physics (finite, in range).
#define PLUMAGE_CHECK(condition, detail)                                          \
    do {                                                                          \
        if (!(condition)) [[unlikely]]                                            \
            ::plumage::throw_invariant(#condition, __FILE__, __LINE__, (detail)); \
    } while (false)
