// Small helpers shared by the tests.
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "common/error.h"

namespace plumage::testing {

// The InputError message that f() throws, or "no InputError" if it throws none.
template <typename F>
std::string input_error_message(F&& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e.what();
    }
    return "no InputError";
}

// The whole content of a text file ("" if it cannot be read).
inline std::string read_text_file(const std::filesystem::path& path) {
    std::ifstream in(path);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

}  // namespace plumage::testing

namespace plumage::testing {

// Round-off bound for thin-film results near grazing incidence. The film series'
// denominator 1 − r_21 r_23 shrinks like 4 q_1 / q_2 ∝ cos θ_i as both reflection
// coefficients approach −1 and 1, so the relative round-off grows like ε / cos θ_i.
inline double grazing_tolerance(double base, double cos_theta_i) {
    constexpr double kEpsilon = 2.220446049250313e-16;
    return cos_theta_i > 0.0 ? base + 10.0 * kEpsilon / cos_theta_i : base;
}

}  // namespace plumage::testing
