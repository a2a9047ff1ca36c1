// Spongy keratin (channel-type, or a packing of air spheres) as a scattering medium for the
// tracer, from its structure alone: the glue the studies share between a generated volume and
// sim::ScatteringMedium (the wave-optics level of physics, between the tracer's thin films and
// full wave). The species study fills the parrot's barb medulla with it (channel-type, first
// Born); the spongy study's build_case computes the same medium for its slabs (same steps, same
// seeds and medium name: build_spongy_medium is a drop-in for it).
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
// Sphere packings and the sphere route. With morphology = spheres the volume is air spheres of
// radius sphere_radius_um in keratin (geometry::make_sphere_volume, random sequential addition
// with minimum centre separation s = min_separation_diameters × 2a); length_scale_um and
// shell_relative_width are then unused. The Born route runs on it as on any volume. When the
// spheres are disjoint (min_separation_diameters >= 1: a hard-sphere packing) the sphere route
// runs as well: the structure factor S(q) of the centres measured in the periodic box
// (sim/wave/volume/structure_factor.h; linear in q between shells, held at the first shell below
// it, as the Born route holds its spectrum), times Mie of one air sphere in the Bruggeman medium of
// air at the spheres' volume fraction φ = N (4π/3) a³ / L³ and keratin (sim::wave::sphere_medium;
// the effective-medium convention of structcol: each sphere's contrast is to ε_eff). The two
// routes differ by 1/(1 − φ)² in μ_s even at weak contrast (sim/wave/volume/born_medium.h).
//  | sphere_radius_um         | µm | 0.1 | (voxel_um, box_um / 4]: radius a of the air spheres |
//  | min_separation_diameters | 1  | 1.0 | (0, 2]: s / 2a; >= 1 disjoint (the sphere route)   |
// The sphere route's validity, refused by require_sphere_route: a sphere packing (morphology
// spheres, min_separation_diameters >= 1), φ = 1 − keratin_fraction in (0, 0.35] (random
// sequential addition of disjoint spheres jams at φ ≈ 0.38, geometry/spongy_volume.h), and
// polydispersity 0 (the generated packings are monodisperse; so is the route's Mie term).
//
// Literature values for macaw-blue (Ara ararauna) channel-type keratin: Λ ≈ 0.18–0.20 µm (the
// SAXS ring's peak spacing), f ≈ 0.5 (Prum et al. 1998, 1999; Saranathan et al. 2012).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "geometry/spongy_volume.h"
#include "sim/optics/material.h"
#include "sim/scattering_medium.h"
#include "sim/wave/volume/born_medium.h"

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
    geometry::SpongyMorphology morphology = geometry::SpongyMorphology::channel;
    double sphere_radius_um = 0.1;
    double min_separation_diameters = 1.0;

    void validate() const;  // InputError naming the parameter (not the voxel limit: below)
};

struct SpongyMedium {
    // What the generated volume measured (requested values are in the params).
    double measured_fraction = 0.0;      // mean of the voxel indicator
    double measured_scale_um = 0.0;      // 2π / peak wavenumber of the radial spectrum
    double isotropy = 1.0;               // eigenvalue ratio of the peak shell (power_spectrum.h)
    std::vector<double> wavelengths_nm;  // sorted, distinct
    std::vector<sim::wave::ScatteringTable> tables;       // one per wavelength, same order
    std::shared_ptr<const sim::ScatteringMedium> medium;  // the Born route
    // The sphere route (sphere packings only; empty otherwise), same wavelengths and order.
    double sphere_fraction = 0.0;  // φ = N (4π/3) a³ / L³ of the air spheres
    std::vector<sim::wave::ScatteringTable> sphere_tables;
    std::shared_ptr<const sim::ScatteringMedium> sphere_medium;
};

// The medium's route: first Born on the volume's power spectrum (any volume), or Mie × S(q)
// of a sphere packing.
enum class MediumRoute { born, sphere };

// The sphere route's validity (header comment): an empty reason if `params` with this
// polydispersity is a packing it accepts, else the parameter to blame ("morphology",
// "min_separation_diameters", "keratin_fraction" or "polydispersity") and what is wrong,
// with the limit.
struct RouteRefusal {
    std::string key, reason;
};
RouteRefusal sphere_route_refusal(const SpongyMediumParams& params, double polydispersity);
// The largest air-sphere fraction the sphere route accepts (below RSA jamming).
inline constexpr double kSphereRouteMaxFraction = 0.35;

// The largest voxel side sim/wave accepts for these wavelengths: min over λ of
// λ / (4 n_keratin(λ)) in µm (the shortest λ decides for normally dispersive keratin).
double finest_voxel_limit_um(const std::vector<double>& wavelengths_nm,
                             const optics::Material& keratin = *optics::keratin());

