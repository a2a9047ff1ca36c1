#include "common/parameter_spec.h"

#include <cmath>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage {

bool ParameterSpec::contains(double v) const {
    if (!std::isfinite(v)) return false;
    if (min_open ? !(v > min) : !(v >= min)) return false;
    if (max_open ? !(v < max) : !(v <= max)) return false;
    return !integer || v == std::floor(v);
}

std::string ParameterSpec::range_text() const {
    const bool low = std::isfinite(min), high = std::isfinite(max);
    if (low && high) {
        return fmt::format("{}{}, {}{}", min_open ? '(' : '[', min, max, max_open ? ')' : ']');
    }
    if (low) return fmt::format("{} {}", min_open ? ">" : ">=", min);
    if (high) return fmt::format("{} {}", max_open ? "<" : "<=", max);
    return "any finite value";
}

void ParameterSpec::require(double value, std::string_view what) const {
    if (contains(value)) return;
    const std::string unit_text = unit == "1" ? "" : fmt::format(" {}", unit);
    throw InputError(fmt::format("{}: {} = {}{}: expected {} in {}{}{}", what, name, value,
                                 unit_text, meaning.empty() ? "a value" : meaning, range_text(),
                                 unit_text, integer ? " (a whole number)" : ""));
}

}  // namespace plumage
