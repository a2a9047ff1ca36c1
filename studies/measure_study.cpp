// The measure study (`study = "measure"`): the user's own sample — an imported PLY/OBJ mesh or
// OpenVDB level set, validated as `plumage geometry` validates it — given a material and an
// optional thin film, traced by the explicit tracer (sim/tracer.h) and measured by any of the
// instruments: the goniometer (BRDF), the imaging scatterometer (scatterogram), the BTF camera, and
// every instrument of the registry (virtual_gonio/instrument_registry.h: the integrating sphere).
//
// read → build → measure → report, each a named step below. There is no model to compare with:
// the report gives, per measurement, its estimated error and its wall time.
//
// Study file keys (units, ranges; studies/README.md, "measure"):
//   name, seed                                          (studies/sections.h)
//   time_budget_s, target_relative_error                per progressive measurement (BRDF,
//                                                       scatterogram); --time-budget and
//                                                       --target-error override them
//   [spectrum]     first_nm, last_nm, step_nm           (360–830 nm; default 400–700, 50 nm)
//   [sample]       file                                 .ply, .obj or .vdb, relative to the study
//                                                       file
//                  scale_to_um, require_closed, repair  as `plumage geometry` reads a mesh
//                  grid                                 .vdb: the level-set grid (default keratin)
//                  offset_um                            [x, y, z] added after scaling, µm
//                  material                             what the mesh encloses: keratin | melanin
//                                                       | air | lambertian (an opaque diffuse
//                                                       surface of `albedo`, [0, 1])
//                  max_events                           tracer events per path, [1, 10⁶]
//   [sample.film]  material, thickness_um               optional: a thin film on the surface
//                                                       (keratin | melanin; thickness (0, 5] µm)
//   [brdf]         direction_set                        filip2024_in_plane (55 pairs),
//                                                       filip2024_btf (3660), mirror (one specular
//                                                       pair per angle of mirror_angles_deg, in
//                                                       the y–z plane)
//                  detector_half_angle_deg, beam_radius_um, quanta_per_pass, passes
//   [scatterogram] beam_incidence_deg, beam_azimuth_deg, beam_radius_um, image_size,
//                  quanta_per_pass, passes
//   [btf]          mirror_angles_deg (pairs as [brdf]'s mirror set), and the camera's keys
//                  (studies/instrument_tables.h): pixels, patch_size_um, detector_half_angle_deg,
//                  aperture, estimator, quanta_per_light, quanta_per_pixel, max_passes,
//                  target_pixel_error, max_time_s
//   [<instrument>] every instrument of virtual_gonio/instrument_registry.h by its table's name
//                  and its own parameter table, e.g. [integrating_sphere] incidence_deg,
//                  azimuth_deg, beam_radius_um, quanta_per_pass, max_passes,
//                  target_relative_error
// At least one instrument table. The beam and the BTF patch are centred on the origin of the
// patch frame (+z the normal, light from above): place the sample there with offset_um.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/seed.h"
#include "common/version.h"
#include "geometry/mesh_import.h"
#include "geometry/spongy_volume.h"
#include "sim/optics/material.h"
#include "sim/scene.h"
#include "sim/tracer.h"
#include "studies/figure_data.h"
#include "studies/instrument_tables.h"
#include "studies/plots.h"
#include "studies/sections.h"
#include "studies/staged_directory.h"
#include "studies/study.h"
#include "studies/study_checkpoints.h"
#include "studies/study_context.h"
#include "studies/study_progress.h"
#include "studies/text_files.h"
#include "virtual_gonio/btf.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/exr_image.h"
#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/scatterometer.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

struct Sample {
    fs::path file;
    std::string file_as_written;  // [sample] file, relative to the study file
    std::string file_location;    // file:line:col of [sample] file, for errors found later
    std::string grid = "keratin";
    geometry::MeshImportOptions import;
    Vec3d offset_um = Vec3d::Zero();
    std::string material = "keratin";
    double albedo = 0.0;                                 // material = lambertian
    std::optional<std::pair<std::string, double>> film;  // material, thickness in µm
    int max_events = 1000;
};

