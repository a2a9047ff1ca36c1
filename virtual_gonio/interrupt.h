// Cooperative interruption of long measurements. While a ScopedInterruptHandler lives,
// SIGINT and SIGTERM set a flag instead of killing the process; instruments poll it
// between chunks of work, discard the unfinished pass and return, so the last
// completed pass (kept in the checkpoint) survives and nothing half-written appears.
#pragma once

#include <atomic>

namespace plumage::gonio {

class ScopedInterruptHandler {
public:
    ScopedInterruptHandler();   // installs the handlers, clears the flag
    ~ScopedInterruptHandler();  // restores the previous handlers
    ScopedInterruptHandler(const ScopedInterruptHandler&) = delete;
    ScopedInterruptHandler& operator=(const ScopedInterruptHandler&) = delete;
    const std::atomic<bool>& flag() const;
    // Which signal arrived (0: none): the caller exits with 128 + signal.
    int signal_number() const;
};

}  // namespace plumage::gonio
