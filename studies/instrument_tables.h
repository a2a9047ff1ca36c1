// The instruments' tables in study files, one reader per instrument, returning the instrument's
// own configuration: every study that offers an instrument reads its keys by the same rule
// (names, units, ranges, cross-key checks), and a key's error names the file, line and key.
// The study sets what is its own (direction pairs, wavelengths, seed, study text) and passes its
// defaults in.
#pragma once

#include "studies/study_file.h"
#include "virtual_gonio/btf.h"
#include "virtual_gonio/instrument_registry.h"

namespace plumage::studies {

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
