// Where and why the rock-dove simulation departs from Huang's model, each departure tied to a
// measurement (issue 40): the rock-dove study's "Where and why the model departs".
//
//  - Grazing specular pairs (light at 75°, view at its mirror, the 12 of the Filip 2024 set):
//    the excess split by lobe (R, TRT, multi) from a goniometer run on those pairs alone; the
//    same pairs with the tracer stopped after two events (what two film reflections on
//    neighbouring barbules give); and R alone on short cells, where Eq. 7 holds exactly.
//  - TRT: the study's BRDF records against the model's TRT with the exit law of a Lambertian
//    layer under a curved film (analysis/models/huang2022_trt_exit.h): foreshortened and masked by
//    the neighbours, as the simulated melanin sheet lets its light out.
// The physics is in sim/ (the tracer and its event limit), geometry/ (the cells) and analysis/
// (the model and its exit law); this file chooses the cells, runs them and writes the numbers.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "analysis/models/huang2022.h"
#include "common/interrupt.h"
#include "geometry/barbule.h"
#include "virtual_gonio/goniometer.h"

namespace plumage::studies {

// Simulation − model over a set of cells, each lobe's part as a share of the model's total
// there (so the parts add up to `total`), with the Monte Carlo σ of each.
struct LobeExcess {
    double total = 0.0, r = 0.0, trt = 0.0, multi = 0.0;
    double total_sigma = 0.0, r_sigma = 0.0, trt_sigma = 0.0, multi_sigma = 0.0;
    double model_total = 0.0;  // Σ model over the cells and wavelengths (1/sr)
};

struct GrazingDepartures {
    int pairs = 0;
    // Light along the barbules (φ_i = ±90°, the worst cells of the BRDF) and the other pairs.
    LobeExcess along, across;
    // At the pairs along the barbules: the multi lobe with the tracer stopped after two events,
    // as a share of the model's total there (σ), and of the full multi lobe.
    double multi_two_events = 0.0, multi_two_events_sigma = 0.0;
    // R alone (the tracer stopped after one event), simulation / model − 1 (σ): on the study's
    // cells, and on cells short enough for Eq. 7 (coupling `short_cell_coupling`), both over all
    // the grazing pairs.
    double r_default = 0.0, r_default_sigma = 0.0;
    double r_short = 0.0, r_short_sigma = 0.0;
    double short_cell_length_um = 0.0, short_cell_coupling = 0.0;
    // Light along the barbules leaves on a cone about their axis (half-angle, rad); the detector
    // (half-angle) spans ± this much of its azimuth around the specular view.
    double cone_half_angle = 0.0, detector_half_angle = 0.0, cone_transversal_half_range = 0.0;
    double seconds = 0.0;
};

struct TrtDepartures {
    // Simulation / model − 1 for the TRT lobe summed over the BRDF's cells (σ: Monte Carlo),
    // against Huang's exit law (the model as published), the foreshortened one and the
    // foreshortened, masked one (the Lambertian layer's); all cells, views θ_o ≤ 60° and beyond.
    struct Row {
        double huang = 0.0, foreshortened = 0.0, exit = 0.0, sigma = 0.0;
        bool measured = false;  // false: the record has no such cells
    };
    Row all, near, far;
    // Of the light the foreshortened law lets out, the share a neighbouring barbule blocks.
    double blocked_share = 0.0;
    double seconds = 0.0;
    // Per cell of the model's record: its TRT under the exit law (1/sr).
    std::vector<double> exit_cells;
    // What is left against the exit law, with one thing of the simulated patch changed at a time,
    // on every tenth light direction of the BRDF (all its views): simulated TRT / model's TRT
    // under the exit law − 1, σ. First the study's patch itself (its BRDF record on those
    // pairs), then each variant.
    struct Variant {
        std::string what;
        double exit = 0.0, sigma = 0.0;
    };
    std::vector<Variant> variants;
    int variant_pairs = 0;
    double variant_seconds = 0.0;
};

struct Departures {
    LobeExcess brdf;  // the study's BRDF, every cell: the power difference by lobe
    GrazingDepartures grazing;
    TrtDepartures trt;
    bool measured = false;
};

// What the grazing measurement needs of the study.
struct GrazingSetup {
    const analysis::Huang2022Bsdf& model;
    const geometry::BarbuleRow& row;  // the study's patch
    const geometry::TessellationTolerance& tolerance;
    gonio::GoniometerConfig goniometer;  // the study's instrument; pairs and seed are replaced
    double short_cell_coupling = 0.01;   // Eq. 7's longitudinal coupling of the short cells
};

// The 12 grazing specular pairs: light at θ = 75°, φ_i = 0°, 30°, …, 330°; view at θ = 75°,
// φ_i + 180°.
std::vector<gonio::DirectionPair> grazing_specular_pairs();

// Runs the three goniometer measurements on the grazing pairs and the model there. `say`
// names each (the study's progress clock).
GrazingDepartures measure_grazing_departures(const GrazingSetup& setup,
                                             const std::function<void(const std::string&)>& say);

// The study's BRDF records (the simulation's with R, TRT and multi lobes) against the model's
// TRT under the three exit laws, evaluated at each cell's central directions.
TrtDepartures trt_exit_departures(const gonio::BrdfRecord& simulation,
                                  const gonio::BrdfRecord& model,
                                  const analysis::Huang2022Bsdf& huang);

// Fills trt.variants: the TRT lobe on a subset of the BRDF's pairs with the study's cells, with
// short cells (Eq. 7 exact) and with the melanin close under the film, against the exit law.
void measure_trt_variants(const GrazingSetup& setup, const gonio::BrdfRecord& simulation,
                          const gonio::BrdfRecord& model, TrtDepartures& trt,
                          const std::function<void(const std::string&)>& say);

// lobe_excess over every cell of the study's BRDF records (same pairs and wavelengths).
LobeExcess brdf_lobe_excess(const gonio::BrdfRecord& simulation, const gonio::BrdfRecord& model);

// The departures' bullets of the report (markdown), with the multi lobe's share under
// hemispheric light (`multi_share`) for the interreflection bullet.
std::string departures_markdown(const Departures& d, double multi_share);

}  // namespace plumage::studies