// A registered instrument's table as read: its entry, its keys' values and the shared setting
// (the output folder is set when the run has one).
struct Registered {
    const gonio::InstrumentEntry* entry = nullptr;
    gonio::InstrumentValues values;
    gonio::MeasurementSetting setting;
};

struct Settings {
    std::string name;
    Sample sample;
    std::optional<gonio::GoniometerConfig> brdf;
    std::optional<gonio::ScatterometerConfig> scatterogram;
    std::optional<gonio::BtfConfig> btf;
    std::vector<Registered> registered;  // in the registry's order
};

std::shared_ptr<const optics::Material> material_named(const std::string& name) {
    if (name == "keratin") return optics::keratin();
    if (name == "melanin") return optics::melanin();
    return optics::air();
}

Sample read_sample(ParameterTable t, const fs::path& source) {
    Sample s;
    const std::string file = t.required_string(
        "file", {},
        "the sample's mesh (.ply, .obj) or level set (.vdb), relative to the study file");
    s.file_location = t.location("file");
    s.file = source.parent_path() / file;
    s.file_as_written = file;
    if (!fs::is_regular_file(s.file)) {
        throw InputError(fmt::format("{}: sample.file = \"{}\": no such file ({})", s.file_location,
                                     file, s.file.string()));
    }
    if (s.file.extension() == ".vdb") {
        s.grid = t.string("grid", s.grid, {}, "level-set grid name");
    } else {
        s.import = read_mesh_import_options(t);
    }
    const auto offset = t.numbers("offset_um", {0.0, 0.0, 0.0}, between(-1e6, 1e6), 3, 3,
                                  "translation of the sample after scaling, um");
    s.offset_um = Vec3d(offset[0], offset[1], offset[2]);
    s.material = t.required_string("material", {"keratin", "melanin", "air", "lambertian"},
                                   "what the surface encloses (lambertian: an opaque diffuse "
                                   "surface)");
    if (s.material == "lambertian") {
        s.albedo = t.required_number("albedo", between(0.0, 1.0), "albedo of the diffuse surface");
    }
    s.max_events = static_cast<int>(
        t.integer("max_events", s.max_events, 1, 1000000, "tracer events per path"));
    if (t.has("film")) {
        ParameterTable f = t.table("film");
        const std::string material =
            f.required_string("material", {"keratin", "melanin"}, "film material");
        const double d = read_required_film_thickness_um(f, "thickness_um", "film thickness");
        if (s.material == "lambertian") {
            throw InputError(fmt::format(
                "{}: sample.film: a film needs a dielectric beneath it, not a lambertian surface",
                f.location()));
        }
        s.film = {{material, d}};
    } else if (s.material == "air") {
        throw InputError(fmt::format(
            "{}: sample.material = \"air\" without [sample.film]: the sample would not scatter",
            t.location("material")));
    }
    return s;
}

// A specular pair per angle, light at (θ, φ = 90°), view at (θ, φ = 270°): the y–z plane.
std::vector<gonio::DirectionPair> mirror_pairs(ParameterTable& t) {
    const auto angles = t.numbers("mirror_angles_deg", {15.0, 45.0, 75.0}, between(0.0, 85.0), 1,
                                  90, "polar angles of the specular pairs, deg");
    std::vector<gonio::DirectionPair> pairs;
    for (double a : angles) {
        pairs.push_back({gonio::direction_from_angles(a * kDeg, 90.0 * kDeg),
                         gonio::direction_from_angles(a * kDeg, 270.0 * kDeg)});
    }
    return pairs;
}

gonio::GoniometerConfig read_brdf(ParameterTable t, const std::vector<double>& wavelengths,
                                  const StudyContext& ctx) {
    gonio::GoniometerConfig c;  // the measure study's defaults; the keys: instrument_tables.h
    c.direction_set = "filip2024_in_plane";
    c.detector_half_angle_rad = 2.5 * kDeg;
    c.quanta_per_pass = 20000;
    c.max_passes = 4;
    GoniometerKeys keys;
    keys.direction_sets = {"filip2024_in_plane", "filip2024_btf", "mirror"};
    keys.beam_radius = true;
    c = read_goniometer_table(t, c, keys);
    if (c.direction_set == "mirror") c.pairs = mirror_pairs(t);
    c.wavelengths_nm = wavelengths;
    c.estimator = gonio::Estimator::photon;
    c.seed = ctx.stream("measure/brdf");
    return c;
}

