// A check for study tests: no two Monte Carlo measurements of one run drew from the same root
// seed (common/seed.h). Two such measurements share their random numbers, so a report comparing
// them as independent would compare shared noise.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <string>

#include "common/seed.h"

namespace plumage::test {

// Call clear_recorded_measurement_seeds() before the run, this after it.
inline void expect_each_measurement_its_own_streams() {
    std::map<std::uint64_t, std::string> first_use;
    int measurements = 0;
    for (const MeasurementSeed& m : recorded_measurement_seeds()) {
        ++measurements;
        const auto [it, fresh] = first_use.emplace(m.seed, m.what);
        EXPECT_TRUE(fresh) << m.what << " measured with the root seed " << m.seed << " that a "
                           << it->second << " measurement of the same run already drew from";
    }
    EXPECT_GT(measurements, 0) << "the run recorded no Monte Carlo measurement";
}

}  // namespace plumage::test
