#include "common/omp_wait_policy.h"

#include "common/interrupt.h"

#include <climits>
#include <cstdlib>
#include <string>

#include <pthread.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

namespace plumage {

namespace {

// The path of this process's program file, or "" when it cannot be trusted to be the same file:
// no /proc, or the file was replaced or removed since the start (a rebuild). Executing the path,
// not /proc/self/exe, keeps the process's name (ps, top, pgrep show "plumage", not "exe").
std::string own_program_path() {
    char path[PATH_MAX];
    const ssize_t length = ::readlink("/proc/self/exe", path, sizeof path - 1);
    if (length <= 0) return {};
    path[length] = '\0';
    struct stat running {
    }, on_disk{};
    if (::stat("/proc/self/exe", &running) != 0 || ::stat(path, &on_disk) != 0) return {};
    if (running.st_dev != on_disk.st_dev || running.st_ino != on_disk.st_ino) return {};
    return path;
}

}  // namespace

void wait_passively_unless_told(char** argv) {
    // Ctrl-C and SIGTERM are held back from here: a mask outlives exec, so one that arrives
    // during the second start waits, pending, for the new process's handler instead of killing
    // it; and none can slip in between the check of the flag and the exec.
    sigset_t stops;
    sigemptyset(&stops);
    sigaddset(&stops, SIGINT);
    sigaddset(&stops, SIGTERM);
    ::pthread_sigmask(SIG_BLOCK, &stops, nullptr);
    const bool told =
        std::getenv("OMP_WAIT_POLICY") != nullptr || std::getenv("GOMP_SPINCOUNT") != nullptr;
    const std::string program = told || interrupt_requested() ? "" : own_program_path();
    if (!program.empty() && ::setenv("OMP_WAIT_POLICY", "passive", 1) == 0) {
        ::execv(program.c_str(), argv);  // returns only on failure
        ::unsetenv("OMP_WAIT_POLICY");   // as the user had it: this process keeps the default
    }
    ::pthread_sigmask(SIG_UNBLOCK, &stops, nullptr);  // in the new process: delivered now
}

}  // namespace plumage
