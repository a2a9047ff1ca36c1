// The plumage command line. With no arguments it runs the default study.
//
// Exit codes: 0 done, 1 failed, 2 bad input (nothing was written), 128 + signal when
// interrupted (130 for Ctrl-C, 143 for SIGTERM).
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <random>
#include <sstream>
#include <thread>

#include <sys/resource.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "common/build_info.h"
#include "common/distributed.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/memory_limit.h"
#include "common/omp_wait_policy.h"
#include "common/spelling.h"
#include "common/version.h"
#include "studies/bsdf_export.h"
#include "studies/default_study.h"
#include "studies/fit_command.h"
#include "studies/geometry_study.h"
#include "studies/plots.h"
#include "studies/staged_directory.h"
#include "studies/study.h"
#include "studies/thin_film_chart.h"

namespace {

namespace fs = std::filesystem;
namespace st = plumage::studies;

// Options that work before and after any subcommand (`plumage --out D run F` and
// `plumage run F --out D`), listed in every subcommand's --help.
struct CommonOptions {
    int threads = 0;
    std::string output = "results";
    st::RunLimits limits;
    bool no_plots = false;
};

// A number in [lo, hi] (lo excluded when `above`); NaN and infinities refused (CLI11's
// PositiveNumber and Range let NaN through: every comparison with it is false).
CLI::Validator finite_in(const char* option, double lo, double hi, const char* expected,
                         bool above) {
    return CLI::Validator(
        [=](std::string& value) -> std::string {
            double v = 0.0;
            if (!CLI::detail::lexical_cast(value, v) || !std::isfinite(v) || v < lo || v > hi ||
                (above && v == lo)) {
                return fmt::format("{} {}: expected {}", option, value, expected);
            }
            return {};
        },
        "");
}

void add_common_options(CLI::App& app, CommonOptions& o) {
    app.add_option("--threads", o.threads, "worker threads (default 0: all cores)")
        ->type_name("N")
        ->check(CLI::Validator(
            [](std::string& value) -> std::string {
                int n = -1;
                if (!CLI::detail::lexical_cast(value, n) || n < 0 || n > 4096) {
                    return fmt::format(
                        "'{}': expected a whole number of threads from 1 to 4096, "
                        "or 0 for all cores",
                        value);
                }
                return {};
            },
            "0-4096"));
    app.add_option("--out", o.output, "results root folder (default: results)")->type_name("DIR");
    app.add_option("--time-budget", o.limits.time_budget_s,
                   "wall-time budget in seconds for each progressive measurement of a study")
        ->type_name("SECONDS")
        ->check(finite_in("--time-budget", 0.0, 1e12, "a number of seconds > 0", true));
    app.add_option("--target-error", o.limits.target_relative_error,
                   "stop each measurement once its estimated relative RMS error is below this "
                   "(e.g. 0.05)")
        ->type_name("FRACTION")
        ->check(finite_in("--target-error", 0.0, 1.0, "a fraction in [0, 1]", false));
    app.add_flag("--no-plots", o.no_plots,
                 "skip the matplotlib figures (records and reports stay)");
}

std::string read_file(const std::string& path, std::string_view what) {
    std::ifstream in(path);
    if (!in)
        throw plumage::InputError(
            fmt::format("{}: cannot open the {} (does it exist?)", path, what));
    std::ostringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
}

// After CLI11's own message: for each argument that is neither an option, a subcommand nor a
// file, the nearest option or subcommand name within two edits.
void suggest(const CLI::App& app, int argc, char** argv) {
    std::vector<std::string> names;
    for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
        names.push_back(sub->get_name());
    }
    std::vector<std::string> subcommands = names, taking_values;
    for (const CLI::Option* option : app.get_options()) {
        for (const std::string& long_name : option->get_lnames()) {
            names.push_back("--" + long_name);
            if (option->get_type_size() > 0) taking_values.push_back("--" + long_name);
        }
    }
    for (int i = 1; i < argc; ++i) {
        std::string arg = argv[i];
        if (arg.rfind("--", 0) == 0) arg = arg.substr(0, arg.find('='));
        // The value of an option ("--time-budget nan") is no misspelt subcommand.
        if (arg == argv[i] &&
            std::find(taking_values.begin(), taking_values.end(), arg) != taking_values.end()) {
            ++i;
            continue;
        }
        const bool known = std::find(names.begin(), names.end(), arg) != names.end();
        if (known || (arg.rfind("-", 0) != 0 && fs::exists(arg))) continue;
        const auto& pool = arg.rfind("-", 0) == 0 ? names : subcommands;
        const std::string best = plumage::nearest_name(arg, pool);
        if (!best.empty())
            std::cerr << fmt::format("plumage: '{}': did you mean '{}'?\n", arg, best);
    }
}