gonio::ScatterometerConfig read_scatterogram(ParameterTable t,
                                             const std::vector<double>& wavelengths,
                                             const StudyContext& ctx) {
    ScatterometerTable d;  // the measure study's defaults; the keys: instrument_tables.h
    d.beam_incidence_rad = 30.0 * kDeg;
    d.beam_azimuth_rad = 90.0 * kDeg;
    d.config.image_size = 65;
    d.config.quanta_per_pass = 200000;
    d.config.max_passes = 2;
    gonio::ScatterometerConfig c = read_scatterometer_table(t, d, ScatterometerKeys{}).config;
    c.wavelengths_nm = wavelengths;
    c.seed = ctx.stream("measure/scatterogram");
    return c;
}

gonio::BtfConfig read_btf(ParameterTable t, const std::vector<double>& wavelengths,
                          const StudyContext& ctx) {
    gonio::BtfConfig c;  // the measure study's defaults; the keys: studies/instrument_tables.h
    c.pixels = 16;
    c.patch_size_um = 100.0;
    c.quanta_per_light = 200000;
    c = read_btf_camera(t, c);
    c.pairs = mirror_pairs(t);
    c.wavelengths_nm = wavelengths;
    c.seed = ctx.stream("measure/btf");
    return c;
}

Settings read(StudyContext& ctx) {
    const std::string& text = ctx.text();
    const fs::path& source = ctx.source();
    ParameterTable root = ctx.root();
    root.string("study", "measure", {"measure"}, "which study this file describes");
    Settings s;
    s.name = read_study_name(root, source);
    ParameterTable spectrum = root.table("spectrum");
    const std::vector<double> wavelengths = read_wavelengths(spectrum, WavelengthRule{});
    // --time-budget and --target-error replace the file's values (studies/study_context.h).
    const double budget =
        ctx.time_budget_s(root.number("time_budget_s", std::numeric_limits<double>::infinity(),
                                      positive(), "wall-time budget per measurement, s"));
    const double target = ctx.target_relative_error(
        root.number("target_relative_error", 0.0, between(0.0, 1.0),
                    "stop a measurement once its relative error is below this"));
    s.sample = read_sample(root.table("sample"), source);
    if (root.has("brdf")) s.brdf = read_brdf(root.table("brdf"), wavelengths, ctx);
    if (root.has("scatterogram")) {
        s.scatterogram = read_scatterogram(root.table("scatterogram"), wavelengths, ctx);
    }
    if (root.has("btf")) s.btf = read_btf(root.table("btf"), wavelengths, ctx);
    std::string tables = "[brdf], [scatterogram], [btf]";
    for (const gonio::InstrumentEntry& entry : gonio::instrument_registry()) {
        tables += fmt::format(", [{}]", entry.table);
        if (!root.has(entry.table)) continue;
        Registered r;
        r.entry = &entry;
        r.setting.wavelengths_nm = wavelengths;
        r.setting.seed = ctx.stream(fmt::format("measure/{}", entry.table));
        r.setting.config_text = text;
        r.setting.time_budget_s = budget;
        r.setting.target_relative_error = target;
        r.setting.progress = true;
        ParameterTable table = root.table(entry.table);
        r.values = read_instrument_table(table, entry, r.setting);
        s.registered.push_back(std::move(r));
    }
    if (!s.brdf && !s.scatterogram && !s.btf && s.registered.empty()) {
        throw InputError(
            fmt::format("{}: expected at least one instrument table: {}", source.string(), tables));
    }
    if (s.brdf) {
        s.brdf->time_budget_s = budget;
        s.brdf->target_relative_error = target;
        s.brdf->config_text = text;
    }
    if (s.scatterogram) {
        s.scatterogram->time_budget_s = budget;
        s.scatterogram->target_relative_error = target;
        s.scatterogram->config_text = text;
    }
    if (s.btf) s.btf->config_text = text;
    root.reject_unused();
    return s;
}

struct Built {
    std::shared_ptr<const sim::ExplicitScatterer> scatterer;
    Eigen::AlignedBox3d bounds;      // the placed sample, patch frame, µm
    std::vector<std::string> facts;  // report lines
};

