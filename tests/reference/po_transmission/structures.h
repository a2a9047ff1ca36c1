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
//
// The widths study (README.md, "Wider"): the same arc over its layer, and its parts, stretched
// along x by a lateral scale s (the ellipse's x semi-axis, the arc's and the layer's widths × s;
// heights, the film and the gap's profile along the stretched x unchanged):
//  - free_arc: the keratin arc alone;
//  - free_flat_film: a flat keratin film 6.4 s µm wide, 0.59 µm thick (the arc flattened);
//  - flat_film_over_melanin: that flat film with its top at the arc's top (z = 1.34 µm) over the
//    layer: the arc over its layer without the arc's curvature (a uniform gap of 0.75 µm, the
//    arc's gap at its top); turned by a tilt about its centre (flat_film_top), a gap that
//    changes along the film as the arc's does, without the curvature;
//  - semi_transparent_body: the melanin ellipse, its x semi-axis × s (still 1 µm thick).
#pragma once

#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Core>

#include "geometry/elliptical_arc.h"
#include "sim/fullwave/cross_section_2d.h"
#include "sim/optics/material.h"
#include "sim/wave/surface/physical_optics_2d.h"

namespace plumage::reference::po_transmission {

inline constexpr double kFilmUm = 0.59;
inline constexpr double kArcSemiXUm = 4.0, kArcSemiZUm = 1.0, kArcCentreZUm = 0.34;
inline const double kArcPhiEnd = std::atan(1.0 / 3.0);
inline constexpr double kLayerHalfWidthUm = 3.5, kLayerThicknessUm = 1.0;
inline constexpr double kBodySemiXUm = 2.5, kBodySemiZUm = 0.5;
inline constexpr double kThetaIDeg = 30.0;
inline const std::vector<double> kLambdasNm{450.0, 550.0, 650.0};

// The arc's outer surface (centred at the origin; add kArcCentreZUm along z), stretched along x
// by `lateral`: its normal azimuths reach atan(1/(3 s)), where x = ±3.2 s µm.
inline geometry::EllipticalArc outer_arc(double lateral = 1.0) {
    const double phi_end = lateral == 1.0 ? kArcPhiEnd : std::atan(1.0 / (3.0 * lateral));
    return geometry::EllipticalArc(kArcSemiXUm * lateral, kArcSemiZUm, -phi_end, phi_end);
}

// The keratin band between the outer surface and its inward offset, as a polygon with a vertex
// every 0.064 µm in x on each side (100 intervals; its thinnest feature is the film across it, and
// the vertex spacing was once taken for one, so the reference was drawn this coarse); the chords
// depart from the ellipse by less than 2e-4 µm (radius of curvature >= 4 µm).
inline std::shared_ptr<const sim::fullwave::Shape2d> keratin_arc_band(double lateral = 1.0,
                                                                      double raise_um = 0.0) {
    const geometry::EllipticalArc arc = outer_arc(lateral);
    const double a = kArcSemiXUm * lateral, b = kArcSemiZUm, phi_end = arc.phi1();
    const int steps = static_cast<int>(std::lround(100 * lateral));  // 0.064 µm apart in x
    const double x_end =
        a * std::sin(phi_end) / std::hypot(std::sin(phi_end), b / a * std::cos(phi_end));
    std::vector<Eigen::Vector2d> outer, inner;
    for (int m = 0; m <= steps; ++m) {
        const double x = -x_end + 2.0 * x_end * m / steps;
        const double z = b * std::sqrt(1.0 - x * x / (a * a));
        const double phi = std::atan2(x / (a * a), z / (b * b));
        const Eigen::Vector2d p = arc.point(phi) + Eigen::Vector2d(0.0, kArcCentreZUm + raise_um);
        outer.push_back(p);
        inner.push_back(p - kFilmUm * arc.normal(phi));
    }
    std::vector<Eigen::Vector2d> vertices = outer;
    vertices.insert(vertices.end(), inner.rbegin(), inner.rend());
    return sim::fullwave::polygon(vertices);
}

inline sim::fullwave::CrossSection2d film_over_melanin_fullwave(double lateral = 1.0,
                                                                double raise_um = 0.0) {
    const double w = kLayerHalfWidthUm * lateral;
    const std::vector<Eigen::Vector2d> layer{
        {-w, -kLayerThicknessUm}, {w, -kLayerThicknessUm}, {w, 0.0}, {-w, 0.0}};
    return {{{keratin_arc_band(lateral, raise_um), optics::keratin()},
             {sim::fullwave::polygon(layer), optics::melanin()}}};
}

inline sim::fullwave::CrossSection2d free_arc_fullwave(double lateral) {
    return {{{keratin_arc_band(lateral), optics::keratin()}}};
}

// The flat film's top at z = 0.
inline sim::fullwave::CrossSection2d free_flat_film_fullwave(double lateral) {
    const double h = 3.2 * lateral;
    const std::vector<Eigen::Vector2d> film{{-h, -kFilmUm}, {h, -kFilmUm}, {h, 0.0}, {-h, 0.0}};
    return {{{sim::fullwave::polygon(film), optics::keratin()}}};
}

// The flat film's top surface: 6.4 s µm long, centred at the arc's top (x = 0, z = 1.34 µm)
// lifted by `raise_um`, turned by `tilt_deg` (counter-clockwise) about that centre; its normal,
// and its two ends. (Lifted, a long film can be turned further without meeting the layer.)
struct FlatFilmTop {
    Eigen::Vector2d normal, left, right;
};
inline FlatFilmTop flat_film_top(double lateral, double tilt_deg, double raise_um = 0.0) {
    const double h = 3.2 * lateral, t = tilt_deg * std::numbers::pi / 180.0;
    const Eigen::Vector2d centre(0.0, kArcCentreZUm + kArcSemiZUm + raise_um),
        along(std::cos(t), std::sin(t));
    return {{-std::sin(t), std::cos(t)}, centre - h * along, centre + h * along};
}

inline sim::fullwave::CrossSection2d flat_film_over_melanin_fullwave(double lateral,
                                                                     double tilt_deg = 0.0,
                                                                     double raise_um = 0.0) {
    const FlatFilmTop top = flat_film_top(lateral, tilt_deg, raise_um);
    const double w = kLayerHalfWidthUm * lateral;
    const std::vector<Eigen::Vector2d> film{top.left - kFilmUm * top.normal,
                                            top.right - kFilmUm * top.normal, top.right, top.left};
    const std::vector<Eigen::Vector2d> layer{
        {-w, -kLayerThicknessUm}, {w, -kLayerThicknessUm}, {w, 0.0}, {-w, 0.0}};
    return {{{sim::fullwave::polygon(film), optics::keratin()},
             {sim::fullwave::polygon(layer), optics::melanin()}}};
}

// The ellipse, its x semi-axis stretched by `lateral` (the widths study; 1 µm thick throughout).
inline sim::fullwave::CrossSection2d semi_transparent_body_fullwave(double lateral = 1.0) {
    return {{{sim::fullwave::ellipse({0.0, 0.0}, kBodySemiXUm * lateral, kBodySemiZUm),
              optics::melanin()}}};
}

// The physical-optics views (physical_optics_hybrid_2d.h) of the same cross-sections: a film as
// a sheet (its outer surface, its films over air), the layer as four straight faces of a melanin
// body, the ellipse as one closed curve.
inline sim::wave::Curve2d straight_curve(Eigen::Vector2d from, Eigen::Vector2d to,
                                         Eigen::Vector2d normal,
                                         const sim::wave::SurfaceStack2d& stack) {
    sim::wave::Curve2d c;
    c.point = [from, to](double t) { return Eigen::Vector2d(from + t * (to - from)); };
    c.normal = [normal](double) { return normal; };
    c.stack = stack;
    return c;
}

inline sim::wave::SurfaceStack2d keratin_sheet_stack() {
    return {{{optics::keratin(), kFilmUm}}, optics::air()};
}

inline sim::wave::Curve2d arc_sheet(double lateral, double raise_um = 0.0) {
    const geometry::EllipticalArc arc = outer_arc(lateral);
    sim::wave::Curve2d sheet;
    sheet.point = [arc, raise_um](double phi) {
        return Eigen::Vector2d(arc.point(phi) + Eigen::Vector2d(0.0, kArcCentreZUm + raise_um));
    };
    sheet.normal = [arc](double phi) { return arc.normal(phi); };
    sheet.t0 = arc.phi0();
    sheet.t1 = arc.phi1();
    sheet.stack = keratin_sheet_stack();
    return sheet;
}

inline sim::wave::CrossSection2d film_over_melanin_hybrid(double lateral = 1.0,
                                                          double raise_um = 0.0) {
    const sim::wave::SurfaceStack2d bare{{}, optics::melanin()};
    const double w = kLayerHalfWidthUm * lateral, d = kLayerThicknessUm;
    return {{arc_sheet(lateral, raise_um), straight_curve({-w, 0.0}, {w, 0.0}, {0.0, 1.0}, bare),
             straight_curve({w, 0.0}, {w, -d}, {1.0, 0.0}, bare),
             straight_curve({w, -d}, {-w, -d}, {0.0, -1.0}, bare),
             straight_curve({-w, -d}, {-w, 0.0}, {-1.0, 0.0}, bare)}};
}

inline sim::wave::CrossSection2d free_arc_hybrid(double lateral) { return {{arc_sheet(lateral)}}; }

inline sim::wave::CrossSection2d free_flat_film_hybrid(double lateral) {
    const double h = 3.2 * lateral;
    return {{straight_curve({-h, 0.0}, {h, 0.0}, {0.0, 1.0}, keratin_sheet_stack())}};
}

inline sim::wave::CrossSection2d flat_film_over_melanin_hybrid(double lateral,
                                                               double tilt_deg = 0.0,
                                                               double raise_um = 0.0) {
    const FlatFilmTop top = flat_film_top(lateral, tilt_deg, raise_um);
    const sim::wave::SurfaceStack2d bare{{}, optics::melanin()};
    const double w = kLayerHalfWidthUm * lateral, d = kLayerThicknessUm;
    return {{straight_curve(top.left, top.right, top.normal, keratin_sheet_stack()),
             straight_curve({-w, 0.0}, {w, 0.0}, {0.0, 1.0}, bare),
             straight_curve({w, 0.0}, {w, -d}, {1.0, 0.0}, bare),
             straight_curve({w, -d}, {-w, -d}, {0.0, -1.0}, bare),
             straight_curve({-w, -d}, {-w, 0.0}, {-1.0, 0.0}, bare)}};
}

inline sim::wave::CrossSection2d semi_transparent_body_hybrid(double lateral = 1.0) {
    const geometry::EllipticalArc ellipse(kBodySemiXUm * lateral, kBodySemiZUm, -std::numbers::pi,
                                          std::numbers::pi);
    sim::wave::Curve2d c;
    c.point = [ellipse](double phi) { return ellipse.point(phi); };
    c.normal = [ellipse](double phi) { return ellipse.normal(phi); };
    c.t0 = -std::numbers::pi;
    c.t1 = std::numbers::pi;
    c.stack = {{}, optics::melanin()};
    return {{c}};
}

}  // namespace plumage::reference::po_transmission
