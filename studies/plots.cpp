#include "studies/plots.h"

#include <sys/wait.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>

#include <fmt/format.h>

#include "common/error.h"
#include "studies/plots_script.h"

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

bool run_plot(const std::string& kind, const std::filesystem::path& input,
              const std::filesystem::path& png) {
    if (!plots_enabled()) return false;
    if (const std::string problem = plotting_problem(python_interpreter()); !problem.empty()) {
        warn(fmt::format("{} not drawn: {}", png.filename().string(), problem));
        return false;
    }
    const std::string command =
        fmt::format("{} - {} {} {}", shell_quote(python_interpreter()), shell_quote(kind),
                    shell_quote(input.string()), shell_quote(png.string()));
    FILE* pipe = ::popen(command.c_str(), "w");
    if (pipe == nullptr) {
        warn(fmt::format("{} not drawn: cannot start {}", png.filename().string(),
                         python_interpreter()));
        return false;
    }
    const std::size_t length = std::strlen(kPlotsScript);
    const bool written = std::fwrite(kPlotsScript, 1, length, pipe) == length;
    const int status = ::pclose(pipe);
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
