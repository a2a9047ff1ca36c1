#include "sim/scattering_slab.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <exception>
#include <mutex>
#include <numbers>

#include <fmt/format.h>

#include "common/error.h"
#include "common/gauss_legendre.h"

namespace plumage::sim {
namespace {

// A planar quad a b c d (in order around it) as two triangles, wound so that the geometric
// normal (b − a) × (c − a) points along `outward`.
void add_quad(geometry::TriangleMesh& mesh, const Vec3d& a, const Vec3d& b, const Vec3d& c,
              const Vec3d& d, const Vec3d& outward) {
    const auto base = static_cast<std::uint32_t>(mesh.positions.size());
    const bool flip = (b - a).cross(c - a).dot(outward) < 0.0;
    for (const Vec3d& p : {a, b, c, d}) mesh.positions.push_back(p);
    if (flip) {
        mesh.triangles.push_back({base, base + 2, base + 1});
        mesh.triangles.push_back({base, base + 3, base + 2});
    } else {
        mesh.triangles.push_back({base, base + 1, base + 2});
        mesh.triangles.push_back({base, base + 2, base + 3});
    }
}

// The faces of the box |x|, |y| <= w, z0 <= z <= z1 (top and bottom on request).
geometry::TriangleMesh box_faces(double w, double z0, double z1, bool top, bool sides,
                                 bool bottom) {
    geometry::TriangleMesh mesh;
    if (top) {
        add_quad(mesh, {-w, -w, z1}, {w, -w, z1}, {w, w, z1}, {-w, w, z1}, Vec3d::UnitZ());
    }
    if (bottom) {
        add_quad(mesh, {-w, -w, z0}, {w, -w, z0}, {w, w, z0}, {-w, w, z0}, -Vec3d::UnitZ());
    }
    if (sides) {
        add_quad(mesh, {w, -w, z0}, {w, w, z0}, {w, w, z1}, {w, -w, z1}, Vec3d::UnitX());
        add_quad(mesh, {-w, -w, z0}, {-w, w, z0}, {-w, w, z1}, {-w, -w, z1}, -Vec3d::UnitX());
        add_quad(mesh, {-w, w, z0}, {w, w, z0}, {w, w, z1}, {-w, w, z1}, Vec3d::UnitY());
        add_quad(mesh, {-w, -w, z0}, {w, -w, z0}, {w, -w, z1}, {-w, -w, z1}, -Vec3d::UnitY());
    }
    return mesh;
}

void require_unit(const Vec3d& v, const char* what) {
    if (!v.allFinite() || std::abs(v.norm() - 1.0) > 1e-9) {
        throw InputError(
            fmt::format("slab single scattering: {} = ({}, {}, {}): expected a unit "
                        "vector",
                        what, v.x(), v.y(), v.z()));
    }
}

}  // namespace

void ScatteringSlabParams::validate() const {
    if (!std::isfinite(thickness_um) || !(thickness_um > 0.0)) {
        throw InputError(fmt::format("scattering slab: thickness = {} um: expected finite and > 0",
                                     thickness_um));
    }
    if (!std::isfinite(half_width_um) || !(half_width_um >= 10.0 * thickness_um)) {
        throw InputError(fmt::format(
            "scattering slab: half width = {} um: expected finite and >= 10 x the thickness "
            "({} um), so that the slab stands for an infinite one",
            half_width_um, 10.0 * thickness_um));
    }
    if (backing) {
        if (!backing->material) {
            throw InputError("scattering slab: backing material is null: expected a material");
        }
        if (!std::isfinite(backing->thickness_um) || !(backing->thickness_um > 0.0)) {
            throw InputError(
                fmt::format("scattering slab: backing thickness = {} um: expected finite and > 0",
                            backing->thickness_um));
        }
    }
}

SceneDescription scattering_slab_scene(std::shared_ptr<const ScatteringMedium> medium,
                                       const ScatteringSlabParams& params) {
    if (!medium) throw InputError("scattering slab: medium is null: expected a medium");
    params.validate();
    const double w = params.half_width_um, d = params.thickness_um;
    const std::shared_ptr<const optics::Material> inside =
        params.index_matched ? optics::air() : medium->effective_material();

    SurfaceMaterial boundary = dielectric_interface(inside, optics::air());
    boundary.inside_medium = medium;

    SceneDescription scene;
    UnitMesh unit{"scattering slab", {}};
    unit.surfaces.push_back(
        {"slab", box_faces(w, -d, 0.0, true, true, !params.backing.has_value()), boundary});
    if (params.backing) {
        const SlabBacking& backing = *params.backing;
        SurfaceMaterial interface = dielectric_interface(inside, backing.material);
        interface.inside_medium = medium;
        unit.surfaces.push_back(
            {"slab on backing", box_faces(w, -d, 0.0, false, false, true), interface});
        unit.surfaces.push_back({"backing",
                                 box_faces(w, -d - backing.thickness_um, -d, false, true, true),
                                 dielectric_interface(backing.material, optics::air())});
    }
    scene.units.push_back(std::move(unit));
    scene.instances.push_back({0, Eigen::Affine3d::Identity()});
    scene.validate();
    return scene;
}

double slab_single_scattering(const ScatteringMedium& medium, double lambda_nm, double thickness_um,
                              const Vec3d& wi, const Vec3d& wo) {
    require_unit(wi, "wi");
    require_unit(wo, "wo");
    if (!(wi.z() > 0.0)) {
        throw InputError(fmt::format(
            "slab single scattering: wi.z = {}: expected light from above (wi.z > 0)", wi.z()));
    }
    if (!std::isfinite(thickness_um) || !(thickness_um > 0.0)) {
        throw InputError(fmt::format(
            "slab single scattering: thickness = {} um: expected finite and > 0", thickness_um));
    }
    const double mu_s = medium.scattering_coefficient_per_um(lambda_nm);
    const double mu_t = mu_s + medium.absorption_coefficient_per_um(lambda_nm);
    if (!(mu_s > 0.0) || wo.z() == 0.0) return 0.0;
    const double albedo = mu_s / mu_t, tau = mu_t * thickness_um;
    const double mi = wi.z(), mo = std::abs(wo.z());
    const double p = medium.phase((-wi).dot(wo), lambda_nm);
    if (wo.z() > 0.0) {
        return albedo * p * mo / (mi + mo) * -std::expm1(-tau * (1.0 / mi + 1.0 / mo));
    }
    // Transmission: μ_o/(μ_o − μ_i) (e^{−τ/μ_o} − e^{−τ/μ_i}) = (μ_o/μ_i)(τ/μ_o) e^{−τ/μ_i}
    // · (e^{x} − 1)/x with x = τ (1/μ_i − 1/μ_o), stable as μ_o → μ_i.
    const double x = tau * (1.0 / mi - 1.0 / mo);
    const double ratio = std::abs(x) < 1e-8 ? 1.0 + 0.5 * x : std::expm1(x) / x;
    return albedo * p * (tau / mi) * std::exp(-tau / mi) * ratio;
}

SlabSingleScattering slab_single_scattering_totals(const ScatteringMedium& medium, double lambda_nm,
                                                   double thickness_um, const Vec3d& wi) {
    // Composite Gauss–Legendre: 64 panels in μ_o per hemisphere, 64 in φ over [0, π]
    // (the integrand is even in φ − φ_i), 8 Gauss–Legendre nodes each (common/gauss_legendre.h).
    constexpr int kPanels = 64;
    const double phi_i = std::atan2(wi.y(), wi.x());
    SlabSingleScattering out;
    for (double sign : {1.0, -1.0}) {
        double sum = 0.0;
        for (int pm = 0; pm < kPanels; ++pm) {
            for (std::size_t a = 0; a < kGl8Nodes.size(); ++a) {
                const double mo = (pm + 0.5 + 0.5 * kGl8Nodes[a]) / kPanels;
                const double so = std::sqrt(std::max(0.0, 1.0 - mo * mo));
                for (int pp = 0; pp < kPanels; ++pp) {
                    for (std::size_t b = 0; b < kGl8Nodes.size(); ++b) {
                        const double phi =
                            phi_i + std::numbers::pi * (pp + 0.5 + 0.5 * kGl8Nodes[b]) / kPanels;
                        const Vec3d wo(so * std::cos(phi), so * std::sin(phi), sign * mo);
                        sum += kGl8Weights[a] * kGl8Weights[b] *
                               slab_single_scattering(medium, lambda_nm, thickness_um, wi, wo);
                    }
                }
            }
        }
        // dω = dμ dφ; each node's cell is (1/kPanels)/2 × (π/kPanels)/2; φ over [0, 2π): × 2.
        const double total = 2.0 * sum * 0.25 / kPanels * std::numbers::pi / kPanels;
        (sign > 0.0 ? out.reflectance : out.transmittance) = total;
    }
    return out;
}

std::vector<SlabSingleScattering> slab_single_scattering_totals(
    const ScatteringMedium& medium, std::span<const double> wavelengths_nm, double thickness_um,
    const Vec3d& wi) {
    std::vector<SlabSingleScattering> out(wavelengths_nm.size());
    std::exception_ptr error;
    std::mutex error_mutex;
    const auto n = static_cast<std::int64_t>(wavelengths_nm.size());
#pragma omp parallel for schedule(dynamic, 1)
    for (std::int64_t w = 0; w < n; ++w) {
        try {
            const auto k = static_cast<std::size_t>(w);
            out[k] = slab_single_scattering_totals(medium, wavelengths_nm[k], thickness_um, wi);
        } catch (...) {
            std::lock_guard lock(error_mutex);
            if (!error) error = std::current_exception();
        }
    }
    if (error) std::rethrow_exception(error);
    return out;
}

TiledVolumeSlab tiled_volume_slab_scene(geometry::TriangleMesh cell, double cell_um,
                                        const TiledVolumeSlabParams& params) {
    const double L = cell_um, g = params.gap_um;
    if (!std::isfinite(L) || !(L > 0.0)) {
        throw InputError(
            fmt::format("tiled volume slab: cell size = {} um: expected finite and > 0", L));
    }
    if (cell.triangles.empty()) throw InputError("tiled volume slab: the cell mesh is empty");
    const auto [lo, hi] = cell.bounds();
    if ((lo.array() < -1e-6 * L).any() || (hi.array() > L * (1.0 + 1e-6)).any()) {
        throw InputError(fmt::format(
            "tiled volume slab: the cell mesh spans ({}, {}, {})..({}, {}, {}) um: expected it "
            "inside its box [0, {}]^3",
            lo.x(), lo.y(), lo.z(), hi.x(), hi.y(), hi.z(), L));
    }
    if (params.layers < 1 || params.layers > 64) {
        throw InputError(
            fmt::format("tiled volume slab: layers = {}: expected 1 to 64", params.layers));
    }
    if (!std::isfinite(g) || !(g > 0.0) || g > 0.1 * L) {
        throw InputError(fmt::format(
            "tiled volume slab: gap = {} um: expected > 0 and <= a tenth of the cell ({} um)", g,
            0.1 * L));
    }
    const double pitch = L + g;
    const double cubes_half = std::ceil((params.half_width_um - 0.5 * L) / pitch);
    if (!std::isfinite(params.half_width_um) || params.half_width_um < 0.5 * L ||
        cubes_half > 100.0) {
        throw InputError(fmt::format(
            "tiled volume slab: half width = {} um: expected at least half a cell ({} um) and "
            "at most 100.5 cells of {} um",
            params.half_width_um, 0.5 * L, pitch));
    }
    if (params.backing) {
        // The backing's checks are the slab's (material non-null, thickness > 0).
        ScatteringSlabParams{
            .thickness_um = L, .half_width_um = 10.0 * L, .backing = params.backing}
            .validate();
    }
    const int n = static_cast<int>(cubes_half);

    TiledVolumeSlab out;
    out.cubes_per_side = 2 * n + 1;
    out.half_width_um = n * pitch + 0.5 * L;
    out.thickness_um = params.layers * L + (params.layers - 1) * g;
    out.scene.units.push_back(
        {"spongy cube", {{"keratin/air", std::move(cell), spongy_keratin_interface()}}});
    // Cube (i, j, layer) spans x in [i pitch − L/2, i pitch + L/2], the same in y, and
    // z in [−(layer + 1) L − layer g, −layer (L + g)].
    for (int layer = 0; layer < params.layers; ++layer) {
        for (int i = -n; i <= n; ++i) {
            for (int j = -n; j <= n; ++j) {
                const Eigen::Translation3d shift(i * pitch - 0.5 * L, j * pitch - 0.5 * L,
                                                 -(layer + 1) * L - layer * g);
                out.scene.instances.push_back({0, Eigen::Affine3d(shift)});
            }
        }
    }
    if (params.backing) {
        const double top = -out.thickness_um - g;
        UnitMesh unit{"backing", {}};
        unit.surfaces.push_back({"backing",
                                 box_faces(out.half_width_um, top - params.backing->thickness_um,
                                           top, true, true, true),
                                 dielectric_interface(params.backing->material, optics::air())});
        out.scene.units.push_back(std::move(unit));
        out.scene.instances.push_back({1, Eigen::Affine3d::Identity()});
    }
    out.scene.validate();
    return out;
}

}  // namespace plumage::sim
