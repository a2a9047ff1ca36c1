// The rock-dove barbule row cut to 12 × 8 cells (tests only): films in air over melanin, small
// enough for a few seconds of goniometer cells.
#pragma once

#include "geometry/barbule.h"
#include "sim/scene.h"
#include "sim/tracer.h"

namespace plumage::testing {

inline sim::ExplicitScatterer small_barbule_row() {
    geometry::BarbuleRowParams params;
    params.barbules = 12;
    params.cells_per_barbule = 8;
    return sim::ExplicitScatterer(
        sim::barbule_row_scene(geometry::build_barbule_row(params, {0.01, 0.02})));
}

}  // namespace plumage::testing
