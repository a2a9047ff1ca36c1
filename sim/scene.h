// Scenes for the tracer: a SceneDescription (meshes with surface materials, instanced)
// and the Embree scene built from it.
//
// Description. A UnitMesh is a group of surfaces (each a geometry::TriangleMesh with one
// SurfaceMaterial) that share one acceleration structure: a barbule cell's film sheet and
// the melanin sheet 0.3 µm beneath it are one unit, since they overlap in space and two
// overlapping instances would make every ray traverse both. Instances place units
// (unit-local → patch frame, any invertible affine map); Embree builds one BVH per unit
// and a top-level BVH over the instances (single-level instancing, Embree 3).
//
// Sides of a surface. The OUTSIDE of a surface is where its geometric normal points
// (geometry/triangle_mesh.h: counter-clockwise winding seen from outside; for the
// barbule film, the side facing away from the melanin; for a closed body, the exterior).
// Every surface names the material on each side; their indices drive Fresnel, Airy and
// refraction, and their k drives Beer–Lambert attenuation of light travelling on that side
// (sim/medium.h: a segment's medium is that of the side of the surface it ends on).
//
// Surface materials (the `layer`):
//  | kind                | what happens (sim/interface_events.h)                           |
//  |---------------------|-----------------------------------------------------------------|
//  | ThinFilmInterface   | film of material/thickness between outside (above) and inside  |
//  |                     | (below) media: Airy R/T at the local angle; coherent or by      |
//  |                     | intensity (incoherent, for films ≫ coherence length)            |
//  | DielectricInterface | bare interface outside|inside: Fresnel, refraction, TIR         |
//  | DiffuseLayer        | Lambertian reflector with an albedo spectrum in [0, 1], either  |
//  |                     | side (melanin granules: albedo = normal-incidence Fresnel       |
//  |                     | reflectance air → melanin, as analysis/models/huang2022.h)             |
//  | Absorber            | opaque black                                                    |
//
// Parameter ranges (InputError names the unit, the surface and the value): film thickness
// finite and >= 0 µm; every material non-null; meshes with finite vertices, indices in
// range, shading normals empty or one finite unit vector per vertex; instance transforms
// finite and invertible, unit index in range. Albedo values are checked when evaluated
// (finite, in [0, 1]).
//
// Numerical robustness (Scene::intersect, Scene::spawn_point). Embree intersects in
// single precision; the hit point is recomputed in double from Embree's barycentrics on
// the double-precision mesh, so it lies on the facet to double rounding. The facet data it
// needs (first vertex, edges, unit normal, the stored vertices' extent) is gathered per
// triangle when the scene is built, and instances that are a rotation times a scale (all
// that the builders make) map normals by their own linear part without a normalisation.
// These are double-precision rewritings: they move results by rounding (10⁻¹⁶), not by
// anything the spawn offset below must cover. The next ray
// starts from that point moved off the facet along its geometric normal, to the side the
// light continues on (the incidence side after a reflection, the other after a
// transmission), by
//     δ = kSpawnOffsetUlps · 2⁻²⁴ · (|p_world|∞ + ‖L‖∞ |v_local|∞ + |t|∞)
// where 2⁻²⁴ is float's unit round-off, p_world the hit point, v_local the facet's
// largest vertex coordinate as Embree stores it (in its unit's BVH frame, below), and L, t
// the transform Embree applies (the instance transform after the BVH frame). The three terms
// bound the float rounding of the ray origin in the patch frame, of the vertices Embree
// stores, and of Embree's world → instance transform of the ray. Along the normal they
// amount to about √3 + √3 + 3 units of 2⁻²⁴ times those magnitudes (rounding of each
// coordinate, and a few operations for the transform), and the float intersection test
// adds a few more: kSpawnOffsetUlps = 16 covers them with a margin (the tests count
// self-intersections and leaks through thin shells and find none).
// For a 1 mm patch δ ≈ 1·10⁻³ µm, two orders below the 0.3 µm film–melanin gap; in
// general δ ≈ 2·10⁻⁶ × the distance from the patch origin (the instance's translation
// plus the hit's position), and gaps or shells thinner than δ cannot be resolved (10⁻⁴ µm
// at 500 µm from the origin, where a float only resolves 3·10⁻⁵ µm, is beyond any
// single-precision tracer): they give finite, energy-bounded but geometrically wrong
// paths, which PathResult::medium_mismatches reports. Besides the offset, a ray never accepts the
// facet it left (a straight ray cannot meet a plane twice), which costs nothing when the offset
// works and stops self-intersection when it would not. Scenes are built with Embree's
// BVH frame (Scene::bvh_frame). Embree builds each unit's BVH over axis-aligned boxes of its
// facets, in whatever frame the vertices are given. A fibre tilted within its unit (a barbule
// rises at its inclination) has facets as long as the fibre whose boxes then span the fibre's
// whole height, so every ray near it tests most of them. Each unit is therefore stored in its
// principal-axes frame (eigenvectors of its vertices' covariance) when that frame gives the
// smaller summed surface area of the facets' boxes (the leaf term of the SAH cost), centred on
// its box: Embree stores Rᵀ(p − c) in float and applies the instance transform after
// (c, R). Hits are the same surfaces; positions and normals are still computed in double on
// the description's mesh. Measured on the species scenes: twice the rays per second
// (bench/README.md).
// ROBUST flag (robust traversal, no accuracy-reducing optimisations: Embree's remedy for
// rays slipping through the shared edge of two facets). It is not a watertightness
// guarantee (Embree issue 387), so the tracer counts a ray that arrives on a side it did
// not leave into as a medium mismatch; the closed-body tests find none.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/barb.h"
#include "geometry/barbule.h"
#include "geometry/triangle_mesh.h"
#include "sim/embree_device.h"
#include "sim/interface_events.h"
#include "sim/medium.h"
#include "sim/optics/material.h"
#include "sim/optics/multilayer.h"
#include "sim/scattering_medium.h"

