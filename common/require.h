// Preconditions on user input: a message naming the offending item and what was expected
// (invariants are PLUMAGE_CHECK's, common/error.h). One helper for every model, builder and
// instrument; both forms throw InputError (common/error.h), the type for "something a user gave
// us is wrong".
//
//     require(!pairs.empty(), "btf", "no direction pairs");
//         → InputError "btf: no direction pairs"
//     require(width > 0.0, "barbule", "width_um", width, "a finite value > 0");
//         → InputError "barbule: width_um = -1: expected a finite value > 0"
#pragma once

#include <cstddef>
#include <span>
#include <string_view>

namespace plumage {

// Throws InputError("<what>: <message>") unless ok.
void require(bool ok, std::string_view what, std::string_view message);

// Throws InputError("<what>: <key> = <value>: expected <expected>") unless ok; the value is
// printed as fmt's "{}" prints a double (shortest round-trip form).
void require(bool ok, std::string_view what, std::string_view key, double value,
             std::string_view expected);

// The wavelengths of a measurement, one rule for every instrument: 1 to kMaxWavelengths values,
// each finite and > 0 nm (a material's own band is its index's rule, sim/optics/material.h).
// InputError "<what>: wavelength 3 = -1 nm: expected a finite value > 0" otherwise.
inline constexpr std::size_t kMaxWavelengths = 4701;  // 360–830 nm at 0.1 nm
void require_wavelengths(std::span<const double> wavelengths_nm, std::string_view what);

}  // namespace plumage
