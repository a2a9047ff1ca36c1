// The small 2.5D physical-optics row the tests measure (three 6 µm barbules of the rock dove's
// shape) and the direction of (θ in the cross-section's plane, elevation out of it).
#pragma once

#include <cmath>

#include "sim/wave/surface/physical_optics_25d.h"

namespace plumage::sim::wave::po25d_test {

inline PhysicalOptics25dParams small_row() {
    PhysicalOptics25dParams p;
    p.row.cell = barbule_arc(geometry::EllipticalArc(3.0, 0.75, -0.37, 2.64), 0.59, 0.3);
    p.row.count = 3;
    p.row.spacing_um = 3.75;
    p.row.tilt_rad = -0.35;
    p.theta_d = 0.0785;
    return p;
}

inline Vec3d direction(double theta, double elevation) {
    return {std::cos(elevation) * std::sin(theta), std::sin(elevation),
            std::cos(elevation) * std::cos(theta)};
}

}  // namespace plumage::sim::wave::po25d_test