std::string run_thin_film(st::ThinFilmChartOptions options) {
    const auto result = st::run_thin_film_chart(options);
    std::string summary =
        fmt::format("plumage: wrote {} in {:.1f} s (report: {})\n", result.output_dir.string(),
                    result.wall_seconds, (result.output_dir / "report.md").string());
    for (const auto& c : result.normal_incidence) {
        summary += fmt::format("  {} nm film{}: L*a*b* = ({:.1f}, {:.1f}, {:.1f}), hue {:.0f}°\n",
                               c.thickness_nm, c.with_melanin_background ? " + melanin" : "",
                               c.lab.l, c.lab.a, c.lab.b, c.hue_deg);
    }
    return summary;
}

std::string run_geometry(const std::string& file, const CommonOptions& o) {
    st::refuse_limits("geometry", o.limits, "building geometry is not a measurement");
    const auto r = st::run_geometry_study(file, o.output);
    return fmt::format(
        "plumage: wrote {} ({}: {} triangles, {} instances, {:.2f} MB) in {:.1f} s\n",
        r.output_dir.string(), r.kind, r.triangles, r.instances,
        static_cast<double>(r.memory_bytes) / 1e6, r.wall_seconds);
}

// `plumage fit`: --start NAME=VALUE pairs into the command.
// `plumage fit --strict`: the exit code when the fit warns (its results are written all the
// same); 1 and 2 are failures and bad input, 128 + n a signal.
constexpr int kFitWarnedExitCode = 3;

std::string run_fit(st::FitCommand command, const std::vector<std::string>& starts,
                    const CommonOptions& o, bool strict, int& exit_code) {
    st::refuse_limits("fit", o.limits, "a fit is not a progressive measurement");
    for (const std::string& s : starts) {
        const auto eq = s.find('=');
        double value = 0.0;
        if (eq == std::string::npos || !CLI::detail::lexical_cast(s.substr(eq + 1), value)) {
            throw plumage::InputError(
                fmt::format("--start {}: expected NAME=VALUE, e.g. --start d_um=0.55", s));
        }
        command.start[s.substr(0, eq)] = value;
    }
    const auto r = st::run_fit_command(command, o.output);
    std::string summary =
        fmt::format("plumage: wrote {}: chi2/dof {:.4g} over {} observations\n",
                    r.output_dir.string(), r.summary.reduced_chi_square, r.summary.observations);
    for (const std::string& w : r.summary.warnings) {
        std::cerr << "plumage fit: WARNING: " << w << "\n";
        if (strict) exit_code = kFitWarnedExitCode;
    }
    for (const auto& p : r.summary.parameters) {
        if (!p.fixed)
            summary += fmt::format("  {} = {:.6g} ± {:.3g} {}\n", p.name, p.value, p.sigma, p.unit);
    }
    return summary;
}