namespace plumage::sim {

// Albedo as a function of the vacuum wavelength in nm; values must lie in [0, 1].
using AlbedoSpectrum = std::function<double(double lambda_nm)>;
AlbedoSpectrum constant_albedo(double albedo);  // InputError outside [0, 1]
// Normal-incidence unpolarised Fresnel reflectance air → melanin (sim/optics/material.h),
// ≈ 0.07 across the visible: Huang 2022's melanin layer as analysis/models/huang2022.h models it.
AlbedoSpectrum melanin_albedo();

struct ThinFilmInterface {
    std::shared_ptr<const optics::Material> film;
    double thickness_um = 0.0;
    optics::Coherence coherence = optics::Coherence::coherent;
};
struct DielectricInterface {};
struct DiffuseLayer {
    AlbedoSpectrum albedo;
};
struct Absorber {};

struct SurfaceMaterial {
    std::variant<ThinFilmInterface, DielectricInterface, DiffuseLayer, Absorber> layer;
    std::shared_ptr<const optics::Material> outside = optics::air();
    std::shared_ptr<const optics::Material> inside = optics::air();
    // Media of the two sides. Null: Beer–Lambert in that side's material
    // (HomogeneousAbsorbingMedium, inactive at wavelengths where k = 0). A volume
    // treated as a medium (the seam of sim/medium.h) is given here.
    std::shared_ptr<const Medium> outside_medium;
    std::shared_ptr<const Medium> inside_medium;

    bool has_film() const { return std::holds_alternative<ThinFilmInterface>(layer); }
    // InputError naming `where` and the offending value.
    void validate(const std::string& where) const;
};

// Film between `above` (outside) and `below` (inside), e.g. air | keratin d | air.
SurfaceMaterial thin_film_interface(std::shared_ptr<const optics::Material> film,
                                    double thickness_um,
                                    std::shared_ptr<const optics::Material> above = optics::air(),
                                    std::shared_ptr<const optics::Material> below = optics::air(),
                                    optics::Coherence coherence = optics::Coherence::coherent);
SurfaceMaterial dielectric_interface(
    std::shared_ptr<const optics::Material> inside,
    std::shared_ptr<const optics::Material> outside = optics::air());
SurfaceMaterial diffuse_layer(AlbedoSpectrum albedo,
                              std::shared_ptr<const optics::Material> outside = optics::air(),
                              std::shared_ptr<const optics::Material> inside = optics::air());
SurfaceMaterial absorber();
// The keratin/air interface of a spongy volume's mesh (geometry/spongy_volume.h:
// normals point from keratin into air, so keratin is inside).
SurfaceMaterial spongy_keratin_interface(
    std::shared_ptr<const optics::Material> keratin = optics::keratin());

struct Surface {
    std::string name;
    geometry::TriangleMesh mesh;
    SurfaceMaterial material;
};

struct UnitMesh {
    std::string name;
    std::vector<Surface> surfaces;  // one BVH over all of them
};

struct Instance {
    std::size_t unit = 0;
    Eigen::Affine3d transform = Eigen::Affine3d::Identity();  // unit-local → patch frame
};

struct SceneDescription {
    std::vector<UnitMesh> units;
    std::vector<Instance> instances;
    std::shared_ptr<const optics::Material> ambient = optics::air();  // around the scene

