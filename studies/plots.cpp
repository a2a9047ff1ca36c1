#include "studies/plots.h"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <thread>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common/error.h"
#include "common/interrupt.h"
#include "studies/plots_script.h"

extern char** environ;

namespace plumage::studies {
namespace {

std::atomic<bool> g_plots_enabled{true};

std::string shell_quote(const std::string& s) {
    std::string quoted = "'";
    for (char c : s) {
        if (c == '\'') {
            quoted += "'\\''";
        } else {
            quoted += c;
        }
    }
    return quoted + "'";
}

// Why plots cannot be drawn with this interpreter (empty: they can). Asked once per
// interpreter and process: the answer names the interpreter or the missing modules, which a
// failed plot's exit status cannot.
std::string plotting_problem(const std::string& python) {
    static std::mutex mutex;
    static std::map<std::string, std::string> answers;
    const std::lock_guard lock(mutex);
    if (const auto known = answers.find(python); known != answers.end()) return known->second;
    const std::string probe =
        fmt::format("{} -c {} 2>/dev/null", shell_quote(python),
                    shell_quote("import importlib.util as u\n"
                                "print(' '.join(m for m in ('matplotlib', 'numpy', 'h5py') "
                                "if u.find_spec(m) is None) or 'ok')"));
    std::string answer;
    if (FILE* pipe = ::popen(probe.c_str(), "r"); pipe != nullptr) {
        char buffer[256];
        while (std::fgets(buffer, sizeof buffer, pipe) != nullptr) answer += buffer;
        ::pclose(pipe);
    }
    while (!answer.empty() && (answer.back() == '\n' || answer.back() == ' ')) answer.pop_back();
    std::string problem;
    if (answer.empty()) {
        problem = fmt::format(
            "cannot run the interpreter {} (set PLUMAGE_PYTHON to a Python 3 "
            "with matplotlib, numpy and h5py)",
            python);
    } else if (answer != "ok") {
        problem = fmt::format(
            "{} lacks the module(s) {} (Debian: python3-matplotlib "
            "python3-numpy python3-h5py; scripts/install-deps.sh installs them, "
            "or set PLUMAGE_PYTHON)",
            python, answer);
    }
    return answers[python] = problem;
}

void warn(const std::string& what) { std::cerr << "plumage: warning: " << what << '\n'; }

}  // namespace

std::string python_interpreter() {
    const char* chosen = std::getenv("PLUMAGE_PYTHON");
    return chosen != nullptr && *chosen != '\0' ? chosen : "/usr/bin/python3";
}

void set_plots_enabled(bool enabled) { g_plots_enabled.store(enabled); }
bool plots_enabled() { return g_plots_enabled.load(); }

namespace {

// Kills the plotter and reaps it: SIGTERM, then SIGKILL if it has not gone within 0.3 s.
void stop_child(pid_t pid) {
    ::kill(pid, SIGTERM);
    for (int i = 0; i < 30; ++i) {
        if (::waitpid(pid, nullptr, WNOHANG) == pid) return;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ::kill(pid, SIGKILL);
    ::waitpid(pid, nullptr, 0);
}

// How long one plotter may run: PLUMAGE_PLOT_TIMEOUT_S (seconds > 0), default 600 (the default
// study's batch of figures takes about 30 s). A plotter that never returns (a hung backend, a
// stuck file system) is stopped then and its plot counts as failed: the run goes on and keeps its
// records and report, instead of blocking for ever.
double plot_timeout_s() {
    const char* text = std::getenv("PLUMAGE_PLOT_TIMEOUT_S");
    if (text == nullptr) return 600.0;
    char* end = nullptr;
    const double seconds = std::strtod(text, &end);
    if (end == text || *end != '\0' || !(seconds > 0.0)) {
        throw InputError(
            fmt::format("PLUMAGE_PLOT_TIMEOUT_S = '{}': expected a number of seconds > 0", text));
    }
    return seconds;
}

// Runs the interpreter with the embedded script on its standard input and waits for it,
// polling the interrupt flag: on Ctrl-C or SIGTERM the plotter is stopped at once and
// Interrupted is thrown, so the plot stage stops as promptly as any other (popen's pclose
// would wait for the plotter, which the signal to plumage alone does not reach, and leave
// it running after the watchdog's forced exit). Returns whether the whole script was
// written; `status` receives waitpid's status, and -2 when the plotter was stopped after
// plot_timeout_s().
bool run_plotter(const std::vector<std::string>& args, const std::filesystem::path& png,
                 int& status) {
    const double timeout_s = plot_timeout_s();
    // A plotter that dies before reading its script must not take plumage with it.
    std::signal(SIGPIPE, SIG_IGN);
    int fds[2];
    if (::pipe(fds) != 0)
        throw IoError(fmt::format("{} not drawn: cannot open a pipe", png.string()));
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[0], STDIN_FILENO);
    posix_spawn_file_actions_addclose(&actions, fds[0]);
    posix_spawn_file_actions_addclose(&actions, fds[1]);
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    pid_t pid = 0;
    const int spawned = ::posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(fds[0]);
    if (spawned != 0) {
        ::close(fds[1]);
        status = -1;
        return false;
    }
    const std::size_t length = std::strlen(kPlotsScript);
    std::size_t done = 0;
    while (done < length) {
        const ssize_t n = ::write(fds[1], kPlotsScript + done, length - done);
        if (n <= 0) break;
        done += static_cast<std::size_t>(n);
    }
    ::close(fds[1]);
    const auto start = std::chrono::steady_clock::now();
    while (::waitpid(pid, &status, WNOHANG) == 0) {
        if (interrupt_requested()) {
            stop_child(pid);
            throw Interrupted("interrupted while drawing " + png.filename().string());
        }
        if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >
            timeout_s) {
            stop_child(pid);
            status = -2;
            return false;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return done == length;
}

}  // namespace

bool run_plot(const std::string& kind, const std::filesystem::path& input,
              const std::filesystem::path& png) {
    if (!plots_enabled()) return false;
    if (const std::string problem = plotting_problem(python_interpreter()); !problem.empty()) {
        warn(fmt::format("{} not drawn: {}", png.filename().string(), problem));
        return false;
    }
    int status = -1;
    const bool written =
        run_plotter({python_interpreter(), "-", kind, input.string(), png.string()}, png, status);
    if (status == -2) {
        warn(
            fmt::format("plot '{}' of {} stopped after {:g} s (PLUMAGE_PLOT_TIMEOUT_S); the "
                        "records and the report are kept",
                        kind, input.string(), plot_timeout_s()));
        return false;
    }
    if (!written || status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        warn(
            fmt::format("plot '{}' of {} failed (exit status {}; its message is above); the "
                        "records and the report are kept",
                        kind, input.string(), WIFEXITED(status) ? WEXITSTATUS(status) : -1));
        return false;
    }
    return true;
}

bool run_plots(const std::vector<PlotJob>& jobs, const std::filesystem::path& job_list) {
    if (jobs.empty() || !plots_enabled()) return false;
    auto quoted = [](const std::string& s) {
        std::string q = "\"";
        for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
        return q + "\"";
    };
    {
        std::ofstream out(job_list);
        out << "kind,input,png\n";
        for (const PlotJob& j : jobs) {
            out << quoted(j.kind) << ',' << quoted(j.input.string()) << ','
                << quoted(j.png.string()) << '\n';
        }
        if (!out) throw IoError(fmt::format("cannot write the plot list {}", job_list.string()));
    }
    return run_plot("batch", job_list, jobs.front().png);
}

}  // namespace plumage::studies