// `plumage export-bsdf`: beside its source, or where -o says; under --out when that is given, as
// every subcommand writes (the files inside it, a relative -o inside it too). A folder made for
// --out is removed again when the export fails (nothing is written on bad input).
std::string run_bsdf_export(st::BsdfExportOptions o, const CommonOptions& common, bool out_given) {
    st::refuse_limits("export-bsdf", common.limits, "an export tabulates a model exactly");
    std::vector<fs::path> made;  // deepest first
    if (out_given) {
        if (o.output.is_absolute()) {
            throw plumage::InputError(fmt::format(
                "--out {} with -o {}: an absolute -o cannot be under --out; give -o relative to "
                "--out (or leave out one of them)",
                common.output, o.output.string()));
        }
        const fs::path root = common.output;
        for (fs::path p = root; !p.empty() && !fs::exists(p); p = p.parent_path())
            made.push_back(p);
        fs::create_directories(root);
        o.output = o.output.empty() ? root : root / o.output;
    }
    st::BsdfExportResult r;
    try {
        r = st::export_bsdf(o);
    } catch (...) {
        std::error_code ignored;  // removes only empty folders
        for (const fs::path& p : made) fs::remove(p, ignored);
        throw;
    }
    std::string summary;
    for (const fs::path& f : r.files) summary += fmt::format("plumage: wrote {}\n", f.string());
    return summary +
           fmt::format("plumage: {} file(s) in {:.1f} s\n", r.files.size(), r.wall_seconds);
}

// The command line: options, subcommands and what they were given.
struct CommandLine {
    CLI::App app{
        "Plumage: light scattering by bird-feather microstructures.\n"
        "With no subcommand, runs the default study: explicit rock-dove barbules against\n"
        "Huang et al. 2022 (studies/rock_dove.toml), into results/rock_dove/.\n"
        "Exit codes: 0 done, 1 failed, 2 bad input (nothing written), 130 interrupted."};
    CommonOptions common;
    st::ThinFilmChartOptions thin_film;
    std::string run_file, geometry_file;
    st::FitCommand fit;
    std::vector<std::string> fit_starts;
    bool fit_strict = false;
    int exit_code = 0;  // of a command that succeeded but asks for attention (fit --strict)
    std::string fit_data;
    CLI::App *thin_film_cmd = nullptr, *run_cmd = nullptr, *geometry_cmd = nullptr,
             *fit_cmd = nullptr;
    st::BsdfExportOptions bsdf;
    CLI::App* bsdf_cmd = nullptr;

    CommandLine() {
        // The commit too: what a record's /provenance@git_commit will say.
        app.set_version_flag("--version", fmt::format("plumage {} (git {})", plumage::kVersion,
                                                      plumage::git_commit()));
        add_common_options(app, common);
        thin_film_cmd = app.add_subcommand(
            "thin-film",
            "Huang 2022 Figs. 3 and 5: keratin film colour chart and rock-dove spectra");
        thin_film_cmd->add_option("--thickness-step-nm", thin_film.thickness_step_nm)
            ->capture_default_str()
            ->check(CLI::Range(0.01, 100.0));
        thin_film_cmd->add_option("--angle-step-deg", thin_film.angle_step_deg)
            ->capture_default_str()
            ->check(CLI::Range(0.01, 45.0));
        thin_film_cmd->add_option("--max-thickness-nm", thin_film.max_thickness_nm)
            ->capture_default_str()
            ->check(CLI::Range(1.0, 20000.0));
        std::string kinds;
        for (const st::StudyEntry& entry : st::study_registry()) {
            kinds += fmt::format("\n  {:10} {}", entry.kind, entry.description);
        }
        run_cmd = app.add_subcommand(
            "run", "run a study file (TOML; studies/*.toml). Study kinds:" + kinds);
        run_cmd->add_option("STUDY", run_file, "study file, e.g. studies/rock_dove_quick.toml")
            ->required();
        geometry_cmd = app.add_subcommand(
            "geometry",
            "build the geometry of a study file; write PLY/VDB, a PNG preview and a report");
        geometry_cmd
            ->add_option("STUDY", geometry_file,
                         "geometry file (TOML), e.g. studies/geometry/rock_dove_row.toml")
            ->required();
        add_fit_command();
        add_bsdf_export();
        for (CLI::App* sub : {thin_film_cmd, run_cmd, geometry_cmd, fit_cmd, bsdf_cmd})
            add_common_options(*sub, common);
    }

