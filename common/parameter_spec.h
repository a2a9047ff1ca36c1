// One parameter of a model or an instrument, as its table next to its type states it: the name
// users write (study keys, fit names, Python), the unit, the default, the range and the meaning.
// The tables (analysis/models/filip2024.h, analysis/models/huang2022.h,
// virtual_gonio/instrument_registry.h's instruments) are arrays of these, and every rule that needs
// a parameter's range takes it from there: the model's own validation, the fits' bounds, the
// studies' readers and sweeps, the Python bindings. A quantity's range is then written once.
#pragma once

#include <limits>
#include <string>
#include <string_view>

namespace plumage {

struct ParameterSpec {
    std::string_view name;
    std::string_view unit;  // "1" for dimensionless
    double default_value = 0.0;
    double min = -std::numeric_limits<double>::infinity();
    double max = std::numeric_limits<double>::infinity();
    bool min_open = false, max_open = false;  // a bound the value may not take
    bool integer = false;                     // whole numbers only
    std::string_view meaning;

    // Finite, within the range, and whole when `integer`.
    bool contains(double value) const;
    // The range as "[1e-3, 1]", "(0, 0.785398]", "> 0" or "any finite value".
    std::string range_text() const;
    // InputError "<what>: <name> = <value>: expected <meaning> in <range> <unit>" unless
    // contains(value).
    void require(double value, std::string_view what) const;
};

}  // namespace plumage
