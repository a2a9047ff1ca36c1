#include "virtual_gonio/direction_sets.h"
#include "common/constants.h"

#include <cmath>

namespace plumage::gonio {
namespace {

constexpr double kPolarStepDeg = 15.0;
constexpr double kAzimuthStepDeg = 30.0;
constexpr int kAzimuthsPerPolar = 12;
constexpr double kInPlaneViewDeg = 45.0;
constexpr double kInPlaneFirstLightDeg = -81.0;
constexpr double kInPlaneLightStepDeg = 3.0;

// Polar angles first_step × 15°, ..., 75°, each with 12 azimuths; the pole (step 0) has one.
std::vector<Vec3d> rings(int first_step) {
    std::vector<Vec3d> directions;
    for (int step = first_step; step <= 5; ++step) {
        const double theta = step * kPolarStepDeg * kDeg;
        if (step == 0) {
            directions.push_back(Vec3d::UnitZ());
            continue;
        }
        for (int k = 0; k < kAzimuthsPerPolar; ++k) {
            directions.push_back(direction_from_angles(theta, k * kAzimuthStepDeg * kDeg));
        }
    }
    return directions;
}

}  // namespace

Vec3d direction_from_angles(double theta_rad, double phi_rad) {
    const double s = std::sin(theta_rad);
    return {s * std::cos(phi_rad), s * std::sin(phi_rad), std::cos(theta_rad)};
}

std::vector<Vec3d> filip2024_light_directions() { return rings(0); }
std::vector<Vec3d> filip2024_view_directions() { return rings(1); }

std::vector<DirectionPair> filip2024_btf_pairs() {
    const auto lights = filip2024_light_directions();
    const auto views = filip2024_view_directions();
    std::vector<DirectionPair> pairs;
    pairs.reserve(lights.size() * views.size());
    for (const Vec3d& wi : lights) {
        for (const Vec3d& wo : views) pairs.push_back({wi, wo});
    }
    return pairs;
}

std::vector<double> filip2024_in_plane_light_angles() {
    std::vector<double> angles;
    for (int k = 0; k < kFilip2024InPlanePairs; ++k) {
        angles.push_back((kInPlaneFirstLightDeg + k * kInPlaneLightStepDeg) * kDeg);
    }
    return angles;
}

std::vector<DirectionPair> filip2024_in_plane_pairs(double plane_azimuth_rad) {
    const Vec3d wo = direction_from_angles(kInPlaneViewDeg * kDeg, plane_azimuth_rad);
    std::vector<DirectionPair> pairs;
    for (double t : filip2024_in_plane_light_angles()) {
        // A negative angle is a positive polar angle on the far side: azimuth + π.
        const double phi = t >= 0.0 ? plane_azimuth_rad : plane_azimuth_rad + std::numbers::pi;
        pairs.push_back({direction_from_angles(std::abs(t), phi), wo});
    }
    return pairs;
}

}  // namespace plumage::gonio