// The same limit at read time: InputError at table.location(key) (file:line:col) when
// voxel_um exceeds it, naming the wavelength and the limit.
void require_fine_voxels(ParameterTable& table, std::string_view key, double voxel_um,
                         const std::vector<double>& wavelengths_nm,
                         const optics::Material& keratin = *optics::keratin());

// The volume the medium is computed from (channel or spheres, by params.morphology), after
// params.validate(); the spongy study's geometric-optics baseline meshes the same volume.
geometry::SpongyVolume make_spongy_volume(const SpongyMediumParams& params);

// The medium at every wavelength given (duplicates merged, sorted), with weighted absorption
// sampling (sim/scattering_medium.h). `name` names the medium in the tracer's messages.
SpongyMedium build_spongy_medium(const SpongyMediumParams& params,
                                 const std::vector<double>& wavelengths_nm, std::string name = {});

// Each route against 3D full wave: the committed tests/reference/spongy_3d/route_check.csv (as its
// comparison test computed it, embedded at build time), one entry per structure, keratin index
// and route: full wave's and the route's diffuse-R peak and the peak difference's floor (three
// jackknife standard errors over the realisations), whether the route passes (peak within 10 nm,
// every 50-nm band within 15 %, 10 % at n < 1.5, each beyond its noise floor), in how many bands
// the reference could have told a miss (floor within the tolerance), and its worst band, and
// what one full-wave run of that structure cost.
struct RouteFullWaveCheck {
    std::string structure, keratin_index, route, realisations;  // route: "born" or "sphere"
    double full_wave_peak_nm = 0.0, route_peak_nm = 0.0, peak_floor_nm = 0.0;
    bool passes = false;
    int decided_bands = 0;  // bands whose floor is within the tolerance
    // Validated: passes where the reference can decide (at least one such band); a pass with no
    // such band is "within its floors only": the comparison could not have seen a miss.
    bool validated() const { return passes && decided_bands > 0; }
    // "passes", "within its floors only" or "misses"
    std::string verdict() const;
    std::string worst_band;                            // "lo–hi" nm
    double worst_difference = 0.0, worst_floor = 0.0;  // relative
    double full_wave_run_s = 0.0;  // full wave's mean wall time per run of the reference (s)
};
std::vector<RouteFullWaveCheck> routes_against_full_wave();
// The criterion's tolerance on a 50-nm band's diffuse R: 15 % at keratin n >= 1.5, 10 % below.
double spongy_band_tolerance(double keratin_index);
// route_check.csv's route names as reports word them ("born" → "first Born", …).
std::string spongy_route_label(const std::string& route);
// route_check.csv's structure names as reports word them ("air_spheres" → "air spheres in
// keratin", …).
std::string spongy_structure_label(std::string_view structure);

// The report section on them ("## The routes against 3D full wave"), `route` marked as the
// study's; `structure` non-empty: that structure's rows alone.
std::string routes_against_full_wave_text(MediumRoute route, std::string_view structure = {});

// The reference's structures (tests/reference/spongy_3d/structures.h; its test checks these
// numbers against that header): the keratin volume fraction and the length that sets the size
// parameter, the channel spacing Λ or the sphere radius a.
struct SpongyReferenceStructure {
    std::string_view name;  // route_check.csv's structure
    double keratin_fraction = 0.0;
    double length_um = 0.0;
    std::string_view length_name;  // "Λ" or "a"
};
std::vector<SpongyReferenceStructure> spongy_reference_structures();

// Where a route is validated: each (structure, keratin index) of the reference it passes on, the
// structure's keratin fraction and length, and the size parameter x = k0 n_eff ℓ (n_eff
// Bruggeman's at that index and fraction, ℓ the structure's length) over the reference's
// wavelengths (x_lo at the longest, x_hi at the shortest).
struct RouteValidatedCase {
    std::string structure;
    double keratin_index = 0.0, keratin_fraction = 0.0, length_um = 0.0;
    std::string length_name;
    double n_eff = 0.0;  // Bruggeman's, at that index and fraction
    double size_parameter_lo = 0.0, size_parameter_hi = 0.0;
};
std::vector<RouteValidatedCase> route_validated_cases(const std::string& route);

// Why a medium of `structure` (route_check.csv's name) with keratin fraction f and length ℓ, at a
// wavelength λ where keratin's index is n, lies outside the validated cases: none of that
// structure; f more than 0.02 or n more than 0.05 from the nearest one's (in n); or its size
// parameter k0 n_eff ℓ, taken with that case's n_eff so that the index is judged by n alone,
// outside that case's range. Empty when inside.
std::string outside_validated_range(const std::vector<RouteValidatedCase>& validated,
                                    std::string_view structure, double keratin_fraction,
                                    double length_um, double lambda_nm, double keratin_index);

// x = k0 n_eff ℓ = 2π n_eff ℓ / λ.
double spongy_size_parameter(double lambda_nm, double n_eff, double length_um);

}  // namespace plumage::studies
