// The wave-validity study's spongy scenes: each level of physics for a spongy medium judged by 3D
// full wave, with its cost, and per scene the cheapest level within the tolerance.
//
// Scenes: the structures of the committed 3D full-wave reference (tests/reference/spongy_3d: 2 µm
// slabs, periodic over 1.2 µm, of a channel network at f = 0.5, Λ = 0.19 µm, and of hard-sphere
// packings at φ = 0.5, diameter 0.2 µm, air spheres in keratin and keratin spheres in air; keratin
// a constant n = 1.55; three realisations each; diffuse reflectance at normal incidence).
//
// Levels, cheapest first: the sphere route (Mie × S(q); packings only) and first Born by the
// cost measured here, then the strong-contrast forms (sim/wave/volume/strong_contrast.h), which
// do first Born's work and more, then full wave. A level's error and
// verdict are the reference's (studies/spongy_medium.h, routes_against_full_wave: the diffuse-R
// peak within 10 nm and every 50-nm band within 15 %, each beyond its noise floor); full wave is
// the reference and is not run here: one run is 14–26 minutes of one core per realisation, and the
// reference holds three. Costs:
//  - a route: measured in this run, the wall time of its tables at the study's wavelengths from
//    a volume of the reference's kind and size, its generation included (first Born and the
//    strong-contrast forms on a 48³ channel volume: the spectrum and tables cost the same for any
//    48³ volume; the sphere route on a 206-sphere packing: its packing, S(q) and Mie);
//  - full wave: the reference's mean wall time per run (route_check.csv's fw_run_wall_s), times
//    the realisations.
#pragma once

#include <string>
#include <vector>

namespace plumage::record {
class Hdf5Writer;
}

namespace plumage::studies {

struct SpongyLevelJudgement {
    std::string route;          // route_check.csv's name: born, sphere, strong_…
    std::string label;          // as the report words it
    bool passes = false;        // validated: within tolerance where the reference can decide
    std::string verdict;        // RouteFullWaveCheck::verdict()
    double peak_offset_nm = 0;  // the level's diffuse-R peak minus full wave's
    double peak_floor_nm = 0;   // its floor: three jackknife standard errors over realisations
    std::string worst_band;     // "lo–hi" nm
    double worst_difference = 0.0, worst_floor = 0.0;  // relative
    double seconds = 0.0;                              // its cost, measured here
};

struct SpongyScene {
    std::string structure, keratin_index, realisations;
    double full_wave_peak_nm = 0.0;
    double full_wave_seconds = 0.0;            // per run × realisations (the reference's)
    std::vector<SpongyLevelJudgement> levels;  // cheapest first
    std::string cheapest;                      // a level's label, or "full wave"
    double cheapest_seconds = 0.0;
};

// Every scene of the reference, its levels' costs measured at `wavelengths_nm`.
std::vector<SpongyScene> judge_spongy_scenes(const std::vector<double>& wavelengths_nm);

std::string spongy_section(const std::vector<SpongyScene>& scenes);  // "## Spongy volumes …"
void write_spongy(record::Hdf5Writer& h5, const std::vector<SpongyScene>& scenes);

}  // namespace plumage::studies
