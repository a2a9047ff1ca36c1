// Two goniometer records of the same measurement compared cell by cell (tests only).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "virtual_gonio/goniometer.h"

namespace plumage::testing {

// Per wavelength k: χ² = Σ z² over the pairs whose cells have a positive variance, with
// z = (a − b)/√(σa² + σb²), and its count (dof); max |z| and the cells over all wavelengths.
// Per wavelength because a shared path's wavelengths are correlated, its pairs hardly.
struct RecordAgreement {
    std::vector<double> chi2;
    std::vector<int> dof;
    double max_z = 0.0;
    int cells = 0;
};

inline RecordAgreement compare_per_wavelength(const gonio::BrdfRecord& a,
                                              const gonio::BrdfRecord& b) {
    const std::size_t nl = a.config.wavelengths_nm.size();
    RecordAgreement out{std::vector<double>(nl, 0.0), std::vector<int>(nl, 0)};
    for (std::size_t i = 0; i < a.value.size(); ++i) {
        const double var = std::pow(a.standard_error[i], 2) + std::pow(b.standard_error[i], 2);
        if (!(var > 0.0)) continue;
        const double z = (a.value[i] - b.value[i]) / std::sqrt(var);
        out.chi2[i % nl] += z * z;
        ++out.dof[i % nl];
        out.max_z = std::max(out.max_z, std::abs(z));
        ++out.cells;
    }
    return out;
}

}  // namespace plumage::testing
