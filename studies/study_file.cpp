#include "studies/study_file.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/spelling.h"

namespace plumage::studies {

// No upper cap beyond finiteness: a key with a physical ceiling states it with between().
Range positive() { return {0.0, std::numeric_limits<double>::infinity(), true, false}; }
Range non_negative() { return {0.0, std::numeric_limits<double>::infinity(), false, false}; }
Range between(double lo, double hi) { return {lo, hi, false, false}; }

namespace {

std::string describe(const Range& r) {
    const bool has_min = r.min > -1e299, has_max = r.max < 1e299;
    if (has_min && has_max) {
        return fmt::format("a number in {}{}, {}{}", r.min_exclusive ? "(" : "[", r.min, r.max,
                           r.max_exclusive ? ")" : "]");
    }
    if (has_min) return fmt::format("a finite number {} {}", r.min_exclusive ? ">" : ">=", r.min);
    if (has_max) return fmt::format("a finite number {} {}", r.max_exclusive ? "<" : "<=", r.max);
    return "a finite number";
}

bool within(const Range& r, double v) {
    if (!std::isfinite(v)) return false;
    if (r.min_exclusive ? !(v > r.min) : !(v >= r.min)) return false;
    if (r.max_exclusive ? !(v < r.max) : !(v <= r.max)) return false;
    return true;
}

// The unit of a key: its own suffix (_um, _nm), or its table's for the keys of a table named
// after a quantity (sweep.film_thickness_um.from).
std::string_view unit_of(std::string_view full_key) {
    for (int level = 0; level < 2 && !full_key.empty(); ++level) {
        const auto dot = full_key.rfind('.');
        const std::string_view leaf =
            dot == std::string_view::npos ? full_key : full_key.substr(dot + 1);
        if (leaf.ends_with("_um") || leaf.ends_with("_nm")) return leaf.substr(leaf.size() - 2);
        full_key = dot == std::string_view::npos ? std::string_view{} : full_key.substr(0, dot);
    }
    return {};
}

// For a value outside its range that would be inside it in the other length unit of study files
// (590 for a film of 0.59 um), what was most likely meant; "" otherwise.
std::string unit_hint(std::string_view full_key, const Range& r, double v) {
    const std::string_view unit = unit_of(full_key);
    if (unit == "um" && within(r, v / 1000.0)) {
        return fmt::format("; {} looks like nanometres; the key is in µm ({} nm = {} µm)", v, v,
                           v / 1000.0);
    }
    if (unit == "nm" && within(r, v * 1000.0)) {
        return fmt::format("; {} looks like micrometres; the key is in nm ({} µm = {} nm)", v, v,
                           v * 1000.0);
    }
    return {};
}

std::string type_name(const toml::node& node) {
    switch (node.type()) {
        case toml::node_type::table:
            return "a table";
        case toml::node_type::array:
            return "an array";
        case toml::node_type::string:
            return "a string";
        case toml::node_type::integer:
            return "an integer";
        case toml::node_type::floating_point:
            return "a number";
        case toml::node_type::boolean:
            return "a boolean";
        default:
            return "a date or time";
    }
}

}  // namespace

ParameterTable::ParameterTable(std::shared_ptr<const StudyFile> file, const toml::table* table,
                               std::string path)
    : file_(std::move(file)), table_(table), path_(std::move(path)) {}

std::string ParameterTable::full_key(std::string_view key) const {
    return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

std::string ParameterTable::location(std::string_view key) const {
    const toml::node* node = nullptr;
    if (table_ != nullptr && !key.empty()) node = table_->get(key);
    if (node == nullptr) node = table_;
    const std::string file = file_->path().string();
    if (node == nullptr || !node->source().begin) return file;
    return fmt::format("{}:{}:{}", file, node->source().begin.line, node->source().begin.column);
}

std::string ParameterTable::written(std::string_view key) const {
    const toml::node* node = table_ != nullptr ? table_->get(key) : nullptr;
    if (node == nullptr) return {};
    const toml::source_region& at = node->source();
    if (at.begin && at.end && at.begin.line == at.end.line) {
        // Columns count characters: the line's text is used only when it is plain ASCII.
        std::istringstream lines(file_->text());
        std::string line;
        for (std::uint32_t l = 0; l < at.begin.line; ++l) std::getline(lines, line);
        const bool ascii = std::all_of(line.begin(), line.end(),
                                       [](char c) { return static_cast<unsigned char>(c) < 128; });
        if (ascii && at.end.column > at.begin.column && at.end.column - 1 <= line.size())
            return line.substr(at.begin.column - 1, at.end.column - at.begin.column);
    }
    std::ostringstream text;
    if (const auto* value = node->as_floating_point())
        text << *value;
    else if (const auto* integer = node->as_integer())
        text << *integer;
    else
        text << type_name(*node);
    return text.str();
}

void ParameterTable::fail(std::string_view key, const std::string& message) const {
    throw InputError(fmt::format("{}: {} {}", location(key), full_key(key), message));
}

const toml::node* ParameterTable::find(std::string_view key) {
    file_->used_.insert(full_key(key));
    return table_ != nullptr ? table_->get(key) : nullptr;
}

bool ParameterTable::has(std::string_view key) const {
    return table_ != nullptr && table_->contains(key);
}

std::vector<std::string> ParameterTable::keys() const {
    if (table_ == nullptr) return {};
    std::vector<std::pair<std::pair<std::uint32_t, std::uint32_t>, std::string>> keyed;
    for (const auto& [key, node] : *table_) {
        const auto& at = key.source().begin ? key.source().begin : node.source().begin;
        keyed.push_back({{at.line, at.column}, std::string(key.str())});
    }
    std::sort(keyed.begin(), keyed.end());
    std::vector<std::string> names;
    for (auto& k : keyed) names.push_back(std::move(k.second));
    return names;
}

double ParameterTable::number(std::string_view key, double default_value, Range range,
                              std::string_view what) {
    const toml::node* node = find(key);
    if (node == nullptr) return default_value;
    std::optional<double> value;
    if (const auto* f = node->as_floating_point()) value = f->get();
    if (const auto* i = node->as_integer()) value = static_cast<double>(i->get());
    if (!value)
        fail(key, fmt::format("is {}: expected {} ({})", type_name(*node), describe(range), what));
    if (!within(range, *value)) {
        fail(key, fmt::format("= {}: expected {} ({}){}", *value, describe(range), what,
                              unit_hint(full_key(key), range, *value)));
    }
    return *value;
}

std::vector<double> ParameterTable::numbers(std::string_view key,
                                            const std::vector<double>& default_values, Range range,
                                            std::size_t min_count, std::size_t max_count,
                                            std::string_view what) {
    const toml::node* node = find(key);
    if (node == nullptr) return default_values;
    const std::string expected = fmt::format("a list of {} to {} numbers, each {} ({})", min_count,
                                             max_count, describe(range), what);
    const auto* array = node->as_array();
    if (array == nullptr) fail(key, fmt::format("is {}: expected {}", type_name(*node), expected));
    if (array->size() < min_count || array->size() > max_count)
        fail(key, fmt::format("has {} values: expected {}", array->size(), expected));
    std::vector<double> values;
    for (std::size_t i = 0; i < array->size(); ++i) {
        const toml::node& item = *array->get(i);
        std::optional<double> value;
        if (const auto* f = item.as_floating_point()) value = f->get();
        if (const auto* n = item.as_integer()) value = static_cast<double>(n->get());
        if (!value)
            fail(key, fmt::format("at [{}] is {}: expected {}", i, type_name(item), expected));
        if (!within(range, *value)) {
            fail(key, fmt::format("at [{}] = {}: expected {}{}", i, *value, expected,
                                  unit_hint(full_key(key), range, *value)));
        }
        values.push_back(*value);
    }
    return values;
}

double ParameterTable::required_number(std::string_view key, Range range, std::string_view what) {
    if (!has(key)) {
        file_->used_.insert(full_key(key));
        fail(key, fmt::format("is missing: expected {} ({})", describe(range), what));
    }
    return number(key, 0.0, range, what);
}

double ParameterTable::angle_deg(std::string_view key, double default_radians, Range range_deg,
                                 std::string_view what) {
    PLUMAGE_CHECK(key.ends_with("_deg"), std::string(key));
    // An absent key gives the default exactly: the round trip through degrees is not the
    // identity (0.0785 rad comes back as 0.07850000000000001), and a geometry built from a
    // study file that leaves a key out must equal the one built from the same defaults in code.
    if (find(key) == nullptr) return default_radians;
    return number(key, default_radians / kDeg, range_deg, what) * kDeg;
}

long ParameterTable::integer(std::string_view key, long default_value, long min, long max,
                             std::string_view what) {
    const toml::node* node = find(key);
    if (node == nullptr) return default_value;
    const auto* i = node->as_integer();
    if (i == nullptr)
        fail(key, fmt::format("is {}: expected an integer in [{}, {}] ({})", type_name(*node), min,
                              max, what));
    if (i->get() < min || i->get() > max) {
        fail(key,
             fmt::format("= {}: expected an integer in [{}, {}] ({})", i->get(), min, max, what));
    }
    return static_cast<long>(i->get());
}

bool ParameterTable::boolean(std::string_view key, bool default_value, std::string_view what) {
    const toml::node* node = find(key);
    if (node == nullptr) return default_value;
    const auto* b = node->as_boolean();
    if (b == nullptr)
        fail(key, fmt::format("is {}: expected true or false ({})", type_name(*node), what));
    return b->get();
}

std::string ParameterTable::string(std::string_view key, std::string_view default_value,
                                   const std::vector<std::string>& allowed, std::string_view what) {
    const toml::node* node = find(key);
    if (node == nullptr) return std::string(default_value);
    const auto* s = node->as_string();
    std::string choices;
    for (const auto& a : allowed) choices += (choices.empty() ? "" : ", ") + ("\"" + a + "\"");
    if (s == nullptr) {
        fail(key, fmt::format("is {}: expected a string{} ({})", type_name(*node),
                              allowed.empty() ? "" : " among " + choices, what));
    }
    if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), s->get()) == allowed.end()) {
        fail(key, fmt::format("= \"{}\": expected one of {} ({})", s->get(), choices, what));
    }
    return s->get();
}

