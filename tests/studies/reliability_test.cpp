// Regression tests for the defects of issue 13, each reproduced on 84af43f before its fix:
// a study `name` that reached outside the results root and deleted what was there; a
// wavelength step without a lower bound (200 001 wavelengths, or allocation until out of
// memory); orphaned staging folders after a kill; a failed plot losing the whole study; and
// an interrupt that only the goniometer's pass loop heard. They run through the same entry
// points as `plumage run` (studies/study.h), for every study kind. Issue 43's staging defects
// (each reproduced on 880503c): a staging folder of a run in another PID namespace taken for an
// orphan, and study names that collide with the staging folders.
#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/interrupt.h"
#include "sim/optics/spectrum.h"
#include "studies/masking_study.h"
#include "studies/plots.h"
#include "studies/sections.h"
#include "studies/staged_directory.h"
#include "studies/study.h"
#include "studies/study_checkpoints.h"
#include "tests/test_util.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;
using plumage::testing::input_error_message;

std::string read(const fs::path& p) { return testing::read_text_file(p); }

void write(const fs::path& p, const std::string& text) {
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
}

fs::path quick(const std::string& kind) {
    return fs::path(PLUMAGE_SOURCE_DIR) / "studies" / (kind + "_quick.toml");
}

// The quick study of `kind` with the line matching `pattern` replaced.
std::string with_line(const std::string& kind, const std::string& pattern,
                      const std::string& replacement) {
    const std::string text = read(quick(kind));
    const std::regex line(pattern, std::regex::multiline);
    EXPECT_TRUE(std::regex_search(text, line)) << kind << ": no line matches " << pattern;
    return std::regex_replace(text, line, replacement, std::regex_constants::format_first_only);
}

