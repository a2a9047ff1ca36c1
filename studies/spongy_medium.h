// Channel-type spongy keratin as a scattering medium for the tracer, from its structure alone:
// the glue the studies share between a generated volume and sim::ScatteringMedium (DESIGN.md's
// level 2 of physics). The species study fills the parrot's barb medulla with it; the spongy
// study's build_case computes the same medium for its slabs (same steps, same seeds and medium
// name: build_spongy_medium is a drop-in for it).
//
// The route (each step the file named): geometry::make_channel_volume (a periodic cube of
// channel-type keratin/air network, geometry/spongy_volume.h) → sim::wave::sample_indicator
// (its keratin indicator on the voxel grid, index_field.h) → PowerSpectrum::measure_3d (the
// indicator's power spectrum, power_spectrum.h) → sim::wave::born_medium at every wavelength
// (first-Born μ_s, phase function and μ_a with the Bruggeman n_eff, born_medium.h) →
// sim::ScatteringMedium (the tables, linear in λ between them; it refuses wavelengths outside
// them, sim/scattering_medium.h). No colour enters: μ_s(λ) and the phase function come from
// the power spectrum (its peak at q = 2π/Λ met by q = 2 k0 n_eff sin(θ/2)) and the k0⁴ of the
// Born cross-section. For Λ = 0.19 µm, f = 0.5 μ_s falls from 0.73 µm⁻¹ at 400 nm to 0.011 at
// 700 nm, so a traced body of it reflects most in the blue.
//
// Parameter table (InputError names the parameter and value; geometry/spongy_volume.h and
// sim/wave check the rest again):
//  | name                 | unit | default | valid range                                    |
//  |----------------------|------|---------|------------------------------------------------|
//  | length_scale_um      | µm   | 0.19    | (2 voxel_um, box_um / 4]: the channel spacing Λ |
//  |                      |      |         | (Λ = 2π / peak wavenumber of the spectrum)     |
//  | keratin_fraction     | 1    | 0.5     | [0.1, 0.9]: keratin filling fraction f         |
//  | shell_relative_width | 1    | 0.15    | (0, 1]: spectral shell width / k0              |
//  | box_um               | µm   | 2.0     | a whole number of voxels, 4–512 per side       |
//  | voxel_um             | µm   | 0.025   | <= λ_min / (4 n_keratin(λ_min)) (index_field.h) |
//  | seed                 |      | 1       | the volume's random stream (common/seed.h)     |
//  | keratin              |      | keratin | the solid phase's material (non-null)          |
// Wavelengths: at least one, finite, within 300–1000 nm (keratin's dispersion range), each
// traced wavelength of a study must be among them (the medium is exact only at its tables).
//
// Literature values for macaw-blue (Ara ararauna) channel-type keratin: Λ ≈ 0.18–0.20 µm (the
// SAXS ring's peak spacing), f ≈ 0.5 (Prum et al. 1998, 1999; Saranathan et al. 2012).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "sim/optics/material.h"
#include "sim/scattering_medium.h"
#include "sim/wave/born_medium.h"

namespace plumage::studies {

class ParameterTable;

struct SpongyMediumParams {
    double length_scale_um = 0.19;
    double keratin_fraction = 0.5;
    double shell_relative_width = 0.15;
    double box_um = 2.0;
    double voxel_um = 0.025;
    std::uint64_t seed = 1;
    std::shared_ptr<const optics::Material> keratin = optics::keratin();

    void validate() const;  // InputError naming the parameter (not the voxel limit: below)
};

struct SpongyMedium {
    // What the generated volume measured (requested values are in the params).
    double measured_fraction = 0.0;      // mean of the voxel indicator
    double measured_scale_um = 0.0;      // 2π / peak wavenumber of the radial spectrum
    double isotropy = 1.0;               // eigenvalue ratio of the peak shell (power_spectrum.h)
    std::vector<double> wavelengths_nm;  // sorted, distinct
    std::vector<sim::wave::ScatteringTable> tables;  // one per wavelength, same order
    std::shared_ptr<const sim::ScatteringMedium> medium;
};

// The largest voxel side sim/wave accepts for these wavelengths: min over λ of
// λ / (4 n_keratin(λ)) in µm (the shortest λ decides for normally dispersive keratin).
double finest_voxel_limit_um(const std::vector<double>& wavelengths_nm,
                             const optics::Material& keratin = *optics::keratin());

// The same limit at read time: InputError at table.location(key) (file:line:col) when
// voxel_um exceeds it, naming the wavelength and the limit.
void require_fine_voxels(ParameterTable& table, std::string_view key, double voxel_um,
                         const std::vector<double>& wavelengths_nm,
                         const optics::Material& keratin = *optics::keratin());

// The medium at every wavelength given (duplicates merged, sorted), with weighted absorption
// sampling (sim/scattering_medium.h). `name` names the medium in the tracer's messages.
SpongyMedium build_spongy_medium(const SpongyMediumParams& params,
                                 const std::vector<double>& wavelengths_nm, std::string name = {});

}  // namespace plumage::studies
