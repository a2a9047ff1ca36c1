#include "sim/medium.h"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::sim {

HomogeneousAbsorbingMedium::HomogeneousAbsorbingMedium(
    std::shared_ptr<const optics::Material> material)
    : material_(std::move(material)) {
    if (!material_) throw InputError("absorbing medium: material is null: expected a material");
}

std::string HomogeneousAbsorbingMedium::name() const {
    return "beer-lambert(" + material_->name() + ")";
}

double HomogeneousAbsorbingMedium::absorption_coefficient_per_um(double lambda_nm) const {
    const double k = material_->index(lambda_nm).imag();
    return 4.0 * std::numbers::pi * k / (lambda_nm * 1e-3);
}

bool HomogeneousAbsorbingMedium::active(double lambda_nm) const {
    return material_->index(lambda_nm).imag() > 0.0;
}

MediumFlight HomogeneousAbsorbingMedium::fly(double segment_um, double lambda_nm, Rng&) const {
    PLUMAGE_CHECK(std::isfinite(segment_um) && segment_um >= 0.0,
                  fmt::format("segment length {} um", segment_um));
    // exp of a large negative number underflows to 0, never to NaN (k = 10 over 1 mm).
    return {false, segment_um, std::exp(-absorption_coefficient_per_um(lambda_nm) * segment_um)};
}

MediumScatter HomogeneousAbsorbingMedium::scatter(const Vec3d&, double, Rng&) const {
    throw InvariantError(name() + " was asked to scatter: it only absorbs");
}

}  // namespace plumage::sim
