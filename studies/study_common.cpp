#include "studies/study_common.h"

#include <fcntl.h>
#include <omp.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/cpu_time.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/relative_l1.h"

namespace plumage::studies {

analysis::Huang2022Params huang_params_of(const geometry::BarbuleRowParams& row) {
    analysis::Huang2022Params p;
    p.b = row.cell.b;
    p.phi0 = row.cell.phi0;
    p.phi1 = row.cell.phi1;
    p.theta_d = row.cell.theta_d;
    p.H = row.H;
    p.mu = row.mu;
    p.d_um = row.cell.film_thickness_um;
    return p;
}

record::RgbImage side_by_side(const std::vector<const record::RgbImage*>& images) {
    int width = 0, height = 0;
    for (const auto* im : images) width += im->width + 6, height = std::max(height, im->height);
    record::RgbImage out(width - 6, height);
    out.fill(255, 255, 255);
    int x0 = 0;
    for (const auto* im : images) {
        for (int y = 0; y < im->height; ++y)
            for (int x = 0; x < im->width; ++x) {
                const std::size_t i = (static_cast<std::size_t>(y) * im->width + x) * 3;
                out.set(x0 + x, y, im->pixels[i], im->pixels[i + 1], im->pixels[i + 2]);
            }
        x0 += im->width + 6;
    }
    return out;
}

// Σ|a − b| Ω / Σ b Ω over pixels and wavelengths, for one lobe (or all when lobe < 0).
double image_relative_l1(const gonio::Scatterogram& a, const gonio::Scatterogram& b, int lobe_a,
                         int lobe_b) {
    const std::size_t n = a.pixels() * a.config.wavelengths_nm.size();
    const auto& va = lobe_a < 0 ? a.intensity : a.lobe_intensity;
    const auto& vb = lobe_b < 0 ? b.intensity : b.lobe_intensity;
    const std::size_t oa = lobe_a < 0 ? 0 : static_cast<std::size_t>(lobe_a) * n;
    const std::size_t ob = lobe_b < 0 ? 0 : static_cast<std::size_t>(lobe_b) * n;
    RelativeL1 l1;
    const std::size_t nl = a.config.wavelengths_nm.size();
    for (std::size_t i = 0; i < n; ++i) l1.add(va[oa + i], vb[ob + i], a.solid_angle_sr[i / nl]);
    return l1.value();
}

double image_relative_l1_noise_floor(const gonio::Scatterogram& a, const gonio::Scatterogram& b) {
    const std::size_t nl = a.config.wavelengths_nm.size();
    double noise = 0.0, ref = 0.0;
    for (std::size_t i = 0; i < a.pixels() * nl; ++i) {
        const double omega = a.solid_angle_sr[i / nl];
        noise += std::hypot(a.standard_error[i], b.standard_error[i]) * omega;
        ref += b.intensity[i] * omega;
    }
    return ref > 0.0 ? std::sqrt(2.0 / kPi) * noise / ref : 0.0;
}

std::string p_value_text(double p) {
    return p < 1e-15 ? std::string("p < 1e-15") : fmt::format("p = {:.2g}", p);
}

int lobe_index(const std::vector<std::string>& lobes, const std::string& name) {
    for (std::size_t i = 0; i < lobes.size(); ++i)
        if (lobes[i] == name) return static_cast<int>(i);
    return -1;
}

Vec3d polar(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

namespace {

std::mutex checkpoint_mutex;
// Checkpoint folders this process uses, each with the descriptor holding its shared lock.
std::map<std::filesystem::path, int> checkpoint_leases;

constexpr int kInUseElsewhere = -2;

// The descriptor of `folder`'s in-use file, locked `how` (LOCK_SH, LOCK_EX | LOCK_NB);
// kInUseElsewhere when another process holds it, -1 when it cannot be locked (no such file, a
// file system without flock). A run removing the folder holds it exclusively; one that waited
// for it meanwhile finds its file unlinked and starts again.
int lock_in_use(const std::filesystem::path& folder, int how) {
    const std::filesystem::path file = folder / kCheckpointsInUse;
    for (int attempt = 0; attempt < 100; ++attempt) {
        std::error_code ignored;
        if (how == LOCK_SH) std::filesystem::create_directories(folder, ignored);
        const int fd =
            ::open(file.c_str(), O_RDONLY | O_CLOEXEC | (how == LOCK_SH ? O_CREAT : 0), 0644);
        if (fd < 0) return -1;
        int locked;
        while ((locked = ::flock(fd, how)) != 0 && errno == EINTR) {
        }
        struct stat held = {};
        struct stat named = {};
        if (locked == 0 && ::fstat(fd, &held) == 0 && ::stat(file.c_str(), &named) == 0 &&
            held.st_ino == named.st_ino && held.st_dev == named.st_dev) {
            return fd;
        }
        const bool busy = locked != 0 && errno == EWOULDBLOCK;
        ::close(fd);
        if (locked != 0) return busy ? kInUseElsewhere : -1;
    }
    return -1;
}

}  // namespace

std::filesystem::path checkpoint_folder(const std::filesystem::path& results_root,
                                        const std::string& name) {
    const std::filesystem::path folder = results_root / ".checkpoints" / name;
    const std::lock_guard lock(checkpoint_mutex);
    // Without a lock (a file system without flock) the checkpoints still work; only a run of the
    // same study finishing first may remove them under us.
    if (!checkpoint_leases.contains(folder))
        checkpoint_leases[folder] = lock_in_use(folder, LOCK_SH);
    return folder;
}

void remove_checkpoints(const std::filesystem::path& results_root, const std::string& name) {
    const std::filesystem::path folder = results_root / ".checkpoints" / name;
    const std::lock_guard lock(checkpoint_mutex);
    if (const auto lease = checkpoint_leases.find(folder); lease != checkpoint_leases.end()) {
        if (lease->second >= 0) ::close(lease->second);
        checkpoint_leases.erase(lease);
    }
    const int fd = lock_in_use(folder, LOCK_EX | LOCK_NB);
    if (fd == kInUseElsewhere) return;  // another run of the study still measures into it
    std::error_code ignored;
    std::filesystem::remove_all(folder, ignored);
    if (fd >= 0) ::close(fd);
    std::filesystem::remove(results_root / ".checkpoints", ignored);  // only when empty
}

gonio::CheckpointPart input_file_part(const std::string& what, const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::uint64_t hash = 1469598103934665603ULL, size = 0;  // FNV-1a, 64 bits
    std::vector<char> buffer(std::size_t{1} << 20);
    while (in.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || in.gcount() > 0) {
        const auto n = static_cast<std::size_t>(in.gcount());
        for (std::size_t i = 0; i < n; ++i)
            hash = (hash ^ static_cast<unsigned char>(buffer[i])) * 1099511628211ULL;
        size += n;
    }
    if (!in.eof()) {
        throw IoError(
            fmt::format("cannot read {} ({}) to key its checkpoint", file.string(), what));
    }
    return {what, fmt::format("{:016x}, {} bytes", hash, size)};
}

std::string interrupted_with_checkpoint(const std::string& what, int passes,
                                        const std::filesystem::path& checkpoint) {
    if (passes > 0) {
        return fmt::format(
            "interrupted in {} after {} completed passes, kept in {}; run the same "
            "command again to resume from them",
            what, passes, checkpoint.string());
    }
    // <root>/.checkpoints/<name>/<file>: remove the two folders if nothing but our lease is in
    // them (and no other run of the study uses them).
    const std::filesystem::path folder = checkpoint.parent_path();
    std::error_code ignored;
    bool only_lease = true;
    for (const auto& entry : std::filesystem::directory_iterator(folder, ignored))
        only_lease = only_lease && entry.path().filename() == kCheckpointsInUse;
    if (only_lease) {
        remove_checkpoints(folder.parent_path().parent_path(), folder.filename().string());
    }
    return fmt::format("interrupted in {} before its first pass completed (nothing to resume)",
                       what);
}

StudyProgress::StudyProgress(bool enabled)
    : enabled_(enabled),
      open_name_("reading the study file"),
      open_wall_(start_),
      open_cpu_(process_cpu_seconds()) {}

double StudyProgress::elapsed_s() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void StudyProgress::say(const std::string& what) const {
    // Every stage starts here, so a Ctrl-C between stages stops the study before the next.
    throw_if_interrupted(what);
    done(what);
    const auto now = std::chrono::steady_clock::now();
    const double cpu = process_cpu_seconds();
    const std::lock_guard lock(mutex_);
    closed_.push_back(
        {open_name_, std::chrono::duration<double>(now - open_wall_).count(), cpu - open_cpu_});
    open_name_ = what;
    open_wall_ = now;
    open_cpu_ = cpu;
}

void StudyProgress::done(const std::string& what) const {
    if (enabled_) std::cerr << fmt::format("plumage: [{:6.1f} s] {}\n", elapsed_s(), what);
}

std::vector<StageTiming> StudyProgress::stages() const {
    const auto now = std::chrono::steady_clock::now();
    const double cpu = process_cpu_seconds();
    const std::lock_guard lock(mutex_);
    std::vector<StageTiming> out = closed_;
    out.push_back(
        {open_name_, std::chrono::duration<double>(now - open_wall_).count(), cpu - open_cpu_});
    return out;
}

namespace {

// CPU/wall, or "–" when the wall time is too short to divide by.
std::string cpu_per_wall(double cpu_s, double wall_s, std::string_view none) {
    return wall_s > 1e-9 ? fmt::format("{:.2f}", cpu_s / wall_s) : std::string(none);
}

// A stage name as one markdown table cell.
std::string markdown_cell(const std::string& text) {
    std::string out;
    for (const char c : text) {
        if (c == '|') out += '\\';
        out += c == '\n' || c == '\r' ? ' ' : c;
    }
    return out;
}

// A stage name as one CSV field (RFC 4180): quoted, quotes doubled, when it needs to be.
std::string csv_field(const std::string& text) {
    if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
    std::string out = "\"";
    for (const char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
    return out + "\"";
}

}  // namespace

std::string stage_table(std::span<const StageTiming> stages) {
    const int threads = omp_get_max_threads();
    const std::string reading =
        threads == 1
            ? "so CPU/wall stays near 1 unless a library starts threads of its own (Embree builds "
              "its bounding-volume hierarchies on all cores); rerun with --threads N to see which "
              "stages use N threads"
            : fmt::format(
                  "so CPU/wall near 1 marks a serial stage and near {} a stage using every "
                  "thread",
                  threads);
    std::string out = fmt::format(
        "Each stage runs from its progress line on stderr to the next (the first from the start "
        "of the run, the last up to the moment this report was written), on {} OpenMP "
        "thread{}; CPU time counts every thread of plumage (not child processes such as the "
        "plotter), {}. The same figures are in `stages.csv`.\n\n",
        threads, threads == 1 ? "" : "s", reading);
    out += "| stage | wall (s) | CPU (s) | CPU/wall |\n|---|---|---|---|\n";
    double wall = 0.0, cpu = 0.0;
    for (const StageTiming& s : stages) {
        out += fmt::format("| {} | {:.2f} | {:.2f} | {} |\n", markdown_cell(s.name), s.wall_s,
                           s.cpu_s, cpu_per_wall(s.cpu_s, s.wall_s, "–"));
        wall += s.wall_s;
        cpu += s.cpu_s;
    }
    out += fmt::format("| **total** | **{:.2f}** | **{:.2f}** | **{}** |\n", wall, cpu,
                       cpu_per_wall(cpu, wall, "–"));
    return out;
}

void write_stages_csv(const std::filesystem::path& path, std::span<const StageTiming> stages) {
    std::ofstream csv(path);
    csv << "stage,wall time (s),cpu time (s),cpu/wall\n";
    for (const StageTiming& s : stages) {
        csv << fmt::format("{},{:.6f},{:.6f},{}\n", csv_field(s.name), s.wall_s, s.cpu_s,
                           s.wall_s > 1e-9 ? fmt::format("{:.4f}", s.cpu_s / s.wall_s) : "");
    }
    close_written(csv, path);
}

void close_written(std::ofstream& out, const std::filesystem::path& path) {
    out.close();
    if (!out) throw IoError(fmt::format("cannot write {}", path.string()));
}

void write_text_file(const std::filesystem::path& path, std::string_view text) {
    std::ofstream out(path);
    out << text;
    close_written(out, path);
}

MeasurementCost scatterogram_cost(const std::string& measurement, const gonio::Scatterogram& s,
                                  double signal_fraction) {
    return {measurement,
            fmt::format("{} quanta/λ × {} pass{}, {} px", s.config.quanta_per_pass, s.passes,
                        s.passes == 1 ? "" : "es", s.config.image_size),
            fmt::format("median per-pixel σ/I (pixels above {:g} % of the peak)",
                        100.0 * signal_fraction),
            gonio::median_relative_standard_error(s, signal_fraction),
            s.wall_time_s,
            s.cpu_time_s};
}

namespace {

// How the photon estimator aimed its diffuse directions at the detectors (GoniometerConfig).
std::string guided_description(const gonio::GoniometerConfig& c) {
    std::string text;
    if (c.guided_branches > 0) {
        text += fmt::format(", {} guided branch{} at the first diffuse event", c.guided_branches,
                            c.guided_branches == 1 ? "" : "es");
    }
    if (c.guided_fraction > 0.0) {
        text += fmt::format(", {:.0f} % of first diffuse directions guided to the detectors",
                            100.0 * c.guided_fraction);
    }
    return text;
}

}  // namespace

MeasurementCost brdf_cost(const std::string& measurement, const gonio::BrdfRecord& r) {
    const bool photon = r.estimator_used == gonio::Estimator::photon;
    const std::string samples =
        photon ? fmt::format("photon estimator, {} quanta/λ per light × {} pass{}{}{}{}",
                             r.config.quanta_per_pass, r.passes, r.passes == 1 ? "" : "es",
                             r.wavelength_paths_shared ? ", wavelengths sharing paths" : "",
                             r.paths_split ? ", split at the first film" : "",
                             r.diffuse_guided ? guided_description(r.config) : "")
        : r.config.eval_tolerance > 0.0
            ? fmt::format("eval cubature, {}–{} rings per cone until within {:g} %",
                          r.config.eval_rings, r.config.eval_max_rings,
                          100.0 * r.config.eval_tolerance)
            : fmt::format("eval cubature, {} rings per cone", r.config.eval_rings);
    const double error = r.convergence.empty() ? std::numeric_limits<double>::quiet_NaN()
                                               : r.convergence.back().estimated_relative_rms_error;
    return {measurement,
            samples,
            photon ? "relative RMS standard error over the cells > 0"
                   : "relative RMS of the rule against the half-rings rule, cells > 0",
            error,
            r.wall_time_s,
            r.cpu_time_s};
}

std::string measurement_cost_section(std::span<const MeasurementCost> costs) {
    std::string md =
        "## Error and time per measurement\n\nEach measurement's own error estimate (from its "
        "record; the comparisons above set their differences beside these) and its wall and CPU "
        "time.\n\n| measurement | samples | estimated error | of what | wall (s) | CPU (s) |\n"
        "|---|---|---|---|---|---|\n";
    for (const MeasurementCost& c : costs)
        md += fmt::format("| {} | {} | {:.2f} % | {} | {:.3g} | {:.3g} |\n", c.measurement,
                          c.samples, 100.0 * c.error, c.error_kind, c.wall_s, c.cpu_s);
    return md + "\n";
}

std::string run_time_by_stage(const StudyProgress& clock, const std::filesystem::path& dir) {
    const std::vector<StageTiming> stages = clock.stages();
    write_stages_csv(dir / "stages.csv", stages);
    return "## Run time by stage\n\n" + stage_table(stages) + "\n";
}

std::vector<std::vector<std::string>> embedded_csv_rows(std::string_view text) {
    std::vector<std::vector<std::string>> rows;
    std::size_t at = 0;
    while (at < text.size()) {
        std::size_t end = text.find('\n', at);
        if (end == std::string_view::npos) end = text.size();
        std::string_view line = text.substr(at, end - at);
        at = end + 1;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (line.empty()) continue;
        std::vector<std::string> cells;
        std::size_t from = 0;
        while (true) {
            const std::size_t comma = line.find(',', from);
            cells.emplace_back(
                line.substr(from, comma == std::string_view::npos ? comma : comma - from));
            if (comma == std::string_view::npos) break;
            from = comma + 1;
        }
        rows.push_back(std::move(cells));
    }
    return rows;
}

}  // namespace plumage::studies
