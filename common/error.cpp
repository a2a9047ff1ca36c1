#include "common/error.h"

namespace plumage {

void throw_invariant(const char* condition, const char* file, int line, const std::string& detail) {
    throw InvariantError(std::string("internal check failed: ") + condition + " at " + file + ":" +
                         std::to_string(line) + (detail.empty() ? "" : ": " + detail));
}

}  // namespace plumage
