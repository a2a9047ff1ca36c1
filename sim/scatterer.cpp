#include "sim/scatterer.h"

#include "common/error.h"

namespace plumage {

double Scatterer::eval(const Vec3d&, const Vec3d&, double, std::span<double>) const {
    throw InvariantError(
        name() +
        " cannot evaluate f(wi, wo): it is a Monte Carlo scatterer (check can_evaluate())");
}

double Scatterer::pdf(const Vec3d&, const Vec3d&, double) const {
    throw InvariantError(name() + " has no sampling density (check can_evaluate())");
}

}  // namespace plumage
