// Test fields for the power-spectrum tests (power_spectrum_test.cpp, born_2d_test.cpp).
#pragma once

#include <cstddef>
#include <random>
#include <vector>

namespace plumage::sim::wave::fields {

// A 0/1 field of `size` values, each 1 with probability f (white noise: its spectrum is flat).
inline std::vector<double> random_indicator(std::size_t size, double f, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::vector<double> v(size);
    for (double& x : v) x = static_cast<double>(rng() >> 11) * 0x1.0p-53 < f ? 1.0 : 0.0;
    return v;
}

// The population variance of the values, computed in real space (Parseval's other side).
inline double real_space_variance(const std::vector<double>& v) {
    double mean = 0.0;
    for (double x : v) mean += x;
    mean /= static_cast<double>(v.size());
    double var = 0.0;
    for (double x : v) var += (x - mean) * (x - mean);
    return var / static_cast<double>(v.size());
}

}  // namespace plumage::sim::wave::fields
