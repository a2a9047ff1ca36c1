#include "studies/plots.h"

#include <sys/wait.h>

#include <cstdio>
#include <cstring>
#include <fstream>

#include <fmt/format.h>

#include "common/error.h"
#include "studies/plots_script.h"

namespace plumage::studies {
namespace {

constexpr const char* kPython = "/usr/bin/python3";

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

}  // namespace

void run_plot(const std::string& kind, const std::filesystem::path& input,
              const std::filesystem::path& png) {
    const std::string command = fmt::format("{} - {} {} {}", kPython, shell_quote(kind),
                                            shell_quote(input.string()), shell_quote(png.string()));
    FILE* pipe = ::popen(command.c_str(), "w");
    if (pipe == nullptr) throw IoError(fmt::format("cannot start {} for plotting", kPython));
    const std::size_t length = std::strlen(kPlotsScript);
    const bool written = std::fwrite(kPlotsScript, 1, length, pipe) == length;
    const int status = ::pclose(pipe);
    if (!written || status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        throw IoError(fmt::format(
            "plot '{}' of {} failed (exit status {}): plotting needs {} with matplotlib, numpy "
            "and h5py (Debian packages python3-matplotlib python3-numpy python3-h5py; "
            "scripts/install-deps.sh installs them)",
            kind, input.string(), WIFEXITED(status) ? WEXITSTATUS(status) : -1, kPython));
    }
}

void run_plots(const std::vector<PlotJob>& jobs, const std::filesystem::path& job_list) {
    if (jobs.empty()) return;
    auto quoted = [](const std::string& s) {
        std::string q = "\"";
        for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
        return q + "\"";
    };
    {
        std::ofstream out(job_list);
        out << "kind,input,png\n";
        for (const PlotJob& j : jobs) out << quoted(j.kind) << ',' << quoted(j.input.string()) << ',' << quoted(j.png.string()) << '\n';
        if (!out) throw IoError(fmt::format("cannot write the plot list {}", job_list.string()));
    }
    run_plot("batch", job_list, jobs.front().png);
}

}  // namespace plumage::studies
