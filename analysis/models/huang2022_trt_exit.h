// How Huang et al. 2022's TRT lobe lets its light out, against a microfacet Lambertian layer.
//
// The model (analysis/models/huang2022.h, Eqs. 16–17) takes the light the melanin reflects out of
// each lit facet ω_m with the same radiance towards every ω_o the facet faces:
//     f_TRT = R_m / (π cos θ_i) ∫ D(ω_m) ⟨ω_i, ω_m⟩₊ G_i T_i T_o 1(⟨ω_o, ω_m⟩ > 0) dω_m.
// A diffuse layer under a curved film (the explicit barbules: sim/scene.h, a Lambertian melanin
// sheet of albedo R_m under each cell's film) is a microfacet Lambertian surface: a facet seen
// from ω_o is foreshortened by ⟨ω_o, ω_m⟩ / cos θ_o of the barb plane's projected area and is
// hidden where a neighbouring barbule stands in front of it (G_o), so
//     f_TRT,exit = R_m / (π cos θ_i cos θ_o) ∫ D ⟨ω_i, ω_m⟩₊ G_i T_i T_o ⟨ω_o, ω_m⟩₊ G_o dω_m.
// The two agree for a flat film (ω_m = n); on the rock-dove barbules' arc the model's law is
// brighter towards the normal and darker at grazing views. Both are evaluated here by one
// quadrature, so that their ratio is the model's departure from the exit law, free of the
// rule's own error:
//  - φ_m over the arc's parts lit from ω_i (Huang2022Bsdf::visible_arc, which carries G_i),
//    composite Gauss–Legendre, 8 nodes per piece of at most kPieceRad;
//  - θ_m over [−θ_d, θ_d], 16 Gauss–Legendre nodes;
//  - G_o: the exit law integrates over the lit parts that ω_o sees as well, the intersection
//    of visible_arc(ω_i) and visible_arc(ω_o) (the model's 2D visibility, its range ends found
//    by bisection: a per-node visibility test put a node's weight on the wrong side of each
//    end, 5 % of the projected area at 80°);
//  - T from the model's film table (Huang2022Bsdf::tabulated_film_transmittance), R_m the
//    melanin's normal-incidence Fresnel reflectance as in both the model and the simulation.
// With Huang's exit law the rule reproduces Huang2022Bsdf::eval's TRT lobe to 0.5 % (test
// Huang2022TrtExit.HuangLawMatchesTheModelsEval), and with T = 1 its masked, foreshortened
// projected area is the fraction of the barb plane the barbules cover as seen from ω_o, the
// closed form of Eq. 15 (test Huang2022TrtExit.ExitAreaIsTheClosedFormHitFraction); the
// exit law is reciprocal, as a Lambertian layer's must be, and the model's is not (test
// Huang2022TrtExit.LambertianExitLawIsReciprocal).
#pragma once

#include <span>
#include <vector>

#include "analysis/models/huang2022.h"

namespace plumage::analysis {

// TRT at one (ω_i, ω_o), per wavelength (1/sr), by the three exit laws.
struct TrtExitLaws {
    std::vector<double> huang;          // 1(⟨ω_o, ω_m⟩ > 0): the model's law
    std::vector<double> foreshortened;  // ⟨ω_o, ω_m⟩₊ / cos θ_o, no neighbour in the way
    std::vector<double> exit;  // ⟨ω_o, ω_m⟩₊ G_o / cos θ_o: the simulated layer's law
};

// Patch-frame unit directions, both above the barb plane (else every value is 0).
// transmittance_one: T_i = T_o = 1 and R_m = π (a test of the geometry alone).
TrtExitLaws trt_exit_laws(const Huang2022Bsdf& model, const Vec3d& wi, const Vec3d& wo,
                          std::span<const double> wavelengths_nm, bool transmittance_one = false);

// The fraction of the barb plane's area, as seen from w, that the barbules' front faces cover
// and that nothing hides: ∫ D ⟨w, ω_m⟩₊ G_w dω_m / cos θ_w over the whole arc (the exit
// law's geometry with T = 1), by the rule above.
double visible_projected_area(const Huang2022Bsdf& model, const Vec3d& w);

}  // namespace plumage::analysis
