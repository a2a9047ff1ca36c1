#include "studies/study.h"

#include <algorithm>
#include <array>

#include <fmt/format.h>

#include "common/error.h"
#include "studies/ablation_study.h"
#include "studies/extremes_study.h"
#include "studies/masking_study.h"
#include "studies/rock_dove_study.h"
#include "studies/species_study.h"
#include "studies/study_file.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

std::string run_rock_dove(const std::string& text, const fs::path& source, const fs::path& root,
                          const RunLimits& limits) {
    const auto r = run_rock_dove_study(text, source, root, true, limits);
    return fmt::format("plumage: wrote {} in {:.0f} s (open report.md)\n", r.output_dir.string(),
                       r.wall_seconds);
}

std::string run_ablation(const std::string& text, const fs::path& source, const fs::path& root,
                         const RunLimits& limits) {
    const auto r = run_ablation_study(text, source, root, true, limits);
    return fmt::format("plumage: wrote {} in {:.0f} s ({} values skipped; open report.md)\n",
                       r.output_dir.string(), r.wall_seconds, r.skipped);
}

std::string run_extremes(const std::string& text, const fs::path& source, const fs::path& root,
                         const RunLimits& limits) {
    refuse_limits("extremes", limits,
                  "its checks are exact sweeps over fixed grids, not progressive measurements");
    const auto r = run_extremes_study(text, source, root, true);
    return fmt::format(
        "plumage: wrote {} in {:.0f} s: numerical violations {}, energy > 1 {}, energy > 1 by "
        "the published model's construction {} (open report.md)\n",
        r.output_dir.string(), r.wall_seconds, r.numerical_violations, r.energy_violations,
        r.by_construction);
}

std::string run_species(const std::string& text, const fs::path& source, const fs::path& root,
                        const RunLimits& limits) {
    const auto r = run_species_study(text, source, root, true, limits);
    std::string summary = fmt::format("plumage: wrote {} in {:.0f} s (open report.md)\n",
                                      r.output_dir.string(), r.wall_seconds);
    for (const auto& o : r.species) {
        summary += fmt::format(
            "  {}: Filip fit reduced chi2 {:.2f}, relative L1 {:.1f} % (Table 1: {:.1f} %), "
            "reciprocity chi2/dof {:.2f}\n",
            o.species, o.reduced_chi_square, 100.0 * o.fit_relative_l1,
            100.0 * o.table1_relative_l1,
            o.reciprocity_chi_square / std::max(1, o.reciprocity_dof));
    }
    return summary;
}

std::string run_masking(const std::string& text, const fs::path& source, const fs::path& root,
                        const RunLimits& limits) {
    refuse_limits("masking", limits,
                  "its Monte Carlo sample count is set in the study file so that the verdict's "
                  "Sidak bound holds");
    const auto r = run_masking_study(text, source, root, true);
    return fmt::format(
        "plumage: wrote {} in {:.0f} s: {} configuration(s) x {} angles, max |analytic - MC| "
        "{:.2e}, max |z| {:.3f} (Sidak bound {:.2f}): {} (open report.md)\n",
        r.output_dir.string(), r.wall_seconds, r.configurations.size(), r.angles_deg.size(),
        r.max_abs_difference, r.max_abs_z, r.z_bound, r.agrees ? "agrees" : "DISAGREES");
}

constexpr std::array kRegistry{
    StudyEntry{"rock_dove",
               "explicit rock-dove barbules against Huang et al. 2022 (scatterograms, Filip BRDF, "
               "in-plane, validation, convergence)",
               check_rock_dove_study, run_rock_dove},
    StudyEntry{"ablation", "one-at-a-time sweeps of Huang's parameters, simulation against model",
               check_ablation_study, run_ablation},
    StudyEntry{"extremes", "stiff and extreme cases through every scatterer", check_extremes_study,
               run_extremes},
    StudyEntry{"species", "the four Filip 2024 feathers built explicitly, measured and fitted",
               check_species_study, run_species},
    StudyEntry{"masking", "Padron-Griffe's masking term against Monte Carlo", check_masking_study,
               run_masking},
};

}  // namespace

std::span<const StudyEntry> study_registry() { return kRegistry; }

const StudyEntry& study_of(const std::string& text, const fs::path& source) {
    auto file = StudyFile::parse(text, source);
    ParameterTable root = file->root();
    if (!root.has("study") && root.has("geometry")) {
        throw InputError(fmt::format(
            "{}: this is a geometry file (a [geometry] table and no `study` key): build it with "
            "`plumage geometry {}`",
            source.string(), source.string()));
    }
    std::vector<std::string> kinds;
    for (const StudyEntry& entry : kRegistry) kinds.emplace_back(entry.kind);
    const std::string kind =
        root.required_string("study", kinds, "which study this file describes");
    return *std::find_if(kRegistry.begin(), kRegistry.end(),
                         [&](const StudyEntry& e) { return e.kind == kind; });
}

void check_study(const std::string& text, const fs::path& source) {
    study_of(text, source).check(text, source);
}

void refuse_limits(std::string_view study, const RunLimits& limits, std::string_view why) {
    if (!limits.any()) return;
    throw InputError(fmt::format(
        "--time-budget and --target-error do not apply to the {} study: {} (Ctrl-C still stops "
        "it)",
        study, why));
}

}  // namespace plumage::studies
