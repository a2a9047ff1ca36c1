// The parts of a record that every instrument writes the same way (virtual_gonio/RECORD.md):
// /provenance, which run made the record, and /convergence, how the estimate settled pass
// by pass. The goniometer, the imaging scatterometer and the BTF camera write them here,
// so that a reader finds the same names, types and units in each record.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "virtual_gonio/pass_loop.h"  // ConvergenceRow
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::gonio {

struct Provenance {
    std::string scatterer;     // Scatterer::name() of what was measured
    std::uint64_t seed = 0;    // the instrument's seed; written as a uint64 attribute (exact)
    int threads = 1;           // OpenMP threads of the run (written as an int64 attribute)
    double wall_time_s = 0.0;  // wall time of the measurement (s)
    double cpu_time_s = 0.0;   // process CPU time over the same span, all threads (s)
    std::string config;        // the study text that configured the run ("" when none)
};

// Group /provenance with @scatterer, @plumage_version, @git_commit, @date (UTC, ISO 8601, when
// the record is written), @host, @compiler, @<library>_version (build_info.h), @seed (uint64),
// @threads (int64), @wall_time_s, @cpu_time_s, @cpu_per_wall (cpu_time_s / wall_time_s; 0 when
// the wall time is 0) and @config.
void write_provenance(record::Hdf5Writer& h5, const Provenance& provenance);

// /instrument @polarisation: what every instrument measures (the tracer and the models carry
// no polarisation state; every interface weighs s and p equally).
void write_polarisation(record::Hdf5Writer& h5);

// /instrument @wavelength_paths and @path_splitting: how the photon estimator traced its quanta
// (shared paths and splitting, sim/tracer.h), for the goniometer and the scatterometer alike.
void write_path_options(record::Hdf5Writer& h5, bool shared, bool split,
                        bool split_reflections = false);

// Attributes of /convergence's table (units per column and a description) with `columns`, the
// column names, which differ per instrument.
record::Attributes convergence_attributes(const std::string& columns);

// Dataset /convergence, [passes, 4]: pass, wall time (s), quanta, estimated relative error;
// `attributes` name the columns (what "quanta" and "error" count differs per instrument).
void write_convergence(record::Hdf5Writer& h5, std::span<const ConvergenceRow> rows,
                       const record::Attributes& attributes = {});

// The rows write_convergence wrote to `file` (for resuming from a checkpoint).
std::vector<ConvergenceRow> read_convergence(const std::filesystem::path& file);

}  // namespace plumage::gonio