sim::SurfaceMaterial surface_of(const Sample& s) {
    if (s.material == "lambertian") return sim::diffuse_layer(sim::constant_albedo(s.albedo));
    const auto inside = material_named(s.material);
    if (s.film)
        return sim::thin_film_interface(material_named(s.film->first), s.film->second,
                                        optics::air(), inside);
    return sim::dielectric_interface(inside);
}

// The mesh as `plumage geometry` imports it (InputErrors name the study file's key), one
// surface of the sample's material, placed by offset_um.
Built build(const Sample& s) {
    Built b;
    geometry::TriangleMesh mesh;
    try {
        if (s.file.extension() == ".vdb") {
            mesh = geometry::level_set_to_mesh(*geometry::load_level_set(s.file, s.grid));
        } else {
            const geometry::ImportedMesh imported = geometry::import_mesh(s.file, s.import);
            mesh = imported.mesh;
            b.facts.push_back(imported.report.clean() ? "mesh validation: clean"
                                                      : "mesh validation:\n\n```\n" +
                                                            imported.report.summary() + "\n```");
        }
    } catch (const InputError& e) {
        throw InputError(fmt::format("{}: sample.file: {}", s.file_location, e.what()));
    }
    sim::SceneDescription scene;
    scene.units.push_back({"sample", {{"sample", mesh, surface_of(s)}}});
    sim::Instance instance;
    instance.transform = Eigen::Translation3d(s.offset_um);
    scene.instances.push_back(instance);
    const auto box = scene.bounds();
    b.bounds = box;
    b.facts.push_back(fmt::format(
        "{} triangles; extent x [{:.4g}, {:.4g}], y [{:.4g}, {:.4g}], z [{:.4g}, {:.4g}] um",
        mesh.triangles.size(), box.min().x(), box.max().x(), box.min().y(), box.max().y(),
        box.min().z(), box.max().z()));
    sim::TracerOptions options;
    options.max_events = s.max_events;
    b.scatterer = std::make_shared<sim::ExplicitScatterer>(std::move(scene), options);
    return b;
}

// Where the beam's footprint (its radius over cos θ_i, along the light's azimuth) reaches past
// the sample's outline in the patch plane: that light passes the sample by, and the instrument
// reads the sample per unit power of the whole beam. Said in the report, not refused: a sample
// smaller than the beam is a measurement too.
void check_footprint(const Built& b, double beam_radius_um, const std::vector<Vec3d>& lights,
                     const std::string& instrument, std::vector<std::string>& facts) {
    const double reach = std::min(
        {-b.bounds.min().x(), b.bounds.max().x(), -b.bounds.min().y(), b.bounds.max().y()});
    double footprint = 0.0;
    for (const Vec3d& wi : lights) footprint = std::max(footprint, beam_radius_um / wi.z());
    if (footprint > reach) {
        facts.push_back(fmt::format(
            "{}: the beam's footprint reaches {:.4g} um from the origin at the most oblique "
            "light, the sample's outline only {:.4g} um: light beyond it misses the sample",
            instrument, footprint, reach));
    }
}

// A drawn figure the report embeds: its caption and its PNG, relative to the report.
struct Figure {
    std::string caption, png;
};

// One row of the report's measurement table, and the figures it drew (none when plotting was
// off or failed: the report then names only the records).
struct Measured {
    std::string instrument, cells, files;
    double error = 0.0;  // see error_meaning
    std::string error_meaning;
    double wall_s = 0.0;
    std::vector<Figure> figures;
};

// The figure of `png` in `figures` if run_plot drew it.
void add_if_drawn(std::vector<Figure>& figures, bool drawn, std::string caption, std::string png) {
    if (drawn) figures.push_back({std::move(caption), std::move(png)});
}