std::string ParameterTable::required_string(std::string_view key,
                                            const std::vector<std::string>& allowed,
                                            std::string_view what) {
    if (!has(key)) {
        file_->used_.insert(full_key(key));
        fail(key, fmt::format("is missing: expected a string ({})", what));
    }
    return string(key, "", allowed, what);
}

ParameterTable ParameterTable::table(std::string_view key) {
    const toml::node* node = find(key);
    if (node != nullptr && !node->is_table()) {
        fail(key, fmt::format("is {}: expected a table ([{}])", type_name(*node), full_key(key)));
    }
    return ParameterTable(file_, node != nullptr ? node->as_table() : nullptr, full_key(key));
}

namespace {

using KeySet = std::set<std::string, std::less<>>;

std::string_view leaf_of(std::string_view full) {
    const auto dot = full.rfind('.');
    return dot == std::string_view::npos ? full : full.substr(dot + 1);
}

// "; did you mean 'scatterometer.image_size'?" for an unknown key: the nearest key that a getter
// asked for in the same table (within two edits), else the same key asked for in another table
// (a key in the wrong section); "" when there is neither.
std::string suggestion(const KeySet& used, const std::string& prefix, std::string_view typed) {
    std::vector<std::string> siblings;
    const std::string head = prefix.empty() ? "" : prefix + ".";
    for (const std::string& key : used) {
        if (key.starts_with(head) && key.find('.', head.size()) == std::string::npos)
            siblings.push_back(key.substr(head.size()));
    }
    const std::string near = nearest_name(typed, siblings);
    if (!near.empty()) return fmt::format("; did you mean '{}{}'?", head, near);
    // Of the tables that have the key, the one nearest this table (species.parrot.materials
    // for a key under species.parrot, not species.flamingo.materials).
    const std::string* best = nullptr;
    std::size_t best_shared = 0;
    for (const std::string& key : used) {
        if (key.find('.') == std::string::npos || leaf_of(key) != typed) continue;
        const auto shared = static_cast<std::size_t>(
            std::mismatch(key.begin(), key.end(), head.begin(), head.end()).first - key.begin());
        if (best == nullptr || shared > best_shared) best = &key, best_shared = shared;
    }
    if (best == nullptr) return {};
    return fmt::format("; did you mean '{}'? (it belongs in [{}])", *best,
                       best->substr(0, best->rfind('.')));
}

void collect_unused(const toml::table& table, const std::string& prefix, const KeySet& used,
                    const std::string& file, std::string& out) {
    for (const auto& [key, node] : table) {
        const std::string full =
            prefix.empty() ? std::string(key.str()) : prefix + "." + std::string(key.str());
        if (!used.contains(full)) {
            const auto& begin = key.source().begin ? key.source().begin : node.source().begin;
            out += fmt::format("\n  {}:{}:{}: unknown key '{}'{}", file, begin.line, begin.column,
                               full, suggestion(used, prefix, key.str()));
        } else if (const auto* sub = node.as_table()) {
            collect_unused(*sub, full, used, file, out);
        }
    }
}

}  // namespace

