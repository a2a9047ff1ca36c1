#include "studies/geometry_study.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <numbers>

#include <fmt/format.h>

#include "common/error.h"
#include "common/version.h"
#include "geometry/barb.h"
#include "geometry/barbule.h"
#include "geometry/mesh_import.h"
#include "geometry/spongy_volume.h"
#include "studies/sections.h"
#include "studies/staged_directory.h"
#include "studies/study_file.h"
#include "virtual_gonio/png_image.h"

namespace plumage::studies {
namespace {

using geometry::TriangleMesh;
using Colour = std::array<std::uint8_t, 3>;
constexpr Colour kFilm{40, 170, 90}, kMelanin{110, 60, 30}, kCortex{170, 170, 170},
    kMedulla{235, 235, 225}, kBarbule{60, 150, 200}, kInk{20, 20, 20};
constexpr int kPreviewWidth = 1000;

// Everything drawn in a preview, in µm, in the plane's own 2D coordinates.
struct Preview {
    struct Line {
        Eigen::Vector2d a, b;
        Colour colour;
    };
    struct Polygon {
        std::vector<Eigen::Vector2d> points;
        Colour colour;
    };
    std::vector<Line> lines;
    std::vector<Polygon> polygons;
    std::string caption;

    void add_slice(const std::vector<geometry::Segment3>& segments, int u, int v,
                   const Colour& colour) {
        for (const auto& s : segments)
            lines.push_back({{s.a[u], s.a[v]}, {s.b[u], s.b[v]}, colour});
    }
    void write(const std::filesystem::path& path) const {
        Eigen::AlignedBox2d box;
        for (const auto& l : lines) box.extend(l.a), box.extend(l.b);
        for (const auto& p : polygons)
            for (const auto& q : p.points) box.extend(q);
        if (box.isEmpty()) throw InvariantError("geometry preview: nothing to draw");
        const Eigen::Vector2d size = box.sizes().cwiseMax(1e-9);
        const double scale = (kPreviewWidth - 40) / size.x();
        const int height = std::clamp(static_cast<int>(std::ceil(size.y() * scale)) + 40, 60, 4000);
        record::RgbImage image(kPreviewWidth, height);
        image.fill(255, 255, 255);
        auto px = [&](const Eigen::Vector2d& p) {
            return std::array<double, 2>{20.0 + (p.x() - box.min().x()) * scale,
                                         height - 20.0 - (p.y() - box.min().y()) * scale};
        };
        for (const auto& p : polygons) {
            std::vector<std::array<double, 2>> pts;
            for (const auto& q : p.points) pts.push_back(px(q));
            image.fill_polygon(pts, p.colour);
        }
        for (const auto& l : lines) {
            const auto a = px(l.a), b = px(l.b);
            image.draw_line(a[0], a[1], b[0], b[1], l.colour);
        }
        record::write_png(path, image);
    }
};

}  // namespace

namespace {

void write_instances_csv(const std::filesystem::path& path,
                         const std::vector<Eigen::Affine3d>& instances) {
    std::ofstream out(path);
    out << "# row-major 3x4 affine transforms, unit mesh coordinates -> patch frame (um)\n"
        << "m00,m01,m02,m03,m10,m11,m12,m13,m20,m21,m22,m23\n";
    for (const auto& t : instances) {
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c)
                out << fmt::format("{}{:.17g}", r + c == 0 ? "" : ",", t.matrix()(r, c));
        out << '\n';
    }
    if (!out) throw IoError(fmt::format("cannot write {}", path.string()));
}

struct Built {
    std::vector<std::string> files;  // written outputs, for the report
    std::vector<std::string> facts;  // report lines
    std::size_t triangles = 0, instances = 0, memory = 0;
    Preview preview;
};

Built build_barbule_row(ParameterTable geometry, const std::filesystem::path& dir) {
    const geometry::BarbuleRowParams p = read_barbule_row_params(geometry);
    const auto tolerance = read_tolerance(geometry.table("tessellation"));

    geometry::BarbuleRow built;
    try {
        built = geometry::build_barbule_row(p, tolerance);
    } catch (const InputError& e) {
        throw InputError(fmt::format("{}: [geometry]: {}", geometry.location(), e.what()));
    }
    Built out;
    geometry::write_ply(built.cell_film, dir / "cell_film.ply");
    geometry::write_ply(built.cell_melanin, dir / "cell_melanin.ply");
    write_instances_csv(dir / "instances.csv", built.instances);
    out.files = {"cell_film.ply", "cell_melanin.ply", "instances.csv"};
    out.triangles = built.cell_film.triangles.size() + built.cell_melanin.triangles.size();
    out.instances = built.instances.size();
    out.memory = built.memory_bytes();
    const auto box = built.bounds();
    out.facts.push_back(fmt::format("patch extent {:.1f} x {:.1f} x {:.1f} um", box.sizes().x(),
                                    box.sizes().y(), box.sizes().z()));
    out.facts.push_back(
        fmt::format("tessellation achieved: chord {:.3g} um, normal {:.3g} deg",
                    built.tessellation.max_chord_um,
                    built.tessellation.max_normal_error_rad * 180.0 / std::numbers::pi));
    out.facts.push_back(fmt::format("minimum non-intersecting spacing H = {:.4f}",
                                    geometry::minimum_spacing(p.cell, p.mu)));
    // Preview: the transversal cut (x–z) through the middle cell of every barbule.
    double y_cut = 0.0;
    const int middle = p.cells_per_barbule / 2;
    y_cut = built.instances[static_cast<std::size_t>(middle)].translation().y();
    for (const auto& t : built.instances) {
        if (std::abs(t.translation().y() - y_cut) > 1e-6 * p.cell.cell_length_um) continue;
        for (bool melanin : {false, true}) {
            TriangleMesh copy = melanin ? built.cell_melanin : built.cell_film;
            for (auto& v : copy.positions) v = t * v;
            out.preview.add_slice(geometry::slice(copy, 1, y_cut), 0, 2,
                                  melanin ? kMelanin : kFilm);
        }
    }
    out.preview.caption =
        "transversal cut (x right, z up) through one cell of each barbule: film green, melanin "
        "brown";
    return out;
}

Built build_barb_patch(ParameterTable geometry, const std::filesystem::path& dir) {
    const geometry::BarbulePatchParams p = read_barb_patch_params(geometry);
    ParameterTable patch = geometry.table("patch");
    const double length =
        patch.number("length_um", 200.0, positive(), "patch length along the barbs, um");
    const int barbs = static_cast<int>(patch.integer("barbs", 3, 1, 10000, "barbs in the patch"));
    const auto tolerance = read_tolerance(geometry.table("tessellation"));

    geometry::BarbulePatch built;
    geometry::PatchCrossSection section;
    try {
        built = geometry::build_barbule_patch(p, length, barbs, tolerance);
        section = geometry::build_patch_cross_section(p, tolerance);
    } catch (const InputError& e) {
        throw InputError(fmt::format("{}: [geometry]: {}", geometry.location(), e.what()));
    }
    Built out;
    geometry::write_ply(built.barb_cortex, dir / "barb_cortex.ply");
    geometry::write_ply(built.barbule, dir / "barbule.ply");
    write_instances_csv(dir / "barb_instances.csv", built.barb_instances);
    write_instances_csv(dir / "barbule_instances.csv", built.barbule_instances);
    out.files = {"barb_cortex.ply", "barbule.ply", "barb_instances.csv", "barbule_instances.csv"};
    if (!built.barb_medulla.triangles.empty()) {
        geometry::write_ply(built.barb_medulla, dir / "barb_medulla.ply");
        out.files.push_back("barb_medulla.ply");
    }
    out.triangles = built.barb_cortex.triangles.size() + built.barb_medulla.triangles.size() +
                    built.barbule.triangles.size();
    out.instances = built.barb_instances.size() + built.barbule_instances.size();
    out.memory = built.memory_bytes();
    out.facts.push_back(fmt::format("barb period {:.2f} um", section.period_um));
    for (int k = -1; k <= 1; ++k) {
        for (const auto& shape : section.shapes) {
            Preview::Polygon polygon;
            for (const auto& q : shape.polygon)
                polygon.points.push_back(q + Eigen::Vector2d(k * section.period_um, 0.0));
            polygon.colour = shape.role == geometry::SurfaceRole::barb_cortex    ? kCortex
                             : shape.role == geometry::SurfaceRole::barb_medulla ? kMedulla
                                                                                 : kBarbule;
            out.preview.polygons.push_back(std::move(polygon));
        }
    }
    out.preview.caption =
        "cross-section across the barbs (y right, z up), three periods: cortex grey, medulla "
        "white, barbules blue";
    return out;
}

Built build_spongy(ParameterTable geometry, bool channel, const std::filesystem::path& dir) {
    ParameterTable s = geometry.table("spongy");
    geometry::SpongyVolume volume;
    try {
        if (channel) {
            geometry::ChannelVolumeParams p;
            p.length_scale_um = s.number("length_scale_um", p.length_scale_um, positive(),
                                         "dominant length scale a, um");
            p.shell_relative_width = s.number("shell_relative_width", p.shell_relative_width,
                                              positive(), "spectral shell width / k0");
            p.keratin_fraction = s.number("keratin_fraction", p.keratin_fraction,
                                          {0.0, 1.0, true, true}, "keratin filling fraction");
            p.box_um = s.number("box_um", p.box_um, positive(), "periodic box edge, um");
            p.voxel_um = s.number("voxel_um", p.voxel_um, positive(), "voxel edge, um");
            p.seed = static_cast<std::uint64_t>(s.integer("seed", 1, 0, 1L << 62, "random seed"));
            volume = geometry::make_channel_volume(p);
        } else {
            geometry::SphereVolumeParams p;
            p.sphere_radius_um = s.number("sphere_radius_um", p.sphere_radius_um, positive(),
                                          "air sphere radius, um");
            p.min_separation_diameters =
                s.number("min_separation_diameters", p.min_separation_diameters, positive(),
                         "minimum centre distance, in diameters");
            p.keratin_fraction = s.number("keratin_fraction", p.keratin_fraction,
                                          {0.0, 1.0, true, true}, "keratin filling fraction");
            p.box_um = s.number("box_um", p.box_um, positive(), "periodic box edge, um");
            p.voxel_um = s.number("voxel_um", p.voxel_um, positive(), "voxel edge, um");
            p.seed = static_cast<std::uint64_t>(s.integer("seed", 1, 0, 1L << 62, "random seed"));
            volume = geometry::make_sphere_volume(p);
        }
    } catch (const InputError& e) {
        throw InputError(fmt::format("{}: [geometry.spongy]: {}", s.location(), e.what()));
    }
    Built out;
    geometry::save_level_set(*volume.level_set, dir / "keratin.vdb");
    const TriangleMesh interface = geometry::level_set_to_mesh(*volume.level_set);
    geometry::write_ply(interface, dir / "interface.ply");
    {
        std::ofstream csv(dir / "power_spectrum.csv");
        csv << "wavenumber_per_um,power_um3,modes\n";
        for (std::size_t i = 0; i < volume.spectrum.wavenumber_per_um.size(); ++i) {
            csv << fmt::format("{},{},{}\n", volume.spectrum.wavenumber_per_um[i],
                               volume.spectrum.power_um3[i], volume.spectrum.modes[i]);
        }
    }
    out.files = {"keratin.vdb", "interface.ply", "power_spectrum.csv"};
    out.triangles = interface.triangles.size();
    out.memory = volume.level_set->memUsage() + interface.memory_bytes();
    out.facts.push_back(fmt::format("measured keratin fraction {:.4f}", volume.keratin_fraction));
    out.facts.push_back(fmt::format("spectral peak at k = {:.3f} /um, length scale {:.4f} um",
                                    volume.spectrum.peak_wavenumber_per_um,
                                    volume.spectrum.peak_length_um));
    out.preview.add_slice(
        geometry::slice(interface, 2, 0.5 * volume.box_um + 0.25 * volume.voxel_um), 0, 1, kInk);
    out.preview.caption = "keratin/air interface cut at mid-height (x right, y up)";
    return out;
}

Built import_geometry(ParameterTable geometry, bool vdb, const std::filesystem::path& study_dir,
                      const std::filesystem::path& dir) {
    ParameterTable m = geometry.table("mesh");
    const std::filesystem::path file =
        study_dir /
        m.required_string("file", {}, "mesh or volume file, relative to the study file");
    Built out;
    TriangleMesh mesh;
    if (vdb) {
        const std::string grid = m.string("grid", "keratin", {}, "level-set grid name");
        const auto level_set = geometry::load_level_set(file, grid);
        geometry::save_level_set(*level_set, dir / "volume.vdb");
        mesh = geometry::level_set_to_mesh(*level_set);
        out.files = {"volume.vdb", "mesh.ply"};
        out.facts.push_back(
            fmt::format("keratin fraction {:.4f}", geometry::measure_keratin_fraction(*level_set)));
        out.memory = level_set->memUsage();
    } else {
        geometry::MeshImportOptions options;
        // From picometres to metres per file unit: beyond either, a feather's micrometre features
        // would be below double's resolution of the file's numbers or above any scanner's field.
        options.scale_to_um =
            m.number("scale_to_um", 1.0, between(1e-6, 1e6), "micrometres per file unit");
        options.require_closed = m.boolean("require_closed", true, "reject open meshes");
        options.repair = m.boolean("repair", true, "repair what is safe to repair");
        const geometry::ImportedMesh imported = geometry::import_mesh(file, options);
        mesh = imported.mesh;
        out.files = {"mesh.ply"};
        out.facts.push_back(imported.report.clean() ? "mesh validation: clean"
                                                    : "mesh validation:\n\n```\n" +
                                                          imported.report.summary() + "\n```");
    }
    geometry::write_ply(mesh, dir / "mesh.ply");
    out.triangles = mesh.triangles.size();
    out.memory += mesh.memory_bytes();
    const auto box = mesh.bounds();
    out.preview.add_slice(geometry::slice(mesh, 2, 0.5 * (box[0].z() + box[1].z())), 0, 1, kInk);
    out.preview.caption = "cut at mid-height (x right, y up)";
    return out;
}

}  // namespace

