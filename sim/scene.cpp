#include "sim/scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>

#include "common/error.h"
#include "sim/optics/fresnel.h"
#include "sim/optics/thin_film.h"

namespace plumage::sim {
namespace {

constexpr double kFloatRoundoff = 0x1p-24;

void require_material(const std::shared_ptr<const optics::Material>& m, const std::string& where,
                      const char* side) {
    if (!m)
        throw InputError(fmt::format("{}: {} material is null: expected a material", where, side));
}

void validate_mesh(const geometry::TriangleMesh& mesh, const std::string& where) {
    if (mesh.triangles.empty()) {
        throw InputError(
            fmt::format("{}: the mesh has no triangles: expected at least one", where));
    }
    if (mesh.positions.size() >= std::numeric_limits<std::uint32_t>::max()) {
        throw InputError(
            fmt::format("{}: {} vertices: expected fewer than 2^32", where, mesh.positions.size()));
    }
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
        if (!mesh.positions[i].allFinite()) {
            throw InputError(fmt::format(
                "{}: vertex {} is not finite: expected finite coordinates (um)", where, i));
        }
    }
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        for (std::uint32_t v : mesh.triangles[t]) {
            if (v >= mesh.positions.size()) {
                throw InputError(
                    fmt::format("{}: triangle {} refers to vertex {}: expected an index below {}",
                                where, t, v, mesh.positions.size()));
            }
        }
    }
    if (!mesh.shading_normals.empty()) {
        if (mesh.shading_normals.size() != mesh.positions.size()) {
            throw InputError(fmt::format(
                "{}: {} shading normals for {} vertices: expected none or one per vertex", where,
                mesh.shading_normals.size(), mesh.positions.size()));
        }
        for (std::size_t i = 0; i < mesh.shading_normals.size(); ++i) {
            const double norm = mesh.shading_normals[i].norm();
            if (!std::isfinite(norm) || std::abs(norm - 1.0) > 1e-6) {
                throw InputError(fmt::format(
                    "{}: shading normal {} has length {}: expected a unit vector", where, i, norm));
            }
        }
    }
}

double max_abs(const Vec3d& v) { return v.cwiseAbs().maxCoeff(); }

// Whether `linear` is s R (R a rotation or reflection, s > 0) to 1e-14 relative: then LᵀL = s² I.
bool is_scaled_rotation(const Eigen::Matrix3d& linear) {
    const Eigen::Matrix3d gram = linear.transpose() * linear;
    const double s2 = gram.trace() / 3.0;
    return s2 > 0.0 &&
           (gram - s2 * Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= 1e-14 * s2;
}

// Σ over the unit's triangles of the surface area of their bounding boxes in the frame whose
// axes are the columns of `axes`: the leaf term of the SAH cost a BVH built in that frame pays.
double box_area_sum(const UnitMesh& unit, const Eigen::Matrix3d& axes) {
    double sum = 0.0;
    for (const Surface& surface : unit.surfaces) {
        const geometry::TriangleMesh& mesh = surface.mesh;
        for (const geometry::Triangle& t : mesh.triangles) {
            Eigen::AlignedBox3d box;
            for (std::uint32_t v : t) box.extend(axes.transpose() * mesh.positions[v]);
            const Vec3d d = box.diagonal();
            sum += d.x() * d.y() + d.y() * d.z() + d.z() * d.x();
        }
    }
    return sum;
}

}  // namespace

std::vector<Scene::Facet> Scene::facets_of(const geometry::TriangleMesh& mesh,
                                           const std::vector<float>& stored_xyz) {
    std::vector<Facet> facets;
    facets.reserve(mesh.triangles.size());
    for (const geometry::Triangle& tri : mesh.triangles) {
        const Vec3d& a = mesh.positions[tri[0]];
        const Vec3d& b = mesh.positions[tri[1]];
        const Vec3d& c = mesh.positions[tri[2]];
        float extent = 0.0f;
        for (std::uint32_t vertex : tri) {
            for (int k = 0; k < 3; ++k)
                extent = std::max(extent, std::abs(stored_xyz[3 * vertex + k]));
        }
        const Vec3d e1 = b - a, e2 = c - a;
        const Vec3d normal = e1.cross(e2);
        const double area2 = normal.norm();
        facets.push_back({a, e1, e2, area2 > 0.0 ? Vec3d(normal / area2) : Vec3d::Zero(), extent});
    }
    return facets;
}

