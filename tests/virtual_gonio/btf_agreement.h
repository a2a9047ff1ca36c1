// Two BTF estimators of the same pixels compared (virtual_gonio/btf.h): per wavelength, a χ² of
// z = (a − b)/√(σ_a² + σ_b²) over the pixels the forward walk reaches often enough for its
// sparse-hit error to be normal, and the largest |z| within the Šidák bound of a 1 % family-wise
// error. Shared by the camera's tests and the species scenes' (tests/studies).
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/metrics/statistics.h"
#include "sim/scatterer/scatterer.h"
#include "tests/virtual_gonio/record_agreement.h"
#include "virtual_gonio/btf.h"

namespace plumage::gonio {

// Per wavelength: χ², its count and the largest |z| (the goniometer records' struct).
using Agreement = testing::RecordAgreement;

// Pixels where the forward walk has at least min_relative_error precision on its own.
inline Agreement compare(const BtfRecord& detector, const BtfRecord& forward,
                         double min_relative_error = 0.15) {
    const std::size_t nl = forward.config.wavelengths_nm.size();
    Agreement a{std::vector<double>(nl, 0.0), std::vector<int>(nl, 0)};
    for (std::size_t i = 0; i < forward.value.size(); ++i) {
        if (!(forward.value[i] > 0.0) ||
            forward.standard_error[i] > min_relative_error * forward.value[i])
            continue;
        const double var =
            std::pow(detector.standard_error[i], 2) + std::pow(forward.standard_error[i], 2);
        const double z = (detector.value[i] - forward.value[i]) / std::sqrt(var);
        a.chi2[i % nl] += z * z;
        ++a.dof[i % nl];
        a.max_z = std::max(a.max_z, std::abs(z));
    }
    return a;
}

inline void expect_agreement(const Agreement& a, const std::string& what, int min_dof) {
    int cells = 0;
    for (std::size_t k = 0; k < a.chi2.size(); ++k) {
        ASSERT_GE(a.dof[k], min_dof) << what << " wavelength " << k;
        const double p = analysis::chi_square_p_value(a.chi2[k], a.dof[k]);
        EXPECT_GT(p, 1e-3) << what << " wavelength " << k << ": chi2/dof " << a.chi2[k] / a.dof[k]
                           << " over " << a.dof[k];
        ::testing::Test::RecordProperty(what + "_chi2_per_dof_" + std::to_string(k),
                                        std::to_string(a.chi2[k] / a.dof[k]));
        cells += a.dof[k];
    }
    const double bound =
        analysis::two_sided_normal_quantile(analysis::sidak_significance(0.01, cells));
    EXPECT_LT(a.max_z, bound) << what;
    ::testing::Test::RecordProperty(what + "_max_z", std::to_string(a.max_z));
}

// The same configuration measured both ways (the detector's quanta in stratified groups of
// `group`, virtual_gonio/btf.h).
inline void expect_estimators_agree(const Scatterer& scatterer, BtfConfig c,
                                    std::uint64_t per_light, std::uint64_t per_pixel,
                                    const std::string& what, int min_dof, std::uint64_t group = 1) {
    c.quanta_per_light = per_light;
    c.quanta_per_pixel = per_pixel;
    c.seed = 7;
    // The detector estimator's own options (split_reflections, split_aimed_reflections) stay off
    // for the forward one.
    const bool split_reflections = c.split_reflections;
    const bool split_aimed_reflections = c.split_aimed_reflections;
    c.split_reflections = false;
    c.split_aimed_reflections = false;
    c.estimator = BtfEstimator::forward;
    const BtfRecord forward = measure_btf(scatterer, c);
    c.estimator = BtfEstimator::detector;
    c.stratified_group = group;
    c.split_reflections = split_reflections;
    c.split_aimed_reflections = split_aimed_reflections;
    const BtfRecord detector = measure_btf(scatterer, c);
    ::testing::Test::RecordProperty(what + "_forward_s", std::to_string(forward.wall_time_s));
    ::testing::Test::RecordProperty(what + "_detector_s", std::to_string(detector.wall_time_s));
    expect_agreement(compare(detector, forward), what, min_dof);
}

}  // namespace plumage::gonio
