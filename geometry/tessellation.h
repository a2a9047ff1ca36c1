// Tolerances for turning analytic surfaces into triangles, so that error against
// tessellation can be studied: a flat facet of angular extent Δ on a surface of radius
// of curvature ρ departs from it by the chord error ρ(1 − cos(Δ/2)) ≈ ρΔ²/8, and its
// normal differs from the surface normal at its vertices by up to Δ/2.
#pragma once

namespace plumage::geometry {

struct TessellationTolerance {
    double max_chord_um = 0.01;          // largest facet-to-surface distance, µm
    double max_normal_error_rad = 0.02;  // largest facet-normal to surface-normal angle

    // Throws InputError unless both are finite and > 0.
    void validate() const;
    // Largest angular step on a curve of radius of curvature rho_um meeting both bounds.
    double max_angular_step(double rho_um) const;
};

// What a tessellation achieved (bounds evaluated on the generated facets).
struct TessellationReport {
    double max_chord_um = 0.0;
    double max_normal_error_rad = 0.0;
    unsigned long triangles = 0;
};

}  // namespace plumage::geometry
