// The bodies of a 2D cross-section as the full-wave level sees them: shapes painted in order
// (a later body wins where bodies overlap) over air, each with a material of
// sim/optics/material.h. The full-wave solver (full_wave_2d.h) asks one question of a shape,
// "is this point inside?", at the grid's sample points and, for subpixel smoothing, at many
// points inside each pixel a boundary crosses; so the tests below are analytic and cheap.
//
// Frame as physical_optics_2d.h: x horizontal, z up, the structure invariant along y; lengths
// in µm, angles in rad, a positive angle turning +x towards +z.
//
// Shapes:
//  - ellipse: centre, semi-axes along its own x and z, turned by `angle`; a circle when the
//    semi-axes are equal.
//  - ellipse shell: the region within `thickness` of an ellipse or inside it, i.e. bounded by
//    the outward normal offset of the ellipse (the keratin cortex of physical_optics_2d.h's
//    barbule, drawn under its melanin core). Distance to the ellipse by Eberly's bisection
//    ("Distance from a point to an ellipse", 2013), to 1e-12 of the semi-major axis.
//  - polygon: simple, vertices in order (either sense), at least 3; even–odd rule.
//  - layer: z_bottom ≤ z ≤ z_top for every x (films and substrates of planar stacks; z_bottom
//    may be −∞ for a substrate). Only the periodic solver (full_wave_stack) takes layers.
//
// thinnest_um() is the narrowest part of a shape (an ellipse's minor diameter, a shell's
// thickness, a layer's thickness; a polygon's smallest distance from a vertex to an edge across
// the body or a gap: to a point that the boundary reaches only the long way round, more than 1.5
// times the distance, so that a finely sampled smooth curve is not thin where its vertices are
// close, while a sliver, a narrow gap and a corner sharper than about 67° are): the solver
// refuses a grid whose cells do not fit twice across it.
//
// Parameter table:
//  | name              | unit | range                          |
//  |-------------------|------|--------------------------------|
//  | centre, vertices  | µm   | finite                         |
//  | semi_x, semi_z    | µm   | finite, > 0                    |
//  | thickness         | µm   | finite, > 0                    |
//  | angle             | rad  | finite                         |
//  | z_bottom, z_top   | µm   | z_bottom < z_top; z_top finite |
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sim/optics/material.h"

namespace plumage::sim::fullwave {

struct Box2d {
    Eigen::Vector2d min, max;  // may hold ±∞ (layers)
};

class Shape2d {
public:
    virtual ~Shape2d() = default;
    virtual bool contains(const Eigen::Vector2d& p) const = 0;
    virtual Box2d bounds() const = 0;
    virtual double thinnest_um() const = 0;
    virtual bool is_layer() const { return false; }
    virtual std::string describe() const = 0;  // for messages: "ellipse (5, 2) µm at (0, 0)"
};

// InputError (naming the shape and the key) outside the parameter table.
std::shared_ptr<const Shape2d> ellipse(Eigen::Vector2d centre, double semi_x, double semi_z,
                                       double angle_rad = 0.0);
std::shared_ptr<const Shape2d> ellipse_shell(Eigen::Vector2d centre, double semi_x, double semi_z,
                                             double thickness, double angle_rad = 0.0);
std::shared_ptr<const Shape2d> polygon(std::vector<Eigen::Vector2d> vertices);
std::shared_ptr<const Shape2d> layer(double z_bottom, double z_top);

struct Body2d {
    std::shared_ptr<const Shape2d> shape;
    std::shared_ptr<const optics::Material> material;
};

struct CrossSection2d {
    std::vector<Body2d> bodies;  // painted in order over air: the last body containing a point wins

    // Index of the body that owns p, or −1 for air.
    int body_at(const Eigen::Vector2d& p) const;
};

// A row of barbule cross-sections with the project's stack (physical_optics_2d.h's
// barbule_arc: keratin film d over an air gap g over melanin) as closed bodies: each barbule is
// a melanin core, the ellipse of semi-axes (A − d − g, b·A − d − g), under an air shell g and a
// keratin shell d of uniform thickness (outward offsets), so that the outer surface meets
// Huang's ellipse (A, b·A) at the ends of both axes and lies within O((d + g)²/ρ) of it
// elsewhere (ρ its radius of curvature: the inward offset of Huang's ellipse by d + g is not
// defined where ρ < d + g, at the tips of flat barbules). The whole ellipse is drawn, not only
// the arc [φ0, φ1] the other levels sample: under the arc the melanin core is opaque. Centres
// at x = (m − (count − 1)/2)·spacing, z = 0, each turned by the tilt μ as physical_optics_2d.h's
// rows (the major axis along (cos μ, −sin μ)). g = 0 leaves the air shell out. InputError when
// the core would vanish (b·A <= d + g) or a value is outside its range.
CrossSection2d barbule_row(double semi_major_um, double b, double film_um, double gap_um,
                           double spacing_um, double tilt_rad, int count);

}  // namespace plumage::sim::fullwave
