#include "common/seed.h"

#include <mutex>

namespace plumage {

std::uint64_t splitmix64(std::uint64_t x) {
    x += 0x9E3779B97F4A7C15ULL;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
    return x ^ (x >> 31);
}

std::uint64_t derive_seed(std::uint64_t seed, std::string_view purpose, std::uint64_t index) {
    std::uint64_t hash = 0xCBF29CE484222325ULL;  // FNV-1a of the purpose
    for (const char c : purpose) hash = (hash ^ static_cast<unsigned char>(c)) * 0x100000001B3ULL;
    return splitmix64(splitmix64(seed) ^ splitmix64(hash ^ splitmix64(index)));
}

namespace {
std::mutex& ledger_mutex() {
    static std::mutex mutex;
    return mutex;
}
std::vector<MeasurementSeed>& ledger() {
    static std::vector<MeasurementSeed> seeds;
    return seeds;
}
}  // namespace

void record_measurement_seed(std::string_view what, std::uint64_t seed) {
    const std::lock_guard lock(ledger_mutex());
    ledger().push_back({std::string(what), seed});
}

std::vector<MeasurementSeed> recorded_measurement_seeds() {
    const std::lock_guard lock(ledger_mutex());
    return ledger();
}

void clear_recorded_measurement_seeds() {
    const std::lock_guard lock(ledger_mutex());
    ledger().clear();
}

}  // namespace plumage
