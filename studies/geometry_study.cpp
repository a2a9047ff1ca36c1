#include "studies/geometry_study.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <numbers>
#include <span>

#include <fmt/format.h>

#include "common/error.h"
#include "common/version.h"
#include "geometry/barb.h"
#include "geometry/barbule.h"
#include "geometry/mesh_import.h"
#include "geometry/spongy_volume.h"
#include "studies/plots.h"
#include "studies/sections.h"
#include "studies/staged_directory.h"
#include "studies/study_file.h"
#include "studies/text_files.h"
#include "virtual_gonio/record/hdf5_file.h"

namespace plumage::studies {
namespace {

using geometry::TriangleMesh;

// Everything drawn in a preview, in µm, in the plane's own 2D coordinates; plots.py
// (geometry_preview) draws it from preview.h5: filled phases, outlines, legend, scale bar.
struct Preview {
    struct Phase {
        std::string name, colour;  // colour: a matplotlib colour ("#rrggbb")
        bool filled = false;       // an area (polygons, closed outlines) or a line
    };
    struct Line {
        Eigen::Vector2d a, b;
        int phase = 0;
    };
    struct Polygon {
        std::vector<Eigen::Vector2d> points;
        int phase = 0;
    };
    std::vector<Phase> phases;
    std::vector<Line> lines;
    std::vector<Polygon> polygons;
    std::string caption, x_label = "x (µm)", y_label = "y (µm)";

