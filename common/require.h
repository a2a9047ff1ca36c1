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

#include <string_view>

namespace plumage {

// Throws InputError("<what>: <message>") unless ok.
void require(bool ok, std::string_view what, std::string_view message);

// Throws InputError("<what>: <key> = <value>: expected <expected>") unless ok; the value is
// printed as fmt's "{}" prints a double (shortest round-trip form).
void require(bool ok, std::string_view what, std::string_view key, double value,
             std::string_view expected);

}  // namespace plumage
