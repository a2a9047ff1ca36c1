// The Lambertian reflector, f = ρ/π: the instruments' calibration target (a virtual
// Spectralon) and the simplest Scatterer. Parameter: albedo ρ ∈ [0, 1] (default 0.8).
#pragma once

#include "sim/scatterer/scatterer.h"

namespace plumage::analysis {

class LambertianScatterer final : public Scatterer {
public:
    explicit LambertianScatterer(double albedo = 0.8);  // InputError outside [0, 1]
    std::string name() const override { return "lambertian"; }
    const std::vector<std::string>& lobe_names() const override;
    // Cosine-weighted reflection into the upper hemisphere, weight ρ.
    std::optional<ScatterEvent> sample(const Vec3d& wi, double lambda_nm, const Vec2& position_um,
                                       Rng& rng) const override;
    bool can_evaluate() const override { return true; }
    double eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm,
                std::span<double> per_lobe = {}) const override;
    double pdf(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const override;
    double albedo() const { return albedo_; }

private:
    double albedo_;
};

}  // namespace plumage::analysis