// The BRDF, checkpointed in `checkpoint` under the identity of the study text, the
// configuration and `inputs` (the sample file's content).
Measured measure_brdf_record(const Built& b, const gonio::GoniometerConfig& c, const fs::path& dir,
                             const fs::path& checkpoint,
                             const std::vector<gonio::CheckpointPart>& inputs,
                             const StudyProgress& clock) {
    clock.say(fmt::format("BRDF on {} ({} pairs)", c.direction_set, c.pairs.size()));
    gonio::RunControl control;
    control.checkpoint = checkpoint;
    control.checkpoint_inputs = inputs;
    fs::create_directories(checkpoint.parent_path());
    const gonio::BrdfRecord r = gonio::measure_brdf(*b.scatterer, c, control);
    if (r.interrupted) {
        throw Interrupted(interrupted_with_checkpoint("the BRDF", r.passes, checkpoint));
    }
    gonio::write_brdf_record(r, dir / "brdf.h5");
    std::string files = "brdf.h5";
    std::vector<Figure> figures;
    if (c.direction_set == "filip2024_btf") {
        write_fingerprint_figure(dir / "brdf_fingerprint.h5", "Measured sample: BRDF fingerprint",
                                 {{"sample", &r}}, 61, 60);
        add_if_drawn(figures,
                     run_plot("fingerprints", dir / "brdf_fingerprint.h5", dir / "brdf.png"),
                     "BRDF fingerprint (Filip 2024 Fig. 7 layout)", "brdf.png");
        gonio::write_spectral_exr(dir / "brdf.exr",
                                  {gonio::fingerprint_exr_image(r, 61, 60, "sample")}, "measure");
        files += ", brdf_fingerprint.h5, brdf.png, brdf.exr";
    } else {
        // BRDF against the pair's light angle, a column pair per wavelength: drawn as curves at a
        // few wavelengths beside a map of all (plots.py `brdf_wavelengths`).
        const bool mirror = c.direction_set == "mirror";
        std::ofstream csv(dir / "brdf_curves.csv");
        csv << (mirror ? "mirror angle (deg)" : "signed light angle (deg; view at 45 deg)");
        for (double l : c.wavelengths_nm) csv << fmt::format(",{:g} nm,{:g} nm error", l, l);
        csv << '\n';
        const auto angles = gonio::filip2024_in_plane_light_angles();
        for (std::size_t p = 0; p < c.pairs.size(); ++p) {
            const double x = mirror ? std::acos(c.pairs[p].wi.z()) / kDeg : angles[p] / kDeg;
            csv << fmt::format("{:.6g}", x);
            for (std::size_t l = 0; l < c.wavelengths_nm.size(); ++l)
                csv << fmt::format(",{:.9g},{:.9g}", r.at(p, l), r.error_at(p, l));
            csv << '\n';
        }
        close_written(csv, dir / "brdf_curves.csv");
        add_if_drawn(
            figures, run_plot("brdf_wavelengths", dir / "brdf_curves.csv", dir / "brdf.png"),
            mirror ? "BRDF against the mirror angle" : "BRDF against the light angle, view at 45°",
            "brdf.png");
        files += ", brdf_curves.csv, brdf.png";
    }
    const double error =
        r.convergence.empty() ? 0.0 : r.convergence.back().estimated_relative_rms_error;
    return {"goniometer (BRDF)",
            fmt::format("{} pairs × {} λ, {} quanta per light and λ", c.pairs.size(),
                        c.wavelengths_nm.size(), r.quanta),
            files,
            error,
            "estimated relative RMS error",
            r.wall_time_s,
            figures};
}

Measured measure_scatterogram_record(const Built& b, const gonio::ScatterometerConfig& c,
                                     const fs::path& dir, const StudyProgress& clock) {
    clock.say(fmt::format("scatterogram ({} px)", c.image_size));
    const gonio::Scatterogram s = gonio::measure_scatterogram(*b.scatterer, c);
    gonio::write_scatterogram_record(s, dir / "scatterogram.h5");
    {
        record::Hdf5Writer h5(dir / "scatterogram_figure.h5");
        write_scatterogram_figure(h5, s, s, "measured sample");
        h5.commit();
    }
    std::vector<Figure> figures;
    add_if_drawn(figures,
                 run_plot("scatterogram", dir / "scatterogram_figure.h5", dir / "scatterogram.png"),
                 "scatterogram", "scatterogram.png");
    gonio::write_spectral_exr(dir / "scatterogram.exr",
                              {gonio::scatterogram_exr_image(s, "sample")}, "measure");
    return {
        "imaging scatterometer",
        fmt::format("{0}×{0} px × {1} λ, {2} quanta per λ", c.image_size, c.wavelengths_nm.size(),
                    s.quanta),
        "scatterogram.h5, scatterogram.png (its data: scatterogram_figure.h5), scatterogram.exr",
        median_relative_standard_error(s),
        "median per-pixel relative standard error",
        s.wall_time_s,
        figures};
}

