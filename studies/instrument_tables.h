// The instruments' tables in study files, one reader per instrument, returning the instrument's
// own configuration: every study that offers an instrument reads its keys by the same rule
// (names, units, ranges, cross-key checks), and a key's error names the file, line and key.
// The study sets what is its own (direction pairs, wavelengths, seed, study text) and passes its
// defaults in.
#pragma once

#include "studies/study_file.h"
#include "virtual_gonio/btf.h"
#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/instrument_registry.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::studies {

// The goniometer's keys a study offers beyond the ones every goniometer table has
// (detector_half_angle_deg, quanta_per_pass, passes).
struct GoniometerKeys {
    std::vector<std::string> direction_sets;  // `direction_set`'s values; empty: no such key
    double max_detector_half_angle_deg = 20.0;
    bool beam_radius = false;   // beam_radius_um
    bool aperture = false;      // aperture
    bool path_options = false;  // share_wavelength_paths, split_paths, split_reflections,
                                // guided_fraction, guided_branches, connect_lights,
                                // connected_quanta_per_pass
};

// [goniometer] (the measure study: [brdf]), the goniometer (virtual_gonio/goniometer.h):
//  | key                     | unit | range                    | meaning                         |
//  |-------------------------|------|--------------------------|---------------------------------|
//  | direction_set           |      | the study's              | filip2024_btf, _in_plane, ...;  |
//  |                         |      |                          | the Filip sets fill the pairs   |
//  | detector_half_angle_deg | deg  | (0, the study's max]     | every detector cone             |
//  | quanta_per_pass         | 1    | [100, 10⁸]               | per light direction and λ       |
//  | passes                  | 1    | [1, 1000]                | passes at most                  |
//  | beam_radius_um          | µm   | > 0                      | the beam on the patch           |
//  | aperture                |      | view_cone, both_cones    | collimated light or light cones |
//  | share_wavelength_paths  |      | true, false              | one path per quantum for all λ  |
//  | split_paths             |      | true, false              | split at the first film event   |
//  | split_reflections       |      | true, false              | and the reflected one's next    |
//  | guided_fraction         | 1    | [0, 1)                   | diffuse directions aimed        |
//  | guided_branches         | 1    | [0, 3]                   | aimed branches (or the above)   |
//  | connect_lights          |      | true, false              | detector walks connect to light |
//  | connected_quanta_per_pass | 1  | [0, 10⁸]                 | walks per view and pass         |
gonio::GoniometerConfig read_goniometer_table(ParameterTable& table,
                                              gonio::GoniometerConfig defaults,
                                              const GoniometerKeys& keys);

// The scatterometer's keys a study offers beyond the ones every scatterometer table has
// (image_size, quanta_per_pass, passes, beam_incidence_deg, beam_azimuth_deg, beam_radius_um).
struct ScatterometerKeys {
    bool illumination_strata = false;  // illumination_strata (cone and hemisphere light)
    bool cone_aperture = false;        // cone_aperture_deg
    bool path_options = false;         // share_wavelength_paths, split_paths
    std::string_view azimuth_from = "+x";
};

// What a [scatterometer] table sets: the configuration, its beam direction from the two angles,
// and the angles as read (studies compare and report them as angles).
struct ScatterometerTable {
    gonio::ScatterometerConfig config;
    double beam_incidence_rad = 0.0, beam_azimuth_rad = 0.0;
};

// [scatterometer] (the measure study: [scatterogram]), the imaging scatterometer
// (virtual_gonio/scatterometer.h):
//  | key                    | unit | range        | meaning                                  |
//  |------------------------|------|--------------|------------------------------------------|
//  | image_size             | px   | [17, 1025]   | pixels across the scatterogram           |
//  | quanta_per_pass        | 1    | [1000, 10⁸]  | per wavelength and pass                  |
//  | passes                 | 1    | [1, 1000]    | passes at most                           |
//  | beam_incidence_deg     | deg  | [0, 80]      | beam polar angle                         |
//  | beam_azimuth_deg       | deg  | [-360, 360]  | beam azimuth                             |
//  | beam_radius_um         | µm   | > 0          | the beam on the patch                    |
//  | illumination_strata    | 1    | [1, 65536]   | illumination directions per pass         |
//  | cone_aperture_deg      | deg  | (0, 90]      | full aperture of the illumination cone   |
//  | share_wavelength_paths |      | true, false  | one path per quantum for all λ           |
//  | split_paths            |      | true, false  | split at the first film event            |
ScatterometerTable read_scatterometer_table(ParameterTable& table, ScatterometerTable defaults,
                                            const ScatterometerKeys& keys);

// [btf], the BTF camera (virtual_gonio/btf.h):
//  | key                     | unit | range                   | meaning                          |
//  |-------------------------|------|-------------------------|----------------------------------|
//  | pixels                  | 1    | [1, 1024]               | pixels per side                  |
//  | patch_size_um           | µm   | > 0                     | side of the imaged square        |
//  | detector_half_angle_deg | deg  | (0, 30]                 | every pixel's detector cone      |
//  | aperture                |      | view_cone, both_cones   | collimated light, or light cones |
//  | estimator               |      | forward, detector       | detector needs both_cones        |
//  | quanta_per_light        | 1    | [100, 10⁹]              | forward: per light and λ         |
//  | quanta_per_pixel        | 1    | [2, 10⁹]                | detector: per view, pixel, pass  |
//  | stratified_group        | 1    | 2^k in [1, 4096]        | detector: quanta per group       |
//  | split_reflections       |      | true, false             | detector: reflected branch split |
//  | split_aimed_reflections |      | true, false             | detector: aimed reflection split |
//  | max_passes              | 1    | [1, 100000]             | detector only                    |
//  | target_pixel_error      | 1    | [0, 1)                  | median lit-pixel error; 0: none  |
//  | max_time_s              | s    | >= 0                    | no pass ending after it; 0: none |
gonio::BtfConfig read_btf_camera(ParameterTable& table, gonio::BtfConfig defaults);

// [<entry.table>], a registered instrument's table (virtual_gonio/instrument_registry.h): every
// key of its parameter table, range-checked, its default where absent; then the instrument's
// own cross-key check, its InputError prefixed with the table's location. Unknown keys are left
// to the study's reject_unused().
gonio::InstrumentValues read_instrument_table(ParameterTable& table,
                                              const gonio::InstrumentEntry& entry,
                                              const gonio::MeasurementSetting& setting);

}  // namespace plumage::studies