class Reliability : public ::testing::Test {
protected:
    void SetUp() override {
        root_ = fs::temp_directory_path() /
                fmt::format("plumage_reliability_{}_{}", ::getpid(),
                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(root_);
        fs::create_directories(root_);
    }
    void TearDown() override { fs::remove_all(root_); }
    fs::path root_;
};

const std::vector<std::string> kKinds = {"rock_dove", "ablation", "extremes", "species", "masking"};

// Defect 1: an absolute name, "..", "." or a long name is refused when the file is read, with
// file:line:col, in every study kind, and nothing outside (or inside) the results root is
// touched.
TEST_F(Reliability, StudyNameOutsideTheResultsRootIsRefusedAtReadTime) {
    const fs::path victim = root_ / "victim";
    write(victim / "keep.txt", "precious");
    const std::vector<std::string> names = {victim.string(),       "..",  ".", "../rock_dove_quick",
                                            std::string(300, 'a'), "a/b", "",  "sp ace"};
    for (const std::string& kind : kKinds) {
        for (const std::string& name : names) {
            const std::string text =
                with_line(kind, "^name = .*$", fmt::format("name = \"{}\"", name));
            const fs::path source = root_ / (kind + ".toml");
            const StudyEntry& entry = study_of(text, source);
            const std::string message =
                input_error_message([&] { entry.run(text, source, root_ / "results", {}); });
            EXPECT_NE(message.find(fmt::format("{}:", source.string())), std::string::npos)
                << kind << " name '" << name << "': " << message;
            EXPECT_NE(message.find("name = "), std::string::npos) << message;
            EXPECT_EQ(input_error_message([&] { check_study(text, source); }), message);
        }
    }
    EXPECT_EQ(read(victim / "keep.txt"), "precious");
    EXPECT_FALSE(fs::exists(root_ / "results")) << "a refused study wrote something";
}

// The rule itself, and a file stem that breaks it when `name` is not given.
TEST_F(Reliability, StudyNameRule) {
    EXPECT_EQ(study_name_problem("rock_dove-2.v1"), "");
    EXPECT_EQ(study_name_problem(std::string(kMaxStudyNameLength, 'x')), "");
    EXPECT_NE(study_name_problem(std::string(kMaxStudyNameLength + 1, 'x')), "");
    for (const char* bad : {"", ".", "..", "/abs", "a/b", "a\\b", "é", "a b", "a\nb"}) {
        EXPECT_NE(study_name_problem(bad), "") << bad;
    }
    // Issue 43: the names of plumage's own entries in a results root.
    for (const char* reserved : {"x.partial-999999", "y.previous-999998", "a.partial-",
                                 ".checkpoints", ".plumage-results", ".plumage-owner"}) {
        EXPECT_NE(study_name_problem(reserved).find("reserved"), std::string::npos) << reserved;
    }
    EXPECT_EQ(study_name_problem("partial-1.previous"), "");
    std::string text = read(quick("masking"));
    text = std::regex_replace(text, std::regex("^name = .*$", std::regex::multiline), "");
    const std::string message =
        input_error_message([&] { check_study(text, root_ / "my study.toml"); });
    EXPECT_NE(message.find("defaults to the file's stem \"my study\""), std::string::npos)
        << message;
}

// Defect 1, second half: a folder at <root>/<name> that plumage did not write is never
// replaced; one plumage wrote is.
TEST_F(Reliability, AForeignFolderOfTheSameNameIsRefusedAndKept) {
    const fs::path results = root_ / "results";
    write(results / "masking_quick" / "keep.txt", "precious");
    const std::string text = read(quick("masking"));
    const std::string message =
        input_error_message([&] { run_masking_study(text, quick("masking"), results, false); });
    EXPECT_NE(message.find("was not written by plumage"), std::string::npos) << message;
    EXPECT_EQ(read(results / "masking_quick" / "keep.txt"), "precious");
    EXPECT_EQ(std::distance(fs::directory_iterator(results), fs::directory_iterator{}), 1);

    fs::remove_all(results / "masking_quick");
    run_masking_study(text, quick("masking"), results, false);
    ASSERT_TRUE(fs::exists(results / "masking_quick" / kResultsMarker));
    write(results / "masking_quick" / "stale.txt", "from an earlier run");
    run_masking_study(text, quick("masking"), results, false);  // ours: replaced
    EXPECT_FALSE(fs::exists(results / "masking_quick" / "stale.txt"));
    EXPECT_TRUE(fs::exists(results / "masking_quick" / "report.md"));
}

// A pid no process has: fork a child that exits at once and reap it.
pid_t dead_pid() {
    const pid_t child = ::fork();
    if (child == 0) ::_exit(0);
    int status = 0;
    ::waitpid(child, &status, 0);
    return child;
}

std::string first_line(const fs::path& p) {
    std::ifstream in(p);
    std::string line;
    std::getline(in, line);
    return line;
}

// An owner record (studies/staged_directory.h) as process `pid` of this host, boot and PID
// namespace would write it; tests change one field to make a foreign owner.
struct Owner {
    long pid;
    std::string host, boot_id, pid_namespace, start_time = "1";
};
Owner owner_here(long pid) {
    char host[256] = {};
    ::gethostname(host, sizeof host - 1);
    struct stat ns = {};
    ::stat("/proc/self/ns/pid", &ns);
    return {pid, host, first_line("/proc/sys/kernel/random/boot_id"), std::to_string(ns.st_ino)};
}
// A staging folder as a run of `owner` leaves it: the marker and the owner record.
void write_staged(const fs::path& dir, const Owner& o) {
    write(dir / kResultsMarker, "");
    write(dir / kOwnerRecord,
          fmt::format("host={}\nboot_id={}\npid_namespace={}\npid={}\nstart_time={}\n", o.host,
                      o.boot_id, o.pid_namespace, o.pid, o.start_time));
}

// Field 22 of /proc/<pid>/stat.
std::string start_time(pid_t pid) {
    const std::string line = first_line(fmt::format("/proc/{}/stat", pid));
    std::istringstream fields(line.substr(line.rfind(')') + 1));
    std::string field;
    for (int number = 3; number <= 22; ++number) fields >> field;
    return field;
}

// Defect 4: staging folders of killed runs are removed on the next start (and said so); a
// result displaced by a commit that was killed halfway is restored; folders without the
// marker, and folders of live processes, are left alone. Issue 43: "live" is told by the owner
// record's lock, and by the pid with its start time.
TEST_F(Reliability, OrphanedStagingFoldersAreRemovedOnStart) {
    const pid_t gone = dead_pid();
    const fs::path results = root_ / "results";
    const fs::path orphan = results / fmt::format("masking_quick.partial-{}-0000000a", gone);
    write_staged(orphan, owner_here(gone));
    write(orphan / "half.h5", "x");
    const fs::path displaced = results / fmt::format("rock_dove.previous-{}-0000000b", gone);
    write_staged(displaced, owner_here(gone));
    write(displaced / "report.md", "kept");
    write(results / fmt::format("notes.partial-{}", gone) / "mine.txt", "no marker");
    // Alive by its pid and start time (our parent), though nobody holds its lock.
    Owner parent = owner_here(::getppid());
    parent.start_time = start_time(::getppid());
    write_staged(results / "other.partial-1-0000000c", parent);
    // Alive by its lock, though its pid is gone.
    const fs::path locked = results / fmt::format("held.partial-{}-0000000d", gone);
    write_staged(locked, owner_here(gone));
    const int fd = ::open((locked / kOwnerRecord).c_str(), O_RDONLY);
    ASSERT_EQ(::flock(fd, LOCK_EX), 0);

    const std::vector<std::string> actions = StagedDirectory::remove_orphans(results);
    ::close(fd);
    EXPECT_EQ(actions.size(), 3u) << ::testing::PrintToString(actions);
    EXPECT_FALSE(fs::exists(orphan));
    EXPECT_EQ(read(results / "rock_dove" / "report.md"), "kept");
    EXPECT_FALSE(fs::exists(results / "rock_dove" / kOwnerRecord));
    EXPECT_TRUE(fs::exists(results / fmt::format("notes.partial-{}", gone) / "mine.txt"));
    EXPECT_TRUE(fs::exists(results / "other.partial-1-0000000c"));
    EXPECT_TRUE(fs::exists(locked));
    // What is left alone is said once per process.
    EXPECT_EQ(StagedDirectory::remove_orphans(results).size(), 1u);  // now `held`: its lock is free

    // And through a study's start.
    write_staged(results / fmt::format("ablation.partial-{}-0000000e", gone), owner_here(gone));
    run_masking_study(read(quick("masking")), quick("masking"), results, false);
    EXPECT_FALSE(fs::exists(results / fmt::format("ablation.partial-{}-0000000e", gone)));
}

// Issue 43: a run in another container, on another host or before a reboot shared --out; its
// pid means nothing here. A folder whose owner cannot be proven gone is never removed, and said
// so once; one of this boot whose lock is free is gone, whatever its PID namespace.
TEST_F(Reliability, StagingFoldersOfOwnersNotProvenGoneAreLeftAlone) {
    const pid_t gone = dead_pid();
    const fs::path results = root_ / "results";
    Owner other_boot = owner_here(gone), other_host = owner_here(gone), incomplete = owner_here(0);
    other_boot.boot_id = "00000000-0000-0000-0000-000000000000";
    other_host.host = "another-node";
    incomplete.pid_namespace = "";
    write_staged(results / "a.partial-7-00000001", other_boot);
    write_staged(results / "b.previous-7-00000002", other_host);
    write_staged(results / "c.partial-7-00000003", incomplete);
    write(results / "x.partial-999999" / kResultsMarker, "");  // an older plumage's result
    write(results / "x.partial-999999" / "report.md", "mine");
    Owner other_namespace = owner_here(gone);
    other_namespace.pid_namespace = "4026531999";
    write_staged(results / "d.partial-7-00000004", other_namespace);

    const std::vector<std::string> actions = StagedDirectory::remove_orphans(results);
    const std::string said = ::testing::PrintToString(actions);
    EXPECT_EQ(actions.size(), 5u) << said;
    for (const char* kept : {"a.partial-7-00000001", "b.previous-7-00000002",
                             "c.partial-7-00000003", "x.partial-999999"}) {
        EXPECT_TRUE(fs::exists(results / kept / kResultsMarker)) << kept;
        EXPECT_NE(said.find(fmt::format("left {} alone", (results / kept).string())),
                  std::string::npos)
            << kept << ": " << said;
    }
    EXPECT_NE(said.find("did not run on this host and boot"), std::string::npos) << said;
    EXPECT_NE(said.find("no owner record"), std::string::npos) << said;
    EXPECT_FALSE(fs::exists(results / "b"));  // not restored either
    EXPECT_EQ(read(results / "x.partial-999999" / "report.md"), "mine");
    EXPECT_FALSE(fs::exists(results / "d.partial-7-00000004"));
    EXPECT_TRUE(StagedDirectory::remove_orphans(results).empty());  // said once
}

// Issue 43: study names that plumage's own entries take are refused when the file is read, in
// every study kind, with file:line:column; results already there under such names are kept.
TEST_F(Reliability, ReservedNamesAreRefusedAtReadTimeAndSuchFoldersKept) {
    for (const std::string& kind : kKinds) {
        for (const char* name : {"x.partial-999999", "y.previous-999998", ".checkpoints"}) {
            const std::string text =
                with_line(kind, "^name = .*$", fmt::format("name = \"{}\"", name));
            const fs::path source = root_ / (kind + ".toml");
            const std::string message = input_error_message([&] { check_study(text, source); });
            EXPECT_TRUE(std::regex_search(
                message, std::regex(fmt::format(
                             "{}:[0-9]+:[0-9]+: name = \"{}\" .*reserved", source.string(),
                             std::regex_replace(name, std::regex("\\."), "\\.")))))
                << kind << ": " << message;
        }
    }
    const fs::path results = root_ / "results";
    for (const char* name : {"x.partial-999999", "y.previous-999998"}) {
        write(results / name / kResultsMarker, "");
        write(results / name / "report.md", "mine");
    }
    run_masking_study(read(quick("masking")), quick("masking"), results, false);
    EXPECT_EQ(read(results / "x.partial-999999" / "report.md"), "mine");
    EXPECT_EQ(read(results / "y.previous-999998" / "report.md"), "mine");
    EXPECT_FALSE(fs::exists(results / "y"));
}

// Two runs of the same study (the same pid in two PID namespaces) never share a staging folder;
// a committed result carries no owner record and leaves no displaced folder behind.
TEST_F(Reliability, StagingFoldersAreUniqueAndResultsCarryNoOwnerRecord) {
    const fs::path final_path = root_ / "results" / "study";
    StagedDirectory first(final_path);
    StagedDirectory second(final_path);
    EXPECT_NE(first.path(), second.path());
    for (const StagedDirectory* d : {&first, &second}) {
        EXPECT_TRUE(fs::exists(d->path() / kOwnerRecord));
        EXPECT_TRUE(fs::exists(d->path() / kResultsMarker));
        EXPECT_NE(read(d->path() / kOwnerRecord).find(fmt::format("pid={}\n", ::getpid())),
                  std::string::npos);
    }
    EXPECT_TRUE(StagedDirectory::remove_orphans(root_ / "results").empty());  // both alive
    write(first.path() / "report.md", "first");
    first.commit();
    write(second.path() / "report.md", "second");
    second.commit();
    EXPECT_EQ(read(final_path / "report.md"), "second");
    EXPECT_FALSE(fs::exists(final_path / kOwnerRecord));
    EXPECT_EQ(std::distance(fs::directory_iterator(root_ / "results"), fs::directory_iterator{}),
              1);
}

// Two runs of one study sharing --out share its checkpoints (the same identity, the same sums
// pass by pass); the first to finish used to remove them under the other, whose next checkpoint
// then failed (exit 1). Now they stay while another run holds them in use.
TEST_F(Reliability, CheckpointsStayWhileAnotherRunOfTheStudyUsesThem) {
    const fs::path folder = checkpoint_folder(root_, "study");
    EXPECT_EQ(checkpoint_folder(root_, "study"), folder);
    ASSERT_TRUE(fs::exists(folder / kCheckpointsInUse));
    write(folder / "brdf.checkpoint", "passes");
    const int other = ::open((folder / kCheckpointsInUse).c_str(), O_RDONLY);  // another run
    ASSERT_EQ(::flock(other, LOCK_SH), 0);
    remove_checkpoints(root_, "study");
    EXPECT_EQ(read(folder / "brdf.checkpoint"), "passes");
    ::close(other);  // it ends (or is killed)
    checkpoint_folder(root_, "study");
    remove_checkpoints(root_, "study");
    EXPECT_FALSE(fs::exists(root_ / ".checkpoints"));
    // Interrupted before a first pass: nothing kept, nothing left.
    const fs::path checkpoint = checkpoint_folder(root_, "study") / "brdf.checkpoint";
    interrupted_with_checkpoint("the BRDF", 0, checkpoint);
    EXPECT_FALSE(fs::exists(root_ / ".checkpoints"));
}

// Defect 2: a tiny wavelength step is an error naming the bound, at read time, for
// [spectrum] in every study that has one and for the species study's [btf].
TEST_F(Reliability, WavelengthStepHasALowerBound) {
    const std::string bound =
        fmt::format("expected at most {}", optics::WavelengthGrid::kMaxWavelengths);
    for (const std::string kind : {"rock_dove", "ablation", "species"}) {
        for (const char* step : {"1e-320", "0.001"}) {
            const std::string text =
                with_line(kind, "^step_nm = .*$", fmt::format("step_nm = {}", step));
            const std::string message =
                input_error_message([&] { check_study(text, quick(kind)); });
            EXPECT_NE(message.find("step_nm"), std::string::npos) << kind << ": " << message;
            EXPECT_NE(message.find(bound), std::string::npos) << kind << ": " << message;
        }
    }
    const std::string btf = read(quick("species")) + "";
    const std::string text = std::regex_replace(
        btf, std::regex("^\\[btf\\]$", std::regex::multiline), "[btf]\nstep_nm = 1e-320");
    const std::string message = input_error_message([&] { check_study(text, quick("species")); });
    EXPECT_NE(message.find("btf.step_nm"), std::string::npos) << message;
    EXPECT_NE(message.find(bound), std::string::npos) << message;
    // The extremes study has [spectrum] too (no quick-file line to replace: append one).
    const std::string extremes = read(quick("extremes")) + "\n[spectrum]\nstep_nm = 1e-3\n";
    EXPECT_NE(input_error_message([&] { check_study(extremes, quick("extremes")); }).find(bound),
              std::string::npos);
}

// Defect 5: a plot that cannot be drawn is a warning; the records and the report are committed.
TEST_F(Reliability, AFailedPlotKeepsTheRecordsAndTheReport) {
    ::setenv("PLUMAGE_PYTHON", "/nonexistent/python3", 1);
    const auto result = run_masking_study(read(quick("masking")), quick("masking"), root_, false);
    ::unsetenv("PLUMAGE_PYTHON");
    EXPECT_TRUE(fs::exists(result.output_dir / "masking.h5"));
    EXPECT_TRUE(fs::exists(result.output_dir / "report.md"));
    EXPECT_FALSE(fs::exists(result.output_dir / "masking.png"));
    // A Python without matplotlib (here: one that fails every import) is named as such.
    const fs::path python = root_ / "python_without_matplotlib";
    write(python, "#!/bin/sh\necho matplotlib numpy h5py\n");
    fs::permissions(python, fs::perms::owner_all);
    ::setenv("PLUMAGE_PYTHON", python.c_str(), 1);
    ::testing::internal::CaptureStderr();
    const bool drawn = run_plot("masking", result.output_dir / "masking.h5", root_ / "m.png");
    const std::string warning = ::testing::internal::GetCapturedStderr();
    ::unsetenv("PLUMAGE_PYTHON");
    EXPECT_FALSE(drawn);
    EXPECT_NE(warning.find("lacks the module(s) matplotlib numpy h5py"), std::string::npos)
        << warning;
}

// Defect 3, inside the process: an interrupt requested before or during any study stops it
// with Interrupted, and leaves neither a results folder nor a staging folder.
TEST_F(Reliability, EveryStudyStopsOnInterruptAndLeavesNothingHalfWritten) {
    for (const std::string& kind : kKinds) {
        const ScopedInterruptHandler handler;
        request_interrupt(SIGINT);
        const std::string text = read(quick(kind));
        EXPECT_THROW(study_of(text, quick(kind)).run(text, quick(kind), root_, {}), Interrupted)
            << kind;
        EXPECT_TRUE(fs::is_empty(root_) ||
                    (fs::exists(root_ / ".checkpoints") &&
                     std::distance(fs::directory_iterator(root_), fs::directory_iterator{}) == 1))
            << kind << ": left " << fs::directory_iterator(root_)->path();
    }
    EXPECT_FALSE(interrupt_requested()) << "the handler's end clears the request";
}

// Limits given on the command line reach every study or are refused by name.
TEST_F(Reliability, RunLimitsAreAppliedOrRefused) {
    const RunLimits limits{.time_budget_s = 1.0};
    for (const std::string kind : {"extremes", "masking"}) {
        const std::string text = read(quick(kind));
        const std::string message = input_error_message(
            [&] { study_of(text, quick(kind)).run(text, quick(kind), root_, limits); });
        EXPECT_NE(message.find(fmt::format("do not apply to the {} study", kind)),
                  std::string::npos)
            << message;
    }
    EXPECT_TRUE(fs::is_empty(root_));
}

// Which subcommand a file belongs to.
TEST_F(Reliability, GeometryFilesAreNotStudies) {
    const fs::path geometry =
        fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "geometry" / "rock_dove_row.toml";
    const std::string message = input_error_message([&] { check_study(read(geometry), geometry); });
    EXPECT_NE(message.find("plumage geometry"), std::string::npos) << message;
}

}  // namespace
}  // namespace plumage::studies
