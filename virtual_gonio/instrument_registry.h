// The instruments a study file can name by a table of their own: each one's parameter table
// (key, unit, default, range, meaning), how it checks a configuration and how it measures a
// Scatterer into its record. The `measure` study reads every registered instrument's table by
// the same rule (studies/instrument_tables.h: errors name the file, line and key), hands it the
// settings every measurement of a study shares, and puts its result in the report's table and
// its curves in a figure.
//
// A new instrument is one file pair — its work item and reduction on the pass loop
// (virtual_gonio/pass_loop.h), its record writer and `InstrumentEntry <name>_instrument()` — and
// one line in PLUMAGE_INSTRUMENTS below (docs/instruments.md, "Adding an instrument"). The
// goniometer, the scatterometer and the BTF camera predate the registry: their tables in the
// measure study ([brdf], [scatterogram], [btf]) take direction sets, lists and choices, which
// this numeric parameter table does not describe, and draw figures of their own.
#pragma once

#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/parameter_spec.h"
#include "sim/scatterer/scatterer.h"

namespace plumage::gonio {

// One key of an instrument's table (common/parameter_spec.h): its name is the study file's key.
using InstrumentParameter = ParameterSpec;

// The values of an instrument's keys as read from a study file (defaults filled in), by key.
class InstrumentValues {
public:
    void set(std::string_view key, double value) { values_[std::string(key)] = value; }
    // The value of `key`; std::logic_error for a key the instrument's table does not have.
    double operator[](std::string_view key) const;

private:
    std::map<std::string, double, std::less<>> values_;
};

// What every measurement of a study shares; the study sets it.
struct MeasurementSetting {
    std::vector<double> wavelengths_nm;
    std::uint64_t seed = 1;   // this measurement's root: derive_seed(study seed, "<study>/<table>")
    std::string config_text;  // the study file, for the record's provenance
    double time_budget_s = std::numeric_limits<double>::infinity();
    double target_relative_error = 0.0;  // 0: the instrument's own key decides
    std::filesystem::path folder;        // where the records are written
    bool progress = false;
};

// A measurement's summary for a report: its records, one number of error with its meaning, its
// cost, and spectra with standard errors to draw against wavelength.
struct InstrumentResult {
    std::string cells;               // what was measured, e.g. "7 λ × 200000 quanta per λ"
    std::vector<std::string> files;  // written into MeasurementSetting::folder
    double error = 0.0;
    std::string error_meaning;
    double wall_time_s = 0.0;
    struct Curve {
        std::string label;
        std::vector<double> value, standard_error;  // per wavelength
    };
    std::string curves_title, curves_quantity;  // the figure's title; its y axis with unit
    std::vector<Curve> curves;
};

struct InstrumentEntry {
    std::string_view table;  // the study file's table, e.g. "integrating_sphere"
    std::string_view description;
    std::span<const InstrumentParameter> parameters;
    // InputError naming the key when the values and the setting do not make a valid measurement
    // (the cross-key rules the ranges cannot state); nothing is measured.
    void (*check)(const InstrumentValues& values, const MeasurementSetting& setting);
    // Measures `scatterer` and writes the records; throws Interrupted on Ctrl-C.
    InstrumentResult (*measure)(const Scatterer& scatterer, const InstrumentValues& values,
                                const MeasurementSetting& setting);
};

// The registered instruments: one line each. A new instrument is virtual_gonio/<name>.cpp
// defining `InstrumentEntry <name>_instrument()`, plus its line here.
#define PLUMAGE_INSTRUMENTS(X) X(integrating_sphere)

#define PLUMAGE_DECLARE_INSTRUMENT_ENTRY(name) InstrumentEntry name##_instrument();
PLUMAGE_INSTRUMENTS(PLUMAGE_DECLARE_INSTRUMENT_ENTRY)
#undef PLUMAGE_DECLARE_INSTRUMENT_ENTRY

std::span<const InstrumentEntry> instrument_registry();

}  // namespace plumage::gonio
