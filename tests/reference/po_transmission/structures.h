// The two cross-sections on which physical optics' transmission is judged against full wave
// (README.md beside this file): the numbers live here once, for the full-wave reference program
// and for the physical-optics tests. Frame as physical_optics_2d.h: x horizontal, z up, µm.
//
// (a) film_over_melanin: a transparent keratin arc (film 0.59 µm, the rock dove's cortex) over a
//     separate flat melanin layer 1 µm thick, with an air gap that varies along the arc from
//     0.38 µm at its ends to 0.75 µm at its top. The arc's outer surface is the ellipse of
//     semi-axes 4 × 1 µm centred at z = 0.34 µm, for normal azimuths |φ| <= atan(1/3)
//     (x = ±3.2 µm); its inner surface is that curve offset inward by the film. The layer spans
//     |x| <= 3.5 µm, −1 <= z <= 0 µm.
// (b) semi_transparent_body: a melanin ellipse 5 × 1 µm (semi-axes 2.5 × 0.5 µm) at the origin,
//     which transmits 5–38 % of the light through its 1 µm middle (450–650 nm).
#pragma once

#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "geometry/elliptical_arc.h"
#include "sim/fullwave/cross_section_2d.h"
#include "sim/optics/material.h"

namespace plumage::reference::po_transmission {

inline constexpr double kFilmUm = 0.59;
inline constexpr double kArcSemiXUm = 4.0, kArcSemiZUm = 1.0, kArcCentreZUm = 0.34;
inline const double kArcPhiEnd = std::atan(1.0 / 3.0);
inline constexpr double kLayerHalfWidthUm = 3.5, kLayerThicknessUm = 1.0;
inline constexpr double kBodySemiXUm = 2.5, kBodySemiZUm = 0.5;
inline constexpr double kThetaIDeg = 30.0;
inline const std::vector<double> kLambdasNm{450.0, 550.0, 650.0};

// The arc's outer surface (centred at the origin; add kArcCentreZUm along z).
inline geometry::EllipticalArc outer_arc() {
    return geometry::EllipticalArc(kArcSemiXUm, kArcSemiZUm, -kArcPhiEnd, kArcPhiEnd);
}

// The keratin band between the outer surface and its inward offset, as a polygon with a vertex
// every 0.064 µm in x on each side (100 intervals; its thinnest feature is the film across it, and
// the vertex spacing was once taken for one, so the reference was drawn this coarse); the chords
// depart from the ellipse by less than 2e-4 µm (radius of curvature >= 4 µm).
inline std::shared_ptr<const sim::fullwave::Shape2d> keratin_arc_band() {
    const geometry::EllipticalArc arc = outer_arc();
    constexpr int kSteps = 100;
    const double x_end =
        kArcSemiXUm * std::sin(kArcPhiEnd) /
        std::hypot(std::sin(kArcPhiEnd), kArcSemiZUm / kArcSemiXUm * std::cos(kArcPhiEnd));
    std::vector<Eigen::Vector2d> outer, inner;
    for (int m = 0; m <= kSteps; ++m) {
        const double x = -x_end + 2.0 * x_end * m / kSteps;
        const double z = kArcSemiZUm * std::sqrt(1.0 - x * x / (kArcSemiXUm * kArcSemiXUm));
        const double phi =
            std::atan2(x / (kArcSemiXUm * kArcSemiXUm), z / (kArcSemiZUm * kArcSemiZUm));
        const Eigen::Vector2d p = arc.point(phi) + Eigen::Vector2d(0.0, kArcCentreZUm);
        outer.push_back(p);
        inner.push_back(p - kFilmUm * arc.normal(phi));
    }
    std::vector<Eigen::Vector2d> vertices = outer;
    vertices.insert(vertices.end(), inner.rbegin(), inner.rend());
    return sim::fullwave::polygon(vertices);
}

inline sim::fullwave::CrossSection2d film_over_melanin_fullwave() {
    const std::vector<Eigen::Vector2d> layer{{-kLayerHalfWidthUm, -kLayerThicknessUm},
                                             {kLayerHalfWidthUm, -kLayerThicknessUm},
                                             {kLayerHalfWidthUm, 0.0},
                                             {-kLayerHalfWidthUm, 0.0}};
    return {{{keratin_arc_band(), optics::keratin()},
             {sim::fullwave::polygon(layer), optics::melanin()}}};
}

inline sim::fullwave::CrossSection2d semi_transparent_body_fullwave() {
    return {{{sim::fullwave::ellipse({0.0, 0.0}, kBodySemiXUm, kBodySemiZUm), optics::melanin()}}};
}

}  // namespace plumage::reference::po_transmission
