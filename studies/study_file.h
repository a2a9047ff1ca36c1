// Study files (TOML) with pbrt-style parameter checking: every key a study may hold is
// asked for by name, type and valid range; a key nobody asked for is an error. Errors
// name the file, the line and column, the full key and what was expected, e.g.
//   rock_dove.toml:12:5: geometry.row.H = -1: expected a number > 0 (barbule spacing, in
//   units of the semi-major axis)
// Angles are written in degrees in study files (keys end in _deg) and returned in
// radians.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace toml {
inline namespace v3 {
class table;
class node;
}  // namespace v3
}  // namespace toml

namespace plumage::studies {

class StudyFile;

// Inclusive numeric range with a human description of the quantity.
struct Range {
    double min = -1e300;
    double max = 1e300;
    bool min_exclusive = false;
    bool max_exclusive = false;
};
Range positive();
Range non_negative();
Range between(double lo, double hi);

class ParameterTable {
public:
    // Typed getters; each marks the key as used. `what` describes the quantity and unit
    // for error messages ("barbule spacing, in units of the semi-major axis").
    double number(std::string_view key, double default_value, Range range, std::string_view what);
    double required_number(std::string_view key, Range range, std::string_view what);
    // key must end in "_deg"; the value is returned in radians, range given in degrees.
    double angle_deg(std::string_view key, double default_radians, Range range_deg,
                     std::string_view what);
    long integer(std::string_view key, long default_value, long min, long max,
                 std::string_view what);
    // A list of numbers (`key = [0.5, 1, 2]`), each within range, from min_count to max_count
    // of them; an absent key gives default_values.
    std::vector<double> numbers(std::string_view key, const std::vector<double>& default_values,
                                Range range, std::size_t min_count, std::size_t max_count,
                                std::string_view what);
    bool boolean(std::string_view key, bool default_value, std::string_view what);
    std::string string(std::string_view key, std::string_view default_value,
                       const std::vector<std::string>& allowed, std::string_view what);
    std::string required_string(std::string_view key, const std::vector<std::string>& allowed,
                                std::string_view what);
    bool has(std::string_view key) const;
    // The keys of this table in the order the file writes them (for tables of named entries,
    // e.g. [configurations.NAME]); listing does not mark them as used.
    std::vector<std::string> keys() const;
    // A sub-table (section); empty table if absent. Marks the key as used.
    ParameterTable table(std::string_view key);

    // Throws InputError naming every key below this table (recursively) that no getter
    // asked for, each with its line. Call it once on the root after reading a study.
    void reject_unused() const;
    // "file:line:col" of this table (or of one of its keys), for errors raised later.
    std::string location(std::string_view key = {}) const;
    // The value of `key` as the file writes it ("3e2", "[400, 500]"); "" when it is absent.
    std::string written(std::string_view key) const;
    const std::string& path() const { return path_; }

private:
    friend class StudyFile;
    ParameterTable(std::shared_ptr<const StudyFile> file, const toml::table* table,
                   std::string path);
    const toml::node* find(std::string_view key);
    std::string full_key(std::string_view key) const;
    [[noreturn]] void fail(std::string_view key, const std::string& message) const;

    std::shared_ptr<const StudyFile> file_;
    const toml::table* table_;  // null: the section is absent
    std::string path_;
};

class StudyFile : public std::enable_shared_from_this<StudyFile> {
public:
    // Parses the file; InputError with file:line:col on a syntax error or missing file.
    static std::shared_ptr<StudyFile> load(const std::filesystem::path& path);
    static std::shared_ptr<StudyFile> parse(std::string_view text,
                                            const std::filesystem::path& name);
    ~StudyFile();

    ParameterTable root();
    const std::filesystem::path& path() const { return path_; }
    const std::string& text() const { return text_; }

private:
    friend class ParameterTable;
    StudyFile() = default;
    // Full dotted keys that some getter asked for.
    mutable std::set<std::string, std::less<>> used_;
    std::filesystem::path path_;
    std::string text_;
    std::unique_ptr<toml::table> table_;
};

}  // namespace plumage::studies
