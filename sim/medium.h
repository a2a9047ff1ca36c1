// Participating media: what happens to light between two surfaces.
//
// This is the seam where a volume is handled as a medium instead of as explicit interfaces.
// Spongy keratin can be traced both ways: as its explicit keratin/air mesh (geometric optics,
// the baseline: sim/scattering_slab.h's tiled_volume_slab_scene), or as the wave-optical
// medium whose scattering coefficient and phase function come from the volume's power
// spectrum (sim/wave/volume/born_medium.h → sim/scattering_medium.h), which the spongy study's
// slabs and the species study's parrot medulla use. The tracer is the same for both: it asks the
// medium for a free flight on every segment and for a new direction at every scattering
// event.
//
// Where media live: every surface of a scene names the medium on each of its two sides
// (sim/scene.h). The tracer takes the medium of a segment from the surface the segment
// ends on (the side the light arrives from), pbrt's "medium interface" rule, so media
// must be enclosed by surfaces; light that leaves the scene is in the ambient medium,
// which does not attenuate. The implementation here is Beer–Lambert absorption inside a
// homogeneous absorbing material (melanin, a k = 10 absorber); sim/scattering_medium.h
// scatters (tabulated μ_s, μ_a and phase function per wavelength, the wave-optical spongy
// keratin) and sim/scattering_slab.h builds a slab of it. The tracer files light that
// scattered in any medium under its "volume" lobe (sim/tracer.h); scenes whose media are all
// HomogeneousAbsorbingMedium have no such lobe.
//
// Units: distances in µm, wavelengths in nm (vacuum). Directions are propagation
// directions (where the light travels), unit vectors.
#pragma once

#include <memory>
#include <string>

#include <Eigen/Core>

#include "sim/optics/material.h"
#include "sim/scatterer/random.h"

namespace plumage::sim {

using Vec3d = Eigen::Vector3d;

// The outcome of a free flight of at most distance_um through a medium.
struct MediumFlight {
    bool scattered;      // the light scatters at distance_um (< the segment length)
    double distance_um;  // where it scatters, or the full segment length
    double weight;       // throughput factor over the flight, in [0, 1]
};

struct MediumScatter {
    Vec3d direction;  // new propagation direction, unit
    double weight;    // phase function / sampling density (1 for exact sampling), >= 0
};

class Medium {
public:
    virtual ~Medium() = default;
    virtual std::string name() const = 0;
    // Whether the medium does anything at this wavelength; the tracer skips inactive
    // media (a lossless keratin interior costs nothing).
    virtual bool active(double lambda_nm) const = 0;
    // Light travels segment_um (finite, >= 0) through the medium towards the next surface.
    virtual MediumFlight fly(double segment_um, double lambda_nm, Rng& rng) const = 0;
    // A scattering event (only after fly() returned scattered = true).
    virtual MediumScatter scatter(const Vec3d& direction, double lambda_nm, Rng& rng) const = 0;
};

// Beer–Lambert absorption in a homogeneous material of complex index n + ik:
// intensity falls as exp(−α s) over a path s with α = 4π k / λ (λ in µm). The direction
// of the light is that given by the real parts at the interfaces (sim/interface_events.h);
// for strong absorbers (k ≳ 0.1) light dies within a few wavelengths, so that choice is
// immaterial there, and for weak ones it is exact to O(k²).
class HomogeneousAbsorbingMedium final : public Medium {
public:
    explicit HomogeneousAbsorbingMedium(std::shared_ptr<const optics::Material> material);
    std::string name() const override;
    bool active(double lambda_nm) const override;
    MediumFlight fly(double segment_um, double lambda_nm, Rng& rng) const override;
    // Never called: the medium does not scatter (InvariantError).
    MediumScatter scatter(const Vec3d& direction, double lambda_nm, Rng& rng) const override;

    double absorption_coefficient_per_um(double lambda_nm) const;
    const std::shared_ptr<const optics::Material>& material() const { return material_; }

private:
    std::shared_ptr<const optics::Material> material_;
};

}  // namespace plumage::sim
