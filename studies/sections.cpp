#include "studies/sections.h"

#include <fmt/format.h>

#include "common/error.h"
#include "sim/optics/spectrum.h"
#include "sim/random.h"

namespace plumage::studies {

std::string study_name_problem(std::string_view name) {
    if (name.empty()) return "is empty";
    if (name == "." || name == "..") return "is a relative folder reference";
    if (name.size() > kMaxStudyNameLength) {
        return fmt::format("has {} characters (at most {})", name.size(), kMaxStudyNameLength);
    }
    for (const char c : name) {
        const bool plain = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') ||
                           (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
        if (!plain) {
            return fmt::format("contains '{}' (only letters, digits, '.', '_' and '-')",
                               c == '/' ? std::string("/") : std::string(1, c));
        }
    }
    return {};
}

std::string read_study_name(ParameterTable& root, const std::filesystem::path& source) {
    const bool given = root.has("name");
    const std::string name = root.string("name", source.stem().string(), {}, "results folder name");
    const std::string problem = study_name_problem(name);
    if (problem.empty()) return name;
    if (given) {
        throw InputError(fmt::format(
            "{}: name = \"{}\" {}: expected one plain folder name inside the results root "
            "({} characters at most from [A-Za-z0-9._-], not \".\" or \"..\")",
            root.location("name"), name, problem, kMaxStudyNameLength));
    }
    throw InputError(fmt::format(
        "{}: the results folder name defaults to the file's stem \"{}\", which {}: set name = "
        "\"...\" (one plain folder name from [A-Za-z0-9._-])",
        source.string(), name, problem));
}

std::uint64_t read_seed(ParameterTable& root) {
    return static_cast<std::uint64_t>(
        root.integer("seed", static_cast<long>(kDefaultSeed), 0, 1L << 62, "random seed"));
}

std::vector<double> read_wavelengths(ParameterTable& table, const WavelengthRule& rule) {
    const std::string range = fmt::format("{} nm, {}", rule.min_nm, rule.range_reason);
    const double first =
        table.number("first_nm", rule.first_nm, between(rule.min_nm, rule.max_nm),
                     fmt::format("first wavelength, nm; {}-{}", rule.min_nm, range));
    const double last = table.number("last_nm", rule.last_nm, between(rule.min_nm, rule.max_nm),
                                     fmt::format("last wavelength, nm; {}-{}", rule.min_nm, range));
    const double step = table.number("step_nm", rule.step_nm, positive(), "wavelength step, nm");
    if (!(last > first)) {
        throw InputError(fmt::format("{}: {}.last_nm = {} is not above first_nm = {}",
                                     table.location("last_nm"), table.path(), last, first));
    }
    const double count = optics::WavelengthGrid::uniform_count(first, last, step);
    const auto max_count = optics::WavelengthGrid::kMaxWavelengths;
    if (count > static_cast<double>(max_count)) {
        throw InputError(fmt::format(
            "{}: {}.step_nm = {} gives {:.3g} wavelengths over {}-{} nm: expected at most {} "
            "(step_nm >= {:.4g})",
            table.location("step_nm"), table.path(), step, count, first, last, max_count,
            (last - first) / static_cast<double>(max_count - 1)));
    }
    if (count < 2.0) {
        throw InputError(fmt::format(
            "{}: [{}] gives 1 wavelength ({} nm; step_nm = {} exceeds last_nm - first_nm): "
            "expected at least 2 for colour",
            table.location(), table.path(), first, step));
    }
    const optics::WavelengthGrid grid = optics::WavelengthGrid::uniform(first, last, step);
    return {grid.nm().begin(), grid.nm().end()};
}

}  // namespace plumage::studies
