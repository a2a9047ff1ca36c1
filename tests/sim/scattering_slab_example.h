// A small scattering slab for the instruments' tests: a 4 µm slab 400 µm wide of a medium with
// Henyey–Greenstein g = 0.6, μ_s = 0.5/µm, μ_a = 0.02/µm and n_eff = 1.3 at 450, 550 and 650 nm
// (sim/scattering_slab.h): a medium's flights behind a bare interface, and no diffuse surface.
#pragma once

#include <cmath>
#include <memory>
#include <vector>

#include "common/constants.h"
#include "sim/scattering_medium.h"
#include "sim/scattering_slab.h"
#include "sim/tracer.h"

namespace plumage::testing {

inline sim::ExplicitScatterer henyey_greenstein_slab() {
    std::vector<sim::MediumTable> tables;
    for (double lambda : {450.0, 550.0, 650.0}) {
        sim::MediumTable t;
        t.lambda_nm = lambda;
        t.n_eff = 1.3;
        t.mu_s_per_um = 0.5;
        t.mu_a_per_um = 0.02;
        const double g = 0.6;
        for (int i = 0; i < 181; ++i) {
            const double mu = std::cos(kPi * i / 180.0);
            t.cos_theta.push_back(mu);
            t.phase_per_sr.push_back((1.0 - g * g) /
                                     (4.0 * kPi * std::pow(1.0 + g * g - 2.0 * g * mu, 1.5)));
        }
        tables.push_back(t);
    }
    auto medium = std::make_shared<const sim::ScatteringMedium>(tables);
    sim::ScatteringSlabParams params;
    params.thickness_um = 4.0;
    params.half_width_um = 200.0;
    return sim::ExplicitScatterer(sim::scattering_slab_scene(medium, params));
}

}  // namespace plumage::testing