    int phase(std::string name, std::string colour, bool filled) {
        phases.push_back({std::move(name), std::move(colour), filled});
        return static_cast<int>(phases.size()) - 1;
    }
    void add_slice(const std::vector<geometry::Segment3>& segments, int u, int v, int phase_index) {
        for (const auto& s : segments)
            lines.push_back({{s.a[u], s.a[v]}, {s.b[u], s.b[v]}, phase_index});
    }
    void write(const std::filesystem::path& path) const {
        if (lines.empty() && polygons.empty())
            throw InvariantError("geometry preview: nothing to draw");
        using Dims = std::vector<std::uint64_t>;
        record::Hdf5Writer h5(path);
        std::string names, colours, filled;
        for (std::size_t i = 0; i < phases.size(); ++i) {
            const char* sep = i ? "|" : "";
            names += sep + phases[i].name;
            colours += sep + phases[i].colour;
            filled += sep + std::string(phases[i].filled ? "1" : "0");
        }
        h5.set_attribute("/", "caption", caption);
        h5.set_attribute("/", "x_label", x_label);
        h5.set_attribute("/", "y_label", y_label);
        h5.set_attribute("/", "phase_names", names);
        h5.set_attribute("/", "phase_colours", colours);
        h5.set_attribute("/", "phase_filled", filled);
        if (!lines.empty()) {
            std::vector<double> xy, phase_of;
            for (const auto& l : lines) {
                xy.insert(xy.end(), {l.a.x(), l.a.y(), l.b.x(), l.b.y()});
                phase_of.push_back(l.phase);
            }
            h5.write("segments", std::span<const double>(xy), Dims{lines.size(), 4},
                     {{"units", "um"},
                      {"description",
                       "cut outlines: x0, y0, x1, y1 of each segment, in the "
                       "plane of the cut (/@x_label, /@y_label)"}});
            h5.write("segment_phase", std::span<const double>(phase_of), Dims{lines.size()},
                     {{"units", "1"},
                      {"description", "index of each segment's phase in /@phase_names"}});
        }
        if (!polygons.empty()) {
            std::vector<double> xy, offsets = {0.0}, phase_of;
            for (const auto& p : polygons) {
                for (const auto& q : p.points) xy.insert(xy.end(), {q.x(), q.y()});
                offsets.push_back(static_cast<double>(xy.size() / 2));
                phase_of.push_back(p.phase);
            }
            h5.write("polygon_vertices", std::span<const double>(xy), Dims{xy.size() / 2, 2},
                     {{"units", "um"}, {"description", "vertices of every filled polygon, x y"}});
            h5.write("polygon_offsets", std::span<const double>(offsets), Dims{offsets.size()},
                     {{"units", "1"},
                      {"description",
                       "polygon k: rows offsets[k] to offsets[k+1] of "
                       "polygon_vertices"}});
            h5.write("polygon_phase", std::span<const double>(phase_of), Dims{polygons.size()},
                     {{"units", "1"},
                      {"description", "index of each polygon's phase in /@phase_names"}});
        }
        h5.commit();
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
    close_written(out, path);
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
    // Surfaces, not areas (barbule.h): the keratin cortex is a thin film on the outer surface,
    // the melanin layer lies beneath it across an air gap.
    const int film =
        out.preview.phase("outer surface (keratin cortex as a thin film)", "#28aa5a", false);
    const int melanin_surface =
        out.preview.phase("melanin layer's surface (air gap above)", "#6e3c1e", false);
    double y_cut = 0.0;
    const int middle = p.cells_per_barbule / 2;
    y_cut = built.instances[static_cast<std::size_t>(middle)].translation().y();
    for (const auto& t : built.instances) {
        if (std::abs(t.translation().y() - y_cut) > 1e-6 * p.cell.cell_length_um) continue;
        for (bool melanin : {false, true}) {
            TriangleMesh copy = melanin ? built.cell_melanin : built.cell_film;
            for (auto& v : copy.positions) v = t * v;
            out.preview.add_slice(geometry::slice(copy, 1, y_cut), 0, 2,
                                  melanin ? melanin_surface : film);
        }
    }
    out.preview.caption =
        "transversal cut (x right, z up) through one cell of each barbule: film green, melanin "
        "brown";
    out.preview.y_label = "z (µm)";
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
    const int cortex = out.preview.phase("barb cortex (keratin)", "#aaaaaa", true);
    const int medulla = out.preview.phase("barb medulla", "#ebebe1", true);
    const int barbule = out.preview.phase("barbules (keratin)", "#3c96c8", true);
    for (int k = -1; k <= 1; ++k) {
        for (const auto& shape : section.shapes) {
            Preview::Polygon polygon;
            for (const auto& q : shape.polygon)
                polygon.points.push_back(q + Eigen::Vector2d(k * section.period_um, 0.0));
            polygon.phase = shape.role == geometry::SurfaceRole::barb_cortex    ? cortex
                            : shape.role == geometry::SurfaceRole::barb_medulla ? medulla
                                                                                : barbule;
            out.preview.polygons.push_back(std::move(polygon));
        }
    }
    out.preview.caption =
        "cross-section across the barbs (y right, z up), three periods: cortex grey, medulla "
        "white, barbules blue";
    out.preview.x_label = "y (µm)";
    out.preview.y_label = "z (µm)";
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
        close_written(csv, dir / "power_spectrum.csv");
    }
    out.files = {"keratin.vdb", "interface.ply", "power_spectrum.csv"};
    out.triangles = interface.triangles.size();
    out.memory = volume.level_set->memUsage() + interface.memory_bytes();
    out.facts.push_back(fmt::format("measured keratin fraction {:.4f}", volume.keratin_fraction));
    out.facts.push_back(fmt::format("spectral peak at k = {:.3f} /um, length scale {:.4f} um",
                                    volume.spectrum.peak_wavenumber_per_um,
                                    volume.spectrum.peak_length_um));
    // The interface mesh is closed (keratin ∩ box), so its cut is closed outlines: plots.py
    // fills them by nesting, keratin inside.
    const int keratin = out.preview.phase("keratin", "#d9a441", true);
    out.preview.phase("air (blank)", "#ffffff", true);
    out.preview.add_slice(
        geometry::slice(interface, 2, 0.5 * volume.box_um + 0.25 * volume.voxel_um), 0, 1, keratin);
    out.preview.caption = "keratin/air cut at mid-height (x right, y up)";
    return out;
}

Built import_geometry(ParameterTable geometry, bool vdb, const std::filesystem::path& study_dir,
                      const std::filesystem::path& dir) {
    ParameterTable m = geometry.table("mesh");
    const std::filesystem::path file =
        study_dir /
        m.required_string("file", {}, "mesh or volume file, relative to the study file");
    // The readers name the mesh or volume file, not the study key that pointed at it.
    const auto naming_the_key = [&](const InputError& e) {
        return InputError(fmt::format("{}: geometry.mesh.file: {}", m.location("file"), e.what()));
    };
    Built out;
    TriangleMesh mesh;
    if (vdb) {
        const std::string grid = m.string("grid", "keratin", {}, "level-set grid name");
        openvdb::FloatGrid::Ptr level_set;
        try {
            level_set = geometry::load_level_set(file, grid);
        } catch (const InputError& e) {
            throw naming_the_key(e);
        }
        geometry::save_level_set(*level_set, dir / "volume.vdb");
        mesh = geometry::level_set_to_mesh(*level_set);
        out.files = {"volume.vdb", "mesh.ply"};
        out.facts.push_back(
            fmt::format("keratin fraction {:.4f}", geometry::measure_keratin_fraction(*level_set)));
        out.memory = level_set->memUsage();
    } else {
        const geometry::MeshImportOptions options = read_mesh_import_options(m);
        geometry::ImportedMesh imported;
        try {
            imported = geometry::import_mesh(file, options);
        } catch (const InputError& e) {
            throw naming_the_key(e);
        }
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
    out.preview.add_slice(geometry::slice(mesh, 2, 0.5 * (box[0].z() + box[1].z())), 0, 1,
                          out.preview.phase(vdb ? "keratin (inside the level set)"
                                                : "inside the mesh (filled where its cut closes)",
                                            "#d9a441", true));
    out.preview.caption = "cut at mid-height (x right, y up)";
    if (vdb) out.preview.phase("air (blank)", "#ffffff", true);
    return out;
}

}  // namespace

namespace {

GeometryStudyResult run_geometry_file(const std::shared_ptr<StudyFile>& file,
                                      const std::filesystem::path& study_file,
                                      const std::filesystem::path& results_root,
                                      std::chrono::steady_clock::time_point start) {
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

    built.preview.write(out.path() / "preview.h5");
    run_plot("geometry_preview", out.path() / "preview.h5", out.path() / "preview.png");
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
        md << ", preview.h5 (the preview's data), preview.png.\n\n## Study file\n\n```toml\n"
           << file->text() << "\n```\n";
        close_written(md, out.path() / "report.md");
    }
    out.commit();
    return {out.final_path(), kind, built.triangles, built.instances, built.memory, seconds};
}

}  // namespace

GeometryStudyResult run_geometry_study(const std::filesystem::path& study_file,
                                       const std::filesystem::path& results_root) {
    const auto start = std::chrono::steady_clock::now();
    return run_geometry_file(StudyFile::load(study_file), study_file, results_root, start);
}

GeometryStudyResult run_geometry_study(const std::string& text, const std::filesystem::path& source,
                                       const std::filesystem::path& results_root) {
    const auto start = std::chrono::steady_clock::now();
    return run_geometry_file(StudyFile::parse(text, source), source, results_root, start);
}

}  // namespace plumage::studies
