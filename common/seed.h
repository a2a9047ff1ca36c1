// Seeds from seeds: the (seed, purpose, index) rule of docs/architecture.md, shared by every floor
// (the geometry's jitter, the tracer's streams, the studies' instruments).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace plumage {

// SplitMix64 (Steele, Lea and Flood 2014): a bijective 64-bit mixer.
std::uint64_t splitmix64(std::uint64_t x);

// The seed of one purpose (an instrument, a Monte Carlo loop, a geometry's jitter), e.g.
// derive_seed(seed, "species/brdf", species_index): the only way seeds are derived from a
// user's `seed`. Purpose and index are hashed, never added to the seed, so that seed S and
// S + 1 (or S + 100) share no stream, and neither do two purposes of one seed.
std::uint64_t derive_seed(std::uint64_t seed, std::string_view purpose, std::uint64_t index = 0);

// The root seeds a process's Monte Carlo measurements drew from. Every instrument measurement
// (goniometer, scatterometer, BTF camera) records the seed its per-item streams are derived from;
// two measurements with one root draw the same random numbers, so a report that compares them
// as independent would be comparing shared noise. Studies therefore hand each measurement
// derive_seed(seed, "<study>/<measurement>", index), never the user's seed itself, and a test
// runs the studies and checks that no root was recorded twice. Thread-safe; a few bytes per
// measurement, never cleared by the suite itself.
struct MeasurementSeed {
    std::string what;  // the instrument
    std::uint64_t seed;
};
void record_measurement_seed(std::string_view what, std::uint64_t seed);
std::vector<MeasurementSeed> recorded_measurement_seeds();
void clear_recorded_measurement_seeds();

}  // namespace plumage