    void validate() const;               // InputError naming the unit, surface or instance
    Eigen::AlignedBox3d bounds() const;  // patch frame, µm; empty when nothing is placed
    bool has_film() const;
};

// Builders.
struct BarbuleRowMaterials {
    std::shared_ptr<const optics::Material> film = optics::keratin();
    optics::Coherence film_coherence = optics::Coherence::coherent;
    AlbedoSpectrum melanin = melanin_albedo();
};
// One unit per cell: the film sheet (air | keratin d | air, d = the cell's
// film_thickness_um, above = the outward side) and the melanin sheet (diffuse), placed by
// the row's instances.
SceneDescription barbule_row_scene(const geometry::BarbuleRow& row,
                                   const BarbuleRowMaterials& materials = {});

// Barb + barbule patch (geometry/barb.h). The medulla is one of two kinds:
//  - white (the default, `medulla`): a diffuse surface, keratin on both sides, with an albedo
//    spectrum. No published value is known to the suite: a study sets it; the default
//    0.8 stands for a whitish scattering medulla.
//  - spongy (`spongy_medulla` set): the medulla volume is spongy keratin, a scattering medium
//    (sim/scattering_medium.h; its tables computed from a spongy volume, e.g. by
//    studies/spongy_medium.h). The medulla surface is a DielectricInterface with the cortex's
//    keratin outside and the medium's effective material (n_eff(λ), Bruggeman) inside, the
//    medium as its inside medium, as sim/scattering_slab.h bounds a slab: Fresnel and
//    refraction between keratin and n_eff, free flights and scattering inside. No albedo or
//    colour enters; what the medulla reflects is what the medium scatters back.
//    Optional melanin core (core_scale > 0): real blue barbs (Ara ararauna) have the spongy
//    layer around a core of air-filled medullary cells lined with melanin, which absorbs what
//    the spongy layer transmits and so saturates the blue (Prum et al. 1998, 1999). The core
//    is the medulla's cross-section scaled about its centre (geometry::BarbParams
//    medulla_offset_y/z_um) by core_scale, and inset at both ends along the barb by the
//    narrowest shell wall (1 − core_scale) × the medulla's semi-minor axis, so that no core
//    face lies on a medulla face (nor a medulla face on the cortex: spongy_medulla_mesh). Its
//    surface is a DielectricInterface n_eff (outside, the scattering medium as outside medium) |
//    core material (inside, melanin by default): Fresnel from the actual indices, and melanin's k
//    absorbs by Beer–Lambert (HomogeneousAbsorbingMedium; α = 4πk/λ ≈ 3 µm⁻¹ at 450 nm, so light
//    entering the core dies within a micron). A dielectric rather than a diffuse melanin_albedo()
//    layer because the shell's n_eff, not air, is what lies against the core (melanin_albedo() is
//    the reflectance air → melanin), and so that the core reflects, refracts and absorbs by the
//    same event rules as every other body; with core_scale = 0 the whole medulla is spongy
//    and light crossing it leaves through the cortex on the other side.
//    Path lengths (sim/tracer.h max_events, default 1000; a path that needs more is dropped
//    and its light lost): a whole 70 µm medulla of macaw-blue keratin is optically thick in
//    the blue (μ_s ≈ 0.6 µm⁻¹ at 400 nm), and its longest diffusion paths exceed the bound
//    (measured: 0.4 % of the paths at 400 nm); a shell of a few µm around a core needs tens
//    of scatterings. Independently, the cortex between air and n_eff is a light guide whose
//    skew rays a smooth tube keeps (about 1 path in 3000 reaches the bound).
// Parameter table (InputError naming the parameter and value):
//  | name                       | unit | default  | valid range                            |
//  |----------------------------|------|----------|----------------------------------------|
//  | keratin                    |      | keratin  | non-null                               |
//  | medulla                    |      | 0.8      | albedo spectrum in [0, 1] (white only) |
//  | spongy_medulla.medium      |      | —        | non-null                               |
//  | spongy_medulla.core_scale  | 1    | 0 (none) | [0, 0.98]                              |
//  | spongy_medulla.core        |      | melanin  | non-null                               |
// A spongy medulla in a patch without a medulla (medulla_scale = 0) is refused, so that a
// study cannot ask for one and silently get none.
struct SpongyMedulla {
    static constexpr double kMaxCoreScale = 0.98;