    // Whether --out was given, before or after the subcommand, rather than left at its default.
    bool out_given() {
        std::size_t count = app.get_option("--out")->count();
        for (CLI::App* sub : {thin_film_cmd, run_cmd, geometry_cmd, fit_cmd, bsdf_cmd})
            count += sub->get_option("--out")->count();
        return count > 0;
    }

    // `export-bsdf` (studies/bsdf_export.h): a model of a study as an RGL tensor .bsdf.
    void add_bsdf_export() {
        bsdf_cmd = app.add_subcommand(
            "export-bsdf",
            "write a study's fitted model as a measured BRDF (.bsdf: Mitsuba 3 `measured`, "
            "pbrt-v4 \"measured\")");
        bsdf_cmd
            ->add_option("SOURCE", bsdf.source,
                         "a rock-dove study's fit/huang2022_fit.h5, a species study's species.h5, "
                         "'huang2022' or 'filip2024:<preset>'")
            ->required();
        bsdf_cmd->add_option("-o,--output", bsdf.output,
                             "file, or folder (default: beside SOURCE; with --out DIR: inside "
                             "DIR, and a relative -o too)");
        bsdf_cmd->add_option("--theta-nodes", bsdf.theta_nodes,
                             "θ_i nodes over 0–85° (default: the model's, Huang 2022 19, Filip "
                             "2024 10)");
        bsdf_cmd->add_option("--phi-nodes", bsdf.phi_nodes,
                             "φ_i nodes over ±180°, 1: isotropic (default: the model's, Huang "
                             "2022 49, Filip 2024 25)");
        bsdf_cmd->add_option("--resolution", bsdf.resolution, "N of the N × N sample square")
            ->capture_default_str();
        bsdf_cmd->add_option("--first-nm", bsdf.first_nm)->capture_default_str();
        bsdf_cmd->add_option("--last-nm", bsdf.last_nm)->capture_default_str();
        bsdf_cmd->add_option("--step-nm", bsdf.step_nm)->capture_default_str();
        bsdf_cmd->add_flag("--force", bsdf.force,
                           "replace an existing regular file that plumage did not write (never "
                           "a device, folder or link)");
    }

    void add_fit_command() {
        fit_cmd = app.add_subcommand(
            "fit",
            "fit Huang 2022 (to a scatterogram record) or Filip 2024 (to a BRDF CSV or record); "
            "write parameters.json, the residual map and a report (docs/user_data.md)");
        fit_cmd->add_option("DATA", fit_data, "the data: .csv or .h5 (docs/user_data.md)")
            ->required();
        fit_cmd->add_option("--model", fit.model, "huang2022 or filip2024")
            ->required()
            ->check(CLI::IsMember({"huang2022", "filip2024"}));
        fit_cmd->add_option("--name", fit.name, "results folder (default fit_<model>_<data stem>)");
        fit_cmd->add_option("--preset", fit.preset, "filip2024: start from this preset (parrot)");
        fit_cmd->add_option("--start", fit_starts, "a starting value, NAME=VALUE (repeatable)");
        fit_cmd->add_option("--fix", fit.fixed, "hold a parameter at its start (repeatable)");
        fit_cmd->add_flag("--strict", fit_strict,
                          "exit with status 3 when the fit warns (chi2/dof far above 1, a "
                          "parameter on a bound, not converged, ...); the results are written");
        fit_cmd->add_option("--free", fit.free,
                            "fit a parameter held by default (huang2022: phi0, phi1; filip2024: "
                            "theta_max, brdf_scale)");
        fit_cmd
            ->add_option("--pixel-stride", fit.pixel_stride,
                         "huang2022: fit the pixels with (row + column) % N == 0")
            ->capture_default_str();
    }
};

// Each worker thread reserves a stack (RLIMIT_STACK, 8 MiB by default): --threads 1000 under a
// memory limit aborted in the OpenMP runtime (exit 134) instead of being refused.
void require_thread_memory(int threads) {
    rlimit stack{};
    const double per_thread =
        ::getrlimit(RLIMIT_STACK, &stack) == 0 && stack.rlim_cur != RLIM_INFINITY
            ? static_cast<double>(stack.rlim_cur)
            : 8.0 * 1024 * 1024;
    plumage::require_memory(
        threads * per_thread,
        fmt::format("--threads {} (a stack of {:.3g} MB each)", threads, per_thread / 1e6));
}