bool Scene::uses_shading_normal(const SurfaceMaterial& material) {
    return std::holds_alternative<ThinFilmInterface>(material.layer) ||
           std::holds_alternative<DielectricInterface>(material.layer);
}

std::vector<Scene::ShadingFacet> Scene::shading_facets_of(const geometry::TriangleMesh& mesh) {
    std::vector<ShadingFacet> shading;
    if (mesh.shading_normals.empty()) return shading;
    shading.reserve(mesh.triangles.size());
    for (const geometry::Triangle& tri : mesh.triangles) {
        shading.push_back({mesh.shading_normals[tri[0]], mesh.shading_normals[tri[1]],
                           mesh.shading_normals[tri[2]]});
    }
    return shading;
}

Scene::BvhFrame Scene::bvh_frame(const UnitMesh& unit) {
    std::size_t count = 0;
    Vec3d mean = Vec3d::Zero();
    for (const Surface& surface : unit.surfaces) {
        for (const Vec3d& p : surface.mesh.positions) mean += p;
        count += surface.mesh.positions.size();
    }
    mean /= static_cast<double>(std::max<std::size_t>(count, 1));
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    for (const Surface& surface : unit.surfaces) {
        for (const Vec3d& p : surface.mesh.positions)
            covariance += (p - mean) * (p - mean).transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
    Eigen::Matrix3d principal = solver.eigenvectors();
    if (principal.determinant() < 0.0) principal.col(0) = -principal.col(0);
    BvhFrame frame;
    frame.rotation = Eigen::Matrix3d::Identity();
    if (solver.info() == Eigen::Success && principal.allFinite() &&
        box_area_sum(unit, principal) < box_area_sum(unit, frame.rotation)) {
        frame.rotation = principal;
    }
    Eigen::AlignedBox3d box;
    for (const Surface& surface : unit.surfaces) {
        for (const Vec3d& p : surface.mesh.positions) box.extend(frame.rotation.transpose() * p);
    }
    frame.centre = box.isEmpty() ? Vec3d::Zero() : Vec3d(frame.rotation * box.center());
    return frame;
}

AlbedoSpectrum constant_albedo(double albedo) {
    if (!std::isfinite(albedo) || albedo < 0.0 || albedo > 1.0) {
        throw InputError(fmt::format("albedo = {}: expected a value in [0, 1]", albedo));
    }
    return [albedo](double) { return albedo; };
}

AlbedoSpectrum melanin_albedo() {
    return [melanin = optics::melanin()](double lambda_nm) {
        return optics::fresnel_intensities_unpolarised(1.0, melanin->index(lambda_nm), 1.0)
            .reflectance;
    };
}

void SurfaceMaterial::validate(const std::string& where) const {
    require_material(outside, where, "outside");
    require_material(inside, where, "inside");
    if (const auto* film = std::get_if<ThinFilmInterface>(&layer)) {
        require_material(film->film, where, "film");
        optics::require_thickness(film->thickness_um, where);
    }
    if (const auto* diffuse = std::get_if<DiffuseLayer>(&layer)) {
        if (!diffuse->albedo) {
            throw InputError(fmt::format("{}: diffuse layer without an albedo spectrum", where));
        }
    }
}

SurfaceMaterial thin_film_interface(std::shared_ptr<const optics::Material> film,
                                    double thickness_um,
                                    std::shared_ptr<const optics::Material> above,
                                    std::shared_ptr<const optics::Material> below,
                                    optics::Coherence coherence) {
    SurfaceMaterial m;
    m.layer = ThinFilmInterface{std::move(film), thickness_um, coherence};
    m.outside = std::move(above);
    m.inside = std::move(below);
    m.validate("thin film interface");
    return m;
}

SurfaceMaterial dielectric_interface(std::shared_ptr<const optics::Material> inside,
                                     std::shared_ptr<const optics::Material> outside) {
    SurfaceMaterial m;
    m.layer = DielectricInterface{};
    m.outside = std::move(outside);
    m.inside = std::move(inside);
    m.validate("dielectric interface");
    return m;
}

SurfaceMaterial diffuse_layer(AlbedoSpectrum albedo,
                              std::shared_ptr<const optics::Material> outside,
                              std::shared_ptr<const optics::Material> inside) {
    SurfaceMaterial m;
    m.layer = DiffuseLayer{std::move(albedo)};
    m.outside = std::move(outside);
    m.inside = std::move(inside);
    m.validate("diffuse layer");
    return m;
}

SurfaceMaterial absorber() {
    SurfaceMaterial m;
    m.layer = Absorber{};
    return m;
}

SurfaceMaterial spongy_keratin_interface(std::shared_ptr<const optics::Material> keratin) {
    return dielectric_interface(std::move(keratin), optics::air());
}

void SceneDescription::validate() const {
    if (!ambient) throw InputError("scene: ambient material is null: expected a material (air)");
    for (std::size_t u = 0; u < units.size(); ++u) {
        const UnitMesh& unit = units[u];
        if (unit.surfaces.empty()) {
            throw InputError(fmt::format("scene unit {} '{}': no surfaces: expected at least one",
                                         u, unit.name));
        }
        for (std::size_t s = 0; s < unit.surfaces.size(); ++s) {
            const std::string where = fmt::format("scene unit {} '{}', surface {} '{}'", u,
                                                  unit.name, s, unit.surfaces[s].name);
            validate_mesh(unit.surfaces[s].mesh, where);
            unit.surfaces[s].material.validate(where);
        }
    }
    for (std::size_t i = 0; i < instances.size(); ++i) {
        const Instance& instance = instances[i];
        if (instance.unit >= units.size()) {
            throw InputError(fmt::format("scene instance {}: unit {}: expected an index below {}",
                                         i, instance.unit, units.size()));
        }
        const Eigen::Matrix4d& m = instance.transform.matrix();
        const double det = instance.transform.linear().determinant();
        if (!m.allFinite() || !std::isfinite(det) || std::abs(det) < 1e-300) {
            throw InputError(fmt::format(
                "scene instance {}: transform is not finite and invertible (det = {})", i, det));
        }
    }
}

Eigen::AlignedBox3d SceneDescription::bounds() const {
    std::vector<Eigen::AlignedBox3d> unit_boxes(units.size());
    for (std::size_t u = 0; u < units.size(); ++u) {
        for (const Surface& s : units[u].surfaces) {
            for (const Vec3d& p : s.mesh.positions) unit_boxes[u].extend(p);
        }
    }
    Eigen::AlignedBox3d box;
    for (const Instance& instance : instances) {
        const Eigen::AlignedBox3d& local = unit_boxes.at(instance.unit);
        if (local.isEmpty()) continue;
        for (int corner = 0; corner < 8; ++corner) {
            box.extend(instance.transform *
                       local.corner(static_cast<Eigen::AlignedBox3d::CornerType>(corner)));
        }
    }
    return box;
}

bool SceneDescription::has_film() const {
    for (const UnitMesh& unit : units) {
        for (const Surface& s : unit.surfaces) {
            if (s.material.has_film()) return true;
        }
    }
    return false;
}

SceneDescription barbule_row_scene(const geometry::BarbuleRow& row,
                                   const BarbuleRowMaterials& materials) {
    SceneDescription scene;
    UnitMesh cell{"barbule cell", {}};
    cell.surfaces.push_back(
        {"film", row.cell_film,
         thin_film_interface(materials.film, row.params.cell.film_thickness_um, optics::air(),
                             optics::air(), materials.film_coherence)});
    cell.surfaces.push_back({"melanin", row.cell_melanin, diffuse_layer(materials.melanin)});
    scene.units.push_back(std::move(cell));
    scene.instances.reserve(row.instances.size());
    for (const Eigen::Affine3d& t : row.instances) scene.instances.push_back({0, t});
    scene.validate();
    return scene;
}

void SpongyMedulla::validate() const {
    if (!medium) throw InputError("spongy medulla: medium is null: expected a scattering medium");
    if (!core) throw InputError("spongy medulla: core material is null: expected a material");
    if (!std::isfinite(core_scale) || core_scale < 0.0 || core_scale > kMaxCoreScale) {
        throw InputError(
            fmt::format("spongy medulla: core_scale = {}: expected a value in [0, {}] (0: no core)",
                        core_scale, kMaxCoreScale));
    }
}

namespace {

// The medulla's smaller semi-axis (µm).
double medulla_semi_minor_um(const geometry::BarbParams& b) {
    return b.medulla_scale * 0.5 * b.barb_width_um * std::min(1.0, b.barb_axis_ratio);
}

// `mesh` (a straight tube along x) scaled about (x_mid, centre_y, centre_z): by `across` in y
// and z, and in x so that each end moves in by `inset_um`. Positive scales keep the winding
// (outward normals); shading normals transform by the inverse transpose.
geometry::TriangleMesh scaled_tube(const geometry::TriangleMesh& mesh,
                                   const Eigen::Vector2d& centre_yz, double across, double inset_um,
                                   const char* what) {
    double x_min = std::numeric_limits<double>::infinity(), x_max = -x_min;
    for (const Vec3d& p : mesh.positions) {
        x_min = std::min(x_min, p.x());
        x_max = std::max(x_max, p.x());
    }
    const double half = 0.5 * (x_max - x_min);
    if (!(half > inset_um)) {
        throw InputError(fmt::format(
            "spongy medulla: the barb ({} um long) is too short for the {} inset by {} um at "
            "each end",
            2.0 * half, what, inset_um));
    }
    const Vec3d centre(0.5 * (x_min + x_max), centre_yz.x(), centre_yz.y());
    const Vec3d scale((half - inset_um) / half, across, across);
    geometry::TriangleMesh out = mesh;
    for (Vec3d& p : out.positions) p = centre + (p - centre).cwiseProduct(scale);
    for (Vec3d& n : out.shading_normals) n = n.cwiseQuotient(scale).normalized();
    return out;
}

}  // namespace

geometry::TriangleMesh spongy_medulla_mesh(const geometry::BarbulePatch& patch) {
    if (patch.barb_medulla.triangles.empty()) return {};
    const geometry::BarbParams& b = patch.params.barb;
    // The cortex's wall across the barb for a centred medulla, halved (an offset medulla's
    // narrowest wall is thinner; any gap well above the spawn offset separates the caps).
    const double inset = 0.5 * (1.0 - b.medulla_scale) / b.medulla_scale * medulla_semi_minor_um(b);
    return scaled_tube(patch.barb_medulla, {b.medulla_offset_y_um, b.medulla_offset_z_um}, 1.0,
                       inset, "medulla");
}

geometry::TriangleMesh medulla_core_mesh(const geometry::BarbulePatch& patch, double core_scale) {
    if (core_scale <= 0.0 || patch.barb_medulla.triangles.empty()) return {};
    const geometry::BarbParams& b = patch.params.barb;
    // The narrowest wall of the shell between core and medulla, across the barb; the ends are
    // inset by the same so that the core's caps do not lie on the medulla's.
    const double wall = (1.0 - core_scale) * medulla_semi_minor_um(b);
    return scaled_tube(spongy_medulla_mesh(patch), {b.medulla_offset_y_um, b.medulla_offset_z_um},
                       core_scale, wall, "medulla core");
}

SceneDescription barbule_patch_scene(const geometry::BarbulePatch& patch,
                                     const BarbulePatchMaterials& materials) {
    SceneDescription scene;
    UnitMesh barb{"barb", {}};
    barb.surfaces.push_back({"cortex", patch.barb_cortex, dielectric_interface(materials.keratin)});
    if (materials.spongy_medulla) {
        const SpongyMedulla& spongy = *materials.spongy_medulla;
        spongy.validate();
        if (patch.barb_medulla.triangles.empty()) {
            throw InputError(
                "spongy medulla: the patch has no medulla (medulla_scale = 0): expected a "
                "medulla to fill with the medium");
        }
        // n_eff inside; the same material object on the core's outside, so that the tracer
        // sees the shell as one medium from both of its surfaces.
        const std::shared_ptr<const optics::Material> shell = spongy.medium->effective_material();
        SurfaceMaterial boundary = dielectric_interface(shell, materials.keratin);
        boundary.inside_medium = spongy.medium;
        barb.surfaces.push_back({"medulla", spongy_medulla_mesh(patch), boundary});
        if (spongy.core_scale > 0.0) {
            SurfaceMaterial core = dielectric_interface(spongy.core, shell);
            core.outside_medium = spongy.medium;
            barb.surfaces.push_back(
                {"medulla core", medulla_core_mesh(patch, spongy.core_scale), core});
        }
    } else if (!patch.barb_medulla.triangles.empty()) {
        barb.surfaces.push_back(
            {"medulla", patch.barb_medulla,
             diffuse_layer(materials.medulla, materials.keratin, materials.keratin)});
    }
    UnitMesh barbule{"barbule", {}};
    barbule.surfaces.push_back(
        {"barbule", patch.barbule,
         materials.barbule ? *materials.barbule : dielectric_interface(materials.keratin)});
    scene.units.push_back(std::move(barb));
    scene.units.push_back(std::move(barbule));
    for (const Eigen::Affine3d& t : patch.barb_instances) scene.instances.push_back({0, t});
    for (const Eigen::Affine3d& t : patch.barbule_instances) scene.instances.push_back({1, t});
    scene.validate();
    return scene;
}

SceneDescription single_mesh_scene(geometry::TriangleMesh mesh, SurfaceMaterial material,
                                   std::string name) {
    SceneDescription scene;
    UnitMesh unit{name, {}};
    unit.surfaces.push_back({std::move(name), std::move(mesh), std::move(material)});
    scene.units.push_back(std::move(unit));
    scene.instances.push_back({0, Eigen::Affine3d::Identity()});
    scene.validate();
    return scene;
}

Scene::Scene(SceneDescription description, std::shared_ptr<const EmbreeDevice> device)
    : description_(std::move(description)), device_(std::move(device)) {
    PLUMAGE_CHECK(device_ != nullptr, "Scene needs an Embree device");
    description_.validate();
    bounds_ = description_.bounds();
    build_units();
    build_instances();
}

void Scene::build_units() {
    const EmbreeDevice& dev = *device_;
    // Media: one Beer–Lambert medium per distinct material, unless a side names its own.
    std::map<const optics::Material*, std::shared_ptr<const Medium>> absorbing;
    auto medium_for = [&](const std::shared_ptr<const optics::Material>& material,
                          const std::shared_ptr<const Medium>& given) {
        if (given) return given;
        auto& m = absorbing[material.get()];
        if (!m) m = std::make_shared<HomogeneousAbsorbingMedium>(material);
        return m;
    };

    // One Embree scene per unit, one triangle geometry per surface (geomID = its global index).
    for (const UnitMesh& unit : description_.units) {
        const BvhFrame frame = bvh_frame(unit);
        unit_frames_.push_back(frame);
        EmbreeScene unit_scene(dev, RTC_SCENE_FLAG_ROBUST, RTC_BUILD_QUALITY_HIGH);
        for (std::size_t s = 0; s < unit.surfaces.size(); ++s) {
            const Surface& surface = unit.surfaces[s];
            std::vector<float> xyz;
            xyz.reserve(3 * surface.mesh.positions.size());
            for (const Vec3d& p : surface.mesh.positions) {
                const Vec3d q = frame.rotation.transpose() * (p - frame.centre);
                xyz.insert(xyz.end(), {static_cast<float>(q.x()), static_cast<float>(q.y()),
                                       static_cast<float>(q.z())});
            }
            surfaces_.push_back(
                {&surface, medium_for(surface.material.outside, surface.material.outside_medium),
                 medium_for(surface.material.inside, surface.material.inside_medium),
                 facets_of(surface.mesh, xyz),
                 uses_shading_normal(surface.material) ? shading_facets_of(surface.mesh)
                                                       : std::vector<ShadingFacet>{}});
            vertex_buffers_.push_back(padded_vertex_buffer(xyz));
            EmbreeGeometry geometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
            rtcSetSharedGeometryBuffer(geometry.get(), RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                       vertex_buffers_.back().data(), 0, 3 * sizeof(float),
                                       surface.mesh.positions.size());
            dev.check("rtcSetSharedGeometryBuffer (vertices)");
            static_assert(sizeof(geometry::Triangle) == 3 * sizeof(std::uint32_t));
            rtcSetSharedGeometryBuffer(geometry.get(), RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                       surface.mesh.triangles.data(), 0, sizeof(geometry::Triangle),
                                       surface.mesh.triangles.size());
            dev.check("rtcSetSharedGeometryBuffer (indices)");
            // Embree's geomID is the global surface index, so that a hit finds its facet
            // without first reading its instance's record (the two loads overlap).
            rtcCommitGeometry(geometry.get());
            rtcAttachGeometryByID(unit_scene.get(), geometry.get(),
                                  static_cast<unsigned>(surfaces_.size() - 1));
            dev.check("rtcCommitGeometry / rtcAttachGeometryByID");
        }
        unit_scene.commit(dev);
        unit_scenes_.push_back(std::move(unit_scene));
    }
}

void Scene::build_instances() {
    const EmbreeDevice& dev = *device_;
    top_.emplace(dev, RTC_SCENE_FLAG_ROBUST, RTC_BUILD_QUALITY_HIGH);
    instances_.reserve(description_.instances.size());
    // Distinct (unit, linear part), by the bits of the matrix entries.
    std::map<std::array<std::uint64_t, 10>, std::uint32_t> linear_part_of;
    for (std::size_t i = 0; i < description_.instances.size(); ++i) {
        const Instance& instance = description_.instances[i];
        const Eigen::Matrix3d linear = instance.transform.linear();
        // What Embree applies: the instance's transform after the unit's BVH frame.
        const BvhFrame& frame = unit_frames_[instance.unit];
        const Eigen::Matrix3d embree_linear = linear * frame.rotation;
        const Vec3d embree_translation = instance.transform * frame.centre;
        std::array<std::uint64_t, 10> key{instance.unit};
        std::memcpy(key.data() + 1, linear.data(), 9 * sizeof(double));
        const auto [part, added] =
            linear_part_of.try_emplace(key, static_cast<std::uint32_t>(linear_parts_.size()));
        if (added) {
            double normal_scale = 0.0;
            std::uint32_t general_normal = 0;
            if (is_scaled_rotation(linear)) {
                // (s R)^-T = R / s = linear / s²: normalised, a unit normal maps to
                // linear · n / s.
                normal_scale = 1.0 / std::sqrt((linear.transpose() * linear).trace() / 3.0);
            } else {
                general_normal = static_cast<std::uint32_t>(general_normal_matrices_.size());
                general_normal_matrices_.push_back(linear.inverse().transpose());
            }
            linear_parts_.push_back({linear, normal_scale,
                                     embree_linear.cwiseAbs().rowwise().sum().maxCoeff(),
                                     general_normal});
        }
        instances_.push_back(
            {instance.transform.translation(), max_abs(embree_translation), part->second});
        EmbreeGeometry geometry(dev, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(geometry.get(), unit_scenes_[instance.unit].get());
        // Column-major 3×4: the three columns of L, then t.
        float m[12];
        for (int c = 0; c < 3; ++c) {
            for (int r = 0; r < 3; ++r) m[3 * c + r] = static_cast<float>(embree_linear(r, c));
        }
        for (int r = 0; r < 3; ++r) m[9 + r] = static_cast<float>(embree_translation(r));
        rtcSetGeometryTransform(geometry.get(), 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, m);
        dev.check("rtcSetGeometryInstancedScene / rtcSetGeometryTransform");
        const unsigned id = geometry.commit_and_attach(dev, *top_);
        PLUMAGE_CHECK(id == i, "Embree instance IDs are assigned in attach order");
    }
    top_->commit(dev);
}

Scene::~Scene() = default;

RTCScene Scene::embree_scene() const { return top_->get(); }

const SurfaceMaterial& Scene::surface_material(std::size_t surface) const {
    return surfaces_.at(surface).surface->material;
}

const std::string& Scene::surface_name(std::size_t surface) const {
    return surfaces_.at(surface).surface->name;
}

const Medium& Scene::medium(std::size_t surface, bool outside) const {
    const SurfaceData& s = surfaces_.at(surface);
    return outside ? *s.outside_medium : *s.inside_medium;
}

std::optional<SurfaceHit> Scene::intersect(const Vec3d& origin, const Vec3d& direction,
                                           const PrimitiveRef& skip, int* skipped) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rh = make_ray_hit(origin, direction);
    // A rejected hit moves tnear strictly past it, so each facet is rejected at most once
    // and the loop ends.
    for (;;) {
        rh.ray.tfar = std::numeric_limits<float>::infinity();
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(top_->get(), &context, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;

        const PrimitiveRef primitive{rh.hit.instID[0], rh.hit.geomID, rh.hit.primID};
        if (primitive == skip) {
            // The facet the ray left: a straight ray cannot meet its plane again.
            if (skipped != nullptr) ++*skipped;
            rh.ray.tnear = std::nextafter(rh.ray.tfar, std::numeric_limits<float>::infinity());
            continue;
        }
        const InstanceData& instance = instances_[primitive.instance];
        const LinearPart& part = linear_parts_[instance.linear_part];
        const SurfaceData& data = surfaces_[primitive.surface];
        const Facet& facet = data.facets[primitive.triangle];
        const double u = rh.hit.u, v = rh.hit.v;
        const Vec3d position =
            part.linear * (facet.a + u * facet.e1 + v * facet.e2) + instance.translation;
        // A zero-area facet has the zero normal, which the tracer skips (no projected area).
        Vec3d geometric, shading;
        if (part.normal_scale > 0.0) {
            // linear = s R: unit normals map to R n = linear n / s. The shading normal is
            // interpolated, tested against the facet and normalised in the unit frame (R
            // keeps lengths and signs of dot products up to the factor s), so that its
            // square root and division do not wait for the transform.
            geometric = part.normal_scale * (part.linear * facet.normal);
            shading = geometric;
            if (!data.shading.empty()) {
                const ShadingFacet& s = data.shading[primitive.triangle];
                const Vec3d interpolated = (1.0 - u - v) * s.a + u * s.b + v * s.c;
                // Zero, and then rejected, when the interpolated normal vanishes.
                if (interpolated.dot(facet.normal) > 0.0) {
                    shading =
                        (part.normal_scale / interpolated.norm()) * (part.linear * interpolated);
                }
            }
        } else {
            const Eigen::Matrix3d& normal_matrix = general_normal_matrices_[part.general_normal];
            geometric = (normal_matrix * facet.normal).normalized();
            shading = geometric;
            if (!data.shading.empty()) {
                const ShadingFacet& s = data.shading[primitive.triangle];
                const Vec3d interpolated =
                    (normal_matrix * ((1.0 - u - v) * s.a + u * s.b + v * s.c)).normalized();
                if (interpolated.dot(geometric) > 0.0) shading = interpolated;
            }
        }
        const double offset = kSpawnOffsetUlps * kFloatRoundoff *
                              (max_abs(position) + part.linear_norm * facet.vertex_extent +
                               instance.translation_norm);
        // The Euclidean distance, not the projection on the direction: a hit within float
        // error of the origin can lie a little behind it, and a distance must not be negative.
        return SurfaceHit{(position - origin).norm(), position,  {shading, geometric},
                          primitive.surface,          primitive, offset};
    }
}

}  // namespace plumage::sim