Measured measure_btf_record(const Built& b, const gonio::BtfConfig& c, const fs::path& dir,
                            const StudyProgress& clock) {
    clock.say(fmt::format("BTF ({} pairs, {} px)", c.pairs.size(), c.pixels));
    const gonio::BtfRecord r = gonio::measure_btf(*b.scatterer, c);
    gonio::write_btf_record(r, dir / "btf.h5");
    std::vector<std::size_t> pairs(c.pairs.size());
    for (std::size_t p = 0; p < pairs.size(); ++p) pairs[p] = p;
    write_btf_figure(dir / "btf_figure.h5", "Measured sample: BTF", r, pairs);
    std::vector<Figure> figures;
    add_if_drawn(figures, run_plot("btf_tiles", dir / "btf_figure.h5", dir / "btf.png"),
                 "BTF images", "btf.png");
    std::vector<gonio::SpectralImage> parts;
    for (std::size_t p : pairs)
        parts.push_back(gonio::btf_exr_image(r, p, fmt::format("pair{}", p)));
    gonio::write_spectral_exr(dir / "btf.exr", parts, "measure");
    // Relative error of the whole patch's mean per (pair, λ): Σσ²/(Σv)², the pixels independent.
    double sum_rel2 = 0.0;
    std::size_t cells = 0;
    for (std::size_t p = 0; p < pairs.size(); ++p) {
        for (std::size_t l = 0; l < c.wavelengths_nm.size(); ++l) {
            double v = 0.0, v2 = 0.0;
            for (int row = 0; row < c.pixels; ++row) {
                for (int col = 0; col < c.pixels; ++col) {
                    v += r.value[r.index(p, row, col, l)];
                    const double se = r.standard_error[r.index(p, row, col, l)];
                    v2 += se * se;
                }
            }
            if (v > 0.0) sum_rel2 += v2 / (v * v), ++cells;
        }
    }
    return {
        "BTF camera",
        fmt::format("{} pairs × {}² px × {} λ", c.pairs.size(), c.pixels, c.wavelengths_nm.size()),
        "btf.h5, btf_figure.h5, btf.png, btf.exr",
        cells ? std::sqrt(sum_rel2 / static_cast<double>(cells)) : 0.0,
        "relative RMS error of the patch-mean BRDF",
        r.wall_time_s,
        figures};
}

// A registered instrument (virtual_gonio/instrument_registry.h): its records, its row, and its
// curves drawn against wavelength.
Measured measure_registered_record(const Built& b, Registered r, const fs::path& dir,
                                   const StudyProgress& clock) {
    std::string name(r.entry->table);
    std::replace(name.begin(), name.end(), '_', ' ');
    clock.say(name);
    r.setting.folder = dir;
    const gonio::InstrumentResult result = r.entry->measure(*b.scatterer, r.values, r.setting);
    std::string files;
    for (const std::string& f : result.files) {
        if (!files.empty()) files += ", ";
        files += f;
    }
    std::vector<Figure> figures;
    if (!result.curves.empty()) {
        const std::string stem = std::string(r.entry->table) + "_curves";
        write_instrument_curves_figure(dir / (stem + ".h5"), r.setting.wavelengths_nm, result);
        add_if_drawn(figures,
                     run_plot("instrument_curves", dir / (stem + ".h5"), dir / (stem + ".png")),
                     result.curves_title, stem + ".png");
        files += fmt::format(", {0}.png (its data: {0}.h5)", stem);
    }
    return {fmt::format("{} ({})", name, r.entry->description),
            result.cells,
            files,
            result.error,
            result.error_meaning,
            result.wall_time_s,
            figures};
}