// Runs what the command line asks for; returns the summary for stdout.
std::string run_command(CommandLine& cli) {
    const CommonOptions& common = cli.common;
    if (common.threads > 0) require_thread_memory(common.threads);
    if (cli.geometry_cmd->parsed()) return run_geometry(cli.geometry_file, common);
    if (cli.fit_cmd->parsed()) {
        cli.fit.data = cli.fit_data;
        return run_fit(cli.fit, cli.fit_starts, common, cli.fit_strict, cli.exit_code);
    }
    if (cli.bsdf_cmd->parsed()) return run_bsdf_export(cli.bsdf, common, cli.out_given());
    if (cli.thin_film_cmd->parsed()) {
        st::refuse_limits("thin-film", common.limits, "the chart is an exact evaluation");
        cli.thin_film.output_dir = fs::path(common.output) / "thin_film";
        cli.thin_film.plots = !common.no_plots;
        return run_thin_film(cli.thin_film);
    }
    std::string text = st::kDefaultStudy;
    fs::path source = "rock_dove.toml (built in)";
    if (cli.run_cmd->parsed()) {
        text = read_file(cli.run_file, "study file");
        source = cli.run_file;
    }
    return st::study_of(text, source).run(text, source, common.output, common.limits);
}

// The exit code of a failure, with its message on stderr. Whatever a stage threw once a
// signal had arrived (an abandoned measurement's partial result, say) is the interruption's
// doing.
// "; no space left on device ..." when the results root's file system is full (a write that
// failed for that reason says only that it failed).
std::string full_disk_note(const std::string& output) {
    struct statvfs fs_info {};
    fs::path probe = output;
    std::error_code ignored;
    while (!probe.empty() && !fs::exists(probe, ignored)) probe = probe.parent_path();
    if (probe.empty()) probe = ".";
    if (::statvfs(probe.c_str(), &fs_info) != 0) return {};
    const double free_bytes =
        static_cast<double>(fs_info.f_bavail) * static_cast<double>(fs_info.f_frsize);
    if (free_bytes >= 1024.0 * 1024.0) return {};
    return fmt::format(
        "; the file system of '{}' is full ({:.0f} kB free): no space left on device",
        probe.string(), free_bytes / 1024.0);
}

int report_failure(const std::exception& e, const std::string& output) {
    if (plumage::interrupt_signal() != 0) {
        std::cerr << fmt::format(
            "plumage: {}; nothing half-written is left in {} (an earlier result of the same name "
            "is "
            "untouched; finished measurement passes stay in checkpoints). Run the same command "
            "again "
            "to resume.\n",
            e.what(), output);
        return 128 + plumage::interrupt_signal();
    }
    if (dynamic_cast<const plumage::InputError*>(&e) != nullptr) {
        std::cerr << "plumage: error: " << e.what() << '\n';
        return 2;
    }
    std::cerr << "plumage: failed: " << e.what() << full_disk_note(output) << '\n';
    return 1;
}

// Ends the process with `code`, the interrupt handler still installed: a Ctrl-C that arrives
// after the work is done (during the exit sequence) must not kill the process by signal.
// Every file is closed by now; only the streams need flushing.
// Under MPI (common/distributed.h): success finalises on every rank; a failure on any rank
// ends the whole job at once (the others may be waiting for it), the message naming the rank.
[[noreturn]] void finish(int code) {
    std::cout.flush();
    std::cerr.flush();
    std::fflush(nullptr);
    if (code != 0 && plumage::distributed::active()) {
        plumage::distributed::abort_job(
            code, fmt::format("stopping all {} ranks", plumage::distributed::size()));
    }
    plumage::distributed::finalize();
    std::_Exit(code);
}

