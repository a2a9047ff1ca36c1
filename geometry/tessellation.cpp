#include "geometry/tessellation.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::geometry {

void TessellationTolerance::validate() const {
    if (!std::isfinite(max_chord_um) || !(max_chord_um > 0.0)) {
        throw InputError(fmt::format("tessellation: max_chord_um = {}: expected a finite value > 0",
                                     max_chord_um));
    }
    if (!std::isfinite(max_normal_error_rad) || !(max_normal_error_rad > 0.0) ||
        max_normal_error_rad > 0.5) {
        throw InputError(
            fmt::format("tessellation: max_normal_error_rad = {}: expected a value in (0, 0.5]",
                        max_normal_error_rad));
    }
}

double TessellationTolerance::max_angular_step(double rho_um) const {
    // Chord: ρ(1 − cos(Δ/2)) <= ε  ⇔  Δ <= 2 acos(1 − ε/ρ); normal: Δ/2 <= ε_n.
    const double chord_step = 2.0 * std::acos(std::max(-1.0, 1.0 - max_chord_um / rho_um));
    return std::min(chord_step, 2.0 * max_normal_error_rad);
}

}  // namespace plumage::geometry
