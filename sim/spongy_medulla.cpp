#include "sim/spongy_medulla.h"

#include <algorithm>
#include <cmath>

#include "sim/optics/material.h"

namespace plumage::sim {

double bragg_peak_nm(double spacing_um, double keratin_fraction) {
    constexpr double kStartIndex = 1.3;  // between air and keratin: any visible start converges
    double lambda = 2.0 * kStartIndex * spacing_um * 1e3;
    for (int k = 0; k < 20; ++k) {
        const double n_keratin = optics::keratin()->index(std::clamp(lambda, 300.0, 1000.0)).real();
        lambda = 2.0 * (keratin_fraction * n_keratin + (1.0 - keratin_fraction)) * spacing_um * 1e3;
    }
    return lambda;
}

AlbedoSpectrum bragg_band_albedo(double spacing_um, double keratin_fraction, double band_width_nm,
                                 double albedo, double base_albedo) {
    const double peak = bragg_peak_nm(spacing_um, keratin_fraction);
    return [=](double lambda) {
        const double u = (lambda - peak) / band_width_nm;
        return base_albedo + (albedo - base_albedo) * std::exp(-0.5 * u * u);
    };
}

}  // namespace plumage::sim