GeometryStudyResult run_geometry_study(const std::filesystem::path& study_file,
                                       const std::filesystem::path& results_root) {
    const auto start = std::chrono::steady_clock::now();
    auto file = StudyFile::load(study_file);
    ParameterTable root = file->root();
    if (root.has("study") && !root.has("geometry")) {
        throw InputError(fmt::format(
            "{}: this is a study file (it has a `study` key): run it with `plumage run {}`",
            study_file.string(), study_file.string()));
    }
    const std::string name = read_study_name(root, study_file);
    ParameterTable geometry = root.table("geometry");
    const std::vector<std::string> kinds = {"barbule_row",    "barb_patch", "spongy_channel",
                                            "spongy_spheres", "mesh",       "vdb"};
    const std::string kind = geometry.required_string("kind", kinds, "what to build");

    StagedDirectory out(results_root / name);
    Built built;
    if (kind == "barbule_row") built = build_barbule_row(geometry, out.path());
    if (kind == "barb_patch") built = build_barb_patch(geometry, out.path());
    if (kind == "spongy_channel" || kind == "spongy_spheres")
        built = build_spongy(geometry, kind == "spongy_channel", out.path());
    if (kind == "mesh" || kind == "vdb")
        built = import_geometry(geometry, kind == "vdb", study_file.parent_path(), out.path());
    root.reject_unused();
    throw_if_interrupted("writing the preview and the report");

    built.preview.write(out.path() / "preview.png");
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    {
        std::ofstream md(out.path() / "report.md");
        md << fmt::format("# Geometry: {} ({})\n\n![preview](preview.png)\n\n*{}*\n\n", name, kind,
                          built.preview.caption);
        md << fmt::format(
            "- unit-mesh triangles: {}\n- instances: {}\n- memory (meshes + transforms): {:.3f} "
            "MB\n",
            built.triangles, built.instances, static_cast<double>(built.memory) / 1e6);
        for (const auto& f : built.facts) md << "- " << f << '\n';
        md << fmt::format("- built in {:.2f} s (plumage {})\n\nFiles: ", seconds, kVersion);
        for (std::size_t i = 0; i < built.files.size(); ++i)
            md << (i ? ", " : "") << built.files[i];
        md << ", preview.png.\n\n## Study file\n\n```toml\n" << file->text() << "\n```\n";
        if (!md) throw IoError("cannot write report.md");
    }
    out.commit();
    return {out.final_path(), kind, built.triangles, built.instances, built.memory, seconds};
}

}  // namespace plumage::studies
