// The memory a run may use, and the check every stage makes before it allocates what its
// validated inputs imply (a grid, a volume, a table): refused with the key, the value, the
// estimate and the limit, before any work, instead of running until memory is gone.
//
// The limit is the smallest of: the machine's physical memory (/proc/meminfo MemTotal), the
// control group's memory.max (cgroup v2) or memory.limit_in_bytes (v1), and RLIMIT_AS; the
// environment variable PLUMAGE_MEMORY_LIMIT_GB (a positive number of GB, 1e9 bytes) lowers or
// raises it for one run.
#pragma once

#include <cstdint>
#include <string>

namespace plumage {

struct MemoryLimit {
    std::uint64_t bytes = 0;
    std::string source;  // where it came from, for messages ("the machine's memory", ...)
};

// Read once per process (InputError if PLUMAGE_MEMORY_LIMIT_GB is set but not a number > 0).
const MemoryLimit& memory_limit();

// InputError "<what>: needs an estimated X GB, over the memory limit Y GB (<source>)" when
// `estimate_bytes` exceeds the limit; `what` names the key and value that set the size.
void require_memory(double estimate_bytes, const std::string& what);

}  // namespace plumage