void ParameterTable::reject_unused() const {
    if (table_ == nullptr) return;
    std::string unknown;
    collect_unused(*table_, path_, file_->used_, file_->path().string(), unknown);
    if (!unknown.empty()) {
        throw InputError(fmt::format("{}: unknown keys (misspelt, or not used by this study):{}",
                                     file_->path().string(), unknown));
    }
}

StudyFile::~StudyFile() = default;

std::shared_ptr<StudyFile> StudyFile::parse(std::string_view text,
                                            const std::filesystem::path& name) {
    auto file = std::shared_ptr<StudyFile>(new StudyFile());
    file->path_ = name;
    file->text_ = std::string(text);
    try {
        file->table_ = std::make_unique<toml::table>(toml::parse(file->text_, name.string()));
    } catch (const toml::parse_error& e) {
        throw InputError(fmt::format("{}:{}:{}: not valid TOML: {}", name.string(),
                                     e.source().begin.line, e.source().begin.column,
                                     e.description()));
    }
    return file;
}

std::shared_ptr<StudyFile> StudyFile::load(const std::filesystem::path& path) {
    std::ifstream in(path);
    if (!in)
        throw InputError(
            fmt::format("{}: cannot open the study file (does it exist?)", path.string()));
    std::ostringstream text;
    text << in.rdbuf();
    return parse(text.str(), path);
}

ParameterTable StudyFile::root() { return ParameterTable(shared_from_this(), table_.get(), ""); }

}  // namespace plumage::studies