void write_report(const fs::path& path, const Settings& s, const Built& b,
                  const std::vector<Measured>& rows, const std::string& text,
                  const std::string& run_time) {
    std::ofstream md(path);
    md << fmt::format("# Measurement: {}\n\nSample `{}` ({}", s.name,
                      s.sample.file.filename().string(), s.sample.material);
    if (s.sample.material == "lambertian") md << fmt::format(", albedo {}", s.sample.albedo);
    if (s.sample.film) {
        md << fmt::format(", with a {} film {} µm thick", s.sample.film->first,
                          s.sample.film->second);
    }
    md << ") traced by the explicit tracer (sim/tracer.h), plumage " << kVersion << ".\n\n";
    for (const auto& f : b.facts) md << "- " << f << '\n';
    md << "\n| instrument | cells | error | what the error is | wall time (s) | files |\n"
          "|---|---|---|---|---|---|\n";
    for (const auto& r : rows) {
        md << fmt::format("| {} | {} | {:.3g} | {} | {:.2f} | {} |\n", r.instrument, r.cells,
                          r.error, r.error_meaning, r.wall_s, r.files);
    }
    md << "\nRecords: virtual_gonio/RECORD.md.\n\n";
    bool drawn = false;
    for (const auto& r : rows) drawn = drawn || !r.figures.empty();
    if (drawn) md << "## Figures\n\n";
    for (const auto& r : rows) {
        for (const Figure& f : r.figures)
            md << fmt::format("{}: {}\n\n![{}]({})\n\n", r.instrument, f.caption, f.caption, f.png);
    }
    md << run_time;
    md << "## Study file\n\n```toml\n" << text << "\n```\n";
    if (!md) throw IoError(fmt::format("cannot write {}", path.string()));
}

std::string run(const std::string& text, const fs::path& source, const fs::path& results_root,
                const RunLimits& limits) {
    StudyContext ctx(text, source, results_root, limits, true);
    const StudyProgress& clock = ctx.clock();
    Settings s = read(ctx);  // read
    ctx.begin(s.name);
    clock.say("importing the sample and building its scene");
    // The sample file's content keys the BRDF's checkpoint. Hashed before it is imported: a file
    // changed in between leaves a checkpoint keyed by content it was not made from, which no
    // later run resumes (hashed after, a checkpoint of the old content would carry the new
    // content's key).
    std::vector<gonio::CheckpointPart> inputs;
    if (s.brdf) {
        inputs.push_back(input_file_part(
            fmt::format("the content of the sample file '{}'", s.sample.file_as_written),
            s.sample.file));
    }
    Built b = build(s.sample);  // build
    if (s.brdf) {
        std::vector<Vec3d> lights;
        for (const auto& pair : s.brdf->pairs) lights.push_back(pair.wi);
        check_footprint(b, s.brdf->beam_radius_um, lights, "BRDF", b.facts);
    }
    if (s.scatterogram) {
        check_footprint(b, s.scatterogram->beam_radius_um, {s.scatterogram->beam_direction},
                        "scatterogram", b.facts);
    }
    const fs::path out = ctx.out();
    std::vector<Measured> rows;  // measure
    if (s.brdf) {
        rows.push_back(measure_brdf_record(b, *s.brdf, out, ctx.checkpoints() / "brdf.checkpoint",
                                           inputs, clock));
    }
    if (s.scatterogram) rows.push_back(measure_scatterogram_record(b, *s.scatterogram, out, clock));
    if (s.btf) rows.push_back(measure_btf_record(b, *s.btf, out, clock));
    for (Registered& r : s.registered) rows.push_back(measure_registered_record(b, r, out, clock));
    clock.say("writing the report");  // report
    write_report(out / "report.md", s, b, rows, text, ctx.run_time_by_stage());
    const fs::path final_path = ctx.commit();
    std::string summary = fmt::format("plumage: wrote {}:", final_path.string());
    for (const auto& r : rows)
        summary += fmt::format(" {} {:.3g} in {:.1f} s;", r.instrument, r.error, r.wall_s);
    return summary + "\n";
}

void check(const std::string& text, const fs::path& source) {
    StudyContext ctx(text, source);
    read(ctx);
}

}  // namespace

StudyEntry measure_study_entry() {
    return {"measure",
            "an imported mesh or level set with a material and film, measured by the goniometer, "
            "scatterometer, BTF camera and/or any registered instrument (integrating sphere)",
            check, run};
}

}  // namespace plumage::studies