    std::shared_ptr<const ScatteringMedium> medium;
    double core_scale = 0.0;
    std::shared_ptr<const optics::Material> core = optics::melanin();

    void validate() const;  // InputError naming the parameter
};
struct BarbulePatchMaterials {
    std::shared_ptr<const optics::Material> keratin = optics::keratin();
    AlbedoSpectrum medulla = constant_albedo(0.8);  // white medulla
    std::optional<SpongyMedulla> spongy_medulla;    // set: replaces the white medulla
    std::optional<SurfaceMaterial> barbule;         // default: keratin/air dielectric
};
// Units: "barb" (cortex: keratin/air dielectric; medulla: diffuse with keratin on its
// outside, or the spongy medulla's "medulla" and "medulla core" surfaces above) and
// "barbule"; instances from the patch. The patch starts its barbules just outside the
// cortex (geometry::BarbulePatch::root_clearance_um): with no nested dielectric priorities
// here, every closed body must be disjoint from the others or nested inside one whose
// inside material is its outside material (cortex ⊃ medulla ⊃ core).
SceneDescription barbule_patch_scene(const geometry::BarbulePatch& patch,
                                     const BarbulePatchMaterials& materials = {});

// The spongy medulla's mesh: the patch's medulla with both ends moved in along the barb by
// half the cortex wall, (1 − medulla_scale)/2 × the barb's semi-minor axis. geometry/barb.h
// sweeps cortex and medulla over the same length, so their end caps are coplanar; a ray
// meeting both at once may take the cortex's, and its segment then counts as keratin, not as
// the medium (a medium mismatch, and a flight through the medulla without scattering).
// The white medulla keeps the patch's mesh (its records do not change). Empty without a
// medulla.
geometry::TriangleMesh spongy_medulla_mesh(const geometry::BarbulePatch& patch);
// The spongy medulla's melanin core mesh: spongy_medulla_mesh scaled as described above.
// Empty for core_scale = 0 or a patch without a medulla.
geometry::TriangleMesh medulla_core_mesh(const geometry::BarbulePatch& patch, double core_scale);

// One mesh, one material, placed once (identity), e.g. a spongy volume's mesh with
// spongy_keratin_interface().
SceneDescription single_mesh_scene(geometry::TriangleMesh mesh, SurfaceMaterial material,
                                   std::string name = "mesh");

// Identifies a facet: instance, surface (global index, Scene::surface_material), triangle.
struct PrimitiveRef {
    static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
    std::uint32_t instance = kNone;
    std::uint32_t surface = kNone;
    std::uint32_t triangle = kNone;
    bool operator==(const PrimitiveRef&) const = default;
};

struct SurfaceHit {
    double distance_um;      // from the ray origin along the unit direction
    Vec3d position;          // on the facet, patch frame (double precision)
    SurfaceNormals normals;  // patch frame, unit; geometric points to the outside. On a
                             // diffuse or absorbing surface shading = geometric (its events
                             // use the geometric normal, so its mesh's normals are not read)
    std::size_t surface;     // global surface index (Scene::surface_material)
    PrimitiveRef primitive;
    double spawn_offset_um;  // δ above
};

class Scene {
public:
    static constexpr double kSpawnOffsetUlps = 16.0;

    explicit Scene(SceneDescription description,
                   std::shared_ptr<const EmbreeDevice> device = default_embree_device());
    ~Scene();
    Scene(const Scene&) = delete;
    Scene& operator=(const Scene&) = delete;

    // Nearest hit along origin + t direction (direction unit, t > 0), never on `skip`.
    // skipped (optional) counts hits rejected because they were on `skip`.
    std::optional<SurfaceHit> intersect(const Vec3d& origin, const Vec3d& direction,
                                        const PrimitiveRef& skip = {},
                                        int* skipped = nullptr) const;
    // Where a ray leaving the hit continues from (see above).
    // Inline: the tracer calls it after every event.
    Vec3d spawn_point(const SurfaceHit& hit, bool to_outside) const {
        return hit.position +
               (to_outside ? hit.spawn_offset_um : -hit.spawn_offset_um) * hit.normals.geometric;
    }

