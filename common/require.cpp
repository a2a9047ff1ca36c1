#include "common/require.h"

#include <fmt/format.h>

#include <string>

#include "common/error.h"

namespace plumage {

void require(bool ok, std::string_view what, std::string_view message) {
    if (!ok) throw InputError(std::string(what) + ": " + std::string(message));
}

void require(bool ok, std::string_view what, std::string_view key, double value,
             std::string_view expected) {
    if (!ok) throw InputError(fmt::format("{}: {} = {}: expected {}", what, key, value, expected));
}

}  // namespace plumage
