// A film's unpolarised R and T at one wavelength, seen from one side, tabulated in cos θ.
//
// Why: the tracer evaluates the film at every film hit, and the Airy summation (s and p,
// with its input checks) costs about 430 ns (bench/README.md), more than an Embree ray on
// this machine. The instruments trace many paths per wavelength of their grid, so a table
// per wavelength pays for itself after a few hundred film hits.
//
// Grid and error bound: uniform in c = cos θ on [1/8, 1], linear interpolation. The
// interpolation error in an interval of width h is (h²/8)|f''(ξ)| at most, attained near
// the midpoint; the table doubles its resolution (129 … 8193 nodes) until, at EVERY
// interval midpoint, |interpolated − exact| <= tolerance / 4 for both R and T. f''
// changes by far less than a factor of 4 within one interval once the midpoints are that
// accurate, so the error anywhere is below `tolerance` (default 1e-5, absolute); the test
// checks it at 10⁵ random points against direct evaluation. A 0.59 µm keratin film in
// air takes 1025 nodes per side and wavelength (16 kB).
//
// Below c = 1/8 (beyond 82.8°) hits are evaluated directly: towards grazing both of the
// film's internal reflection coefficients approach unit modulus, its finesse grows
// without bound and R(c) develops resonances of width ∝ c, which no uniform grid follows
// (the first interval alone needed 16385 nodes at 700 nm for the rock-dove film). Such
// hits are rare under near-normal light (a fraction ≈ c²/2 of the hits on a convex
// fibre) and cost one Airy evaluation each.
//
// When the response is not smooth in c the table is refused (build() returns nullopt) and
// the tracer evaluates directly: when light can be totally reflected inside the film or
// at its far side (the incidence index exceeds the film's or the exit medium's real
// index), R has a square-root kink at the critical angle that linear interpolation
// cannot follow, and when 8193 nodes do not meet the tolerance (thick coherent films,
// whose fringes in c are too dense: flag them incoherent, see sim/optics/multilayer.h).
#pragma once

#include <algorithm>
#include <cstddef>
#include <optional>
#include <vector>

#include "sim/interface_events.h"

namespace plumage::sim {

class FilmTable {
public:
    static constexpr double kDefaultTolerance = 1e-5;
    static constexpr int kMinNodes = 129;
    static constexpr int kMaxNodes = 8193;

    static std::optional<FilmTable> build(const FilmOptics& film, bool from_outside,
                                          double lambda_nm, double tolerance = kDefaultTolerance);

    static constexpr double kMinCos = 0.125;  // below: not tabulated (see above)

    // cos_theta in [kMinCos, 1] (clamped to it). Inline: the tracer calls it at every film hit.
    FilmResponse operator()(double cos_theta) const {
        const double x = (std::clamp(cos_theta, kMinCos, 1.0) - kMinCos) * scale_;
        const std::size_t i = std::min(static_cast<std::size_t>(x), nodes_.size() - 2);
        const double f = x - static_cast<double>(i);
        const FilmResponse& lo = nodes_[i];
        const FilmResponse& hi = nodes_[i + 1];
        return {lo.reflectance + f * (hi.reflectance - lo.reflectance),
                lo.transmittance + f * (hi.transmittance - lo.transmittance)};
    }
    int nodes() const { return static_cast<int>(nodes_.size()); }
    // Largest |interpolated − exact| found at the interval midpoints (R and T).
    double midpoint_error() const { return midpoint_error_; }

private:
    // R and T side by side: a look-up reads one or two adjacent cache lines, not two apart.
    std::vector<FilmResponse> nodes_;
    double scale_ = 0.0;  // c ↦ (c − kMinCos) · scale_ is the fractional node index
    double midpoint_error_ = 0.0;
};

// Film responses from tables for both sides, falling back to direct evaluation for a
// side whose table was refused.
class TabulatedFilmResponse final : public FilmResponseSource {
public:
    TabulatedFilmResponse(const FilmOptics& film, double lambda_nm, const FilmTable* outside,
                          const FilmTable* inside)
        : direct_(film, lambda_nm), outside_(outside), inside_(inside) {}
    FilmResponse response(bool from_outside, double cos_theta) const override {
        const FilmTable* table = from_outside ? outside_ : inside_;
        return table != nullptr && cos_theta >= FilmTable::kMinCos
                   ? (*table)(cos_theta)
                   : direct_.response(from_outside, cos_theta);
    }

private:
    DirectFilmResponse direct_;
    const FilmTable* outside_;
    const FilmTable* inside_;
};

}  // namespace plumage::sim
