#include "common/interrupt.h"

#include <semaphore.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <mutex>
#include <set>
#include <thread>

namespace plumage {
namespace {

std::atomic<bool> g_interrupted{false};
std::atomic<int> g_signal{0};
std::atomic<int> g_signals_seen{0};
struct sigaction g_previous_int, g_previous_term;
// The watchdog sleeps on this semaphore: sem_post is async-signal-safe, a condition
// variable is not.
sem_t g_wake;
std::atomic<bool> g_watchdog_stop{false};
std::thread g_watchdog;

std::mutex g_cleanup_mutex;
std::multiset<std::filesystem::path>& cleanup_paths() {
    static std::multiset<std::filesystem::path> paths;
    return paths;
}

void on_signal(int signal) {
    g_signal.store(signal);
    g_interrupted.store(true);
    g_signals_seen.fetch_add(1);
    sem_post(&g_wake);
}

[[noreturn]] void force_stop(const char* why) {
    const int signal = g_signal.load();
    std::fprintf(stderr,
                 "plumage: interrupted (%s): stopped by force; removing unfinished results "
                 "folders (finished passes stay in their checkpoints)\n",
                 why);
    {
        std::lock_guard lock(g_cleanup_mutex);
        for (const auto& path : cleanup_paths()) {
            std::error_code ignored;
            std::filesystem::remove_all(path, ignored);
        }
    }
    std::fflush(stderr);
    ::_exit(128 + (signal > 0 ? signal : SIGINT));
}

void watchdog() {
    while (true) {
        while (sem_wait(&g_wake) != 0) {
        }
        if (g_watchdog_stop.load()) return;
        if (!g_interrupted.load()) continue;
        // Give the cooperative stop its time, waking early on a second signal or on shutdown.
        const auto deadline = std::chrono::steady_clock::now() + kForcedStopAfter;
        const int seen = g_signals_seen.load();
        while (std::chrono::steady_clock::now() < deadline) {
            if (g_watchdog_stop.load()) return;
            if (g_signals_seen.load() > seen) force_stop("second signal");
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        if (g_watchdog_stop.load()) return;
        force_stop("the running stage did not stop within 1.5 s");
    }
}

}  // namespace

ScopedInterruptHandler::ScopedInterruptHandler() {
    g_interrupted.store(false);
    g_signal.store(0);
    g_signals_seen.store(0);
    g_watchdog_stop.store(false);
    sem_init(&g_wake, 0, 0);
    g_watchdog = std::thread(watchdog);
    struct sigaction action {};
    action.sa_handler = on_signal;
    sigemptyset(&action.sa_mask);
    // Restart interrupted system calls: the flag is polled, nothing waits for EINTR, and a
    // read from a pipe (the plot's interpreter) must not fail half-way because of Ctrl-C.
    action.sa_flags = SA_RESTART;
    sigaction(SIGINT, &action, &g_previous_int);
    sigaction(SIGTERM, &action, &g_previous_term);
}

ScopedInterruptHandler::~ScopedInterruptHandler() {
    sigaction(SIGINT, &g_previous_int, nullptr);
    sigaction(SIGTERM, &g_previous_term, nullptr);
    g_watchdog_stop.store(true);
    sem_post(&g_wake);
    g_watchdog.join();
    sem_destroy(&g_wake);
    // Work done after the handler is gone (the next test, the next library call) must not
    // see a stale request; the signal number stays readable for the exit code.
    g_interrupted.store(false);
}

const std::atomic<bool>& ScopedInterruptHandler::flag() const { return g_interrupted; }
int ScopedInterruptHandler::signal_number() const { return g_signal.load(); }

const std::atomic<bool>& interrupt_flag() { return g_interrupted; }
int interrupt_signal() { return g_signal.load(); }

void request_interrupt(int signal_number) {
    g_signal.store(signal_number);
    g_interrupted.store(true);
}

void throw_if_interrupted(const std::string& stage) {
    if (interrupt_requested()) throw Interrupted("interrupted before " + stage);
}

CleanupRegistration::CleanupRegistration(std::filesystem::path path) : path_(std::move(path)) {
    std::lock_guard lock(g_cleanup_mutex);
    cleanup_paths().insert(path_);
}

CleanupRegistration::~CleanupRegistration() {
    std::lock_guard lock(g_cleanup_mutex);
    const auto it = cleanup_paths().find(path_);
    if (it != cleanup_paths().end()) cleanup_paths().erase(it);
}

}  // namespace plumage
