#include "common/memory_limit.h"

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage {
namespace {

// The first number of a one-line file ("max" or a missing file: none).
std::uint64_t number_in(const char* path) {
    std::ifstream in(path);
    std::uint64_t value = 0;
    if (in >> value) return value;
    return 0;
}

std::uint64_t physical_memory() {
    std::ifstream in("/proc/meminfo");
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream fields(line);
        std::string key;
        std::uint64_t kib = 0;
        if (fields >> key >> kib && key == "MemTotal:") return kib * 1024;
    }
    return 0;
}

MemoryLimit read_limit() {
    MemoryLimit limit{std::numeric_limits<std::uint64_t>::max(), "no limit found"};
    const auto lower = [&limit](std::uint64_t bytes, const char* source) {
        if (bytes > 0 && bytes < limit.bytes) limit = {bytes, source};
    };
    lower(physical_memory(), "the machine's memory");
    lower(number_in("/sys/fs/cgroup/memory.max"), "the control group's memory.max");
    lower(number_in("/sys/fs/cgroup/memory/memory.limit_in_bytes"),
          "the control group's memory limit");
    rlimit address_space{};
    if (::getrlimit(RLIMIT_AS, &address_space) == 0 && address_space.rlim_cur != RLIM_INFINITY)
        lower(address_space.rlim_cur, "the address-space limit (ulimit -v)");
    if (const char* text = std::getenv("PLUMAGE_MEMORY_LIMIT_GB"); text != nullptr) {
        char* end = nullptr;
        const double gb = std::strtod(text, &end);
        if (end == text || *end != '\0' || !(gb > 0.0 && gb < 1e9)) {
            throw InputError(
                fmt::format("PLUMAGE_MEMORY_LIMIT_GB = '{}': expected a number of GB > 0", text));
        }
        limit = {static_cast<std::uint64_t>(gb * 1e9), "PLUMAGE_MEMORY_LIMIT_GB"};
    }
    return limit;
}

}  // namespace

const MemoryLimit& memory_limit() {
    static const MemoryLimit limit = read_limit();
    return limit;
}

void require_memory(double estimate_bytes, const std::string& what) {
    const MemoryLimit& limit = memory_limit();
    if (!(estimate_bytes <= static_cast<double>(limit.bytes))) {
        throw InputError(fmt::format(
            "{}: needs an estimated {:.3g} GB of memory, over the limit of {:.3g} GB ({}; "
            "PLUMAGE_MEMORY_LIMIT_GB sets another)",
            what, estimate_bytes / 1e9, static_cast<double>(limit.bytes) / 1e9, limit.source));
    }
}

}  // namespace plumage
