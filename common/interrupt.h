// Cooperative interruption of long work, with a forced stop as a backstop.
//
// While a ScopedInterruptHandler lives, SIGINT and SIGTERM set one process-wide flag instead
// of killing the process. Long loops poll interrupt_requested() between chunks of work (inside
// OpenMP regions they abandon the remaining chunks; between stages throw_if_interrupted()
// throws Interrupted), so the last completed pass (kept in a checkpoint) survives and the
// results folder being staged is removed by its owner's destructor.
//
// A stage that does not answer within kForcedStopAfter of the signal (a long call inside a
// library, a loop that does not poll) is stopped by force: a watchdog thread removes every
// folder registered with CleanupRegistration (staging folders: never finished results, never
// checkpoints) and ends the process with exit code 128 + signal, saying so on stderr. A second
// signal does the same at once. Checkpoints are written to a temporary name and renamed, so a
// forced stop never leaves one half-written.
#pragma once

#include <atomic>
#include <chrono>
#include <filesystem>

#include "common/error.h"

namespace plumage {

// How long a stage may take to answer an interrupt before it is stopped by force.
inline constexpr std::chrono::milliseconds kForcedStopAfter{1500};

class ScopedInterruptHandler {
public:
    ScopedInterruptHandler();   // installs the handlers, clears the flag, starts the watchdog
    ~ScopedInterruptHandler();  // stops the watchdog, restores the handlers, clears the flag
    ScopedInterruptHandler(const ScopedInterruptHandler&) = delete;
    ScopedInterruptHandler& operator=(const ScopedInterruptHandler&) = delete;
    const std::atomic<bool>& flag() const;
    // Which signal arrived (0: none): the caller exits with 128 + signal.
    int signal_number() const;
};

// The process-wide flag (false when no handler was ever installed): pass its address where an
// instrument takes a `const std::atomic<bool>*`.
const std::atomic<bool>& interrupt_flag();
inline bool interrupt_requested() { return interrupt_flag().load(std::memory_order_relaxed); }
// The last signal that set the flag (kept after the handler is gone, for the exit code).
int interrupt_signal();
// Sets the flag as a signal would (tests; a worker that must stop the run).
void request_interrupt(int signal_number);

// The run was interrupted; the message says what was kept and how to resume.
class Interrupted final : public Error {
public:
    using Error::Error;
};
// Throws Interrupted("interrupted before <stage>") when the flag is set: call it as a stage
// starts.
void throw_if_interrupted(const std::string& stage);

// While it lives, `path` is removed if the process is stopped by force.
class CleanupRegistration {
public:
    explicit CleanupRegistration(std::filesystem::path path);
    ~CleanupRegistration();
    CleanupRegistration(const CleanupRegistration&) = delete;
    CleanupRegistration& operator=(const CleanupRegistration&) = delete;

private:
    std::filesystem::path path_;
};

}  // namespace plumage