    const SceneDescription& description() const { return description_; }
    std::size_t surface_count() const { return surfaces_.size(); }
    const SurfaceMaterial& surface_material(std::size_t surface) const;
    const std::string& surface_name(std::size_t surface) const;
    // The resolved media of a surface's sides (never null; may be inactive).
    const Medium& medium(std::size_t surface, bool outside) const;
    Eigen::AlignedBox3d bounds() const { return bounds_; }
    // The top-level Embree scene, for benchmarks against bare rtcIntersect1.
    RTCScene embree_scene() const;

    // The frame a unit's BVH is built in (see above): unit-local p ↦ rotationᵀ (p − centre).
    struct BvhFrame {
        Eigen::Matrix3d rotation;  // columns: the frame's axes in unit-local coordinates
        Vec3d centre;              // unit-local, µm
    };
    static BvhFrame bvh_frame(const UnitMesh& unit);

private:
    // What Scene::intersect needs of one facet, gathered at build time so that a hit reads
    // one record instead of an index triple, three vertices and three stored floats, and
    // does not recompute the facet's normal. Unit-local, double precision from the
    // description's mesh: a hit point a + u e1 + v e2 lies on the double-precision facet to
    // double rounding (≈ 10⁻¹⁶ × its coordinates, eight orders below the spawn offset δ).
    struct Facet {
        Vec3d a;               // first vertex
        Vec3d e1, e2;          // b − a, c − a
        Vec3d normal;          // unit (e1 × e2 normalised); zero for a zero-area facet
        double vertex_extent;  // largest |coordinate| of a, b, c as Embree stores them (float)
    };
    struct ShadingFacet {
        Vec3d a, b, c;  // the vertices' shading normals
    };
    struct SurfaceData {
        const Surface* surface;
        std::shared_ptr<const Medium> outside_medium, inside_medium;
        std::vector<Facet> facets;          // one per triangle
        std::vector<ShadingFacet> shading;  // one per triangle; empty without shading normals
                                            // or when the events do not read them
    };
    static std::vector<Facet> facets_of(const geometry::TriangleMesh& mesh,
                                        const std::vector<float>& stored_xyz);
    static std::vector<ShadingFacet> shading_facets_of(const geometry::TriangleMesh& mesh);
    // Whether the surface's events read the shading normal: films and bare interfaces do;
    // diffuse and absorbing ones use the geometric normal (sim/interface_events.h), so their
    // shading normals are not gathered and a hit reports the geometric normal in both fields.
    static bool uses_shading_normal(const SurfaceMaterial& material);
    // The constructor's two steps: one Embree scene per unit (its surfaces' geometries, facets
    // and media), then the top scene's instances of them.
    void build_units();
    void build_instances();
    // What a hit needs of an instance's linear part. Instances share it (the rock-dove patch's
    // 4000 cells have one, the barb patch's 485 fibres two), so it is kept once per distinct
    // (unit, linear part) and the per-instance record stays small: a hit reads a random
    // instance, and the records of a large patch would otherwise crowd Embree's nodes out of
    // the cache (4000 × 128 bytes, as large as the L2 cache of the machine in bench/README.md).
    struct LinearPart {
        Eigen::Matrix3d linear;  // the instance transform: p ↦ linear p + translation
        // When `linear` is s R (R orthogonal, s > 0; every instance the builders make), a
        // unit-local unit normal n maps to the unit normal normal_scale · linear · n with
        // normal_scale = 1/s. Otherwise normal_scale is 0 and the normal is
        // general_normal_matrices_[general_normal] · n normalised (the inverse transpose).
        double normal_scale;
        double linear_norm;  // ‖L R‖∞: Embree's linear part (R: the BVH frame)
        std::uint32_t general_normal;
    };
    // Per instance: one cache line.
    struct alignas(64) InstanceData {
        Vec3d translation;
        double translation_norm;    // |t + L c|∞: Embree's translation (c: the BVH frame's)
        std::uint32_t linear_part;  // index in linear_parts_
    };

    SceneDescription description_;
    std::shared_ptr<const EmbreeDevice> device_;
    std::vector<SurfaceData> surfaces_;
    std::vector<BvhFrame> unit_frames_;
    std::vector<InstanceData> instances_;
    std::vector<LinearPart> linear_parts_;
    std::vector<Eigen::Matrix3d> general_normal_matrices_;
    std::vector<std::vector<float>> vertex_buffers_;  // shared with Embree; padded
    std::vector<EmbreeScene> unit_scenes_;
    std::optional<EmbreeScene> top_;
    Eigen::AlignedBox3d bounds_;
};

}  // namespace plumage::sim