// Under MPI every rank runs the study (common/distributed.h); only rank 0 writes into --out.
// The others write into a scratch root of their own in the node's temporary folder,
// "plumage-scratch-<host>-<pid>-<tag>", owned like a staging folder (a locked owner record,
// studies/staged_directory.h) and removed at the end. One whose owner is provably gone (a rank
// of this host and boot that was killed) is removed by the next rank that starts here; one of
// a process this rank cannot see (another PID namespace, container or node sharing the folder)
// is left alone: a pid alone proved nothing there.
std::string rank_scratch_root(std::optional<st::OwnerLock>& owner) {
    char host[256] = {};
    ::gethostname(host, sizeof host - 1);
    const std::string prefix = fmt::format("plumage-scratch-{}-", host);
    std::error_code ignored;
    for (const auto& entry : fs::directory_iterator(fs::temp_directory_path(), ignored)) {
        if (entry.path().filename().string().rfind(prefix, 0) != 0) continue;
        if (st::owner_provably_gone(entry.path())) fs::remove_all(entry.path(), ignored);
    }
    std::random_device random;
    for (int attempt = 0; attempt < 8; ++attempt) {
        const fs::path root =
            fs::temp_directory_path() / fmt::format("{}{}-{:08x}", prefix, ::getpid(), random());
        if (!fs::create_directory(root)) continue;  // new, so ours alone
        owner.emplace(root / st::kOwnerRecord);
        return root.string();
    }
    throw plumage::IoError(fmt::format("cannot create a scratch folder {}* in {}", prefix,
                                       fs::temp_directory_path().string()));
}

}  // namespace

int main(int argc, char** argv) {
    // Ctrl-C and SIGTERM stop every stage (common/interrupt.h), from the first instant: a
    // signal during start-up stops the run at its first stage with exit code 130 as well.
    const plumage::ScopedInterruptHandler interrupt;
    CommandLine cli;
    try {
        cli.app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = cli.app.exit(e);
        if (code != 0) suggest(cli.app, argc, argv);
        // Bad input exits 2, the command line's included (CLI11's own codes are 104-109).
        finish(code == 0 ? 0 : 2);
    }
    // Idle OpenMP threads sleep rather than spin unless the user said otherwise: spinning ones
    // made 2 threads slower than 1 when another process held a core. This may execute the
    // program again (common/omp_wait_policy.h), so it comes before anything is written; not
    // for one thread (nothing waits).
    const int threads = cli.common.threads > 0 ? cli.common.threads : omp_get_max_threads();
    if (threads > 1) plumage::wait_passively_unless_told(argv);
    if (cli.common.threads > 0) omp_set_num_threads(cli.common.threads);
    plumage::distributed::init(&argc, &argv);
    const bool rank0 = plumage::distributed::rank() == 0;
    std::string scratch;
    std::optional<plumage::CleanupRegistration> scratch_cleanup;  // removed by a forced stop too
    std::optional<st::OwnerLock> scratch_owner;                   // held while this rank lives
    if (!rank0) {
        plumage::distributed::silence_other_ranks();
        try {
            scratch = rank_scratch_root(scratch_owner);
        } catch (const std::exception& e) {
            plumage::distributed::abort_job(1, fmt::format("no scratch folder: {}", e.what()));
        }
        scratch_cleanup.emplace(scratch);
        cli.common.output = scratch;
        cli.common.no_plots = true;
    }
    st::set_plots_enabled(!cli.common.no_plots);
    int code = 0;
    std::string failure;
    try {
        const std::string summary = run_command(cli);
        if (rank0) std::cout << summary;
        code = cli.exit_code;
    } catch (const std::exception& e) {
        code = report_failure(e, cli.common.output);
        failure = e.what();
    }
    if (!scratch.empty()) {
        std::error_code ignored;
        fs::remove_all(scratch, ignored);
    }
    if (code != 0 && !rank0) {
        // The same bad input or interrupt reaches rank 0, which says it once and ends the job;
        // a failure of this rank alone is said by this rank after that grace time.
        std::this_thread::sleep_for(std::chrono::seconds(2));
        plumage::distributed::abort_job(code, failure);
    }
    finish(code);
}
