#include "studies/species_study.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string_view>

#include <fmt/format.h>

#include "analysis/fits/filip2024_fit.h"
#include "analysis/metrics/avian_compare.h"
#include "analysis/metrics/statistics.h"
#include "common/constants.h"
#include "common/error.h"
#include "common/relative_l1.h"
#include "common/version.h"
#include "geometry/barb.h"
#include "sim/albedo.h"
#include "sim/optics/colour.h"
#include "sim/optics/material.h"
#include "sim/optics/spectrum.h"
#include "sim/scatterer/mounted_scatterer.h"
#include "sim/scatterer/period_cell_entry.h"
#include "sim/tracer.h"
#include "studies/figure_data.h"
#include "studies/instrument_tables.h"
#include "studies/measurement_cost.h"
#include "studies/plots.h"
#include "studies/sections.h"
#include "studies/spongy_medium.h"
#include "studies/staged_directory.h"
#include "studies/study.h"
#include "studies/study_checkpoints.h"
#include "studies/study_context.h"
#include "studies/study_file.h"
#include "studies/study_progress.h"
#include "studies/text_files.h"
#include "virtual_gonio/btf.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/display_colour.h"
#include "virtual_gonio/exr_image.h"
#include "virtual_gonio/goniometer.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/record/png_image.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;
using analysis::Filip2024Parameters;
using analysis::kFilip2024ParameterCount;
using analysis::kFilip2024ParameterTable;

// The largest polar angle of the paper's capture (Sect. 4): the beam footprint and the
// light's lateral travel through the patch at this angle decide whether a patch is big enough.
constexpr double kLargestPolarRad = 75.0 * kDeg;

// The medulla of a barb: a white scatterer (constant albedo), or spongy keratin given by its
// structure only (studies/spongy_medium.h: a channel volume → first-Born medium; sim/scene.h's
// SpongyMedulla) around an optional melanin core.
struct MedullaSpec {
    bool spongy = false;
    double albedo = 0.8;           // white only
    SpongyMediumParams structure;  // spongy: Λ, f, volume box and voxel (seed at build)
    double core_scale = 0.0;       // spongy: melanin core, medulla cross-section × this
};

// The spongy medulla's keys (structure only) and the colour keys it refuses: its colour is
// what the medium computes.
constexpr std::array<std::string_view, 6> kSpongyKeys = {
    "spongy_length_scale_um", "spongy_keratin_fraction", "spongy_shell_relative_width",
    "spongy_box_um",          "spongy_voxel_um",         "spongy_core_scale"};
constexpr std::array<std::string_view, 5> kSpongyColourKeys = {
    "medulla_albedo", "medulla_base_albedo", "spongy_band_width_nm", "spongy_spacing_um",
    "medulla_colour"};

struct SpeciesSpec {
    std::string name;         // one of Filip's four: selects the Table 1 column
    std::string description;  // how the geometry resembles the sample (the study file says)
    std::string oriented_by;  // "barbs" or "barbules": which fibres Filip's U(φa) follows
    double mount_rad = 0.0;   // azimuth of the barb axis in the instrument frame
    geometry::BarbulePatchParams patch;
    double length_um = 3000.0;
    int barbs = 10;
    int layers = 1;
    double layer_gap_um = 2.0;  // between the lowest point of a layer and the top of the next
    double layer_shift = 0.5;   // lateral shift of each layer, in barb periods
    // Materials.
    bool melanin_core = false;  // barbules: keratin cortex film over a melanin core
    double cortex_um = 0.0;     // that film's thickness (0: bare keratin | melanin)
    bool cortex_coherent = true;
    double pigment_peak_nm = 480.0, pigment_width_nm = 40.0, pigment_k = 0.0;  // keratin
    MedullaSpec medulla;
};

// The BTF camera of Fig. 9's images: 16 × 16 px over 900 µm, 10° cones, 3 wavelengths.
gonio::BtfConfig species_btf_defaults() {
    gonio::BtfConfig c;
    c.pixels = 16;
    c.patch_size_um = 900.0;
    c.quanta_per_light = 100000;
    c.wavelengths_nm = {450.0, 550.0, 650.0};
    c.detector_half_angle_rad = 10.0 * kDeg;
    return c;
}

// The goniometer of the 61 × 60 BRDF: 5° cones, 20000 quanta in one pass; the pairs, seed and
// study text are set when it is measured.
gonio::GoniometerConfig species_goniometer_defaults() {
    gonio::GoniometerConfig g;
    g.direction_set = "filip2024_btf";
    g.detector_half_angle_rad = 5.0 * kDeg;
    g.aperture = gonio::Aperture::view_cone;  // species*.toml: both_cones
    g.quanta_per_pass = 20000;
    g.max_passes = 1;
    g.estimator = gonio::Estimator::photon;
    return g;
}

struct Settings {
    std::vector<double> wavelengths;
    std::uint64_t seed = kDefaultSeed;
    geometry::TessellationTolerance tolerance;
    // [goniometer]: the goniometer (studies/instrument_tables.h) at the defaults above.
    gonio::GoniometerConfig goniometer = species_goniometer_defaults();
    double time_budget_s = std::numeric_limits<double>::infinity();
    double target_relative_error = 0.0;
    std::uint64_t in_plane_quanta = 50000;
    std::uint64_t albedo_quanta = 200000;
    // [btf]: the camera (studies/instrument_tables.h) at the species defaults below; the pairs,
    // seed and study text are set when it is measured.
    gonio::BtfConfig btf = species_btf_defaults();
    // Every wavelength the study traces (spectrum: BRDF, in-plane sweep, albedo; BTF), sorted:
    // a spongy medulla's tables are computed at each of them.
    std::vector<double> traced_wavelengths;
    bool btf_figure9_only = false;  // [btf] pairs = "figure9": Fig. 9's 12 pairs, not the 3660
    int fit_evaluations = 3000;
    std::vector<SpeciesSpec> species;
};

// A spongy medulla: structure keys only; colour keys are refused (file:line:col).
void read_spongy_medulla(ParameterTable& m, const std::vector<double>& traced_wavelengths,
                         MedullaSpec& medulla) {
    for (const std::string_view key : kSpongyColourKeys) {
        if (m.has(key)) {
            throw InputError(fmt::format(
                "{}: {}.{}: a spongy medulla takes no colour or albedo parameter: its colour is "
                "computed from the structure (spongy_length_scale_um, spongy_keratin_fraction, "
                "spongy_box_um, spongy_voxel_um, spongy_shell_relative_width, spongy_core_scale)",
                m.location(key), m.path(), key));
        }
    }
    SpongyMediumParams& p = medulla.structure;
    p.length_scale_um = m.number("spongy_length_scale_um", p.length_scale_um, between(0.05, 1.0),
                                 "channel length scale Lambda of the spongy keratin, um");
    p.keratin_fraction = m.number("spongy_keratin_fraction", p.keratin_fraction, between(0.1, 0.9),
                                  "spongy keratin filling fraction");
    p.shell_relative_width =
        m.number("spongy_shell_relative_width", p.shell_relative_width, {0.0, 1.0, true, false},
                 "spectral shell width of the channel volume / k0");
    p.box_um =
        m.number("spongy_box_um", p.box_um, positive(), "side of the periodic spongy volume, um");
    p.voxel_um = m.number("spongy_voxel_um", p.voxel_um, positive(), "spongy voxel side, um");
    const double n = p.box_um / p.voxel_um;
    if (std::abs(n - std::round(n)) > 1e-6 * n || n < 4 || n > 512) {
        throw InputError(fmt::format(
            "{}: {}.spongy_box_um = {}: expected a whole number of voxels ({} um), 4 to 512 per "
            "side; it is {:.4f}",
            m.location("spongy_box_um"), m.path(), p.box_um, p.voxel_um, n));
    }
    if (!(p.length_scale_um > 2.0 * p.voxel_um) || p.length_scale_um > p.box_um / 4.0) {
        throw InputError(fmt::format(
            "{}: {}.spongy_length_scale_um = {}: expected above 2 voxels ({} um) and at most a "
            "quarter of the volume's box ({} um)",
            m.location("spongy_length_scale_um"), m.path(), p.length_scale_um, 2.0 * p.voxel_um,
            p.box_um / 4.0));
    }
    require_fine_voxels(m, "spongy_voxel_um", p.voxel_um, traced_wavelengths);
    medulla.core_scale =
        m.number("spongy_core_scale", medulla.core_scale,
                 {0.0, sim::SpongyMedulla::kMaxCoreScale, false, false},
                 "melanin core inside the spongy medulla: its cross-section / the medulla's "
                 "(0: none)");
}

SpeciesSpec read_species(ParameterTable table, const std::string& name,
                         const std::vector<double>& traced_wavelengths) {
    SpeciesSpec s;
    s.name = name;
    s.description = table.string("description", "", {}, "how the geometry resembles the sample");
    s.oriented_by =
        table.required_string("oriented_by", {"barbs", "barbules"},
                              "the fibres Filip's anisotropy direction U(phi_a) follows");
    const double phi_a = analysis::filip2024_preset(name).phi_a_rad;
    // U(φa) = (sin φa, cos φa, 0) is the fibre axis of the anisotropic highlight (H ⟂ U).
    // Turning the sample by ψ takes its +x (barb axis) to (cos ψ, sin ψ) and its +y (barbules)
    // to (−sin ψ, cos ψ); equating with U gives ψ = π/2 − φa (barbs) or ψ = −φa (barbules).
    const double derived = s.oriented_by == "barbs" ? 0.5 * kPi - phi_a : -phi_a;
    s.mount_rad =
        table.angle_deg("mount_deg", std::remainder(derived, 2.0 * kPi), between(-360.0, 360.0),
                        "azimuth of the barb axis on the stage (default: from Table 1's phi_a)");
    s.layers = static_cast<int>(
        table.integer("layers", 1, 1, 8, "vane layers stacked (overlapping feathers)"));
    s.layer_gap_um =
        table.number("layer_gap_um", 2.0, non_negative(), "gap between stacked layers, um");
    s.layer_shift = table.number("layer_shift", 0.5, between(0.0, 1.0),
                                 "lateral shift of each layer, barb periods");
    s.patch = read_barb_patch_params(table);
    ParameterTable patch = table.table("patch");
    s.length_um = patch.number("length_um", 3000.0, positive(), "patch length along the barbs, um");
    s.barbs = static_cast<int>(patch.integer("barbs", 10, 1, 10000, "barbs in the patch"));

    ParameterTable m = table.table("materials");
    s.melanin_core = m.string("barbule_core", "keratin", {"keratin", "melanin"},
                              "what the barbule cortex encloses") == "melanin";
    s.cortex_um =
        read_film_thickness_um(m, "cortex_film_um", 0.0, "keratin cortex over the melanin core");
    s.cortex_coherent =
        m.boolean("cortex_coherent", true, "interference in the cortex film (false: by intensity)");
    s.pigment_k = m.number("pigment_k", 0.0, between(0.0, 1.0),
                           "peak extinction coefficient of the keratin's pigment");
    s.pigment_peak_nm =
        m.number("pigment_peak_nm", 480.0, between(360.0, 830.0), "pigment absorption peak, nm");
    s.pigment_width_nm = m.number("pigment_width_nm", 40.0, between(1.0, 500.0),
                                  "pigment band standard deviation, nm");
    s.medulla.spongy =
        m.string("medulla", "white", {"white", "spongy"}, "the barb medulla") == "spongy";
    if (s.medulla.spongy) {
        read_spongy_medulla(m, traced_wavelengths, s.medulla);
        if (s.patch.barb.medulla_scale <= 0.0) {
            throw InputError(fmt::format(
                "{}: {}.medulla = \"spongy\" but the barb has no medulla (medulla_scale = 0): "
                "expected a medulla_scale > 0 in [species.{}.vane]",
                m.location("medulla"), m.path(), name));
        }
    } else {
        for (const std::string_view key : kSpongyKeys) {
            if (m.has(key)) {
                throw InputError(fmt::format("{}: {}.{} applies only to medulla = \"spongy\"",
                                             m.location(key), m.path(), key));
            }
        }
        s.medulla.albedo =
            m.number("medulla_albedo", s.medulla.albedo, between(0.0, 1.0), "white medulla albedo");
    }
    return s;
}

// [goniometer], [btf], [fit]: the instruments' settings.
void read_instruments(ParameterTable& root, Settings& s) {
    ParameterTable go = root.table("goniometer");
    GoniometerKeys keys;
    keys.aperture = true;
    s.goniometer = read_goniometer_table(go, s.goniometer, keys);
    s.in_plane_quanta = static_cast<std::uint64_t>(
        go.integer("in_plane_quanta", static_cast<long>(s.in_plane_quanta), 100, 100000000,
                   "in-plane sweep: quanta per light direction and wavelength"));
    s.albedo_quanta = static_cast<std::uint64_t>(
        go.integer("albedo_quanta", static_cast<long>(s.albedo_quanta), 100, 1000000000,
                   "albedo at normal incidence: quanta per wavelength"));
    ParameterTable btf = root.table("btf");
    // A few wavelengths: the BTF holds 3660 images, each pixels² × wavelengths values.
    s.btf.wavelengths_nm = read_wavelengths(btf, kFilipWavelengths);
    s.btf = read_btf_camera(btf, s.btf);
    s.btf_figure9_only =
        btf.string("pairs", "filip2024", {"filip2024", "figure9"},
                   "BTF pairs: the 61 x 60 set, or Fig. 9's 12 geometries") == "figure9";
    ParameterTable fit = root.table("fit");
    s.fit_evaluations =
        static_cast<int>(fit.integer("max_function_evaluations", s.fit_evaluations, 50, 1000000,
                                     "Levenberg-Marquardt function evaluations"));
}

// [species]: `run` lists which of Filip's four to build, each from its [species.<name>] table.
void read_species_list(ParameterTable species, Settings& s) {
    const auto all = analysis::filip2024_preset_names();
    const std::vector<std::string> allowed(all.begin(), all.end());
    const std::string list = species.string("run", "parrot,rooster,flamingo,stork", {},
                                            "comma-separated species to run");
    std::vector<std::string> names;
    for (std::size_t a = 0; a <= list.size();) {
        std::size_t b = list.find(',', a);
        if (b == std::string::npos) b = list.size();
        std::string one = list.substr(a, b - a);
        one.erase(0, one.find_first_not_of(' '));
        one.erase(one.find_last_not_of(' ') + 1);
        if (std::find(allowed.begin(), allowed.end(), one) == allowed.end()) {
            throw InputError(
                fmt::format("{}: species.run names '{}': expected a comma-separated list of "
                            "parrot, rooster, flamingo, stork",
                            species.location("run"), one));
        }
        names.push_back(one);
        a = b + 1;
    }
    for (const std::string& n : names) {
        if (!species.has(n))
            throw InputError(
                fmt::format("{}: species.run lists '{}' but there is no [species.{}] table",
                            species.location("run"), n, n));
        s.species.push_back(read_species(species.table(n), n, s.traced_wavelengths));
    }
    // Tables of species left out of `run` are still checked (a typo there is still a typo).
    for (const std::string& n : allowed) {
        if (species.has(n) && std::find(names.begin(), names.end(), n) == names.end())
            read_species(species.table(n), n, s.traced_wavelengths);
    }
}

Settings read_settings(StudyFile& file, std::string& name, const fs::path& source) {
    Settings s;
    ParameterTable root = file.root();
    name = read_study_name(root, source);
    root.string("study", "species", {"species"}, "which study this file describes");
    s.seed = read_seed(root);
    s.time_budget_s = root.number("time_budget_s", s.time_budget_s, positive(),
                                  "wall-time budget per BRDF measurement, s");
    s.target_relative_error =
        root.number("target_relative_error", 0.0, between(0.0, 1.0),
                    "stop a BRDF's passes once its estimated relative error is below this");
    ParameterTable spectrum = root.table("spectrum");
    s.wavelengths = read_wavelengths(spectrum, {.first_nm = 400.0,
                                                .last_nm = 700.0,
                                                .step_nm = 50.0,
                                                .min_nm = kFilipWavelengths.min_nm,
                                                .max_nm = kFilipWavelengths.max_nm,
                                                .range_reason = kFilipWavelengths.range_reason});
    bool bands[3] = {false, false, false};
    for (double l : s.wavelengths) bands[static_cast<int>(analysis::filip2024_channel(l))] = true;
    if (!(bands[0] && bands[1] && bands[2])) {
        throw InputError(
            fmt::format("{}: [spectrum] must put a wavelength in each of Filip's bands (blue "
                        "380-490, green 490-580, red 580-780 nm) for the RGB fit",
                        spectrum.location()));
    }
    s.tolerance = read_tolerance(root.table("tessellation"));
    read_instruments(root, s);
    s.traced_wavelengths = s.wavelengths;
    s.traced_wavelengths.insert(s.traced_wavelengths.end(), s.btf.wavelengths_nm.begin(),
                                s.btf.wavelengths_nm.end());
    std::sort(s.traced_wavelengths.begin(), s.traced_wavelengths.end());
    s.traced_wavelengths.erase(
        std::unique(s.traced_wavelengths.begin(), s.traced_wavelengths.end()),
        s.traced_wavelengths.end());
    read_species_list(root.table("species"), s);
    root.reject_unused();
    return s;
}

// Keratin with a pigment absorption band k(λ) = k_peak exp(−(λ − λ_p)²/(2w²)) (carotenoids in
// the flamingo's keratin), tabulated at 1 nm; without pigment, plain keratin
// (sim/optics/material.h).
std::shared_ptr<const optics::Material> keratin_of(const SpeciesSpec& s) {
    if (s.pigment_k <= 0.0) return optics::keratin();
    std::vector<double> lambda, n, k;
    for (double l = optics::kDispersionMinNm; l <= optics::kDispersionMaxNm + 1e-9; l += 1.0) {
        lambda.push_back(l);
        n.push_back(optics::keratin()->index(l).real());
        const double u = (l - s.pigment_peak_nm) / s.pigment_width_nm;
        k.push_back(s.pigment_k * std::exp(-0.5 * u * u));
    }
    return std::make_shared<optics::TabulatedMaterial>("pigmented keratin", lambda, n, k);
}

struct BuiltSpecies {
    sim::SceneDescription scene;
    std::optional<SpongyMedium> spongy;  // the spongy medulla's medium, when there is one
    double period_um = 0.0;
    double root_clearance_um = 0.0;  // geometry::BarbulePatch::root_clearance_um
    double layer_thickness_um = 0.0;
    std::size_t instances = 0, triangles = 0;
};

// `volume_seed` seeds a spongy medulla's generated volume; `wavelengths` are every wavelength
// the study traces (the medium's tables).
BuiltSpecies build_species(const SpeciesSpec& s, const geometry::TessellationTolerance& tolerance,
                           const std::string& where, std::uint64_t volume_seed,
                           const std::vector<double>& wavelengths) {
    BuiltSpecies out;
    geometry::BarbulePatch patch;
    try {
        patch = geometry::build_barbule_patch(s.patch, s.length_um, s.barbs, tolerance);
    } catch (const InputError& e) {
        throw InputError(fmt::format("{}: {}", where, e.what()));
    }
    // The 3D patch's spacing and barbule root clearance (geometry/barb.h).
    out.period_um = patch.period_um;
    out.root_clearance_um = patch.root_clearance_um;
    sim::BarbulePatchMaterials materials;
    materials.keratin = keratin_of(s);
    if (s.medulla.spongy) {
        SpongyMediumParams structure = s.medulla.structure;
        structure.seed = volume_seed;
        structure.keratin = materials.keratin;
        try {
            out.spongy = build_spongy_medium(structure, wavelengths,
                                             fmt::format("{} spongy medulla", s.name));
        } catch (const InputError& e) {
            throw InputError(fmt::format("{}: {}", where, e.what()));
        }
        materials.spongy_medulla =
            sim::SpongyMedulla{out.spongy->medium, s.medulla.core_scale, optics::melanin()};
    } else {
        materials.medulla = sim::constant_albedo(s.medulla.albedo);
    }
    if (s.melanin_core) {
        materials.barbule =
            s.cortex_um > 0.0
                ? sim::thin_film_interface(materials.keratin, s.cortex_um, optics::air(),
                                           optics::melanin(),
                                           s.cortex_coherent ? optics::Coherence::coherent
                                                             : optics::Coherence::incoherent)
                : sim::dielectric_interface(optics::melanin());
    }
    sim::SceneDescription one = sim::barbule_patch_scene(patch, materials);
    const Eigen::AlignedBox3d box = one.bounds();
    out.layer_thickness_um = box.max().z() - box.min().z();
    // Stacked layers: each one lower by the layer's thickness plus the gap, so no two
    // layers' surfaces intersect, and shifted sideways by a fraction of the barb period.
    out.scene = one;
    out.scene.instances.clear();
    for (int layer = 0; layer < s.layers; ++layer) {
        const Eigen::Translation3d shift(0.0, std::fmod(layer * s.layer_shift, 1.0) * out.period_um,
                                         -layer * (out.layer_thickness_um + s.layer_gap_um));
        for (const sim::Instance& i : one.instances)
            out.scene.instances.push_back({i.unit, shift * i.transform});
    }
    out.scene.validate();
    out.instances = out.scene.instances.size();
    for (const auto& u : out.scene.units) {
        for (const auto& surface : u.surfaces) out.triangles += surface.mesh.triangles.size();
    }
    return out;
}

// L* (D65) of the reflectance factor π f(λ) of one pair, with its standard error.
struct Luminance {
    const optics::ReflectanceToXyz& to_xyz;
    std::vector<double> y_weights;  // Y = Σ w_k R_k
    explicit Luminance(const optics::ReflectanceToXyz& t, std::size_t n) : to_xyz(t) {
        std::vector<double> e(n, 0.0);
        for (std::size_t k = 0; k < n; ++k) {
            e[k] = 1.0;
            y_weights.push_back(to_xyz(e).y);
            e[k] = 0.0;
        }
    }
    std::pair<double, double> operator()(const gonio::BrdfRecord& r, std::size_t pair) const {
        const std::size_t n = y_weights.size();
        std::vector<double> reflectance(n);
        double var = 0.0;
        for (std::size_t k = 0; k < n; ++k) {
            reflectance[k] = kPi * r.at(pair, k);
            var += std::pow(y_weights[k] * kPi * r.error_at(pair, k), 2);
        }
        const optics::Lab lab = optics::lab_from_xyz(to_xyz(reflectance), to_xyz.white());
        const double y = to_xyz(reflectance).y / to_xyz.white().y;
        // dL*/dY = 116/3 Y^(−2/3) above CIE's linear toe (Y > 0.008856), 903.3 below.
        const double slope = y > 0.008856 ? 116.0 / 3.0 * std::pow(y, -2.0 / 3.0) : 903.3;
        return {lab.l, slope * std::sqrt(var) / to_xyz.white().y};
    }
};

double relative_l1(const gonio::BrdfRecord& model, const gonio::BrdfRecord& data) {
    RelativeL1 l1;
    for (std::size_t i = 0; i < data.value.size(); ++i) l1.add(model.value[i], data.value[i]);
    return l1.value();
}

double relative_rms(const gonio::BrdfRecord& model, const gonio::BrdfRecord& data) {
    double sum_sq = 0.0, sum = 0.0;
    for (std::size_t i = 0; i < data.value.size(); ++i) {
        sum_sq += std::pow(model.value[i] - data.value[i], 2);
        sum += data.value[i];
    }
    const double n = static_cast<double>(data.value.size());
    return std::sqrt(sum_sq / n) / std::max(sum / n, 1e-300);
}

std::string parameter_cell(double value, double error, std::string_view unit) {
    const bool angle = unit == "rad";
    const double v = angle ? value / kDeg : value;
    if (!std::isfinite(error)) return fmt::format("{:.3g}", v);
    return fmt::format("{:.3g} ± {:.2g}", v, angle ? error / kDeg : error);
}

// ---- One run: what every step shares. -------------------------------------------------------

struct Run {
    const Settings& s;
    StudyContext& ctx;  // text, clock, streams, output and checkpoints (study_context.h)
    const std::vector<gonio::DirectionPair>& pairs;  // the 61 × 60 set
    const Luminance& luminance;
    const std::vector<double>& in_plane_angles_deg;
    std::size_t nl() const { return s.wavelengths.size(); }
};

// One species' instruments: the goniometer's sample is lit over one period cell (a barb's axis
// is at y = 0 for an odd number of barbs, at P/2 for an even one), mounted; the BTF camera
// images the real patch (its own uniform illumination of the imaged square).
struct Specimen {
    const SpeciesSpec& spec;
    std::size_t index;  // in the study's species list: the streams' index
    const BuiltSpecies& built;
    std::shared_ptr<const sim::ExplicitScatterer> tracer;
    std::shared_ptr<const PeriodCellEntry> cell;
    MountedScatterer sample, imaged;
    fs::path dir;

    Specimen(const SpeciesSpec& sp, std::size_t si, const BuiltSpecies& b, fs::path sdir)
        : spec(sp),
          index(si),
          built(b),
          tracer(std::make_shared<const sim::ExplicitScatterer>(b.scene)),
          cell(std::make_shared<const PeriodCellEntry>(
              tracer, sp.patch.barbule_pitch_um(), b.period_um,
              sp.barbs % 2 == 1 ? 0.0 : 0.5 * b.period_um)),
          sample(cell, sp.mount_rad),
          imaged(tracer, sp.mount_rad),
          dir(std::move(sdir)) {}
};

// One species' measurements, kept for its records and its report section.
struct Measured {
    gonio::GoniometerConfig brdf_config;
    gonio::BrdfRecord brdf, fit_brdf, table1_brdf;
    Filip2024Parameters table1;
    std::vector<analysis::BrdfObservation> observations;  // with the refit's standard errors
    analysis::Filip2024FitResult fit;
};

// ---- Report sections. ------------------------------------------------------------------------

// Angle (0–90°) between two fibre axes given by their φa (modulo 180°).
double axis_angle_deg(double a, double b) { return std::abs(std::remainder(a - b, kPi)) / kDeg; }

std::string patch_materials(const SpeciesSpec& sp) {
    std::string materials = "clear keratin barbules";
    if (sp.melanin_core) {
        materials =
            sp.cortex_um > 0.0
                ? fmt::format("barbules: {:.3f} µm keratin cortex ({}) over melanin", sp.cortex_um,
                              sp.cortex_coherent ? "coherent film" : "by intensity")
                : "barbules: melanin";
    }
    if (sp.pigment_k > 0.0) {
        materials += fmt::format("; keratin pigment k = {:.3g} at {:.0f} nm (σ {:.0f} nm)",
                                 sp.pigment_k, sp.pigment_peak_nm, sp.pigment_width_nm);
    }
    return materials;
}

std::string patch_medulla(const SpeciesSpec& sp, const BuiltSpecies& built) {
    const auto& p = sp.patch;
    if (p.barb.medulla_scale <= 0.0) return "none";
    if (!sp.medulla.spongy) {
        return fmt::format("white, scale {:.2f}, albedo {:.2f}", p.barb.medulla_scale,
                           sp.medulla.albedo);
    }
    const SpongyMedium& m = *built.spongy;
    const SpongyMediumParams& q = sp.medulla.structure;
    std::string coefficients;
    for (const auto& t : m.tables) {
        coefficients += fmt::format("{}{:.0f} nm {:.3f}", coefficients.empty() ? "" : ", ",
                                    t.lambda_nm, t.mu_s_per_um);
    }
    return fmt::format(
        "spongy, scale {:.2f}: channel-type keratin Λ = {:.3f} µm, f = {:.2f} (volume of {:.2f} µm "
        "in {:.3f} µm voxels: measured Λ {:.3f} µm, f {:.3f}) as a first-Born scattering medium, "
        "μ_s per µm {}; {}",
        p.barb.medulla_scale, q.length_scale_um, q.keratin_fraction, q.box_um, q.voxel_um,
        m.measured_scale_um, m.measured_fraction, coefficients,
        sp.medulla.core_scale > 0.0
            ? fmt::format("melanin core at {:.2f} of the medulla", sp.medulla.core_scale)
            : std::string("no core"));
}

// How first Born, the spongy medulla's route, does against 3D full wave on channel-type slabs
// (studies/spongy_medium.h: routes_against_full_wave; tests/reference/spongy_3d).
std::string spongy_route_check_sentence() {
    std::string t;
    for (const RouteFullWaveCheck& c : routes_against_full_wave()) {
        if (c.structure != "channel" || c.route != "born") continue;
        t += fmt::format(
            "{}at keratin n = {} ({} realisations) its diffuse-R peak is {:.0f} nm against full "
            "wave's {:.0f} nm (noise floor {:.0f} nm) and its worst 50-nm band {} nm is {:+.0f} % "
            "off (noise floor {:.0f} %): it {}",
            t.empty() ? "" : "; ", c.keratin_index, c.realisations, c.route_peak_nm,
            c.full_wave_peak_nm, c.peak_floor_nm, c.worst_band, 100.0 * c.worst_difference,
            100.0 * c.worst_floor,
            c.validated() ? "passes"
            : c.passes    ? "lies within its noise floors only, which could not have shown a miss"
                          : "misses the 15 % (10 % at n < 1.5) asked");
    }
    if (t.empty()) return "";
    return " Against 3D full wave on channel-type slabs (f = 0.5, Λ = 0.19 µm, 2 µm thick; "
           "tests/reference/spongy_3d, and the spongy study's report), first Born " +
           t + ".";
}

// Whether each spongy medulla lies where first Born was validated against 3D full wave
// (spongy_medium.h, outside_validated_range), at every wavelength its medium was computed for.
std::string spongy_medulla_range_sentence(const std::vector<SpeciesSpec>& species,
                                          const std::vector<BuiltSpecies>& built) {
    const auto validated = route_validated_cases("born");
    std::string t;
    for (std::size_t i = 0; i < species.size(); ++i) {
        if (!species[i].medulla.spongy || !built[i].spongy) continue;
        const SpongyMediumParams& q = species[i].medulla.structure;
        const SpongyMedium& m = *built[i].spongy;
        // each reason once: a fraction or index off the validated one is off at every wavelength
        std::vector<std::string> reasons;
        for (const double lambda : m.wavelengths_nm) {
            std::stringstream why(outside_validated_range(validated, "channel", m.measured_fraction,
                                                          q.length_scale_um, lambda,
                                                          q.keratin->index(lambda).real()));
            for (std::string reason; std::getline(why, reason, ';');) {
                if (reason.starts_with(" ")) reason.erase(0, 1);
                if (std::find(reasons.begin(), reasons.end(), reason) == reasons.end())
                    reasons.push_back(reason);
            }
        }
        std::string outside;
        for (const std::string& r : reasons) outside += (outside.empty() ? "" : "; ") + r;
        t += fmt::format(
            " The {}'s medulla (channel-type, f {:.3f} measured, Λ = {} µm) is {} the range where "
            "first Born passed ({:.0f}–{:.0f} nm){}.",
            species[i].name, m.measured_fraction, q.length_scale_um,
            outside.empty() ? "inside" : "outside", m.wavelengths_nm.front(),
            m.wavelengths_nm.back(), outside.empty() ? "" : ": " + outside);
    }
    return t;
}

std::string report_introduction(const Settings& s, const std::vector<BuiltSpecies>& built,
                                const fs::path& source) {
    std::string md = fmt::format(
        "# Species study: four feathers of Filip et al. 2024, explicit and fitted\n\n"
        "Plumage {}, study file `{}`. The macaw parrot, Cochin cock (rooster), greater flamingo "
        "and white stork of Filip, Maile and Vávra 2024 as explicit barb + barbule patches "
        "(geometry/barb.h), traced (sim/tracer.h) and measured like the paper's capture: the BRDF "
        "on its 61 × 60 set, the in-plane sweep, BTF images; then the paper's analytic BRDF fitted "
        "to each simulated BRDF. The simulation is a hypothesis about each feather's structure, "
        "not a measurement: where the fit departs from Table 1, either the structure or the model "
        "is missing something, and the report says which it can tell.\n\n"
        "## How each patch resembles its sample\n\n"
        "The paper shows the samples only in photographs and says, per sample, which structures "
        "dominate (Sects. 3 and 5.2). Each patch encodes those statements; the mount azimuth on "
        "the stage comes from Table 1's φa: U(φa) = (sin φa, cos φa, 0) is the axis of the fibres "
        "whose highlight the model's anisotropic term describes, so the barb axis (oriented_by = "
        "barbs) or the barbules' direction (oriented_by = barbules) is turned onto U.\n\n"
        "The vane parameters mean what Padrón-Griffe et al. 2024's code means (studies/README.md, "
        "\"Padrón-Griffe parameters\"): the barb width is its horizontal diameter and the axis "
        "ratio its height over width; a barbule's axis ratio is its thickness over its width; "
        "the length counts half barb widths; barbules leave gaps of `barbule_separation` barbule "
        "widths between them, through which light passes. The patches are the ones of the "
        "earlier parameter meanings, converted (same barbs, barbules and periods); what changed "
        "in the explicit geometry is that barbules end where the authors' end, and that each row "
        "of barbules has its own phase along the barb.\n\n"
        "| species | barb width, axis ratio | medulla | barbules (width, axis ratio, gap, length, "
        "rise) "
        "| barb period | layers | materials | mount |\n"
        "|---|---|---|---|---|---|---|---|\n",
        kVersion, source.string());
    for (std::size_t i = 0; i < s.species.size(); ++i) {
        const SpeciesSpec& sp = s.species[i];
        const auto& p = sp.patch;
        md += fmt::format(
            "| {} | {:.0f} µm, {:.2f} | {} | {:.0f} µm, {:.2f}, {:.2g}, {:.3g} × w/2, {:.0f}° | "
            "{:.0f} µm | {} | {} | {:.0f}° (by {}) |\n",
            sp.name, p.barb.barb_width_um, p.barb.barb_axis_ratio, patch_medulla(sp, built[i]),
            p.barbule_width_um, p.barbule_axis_ratio, p.barbule_separation, p.barbule_length,
            p.barbule_inclination_rad / kDeg, built[i].period_um, sp.layers, patch_materials(sp),
            sp.mount_rad / kDeg, sp.oriented_by);
    }
    md += "\n";
    for (const SpeciesSpec& sp : s.species) {
        if (!sp.description.empty()) md += fmt::format("- **{}**: {}\n", sp.name, sp.description);
    }
    md +=
        "\nA spongy medulla's colour is computed, not set: a generated channel-type volume of the "
        "given Λ and f, its indicator power spectrum, first-Born scattering tables at every "
        "traced wavelength (studies/spongy_medium.h), traced as a scattering medium filling the "
        "medulla with Fresnel boundaries in its Bruggeman index (sim/scene.h).";
    md += spongy_route_check_sentence() + spongy_medulla_range_sentence(s.species, built) + "\n\n";
    md +=
        "Not modelled: the rachis, barbule hooks, curvature of the vane, the sample's backing "
        "(light leaving below the stack is lost, as on a black stage), the spongy keratin as "
        "explicit keratin/air interfaces (the medium is its first-Born average: coherent single "
        "scattering from the structure, incoherent multiple scattering between events), the "
        "granular structure of the melanin core, polarisation.\n\n";
    return md;
}

void write_species_h5_header(record::Hdf5Writer& h5, const SpeciesResult& result) {
    h5.write("wavelength_nm", std::span<const double>(result.wavelengths_nm),
             {result.wavelengths_nm.size()},
             {{"units", "nm"}, {"description", "vacuum wavelengths of the BRDF and albedo"}});
    h5.write("in_plane/light_angle_deg", std::span<const double>(result.in_plane_angles_deg),
             {result.in_plane_angles_deg.size()},
             {{"units", "deg"},
              {"description",
               "signed light angle; view at 45 deg in the plane across the barbs; +45 = retro"}});
}

// The patch, the BTF images and the fingerprints.
// The detector estimator's stop rule, as the report states it.
std::string btf_stop_rule(const Settings& s) {
    std::string rule = fmt::format("at most {} passes", s.btf.max_passes);
    if (s.btf.target_pixel_error > 0.0)
        rule += fmt::format(", until the median per-pixel error is at most {:.1f} %",
                            100.0 * s.btf.target_pixel_error);
    if (s.btf.max_time_s > 0.0)
        rule += fmt::format(", no pass ending after {:.0f} s", s.btf.max_time_s);
    return rule;
}

// The BTF paragraph: what was imaged, how, at what cost and per-pixel error.
std::string section_btf_setup(const Settings& s, const SpeciesOutcome& o, const std::string& name) {
    const bool detector = s.btf.estimator == gonio::BtfEstimator::detector;
    const std::string pairs = s.btf_figure9_only ? "Fig. 9's 12 pairs (`btf.h5`: 12 images"
                                                 : "the 61 × 60 set (`btf.h5`: 3660 images";
    const std::string light = s.btf.aperture == gonio::Aperture::both_cones
                                  ? "light and detector cones of half-angle"
                                  : "collimated light, detector half-angle";
    const std::string estimator =
        detector ? fmt::format(
                       "detector-side estimator, {} quanta per view direction and pixel in each "
                       "of {} passes (all wavelengths on one path{}; {})",
                       s.btf.quanta_per_pixel, o.btf_passes,
                       fmt::format("{}{}{}",
                                   s.btf.stratified_group > 1
                                       ? fmt::format(", starts stratified in groups of {}",
                                                     s.btf.stratified_group)
                                       : std::string(),
                                   s.btf.split_reflections
                                       ? ", reflected branches split again at their next film"
                                       : "",
                                   s.btf.split_aimed_reflections
                                       ? ", reflections aimed at a light's cone split off"
                                       : ""),
                       btf_stop_rule(s))
                 : fmt::format("forward estimator, {} quanta per light direction and wavelength",
                               s.btf.quanta_per_light);
    return fmt::format(
        "Virtual BTF on {0} of {1} × {1} pixels over a {2:.0f} µm square, {3} wavelengths, {4} "
        "{5:.0f}°; {6}; virtual_gonio/btf.h), {7:.0f} s. Median per-pixel relative error over "
        "the lit pixels of Fig. 9's tiles (σ/f, every wavelength; lit: above 1 % of the tile's "
        "brightest pixel): {8:.1f} %. Fig. 9's geometries: light and view at 30°, view at azimuth "
        "0°; light azimuth 0°, 30°, …, 150° on the top row, 180° … 330° below; one exposure for "
        "all (the tiles' data: `btf_figure9.h5`):\n\n![btf]({9}/btf.png)\n\n",
        pairs, s.btf.pixels, s.btf.patch_size_um, s.btf.wavelengths_nm.size(), light,
        s.btf.detector_half_angle_rad / kDeg, estimator, o.btf_seconds,
        100.0 * o.btf_median_pixel_error, name);
}

std::string section_setup(const Run& run, const Specimen& x, const SpeciesOutcome& o) {
    const Settings& s = run.s;
    const SpeciesSpec& sp = x.spec;
    std::string md = fmt::format("## {}\n\n", sp.name);
    md += fmt::format(
        "Patch: {} barbs × {:.0f} µm, {} layer(s), {} instances of {} triangles; mounted at "
        "{:.0f}°; barbules start {:.2f} µm out of the cortex (their root faces would otherwise "
        "reach into it).\n\n",
        sp.barbs, sp.length_um, sp.layers, x.built.instances, x.built.triangles, o.mount_deg,
        x.built.root_clearance_um);
    md += section_btf_setup(s, o, sp.name);
    md += fmt::format(
        "Fingerprints (Fig. 7 layout; simulation | fitted model | Table 1 model; colour at one "
        "exposure for the three, luminance below on one logarithmic scale; data in "
        "`fingerprints.h5`):\n\n![fingerprints]({}/fingerprints.png)\n\n",
        sp.name);
    return md;
}

// Whether each model conserves energy: its largest directional albedo, and a warning where it
// exceeds 1 beyond the quadrature's error.
std::string energy_line(const std::string& which, const analysis::EnergyCheck& e) {
    const double theta = std::acos(std::clamp(e.worst_wi.z(), -1.0, 1.0)) / kDeg;
    if (e.directions_above_one == 0) {
        return fmt::format("{}: directional albedo at most {:.2f} ({:.0f}°, {:.0f} nm)", which,
                           e.max_albedo, theta, e.worst_lambda_nm);
    }
    return fmt::format(
        "**warning: {} do not conserve energy**: directional albedo up to {:.2f} ({:.0f}°, {:.0f} "
        "nm), above 1 at {} of {} directions",
        which, e.max_albedo, theta, e.worst_lambda_nm, e.directions_above_one, e.directions);
}

std::string section_fit(const Measured& m, const SpeciesOutcome& o) {
    return fmt::format(
               "BRDF: {} quanta per light direction and wavelength, estimated relative RMS error "
               "{:.1f} %, {:.0f} s. Fit (best of 4 starts in φa, from {:.0f}°): reduced χ² {:.2f} "
               "over "
               "{} observations ({} free parameters; {}), relative residual Σ|Δf|/Σf {:.1f} %, "
               "RMS/mean {:.1f} % (Table 1's parameters: {:.1f} %, {:.1f} %).\n\n",
               m.brdf.quanta, 100.0 * m.brdf.convergence.back().estimated_relative_rms_error,
               m.brdf.wall_time_s, o.fit_start_phi_a_deg, m.fit.reduced_chi_square,
               m.fit.observations, m.fit.free_parameters.size(), m.fit.termination,
               100.0 * o.fit_relative_l1, 100.0 * o.fit_relative_rms, 100.0 * o.table1_relative_l1,
               100.0 * o.table1_relative_rms) +
           fmt::format("Energy (θ_i ≤ 75°, {} directions): {}; {}.\n\n", o.fit_energy.directions,
                       energy_line("the fitted parameters", o.fit_energy),
                       energy_line("Table 1's parameters", o.table1_energy));
}

// The three cells where the fit misses the simulation most, in units of the simulation's error.
std::string largest_residuals(const Run& run, const Measured& m) {
    std::vector<std::pair<double, std::size_t>> residuals;
    for (std::size_t c = 0; c < m.observations.size(); ++c) {
        const double sigma = m.observations[c].standard_error.value_or(1.0);
        residuals.emplace_back(std::abs(m.fit_brdf.value[c] - m.brdf.value[c]) / sigma, c);
    }
    const std::size_t shown = std::min<std::size_t>(3, residuals.size());
    std::partial_sort(residuals.begin(), residuals.begin() + shown, residuals.end(),
                      std::greater<>());
    auto angles = [](const Vec3d& w) {
        return fmt::format("{:.0f}°/{:.0f}°", std::acos(std::clamp(w.z(), -1.0, 1.0)) / kDeg,
                           std::atan2(w.y(), w.x()) / kDeg);
    };
    std::string worst;
    for (std::size_t r = 0; r < shown; ++r) {
        const std::size_t c = residuals[r].second, p = c / run.nl(), k = c % run.nl();
        worst += fmt::format(
            "{}light {} → view {} at {:.0f} nm: simulation {:.3g}, fit {:.3g} ({:.0f}σ)",
            r == 0 ? "" : "; ", angles(run.pairs[p].wi), angles(run.pairs[p].wo),
            run.s.wavelengths[k], m.brdf.value[c], m.fit_brdf.value[c], residuals[r].first);
    }
    return worst;
}

// A simulated BRDF whose estimated relative RMS error is above this is too noisy for a verdict
// to mean much: the report says "indicative only" (the quick studies' 300 quanta give 80–90 %).
constexpr double kIndicativeOnlyError = 0.25;
// The goodness-of-fit test's level.
constexpr double kFitSignificance = 0.01;

// Does Filip's model describe the simulated BRDF within its Monte Carlo error? A χ² test of the
// refit's residuals (σ² from the photon-count variance model) with its p-value, and the effect
// size sqrt(χ²_red): the typical residual in units of σ, which says how far off the model is
// where p alone only says "not within the noise" for any large sample.
std::string fit_verdict(const Measured& m) {
    const int dof = m.fit.degrees_of_freedom;
    const double chi2 = m.fit.reduced_chi_square * dof;
    const double p = analysis::chi_square_p_value(chi2, dof);
    const double effect = std::sqrt(m.fit.reduced_chi_square);
    std::string verdict = fmt::format(
        "χ² = {:.0f} over {} degrees of freedom (reduced {:.2f}), {}; the typical residual is "
        "{:.2f} σ. ",
        chi2, dof, m.fit.reduced_chi_square, p_value_text(p), effect);
    verdict += p >= kFitSignificance
                   ? "Filip's five terms describe this simulated BRDF within its Monte Carlo "
                     "error (not rejected at the 1 % level)"
                   : fmt::format(
                         "Filip's five terms do not describe this simulated BRDF within "
                         "its Monte Carlo error (rejected at the 1 % level): they miss "
                         "by {:.2f} σ per cell on average (sharper or differently placed "
                         "features than the model's lobes)",
                         effect);
    const double error = m.brdf.convergence.back().estimated_relative_rms_error;
    if (error > kIndicativeOnlyError) {
        verdict += fmt::format(
            " — indicative only: the simulated BRDF's estimated relative error is {:.0f} % "
            "(above {:.0f} %), so the test has little power",
            100.0 * error, 100.0 * kIndicativeOnlyError);
    }
    return verdict;
}

// What the numbers can tell apart: the model against the simulation (the fit's residuals in
// units of the simulation's errors), and the simulated structure against the real feather (the
// Table 1 model standing in for its measurement).
std::string section_reading(const Run& run, const Specimen& x, const Measured& m,
                            const SpeciesOutcome& o) {
    std::array<double, 3> sim_sum{}, table1_sum{};
    for (std::size_t c = 0; c < m.observations.size(); ++c) {
        const int band =
            static_cast<int>(analysis::filip2024_channel(run.s.wavelengths[c % run.nl()]));
        sim_sum[band] += m.brdf.value[c];
        table1_sum[band] += m.table1_brdf.value[c];
    }
    const double fitted_phi = o.fitted[analysis::kFilipPhiA];
    std::string md = fmt::format(
        "**Reading.** The fitted anisotropy axis U(φa = {:.1f}°) lies {:.1f}° from the barb axis "
        "and {:.1f}° from the barbules of the mounted patch (Table 1's: {:.1f}° and {:.1f}°). ",
        fitted_phi / kDeg, o.fit_axis_from_barbs_deg, o.fit_axis_from_barbules_deg,
        axis_angle_deg(m.table1.phi_a_rad, 0.5 * kPi - x.spec.mount_rad),
        axis_angle_deg(m.table1.phi_a_rad, -x.spec.mount_rad));
    md += fmt::format(
        "Model against simulation: {}. Largest residuals: {}. Simulation against the feather "
        "(Table 1's model standing in for the measurement): the simulated patch reflects {:.2f}, "
        "{:.2f}, {:.2f} times Table 1's R, G, B over the 61 × 60 set, a difference of structure "
        "and materials (our hypothesis of the feather) that no fit of the model can remove.\n\n",
        fit_verdict(m), largest_residuals(run, m), sim_sum[0] / std::max(table1_sum[0], 1e-300),
        sim_sum[1] / std::max(table1_sum[1], 1e-300), sim_sum[2] / std::max(table1_sum[2], 1e-300));
    return md;
}

std::string section_albedo_reciprocity(const Run& run, const SpeciesOutcome& o) {
    std::string albedo_line;
    for (std::size_t k = 0; k < run.nl(); ++k)
        albedo_line += fmt::format(" {:.0f} nm {:.3f}±{:.3f};", run.s.wavelengths[k], o.albedo[k],
                                   o.albedo_error[k]);
    std::string md = fmt::format("Albedo at normal incidence:{}\n\n", albedo_line);
    md += fmt::format(
        "Paths that met a surface from a side other than the one they travelled in (medium "
        "mismatches: barbule roots inside the barb cortex, where the barbule surface still "
        "declares air outside): {:.2f} % of the paths at normal incidence, carrying {:.2f} % of "
        "the incident power out of the albedo above.\n\n",
        100.0 * o.mismatched_paths, 100.0 * o.mismatched_albedo);
    const int dof = std::max(1, o.reciprocity_dof);
    const double p = analysis::chi_square_p_value(o.reciprocity_chi_square, dof);
    // The largest of `dof` |z| exceeds this with probability 1 % when every cell is reciprocal.
    const double sidak =
        analysis::two_sided_normal_quantile(analysis::sidak_significance(0.01, dof));
    const bool holds = p > 0.01 && o.reciprocity_max_z < sidak;
    md += fmt::format(
        "Reciprocity over the {} (pair, wavelength) cells the set holds both ways: χ²/dof = "
        "{:.2f} ({}), largest |z| = {:.2f} against the Šidák bound {:.2f} (a 1 % family-wise "
        "error over {} cells): {}. Each couple's z is a score test, its variance estimated "
        "under f(ω_i, ω_o) = f(ω_o, ω_i) from both cells' hits (reciprocity_z, "
        "analysis/metrics/statistics.h): a cell viewed near grazing has few hits of weight "
        "1/cos θ_v, and its own standard error would make z of unequal cells non-normal. ",
        o.reciprocity_dof, o.reciprocity_chi_square / dof, p_value_text(p), o.reciprocity_max_z,
        sidak, o.reciprocity_dof,
        holds ? "consistent with f(ω_i, ω_o) = f(ω_o, ω_i)" : "**not** consistent with it");
    if (run.s.goniometer.aperture == gonio::Aperture::both_cones) {
        md += fmt::format(
            "The instrument is reciprocal by construction: the light comes from a cone of the "
            "detector's half-angle ({:.1f}°) around ω_i and the detector is the cone around "
            "ω_o, both weighted by projected solid angle (aperture = \"both_cones\", "
            "virtual_gonio/goniometer.h), so a cell is the same double-cone average of f "
            "whichever way the pair is lit. {}\n\n",
            run.s.goniometer.detector_half_angle_rad / kDeg,
            holds ? "The simulated patch is reciprocal within its noise."
                  : "A significant excess is then the simulation's own. One source is known: "
                    "the tracer reflects and refracts about interpolated shading normals while "
                    "light lands on the flat facets in proportion to the geometric normal's "
                    "cosine, so a facet answers f(a, b) / f(b, a) = (a·n_g) / (b·n_g) instead "
                    "of 1; the excess shrinks with the tessellation's normal error "
                    "([tessellation] max_normal_error_deg).");
    } else {
        md +=
            "The tracer's physics is reciprocal, but this instrument is not exactly "
            "(aperture = \"view_cone\"): a cell is the BRDF averaged over the detector cone "
            "around ω_o with ω_i exact, so a lobe narrower than the cone (mirror-like barbule "
            "faces) is averaged differently in f(ω_i, ω_o) and f(ω_o, ω_i); aperture = "
            "\"both_cones\" averages over a light cone too and is symmetric.\n\n";
    }
    return md;
}

std::string species_section(const Run& run, const Specimen& x, const Measured& m,
                            const SpeciesOutcome& o) {
    return section_setup(run, x, o) + section_fit(m, o) + section_reading(run, x, m, o) +
           section_albedo_reciprocity(run, o);
}

std::string fits_summary_rows(const SpeciesResult& result) {
    std::string md = "| reduced χ² |";
    for (const auto& o : result.species) md += fmt::format(" {:.2f} |", o.reduced_chi_square);
    md += "\n| relative L1: fit \\| Table 1 |";
    for (const auto& o : result.species)
        md += fmt::format(" {:.1f} % \\| {:.1f} % |", 100.0 * o.fit_relative_l1,
                          100.0 * o.table1_relative_l1);
    md += "\n| relative RMS: fit \\| Table 1 |";
    for (const auto& o : result.species)
        md += fmt::format(" {:.1f} % \\| {:.1f} % |", 100.0 * o.fit_relative_rms,
                          100.0 * o.table1_relative_rms);
    md += "\n| mean BRDF R, G, B (1/sr) |";
    for (const auto& o : result.species)
        md += fmt::format(" {:.3f}, {:.3f}, {:.3f} |", o.mean_brdf_rgb[0], o.mean_brdf_rgb[1],
                          o.mean_brdf_rgb[2]);
    return md + "\n\n";
}

// Fitted parameters beside Table 1: fits.csv and the report's table.
std::string fits_section(const fs::path& dir, const SpeciesResult& result) {
    std::ofstream csv(dir / "fits.csv");
    csv << "parameter,unit";
    for (const auto& o : result.species)
        csv << fmt::format(",{0} fit,{0} fit error,{0} table 1", o.species);
    csv << "\n";
    std::string md =
        "## Fitted parameters beside Table 1\n\nEach cell: fit ± standard error | Table 1. Angles "
        "in degrees. θmax and the units scale are held fixed (analysis/fits/filip2024_fit.h). The "
        "model's colours are camera-RGB bands (blue 380–490, green 490–580, red 580–780 nm); every "
        "simulated wavelength is an observation of its band.\n\n| parameter |";
    for (const auto& o : result.species) md += fmt::format(" {} |", o.species);
    md += "\n|---|";
    for (std::size_t i = 0; i < result.species.size(); ++i) md += "---|";
    md += "\n";
    for (int p = 0; p < kFilip2024ParameterCount; ++p) {
        const auto& info = kFilip2024ParameterTable[p];
        const bool angle = info.unit == "rad";
        const double scale = angle ? 1.0 / kDeg : 1.0;
        csv << fmt::format("{},{}", info.name, angle ? "deg" : info.unit);
        md += fmt::format("| {} |", info.name);
        for (const auto& o : result.species) {
            csv << fmt::format(",{:.6g},{:.6g},{:.6g}", o.fitted[p] * scale,
                               o.fitted_error[p] * scale, o.table1[p] * scale);
            md += fmt::format(" {}{} \\| {:.3g} |",
                              parameter_cell(o.fitted[p], o.fitted_error[p], info.unit),
                              o.at_bound[p] ? " (bound)" : "", o.table1[p] * scale);
        }
        csv << "\n";
        md += "\n";
    }
    close_written(csv, dir / "fits.csv");
    return md + fits_summary_rows(result);
}

// In-plane luminance, Fig. 6a: in_plane_luminance.csv, its plot and a table.
std::string in_plane_section(const fs::path& dir, const SpeciesResult& result,
                             std::vector<PlotJob>& plots) {
    std::ofstream csv(dir / "in_plane_luminance.csv");
    csv << "light angle (deg)";
    for (const auto& o : result.species) csv << fmt::format(",{0},{0} error,{0} fit", o.species);
    csv << "\n";
    for (std::size_t p = 0; p < result.in_plane_angles_deg.size(); ++p) {
        csv << fmt::format("{:.1f}", result.in_plane_angles_deg[p]);
        for (const auto& o : result.species) {
            csv << fmt::format(",{:.5g},{:.5g},{:.5g}", o.in_plane_lstar[p],
                               o.in_plane_lstar_error[p], o.in_plane_fit_lstar[p]);
        }
        csv << "\n";
    }
    close_written(csv, dir / "in_plane_luminance.csv");
    plots.push_back({"luminance", dir / "in_plane_luminance.csv", dir / "in_plane_luminance.png"});
    std::string md =
        "## In-plane luminance (Filip Fig. 6a)\n\nView at 45° in the plane across the barbs, light "
        "from −81° to 81° (+45° retro-reflection, −45° the mirror direction); CIE L* (D65) of the "
        "reflectance factor π f; simulation with 1σ error bars, fitted model dashed. L* = 100 is "
        "a white Lambertian standard (π f = 1); a glossy feather near its mirror direction "
        "reflects more than that towards the detector, so L* above 100 is a highlight, not an "
        "error (L* = 160 is π f ≈ 3.5).\n\n"
        "![in-plane luminance](in_plane_luminance.png)\n\n"
        "| species | L* at −45° (specular) | L* at 0° | L* at +45° (retro) | peak at |\n"
        "|---|---|---|---|---|\n";
    auto at = [&](const SpeciesOutcome& o, double angle) {
        for (std::size_t p = 0; p < result.in_plane_angles_deg.size(); ++p) {
            if (std::abs(result.in_plane_angles_deg[p] - angle) < 0.5)
                return fmt::format("{:.1f} ± {:.1f}", o.in_plane_lstar[p],
                                   o.in_plane_lstar_error[p]);
        }
        return std::string("–");
    };
    for (const auto& o : result.species) {
        md += fmt::format("| {} | {} | {} | {} | {:.0f}° |\n", o.species, at(o, -45.0), at(o, 0.0),
                          at(o, 45.0), o.in_plane_peak_deg);
    }
    return md + "\n";
}

// ---- Build. ----------------------------------------------------------------------------------

// Light entering the central period cell or the BTF square and crossing the stack at 75° must
// stay on the patch.
// `where`: file:line:col of the species' [patch] table (of the species' table when it has none).
void check_patch_size(const SpeciesSpec& sp, const BuiltSpecies& b, const Settings& s,
                      const std::string& where) {
    const Eigen::AlignedBox3d box = b.scene.bounds();
    const double depth = box.max().z() - box.min().z();
    const double cell = 0.5 * std::max(b.period_um, sp.patch.barbule_pitch_um());
    const double half = std::max(cell, 0.5 * std::sqrt(2.0) * s.btf.patch_size_um) +
                        depth * std::tan(kLargestPolarRad);
    const double half_x = 0.5 * (box.max().x() - box.min().x()),
                 half_y = 0.5 * (box.max().y() - box.min().y());
    if (std::min(half_x, half_y) >= half) return;
    throw InputError(fmt::format(
        "{}: [species.{}.patch] gives a patch of {:.0f} x {:.0f} um; light entering the central "
        "period cell or the BTF square and crossing the {:.0f} um deep stack at 75 deg needs "
        "{:.0f} um on every side of the centre: expected a larger length_um or more barbs",
        where, sp.name, 2.0 * half_x, 2.0 * half_y, depth, half));
}

// Every scene first: a geometry the study file gets wrong stops the run before anything is
// written.
// The stream of species i's spongy volume: the study's and the Python scene builder's the same.
std::uint64_t spongy_volume_stream(const StudyContext& ctx, std::size_t species_index) {
    return ctx.stream("species/spongy_volume", static_cast<std::uint64_t>(species_index));
}

std::vector<BuiltSpecies> build_all(const Settings& s, StudyContext& ctx) {
    StudyFile& file = ctx.file();
    const StudyProgress& clock = ctx.clock();
    std::vector<BuiltSpecies> built;
    for (const SpeciesSpec& sp : s.species) {
        clock.say(fmt::format("building the {} patch", sp.name));
        ParameterTable table = file.root().table("species").table(sp.name);
        const std::string where = fmt::format("{}: [species.{}]", table.location(), sp.name);
        built.push_back(build_species(
            sp, s.tolerance, where, spongy_volume_stream(ctx, built.size()), s.traced_wavelengths));
        check_patch_size(sp, built.back(), s,
                         table.has("patch") ? table.table("patch").location() : table.location());
    }
    return built;
}

// ---- Measure. --------------------------------------------------------------------------------

// The BRDF on the 61 × 60 set, checkpointed (Ctrl-C keeps the completed passes).
gonio::BrdfRecord measure_species_brdf(const Run& run, const Specimen& x, Measured& m) {
    const Settings& s = run.s;
    gonio::GoniometerConfig& g = m.brdf_config;
    g = s.goniometer;
    g.pairs = run.pairs;
    g.wavelengths_nm = s.wavelengths;
    g.beam_radius_um = 0.5 * x.built.period_um;  // unused: PeriodCellEntry draws the entry
    g.seed = run.ctx.stream("species/brdf", x.index);
    g.time_budget_s = s.time_budget_s;
    g.target_relative_error = s.target_relative_error;
    g.config_text = run.ctx.text();
    run.ctx.clock().say(fmt::format(
        "{}: BRDF on the 61 x 60 set ({} quanta per light direction and "
        "wavelength, {} wavelengths)",
        x.spec.name, g.quanta_per_pass * static_cast<std::uint64_t>(g.max_passes), run.nl()));
    gonio::RunControl control;
    control.progress = run.ctx.progress();
    const fs::path checkpoints = run.ctx.checkpoints();
    fs::create_directories(checkpoints);
    control.checkpoint = checkpoints / (x.spec.name + "_brdf.checkpoint");
    gonio::BrdfRecord brdf = gonio::measure_brdf(x.sample, g, control);
    if (brdf.interrupted) {
        throw Interrupted(interrupted_with_checkpoint(fmt::format("the {} BRDF", x.spec.name),
                                                      brdf.passes, control.checkpoint));
    }
    gonio::write_brdf_record(brdf, x.dir / "brdf.h5");
    return brdf;
}

// Channel means (R, G, B) over the set.
std::array<double, 3> mean_brdf_rgb(const gonio::BrdfRecord& brdf,
                                    const std::vector<double>& wavelengths) {
    std::array<double, 3> mean{};
    const std::size_t pairs = brdf.config.pairs.size(), nl = wavelengths.size();
    for (std::size_t p = 0; p < pairs; ++p) {
        for (std::size_t k = 0; k < nl; ++k) {
            mean[static_cast<int>(analysis::filip2024_channel(wavelengths[k]))] += brdf.at(p, k);
        }
    }
    std::array<int, 3> count{};
    for (double l : wavelengths) ++count[static_cast<int>(analysis::filip2024_channel(l))];
    for (int c = 0; c < 3; ++c) mean[c] /= static_cast<double>(count[c] * pairs);
    return mean;
}

// Reciprocity over the pairs the set holds both ways (both polar angles ≥ 15°): each couple's
// score z (reciprocity_z), per wavelength.
void reciprocity(const gonio::BrdfRecord& brdf, std::size_t nl, SpeciesOutcome& o) {
    double chi2 = 0.0, max_z = 0.0;
    int dof = 0;
    const auto lights = gonio::filip2024_light_directions();
    const auto views = gonio::filip2024_view_directions();
    auto same = [](const Vec3d& x, const Vec3d& y) { return (x - y).norm() < 1e-9; };
    for (std::size_t li = 0; li < lights.size(); ++li) {
        for (std::size_t vi = 0; vi < views.size(); ++vi) {
            // The swapped pair: the light at this view direction, the view at this light.
            std::size_t l2 = lights.size(), v2 = views.size();
            for (std::size_t k = 0; k < lights.size(); ++k)
                if (same(lights[k], views[vi])) l2 = k;
            for (std::size_t k = 0; k < views.size(); ++k)
                if (same(views[k], lights[li])) v2 = k;
            if (l2 == lights.size() || v2 == views.size()) continue;
            const std::size_t a = li * views.size() + vi, b = l2 * views.size() + v2;
            if (b <= a) continue;  // each couple once; a == b is the same cell
            for (std::size_t k = 0; k < nl; ++k) {
                const double z = analysis::reciprocity_z(
                    {brdf.at(a, k), brdf.error_at(a, k), views[vi].z()},
                    {brdf.at(b, k), brdf.error_at(b, k), views[v2].z()}, brdf.quanta);
                if (std::isnan(z)) continue;  // neither cell has a hit
                chi2 += z * z;
                max_z = std::max(max_z, std::abs(z));
                ++dof;
            }
        }
    }
    o.reciprocity_chi_square = chi2;
    o.reciprocity_dof = dof;
    o.reciprocity_max_z = max_z;
}

// ---- Compare: Filip's model fitted to the simulated BRDF. -----------------------------------

// Least squares is local, and φa is where this fit's local minima are (each fibre family of the
// patch is a candidate highlight axis): start from Table 1 with φa turned by 0°, 45°, 90° and
// 135° (φa is periodic in π) and keep the best unweighted fit.
analysis::Filip2024FitResult best_of_four_starts(const std::vector<analysis::BrdfObservation>& obs,
                                                 const Filip2024Parameters& table1,
                                                 const analysis::Filip2024FitOptions& options,
                                                 SpeciesOutcome& o) {
    std::optional<analysis::Filip2024FitResult> best;
    double best_phi = 0.0;
    for (int turn = 0; turn < 4; ++turn) {
        Filip2024Parameters trial = table1;
        trial.phi_a_rad = std::remainder(table1.phi_a_rad + turn * 0.25 * kPi, kPi);
        analysis::Filip2024FitResult candidate = analysis::fit_filip2024(obs, trial, options);
        if (!best || candidate.residual_rms < best->residual_rms) {
            best = std::move(candidate);
            best_phi = trial.phi_a_rad;
        }
    }
    o.fit_start_phi_a_deg = best_phi / kDeg;
    return *best;
}

// Photon counts make a cell's standard error grow with its own value (σ² ≈ c f for the cells of
// one light direction and wavelength), so weighting by the measured σ pulls the fit low
// (upward fluctuations get small weights, empty cells σ = 0). The refit's weights: the variance
// model σ_k² = c f_fit,k, c per (light, wavelength) from Σσ² / Σf over its views (Pearson's
// χ²), floored at one quantum's worth (f ≥ the smallest nonzero value).
void photon_variance_weights(const gonio::BrdfRecord& brdf, const Filip2024Parameters& first_fit,
                             const Run& run, std::vector<analysis::BrdfObservation>& obs) {
    const std::size_t views = gonio::kFilip2024ViewDirections, nl = run.nl();
    const auto& pairs = run.pairs;
    std::vector<double> variance_per_value(pairs.size() / views * nl, 0.0);
    for (std::size_t l = 0; l < pairs.size() / views; ++l) {
        for (std::size_t k = 0; k < nl; ++k) {
            double var = 0.0, sum = 0.0;
            for (std::size_t v = 0; v < views; ++v) {
                var += std::pow(brdf.error_at(l * views + v, k), 2);
                sum += brdf.at(l * views + v, k);
            }
            variance_per_value[l * nl + k] = sum > 0.0 ? var / sum : 0.0;
        }
    }
    const analysis::Filip2024Brdf first_model(first_fit);
    double smallest = std::numeric_limits<double>::infinity();
    for (double v : brdf.value)
        if (v > 0.0) smallest = std::min(smallest, v);
    if (!std::isfinite(smallest)) smallest = 1e-6;
    for (std::size_t p = 0; p < pairs.size(); ++p) {
        for (std::size_t k = 0; k < nl; ++k) {
            const double c = variance_per_value[(p / views) * nl + k];
            const double f = std::max(
                first_model.eval(pairs[p].wi, pairs[p].wo, run.s.wavelengths[k]), smallest);
            obs[p * nl + k].standard_error = c > 0.0 ? std::sqrt(c * f) : std::sqrt(f * smallest);
        }
    }
}

// Two steps: an unweighted fit (best of four starts), then a refit with photon-count weights.
void fit_filip(const Run& run, const SpeciesSpec& sp, Measured& m, SpeciesOutcome& o) {
    m.table1 = analysis::filip2024_preset(sp.name);
    o.table1 = analysis::to_vector(m.table1);
    for (std::size_t p = 0; p < run.pairs.size(); ++p) {
        for (std::size_t k = 0; k < run.nl(); ++k) {
            m.observations.push_back({run.pairs[p].wi, run.pairs[p].wo, std::nullopt,
                                      run.s.wavelengths[k], m.brdf.at(p, k), std::nullopt});
        }
    }
    run.ctx.clock().say(
        fmt::format("{}: fitting Filip 2024 to {} observations", sp.name, m.observations.size()));
    analysis::Filip2024FitOptions options;
    options.max_function_evaluations = run.s.fit_evaluations;
    // The four φa starts below are this study's global stage, the one its records were made
    // with; the fit's own grid (analysis/fits/filip2024_fit.h) is not run on top of them.
    options.global_starts = 0;
    const analysis::Filip2024FitResult first =
        best_of_four_starts(m.observations, m.table1, options, o);
    photon_variance_weights(m.brdf, first.parameters, run, m.observations);
    m.fit = analysis::fit_filip2024(m.observations, first.parameters, options);
    o.fitted = m.fit.values;
    o.fitted_error = m.fit.standard_errors;
    o.reduced_chi_square = m.fit.reduced_chi_square;
    o.fit_converged = m.fit.converged;
    o.at_bound = m.fit.at_bound;
    // U(φa) = (sin φa, cos φa): the barb axis of the mounted patch is at φa = 90° − ψ, the
    // barbules at φa = −ψ.
    o.fit_axis_from_barbs_deg =
        axis_angle_deg(o.fitted[analysis::kFilipPhiA], 0.5 * kPi - sp.mount_rad);
    o.fit_axis_from_barbules_deg = axis_angle_deg(o.fitted[analysis::kFilipPhiA], -sp.mount_rad);
}

// The fitted and Table 1 models on the same cells, their errors against the simulation, and
// the three fingerprints side by side.
void compare_models(const Specimen& x, Measured& m, SpeciesOutcome& o) {
    gonio::GoniometerConfig ge = m.brdf_config;
    ge.estimator = gonio::Estimator::eval;
    // Both cones take a double cubature, (2 rings²)² evaluations per cell: with 2 rings (64)
    // the models' cells are within 0.2–1.1 % RMS (0.1–0.2 % in L1) of the default 4 rings' on
    // species_quick, below the simulated BRDF's own error, at a sixteenth of the cost (which
    // had made these fits the slowest stage). fit.h5's standard_error (against 1 ring)
    // overstates that.
    if (ge.aperture == gonio::Aperture::both_cones) ge.eval_rings = 2;
    const analysis::Filip2024Brdf fitted_model(m.fit.parameters, "filip2024 fit");
    const analysis::Filip2024Brdf table1_model(m.table1, "filip2024 table 1");
    m.fit_brdf = gonio::measure_brdf(fitted_model, ge);
    m.table1_brdf = gonio::measure_brdf(table1_model, ge);
    // Energy, as an export checks it (studies/bsdf_export.h): 21 directions θ_i ≤ 75°, the
    // first, middle and last wavelengths, 16 polar cells per hemisphere.
    const std::vector<Vec3d> directions =
        analysis::hemisphere_grid(15.0 * kDeg, 75.0 * kDeg, 90.0 * kDeg);
    const std::vector<double>& grid = ge.wavelengths_nm;
    const std::vector<double> lambdas = {grid.front(), grid[grid.size() / 2], grid.back()};
    o.fit_energy = analysis::check_energy(fitted_model, directions, lambdas, 16);
    o.table1_energy = analysis::check_energy(table1_model, directions, lambdas, 16);
    gonio::write_brdf_record(m.fit_brdf, x.dir / "fit.h5");
    o.fit_relative_rms = relative_rms(m.fit_brdf, m.brdf);
    o.table1_relative_rms = relative_rms(m.table1_brdf, m.brdf);
    o.fit_relative_l1 = relative_l1(m.fit_brdf, m.brdf);
    o.table1_relative_l1 = relative_l1(m.table1_brdf, m.brdf);
    o.fit_verdict = analysis::agreement(m.brdf.value, m.brdf.standard_error, m.fit_brdf.value,
                                        m.fit_brdf.standard_error, m.brdf.signal_cells);
    o.table1_verdict = analysis::agreement(m.brdf.value, m.brdf.standard_error, m.table1_brdf.value,
                                           m.table1_brdf.standard_error, m.brdf.signal_cells);
    write_fingerprint_figure(x.dir / "fingerprints.h5",
                             fmt::format("{}: BRDF fingerprints", x.spec.name),
                             {{"simulation", &m.brdf},
                              {"fitted Filip 2024 model", &m.fit_brdf},
                              {"Filip 2024 Table 1 model", &m.table1_brdf}},
                             61, 60);
    run_plot("fingerprints", x.dir / "fingerprints.h5", x.dir / "fingerprints.png");
    gonio::write_spectral_exr(
        x.dir / "fingerprints.exr",
        {gonio::fingerprint_exr_image(m.brdf, 61, 60, "simulation"),
         gonio::fingerprint_exr_image(m.fit_brdf, 61, 60, "fitted Filip 2024 model"),
         gonio::fingerprint_exr_image(m.table1_brdf, 61, 60, "Filip 2024 Table 1 model")},
        "species");
}

// ---- Measure: in-plane sweep, albedo, BTF. --------------------------------------------------

// In the plane across the barbs (turned with the sample): L* of the simulation and the fit.
void in_plane_sweep(const Run& run, const Specimen& x, const Measured& m, SpeciesOutcome& o) {
    gonio::GoniometerConfig ip = m.brdf_config;
    ip.direction_set = "filip2024_in_plane";
    ip.pairs = gonio::filip2024_in_plane_pairs(x.spec.mount_rad + gonio::kPlaneAcrossBarbsRad);
    ip.quanta_per_pass = run.s.in_plane_quanta;
    ip.max_passes = 1;
    ip.seed = run.ctx.stream("species/in_plane", x.index);
    run.ctx.clock().say(fmt::format("{}: in-plane sweep", x.spec.name));
    const gonio::BrdfRecord a = gonio::measure_brdf(x.sample, ip);
    ip.estimator = gonio::Estimator::eval;
    const analysis::Filip2024Brdf fitted_model(m.fit.parameters, "filip2024 fit");
    const gonio::BrdfRecord b = gonio::measure_brdf(fitted_model, ip);
    gonio::write_brdf_record(a, x.dir / "in_plane.h5");
    double peak = -1.0;
    for (std::size_t p = 0; p < ip.pairs.size(); ++p) {
        const auto [l, e] = run.luminance(a, p);
        o.in_plane_lstar.push_back(l);
        o.in_plane_lstar_error.push_back(e);
        o.in_plane_fit_lstar.push_back(run.luminance(b, p).first);
        if (l > peak) {
            peak = l;
            o.in_plane_peak_deg = run.in_plane_angles_deg[p];
        }
    }
}

// Directional albedo at normal incidence over the period cell (sim/albedo.h).
void albedo_at_normal_incidence(const Run& run, const Specimen& x, SpeciesOutcome& o) {
    run.ctx.clock().say(fmt::format("{}: albedo at normal incidence", x.spec.name));
    const std::size_t nl = run.nl();
    o.albedo.assign(nl, 0.0);
    o.albedo_error.assign(nl, 0.0);
    for (std::size_t k = 0; k < nl; ++k) {
        const sim::AlbedoEstimate e = sim::measure_albedo(
            *x.tracer, *x.cell, Vec3d(0.0, 0.0, 1.0), run.s.wavelengths[k], run.s.albedo_quanta,
            run.ctx.stream("species/albedo", x.index * nl + k));
        o.albedo[k] = e.albedo;
        o.albedo_error[k] = e.standard_error;
        o.mismatched_paths += e.mismatched_paths / static_cast<double>(nl);
        o.mismatched_albedo += e.mismatched_albedo / static_cast<double>(nl);
    }
}

// Fig. 9's 12 geometries in the 61 × 60 set: light and view at 30°, the view at azimuth 0, the
// light going round in 30° steps (the red frame of Fig. 7).
std::vector<std::size_t> figure9_pairs(const std::vector<gonio::DirectionPair>& pairs) {
    std::vector<std::size_t> figure9;
    const Vec3d view = gonio::direction_from_angles(30.0 * kDeg, 0.0);
    for (int k = 0; k < 12; ++k) {
        const Vec3d light = gonio::direction_from_angles(30.0 * kDeg, k * 30.0 * kDeg);
        for (std::size_t p = 0; p < pairs.size(); ++p) {
            if ((pairs[p].wi - light).norm() < 1e-9 && (pairs[p].wo - view).norm() < 1e-9)
                figure9.push_back(p);
        }
    }
    PLUMAGE_CHECK(figure9.size() == 12, "the Filip set holds Fig. 9's 12 geometries");
    return figure9;
}

// The virtual BTF on the 61 × 60 set (every pair an image of the patch), and Fig. 9 of it.
void measure_species_btf(const Run& run, const Specimen& x, SpeciesOutcome& o) {
    const Settings& s = run.s;
    gonio::BtfConfig bc = s.btf;  // the camera as read; its pairs, seed and study text here
    if (s.btf_figure9_only) {
        for (const std::size_t p : figure9_pairs(run.pairs)) bc.pairs.push_back(run.pairs[p]);
    } else {
        bc.pairs = run.pairs;
    }
    bc.seed = run.ctx.stream("species/btf", x.index);
    bc.config_text = run.ctx.text();
    run.ctx.clock().say(
        fmt::format("{}: BTF on {} pairs ({} x {} pixels, {} wavelengths, {} estimator)",
                    x.spec.name, bc.pairs.size(), bc.pixels, bc.pixels, bc.wavelengths_nm.size(),
                    gonio::to_string(bc.estimator)));
    gonio::RunControl control;  // the detector estimator's passes are checkpointed
    control.progress = run.ctx.progress();
    const fs::path checkpoints = run.ctx.checkpoints();
    fs::create_directories(checkpoints);
    control.checkpoint = checkpoints / (x.spec.name + "_btf.checkpoint");
    const gonio::BtfRecord btf = gonio::measure_btf(x.imaged, bc, control);
    o.btf_seconds = btf.wall_time_s;
    o.btf_passes = static_cast<int>(btf.convergence.size());
    const std::vector<std::size_t> figure9 = figure9_pairs(bc.pairs);
    o.btf_median_pixel_error = gonio::median_lit_pixel_error(btf, figure9);
    for (const std::size_t p : figure9)
        o.btf_tile_pixel_errors.push_back(
            gonio::median_lit_pixel_error(btf, std::span<const std::size_t>(&p, 1)));
    gonio::write_btf_record(btf, x.dir / "btf.h5");
    write_btf_figure(x.dir / "btf_figure9.h5",
                     fmt::format("{}: virtual BTF, Filip 2024 Fig. 9 geometries", x.spec.name), btf,
                     figure9);
    run_plot("btf_tiles", x.dir / "btf_figure9.h5", x.dir / "btf.png");
    // The tiles of btf.png, one part each, named by their light and view directions.
    std::vector<gonio::SpectralImage> tiles;
    for (const std::size_t p : figure9) {
        const auto& pair = btf.config.pairs[p];
        auto angles = [](const Vec3d& w) {
            return fmt::format("theta {:.0f} phi {:.0f}",
                               std::acos(std::clamp(w.z(), -1.0, 1.0)) / kDeg,
                               std::atan2(w.y(), w.x()) / kDeg);
        };
        tiles.push_back(gonio::btf_exr_image(
            btf, p,
            fmt::format("pair {}: light {}, view {}", p, angles(pair.wi), angles(pair.wo))));
    }
    gonio::write_spectral_exr(x.dir / "btf.exr", tiles, "species");
}

// ---- Report. ---------------------------------------------------------------------------------

void write_species_h5(record::Hdf5Writer& h5, const SpeciesOutcome& o, std::size_t nl) {
    const std::string g5 = "/" + o.species;
    const auto parameters = static_cast<std::uint64_t>(kFilip2024ParameterCount);
    // One unit per parameter, in the order of /@parameter_names.
    std::string units;
    for (int p = 0; p < kFilip2024ParameterCount; ++p) {
        if (!units.empty()) units += ',';
        units += kFilip2024ParameterTable[p].unit;
    }
    h5.write(g5 + "/fit/values", std::span<const double>(o.fitted), {parameters},
             {{"units", units},
              {"description",
               "Filip 2024 parameters fitted to the simulated BRDF, order of /@parameter_names"}});
    h5.write(g5 + "/fit/standard_errors", std::span<const double>(o.fitted_error), {parameters},
             {{"units", units}, {"description", "standard errors of fit/values"}});
    h5.write(g5 + "/fit/table1", std::span<const double>(o.table1), {parameters},
             {{"units", units}, {"description", "Filip 2024 Table 1 column of this species"}});
    h5.set_attribute(g5 + "/fit/values", "reduced_chi_square", o.reduced_chi_square);
    h5.set_attribute(g5 + "/fit/values", "relative_rms", o.fit_relative_rms);
    h5.write(g5 + "/albedo", std::span<const double>(o.albedo), {nl},
             {{"units", "1"},
              {"description", "directional albedo at normal incidence, per wavelength_nm"}});
    h5.write(g5 + "/albedo_standard_error", std::span<const double>(o.albedo_error), {nl},
             {{"units", "1"}, {"description", "standard error of albedo"}});
    h5.write(g5 + "/in_plane/lstar", std::span<const double>(o.in_plane_lstar),
             {o.in_plane_lstar.size()},
             {{"units", "1"},
              {"description",
               "CIE L* (D65) of the reflectance factor pi f, simulation; "
               "above 100 where the factor exceeds the white standard's"}});
    h5.write(g5 + "/in_plane/lstar_standard_error", std::span<const double>(o.in_plane_lstar_error),
             {o.in_plane_lstar.size()},
             {{"units", "1"}, {"description", "standard error of lstar"}});
    h5.write(g5 + "/in_plane/fit_lstar", std::span<const double>(o.in_plane_fit_lstar),
             {o.in_plane_lstar.size()},
             {{"units", "1"}, {"description", "CIE L* (D65) of pi f of the fitted Filip model"}});
    h5.set_attribute(g5, "mount_deg", o.mount_deg);
}

// One species, measured and fitted: steps 1–6, its records and its section of the report.
SpeciesOutcome run_one_species(const Run& run, const Specimen& x, record::Hdf5Writer& h5,
                               std::string& md) {
    SpeciesOutcome o;
    o.species = x.spec.name;
    o.mount_deg = x.spec.mount_rad / kDeg;
    Measured m;
    m.brdf = measure_species_brdf(run, x, m);
    o.brdf_seconds = m.brdf.wall_time_s;
    o.mean_brdf_rgb = mean_brdf_rgb(m.brdf, run.s.wavelengths);
    const std::size_t mirror = figure9_pairs(run.pairs)[6];  // light 30° at 180°, view 30° at 0°
    for (std::size_t k = 0; k < run.nl(); ++k) {
        o.mirror_reflectance.push_back(kPi * m.brdf.at(mirror, k));
        o.mirror_reflectance_error.push_back(kPi * m.brdf.error_at(mirror, k));
    }
    reciprocity(m.brdf, run.nl(), o);
    fit_filip(run, x.spec, m, o);
    compare_models(x, m, o);
    in_plane_sweep(run, x, m, o);
    albedo_at_normal_incidence(run, x, o);
    measure_species_btf(run, x, o);
    write_species_h5(h5, o, run.nl());
    md += species_section(run, x, m, o);
    return o;
}

// The species' spectra at the mirror pair as birds tell them apart (RNL ΔS, analysis/
// avian_compare.h) and in pavo's layout (spectra_pavo.csv).
std::string avian_section(const fs::path& dir, const Run& run, const SpeciesResult& result) {
    std::vector<std::string> names;
    std::vector<std::vector<double>> spectra, errors, percent;
    for (const auto& o : result.species) {
        names.push_back(o.species);
        spectra.push_back(o.mirror_reflectance);
        errors.push_back(o.mirror_reflectance_error);
        percent.emplace_back();
        for (double r : o.mirror_reflectance) percent.back().push_back(100.0 * r);
    }
    write_text_file(dir / "spectra_pavo.csv",
                    analysis::pavo_csv_text(run.s.wavelengths, names, percent));
    write_text_file(dir / "avian_catches.csv",
                    analysis::avian_catches_csv(run.s.wavelengths, names, percent));
    std::string md = fmt::format(
        "## Avian vision\n\nThe simulated spectra π·f at the mirror pair (light 30° at azimuth "
        "180°, view 30° at 0°) under D65, told apart by an ultraviolet- and a violet-sensitive "
        "bird: receptor-noise-limited ΔS in just-noticeable differences (Vorobyev & Osorio 1998; "
        "analysis/metrics/avian_vision.h), on the study's {}–{} nm grid (no light below it reaches "
        "the "
        "UV/violet cone). Spectra in pavo's layout: `spectra_pavo.csv` (`wl` in nm, one column "
        "per species, per cent); their quantum catches for pavo's four birds: `avian_catches.csv`. "
        "In brackets each ΔS's noise floor (the RMS ΔS the Monte Carlo "
        "errors alone give, to first order: it misses the noise of cells that caught no light, "
        "whose σ is 0, so a floor near 0 beside a spectrum with zeros is not to be trusted); "
        "\"–\": a cone catches nothing (zero reflectance on the grid).\n\n",
        run.s.wavelengths.front(), run.s.wavelengths.back());
    for (const auto* system :
         {&analysis::ultraviolet_sensitive_system(), &analysis::violet_sensitive_system()}) {
        md += analysis::rnl_matrix_markdown(names, spectra, errors, run.s.wavelengths, *system) +
              "\n";
    }
    return md;
}

// The BTF's per-pixel noise against its stop rule's target, per species and per tile: whether
// its images are ground truth at the error the study asked for, and which tiles hold the noise.
std::string btf_noise_verdicts(const Settings& s, const SpeciesResult& result) {
    const gonio::BtfConfig& c = s.btf;
    std::string md = fmt::format(
        "Per species, the BTF's noise: the median σ/f over the lit pixels of Fig. 9's tiles (every "
        "wavelength; lit: above 1 % of the tile's brightest pixel) against the target of its stop "
        "rule ({}), and the same median per tile, in Fig. 9's order (light azimuth 0°, 30°, …, "
        "330°; view 30° at 0°).\n\n| species | median σ/f | target | passes, time | per tile "
        "(%) |\n|---|---|---|---|---|\n",
        c.estimator == gonio::BtfEstimator::detector ? btf_stop_rule(s)
                                                     : "the forward estimator: one pass");
    for (const SpeciesOutcome& o : result.species) {
        std::string target = "none set";
        if (c.estimator == gonio::BtfEstimator::detector && c.target_pixel_error > 0.0) {
            const bool reached = o.btf_median_pixel_error <= c.target_pixel_error;
            target = fmt::format("{:.1f} %: **{}**", 100.0 * c.target_pixel_error,
                                 reached ? "reached" : "not reached");
            if (!reached)
                target += o.btf_passes >= c.max_passes ? " (max_passes done)"
                                                       : " (the time limit ended the passes)";
        }
        std::string tiles;
        for (const double e : o.btf_tile_pixel_errors) {
            if (!tiles.empty()) tiles += ", ";
            tiles += std::isfinite(e) ? fmt::format("{:.1f}", 100.0 * e) : "–";
        }
        md += fmt::format("| {} | {:.1f} % | {} | {}, {:.0f} s | {} |\n", o.species,
                          100.0 * o.btf_median_pixel_error, target, o.btf_passes, o.btf_seconds,
                          tiles);
    }
    return md + "\n";
}

// The report's opening: per species, the simulated BRDF against the fitted model and against
// Table 1's, from the simulation's Monte Carlo noise alone (analysis/metrics/verdict.h); then
// the BTF's noise against its target.
std::string verdict_block(const Settings& s, const SpeciesResult& result) {
    std::string md =
        "## Verdicts\n\nPer species, the simulated BRDF (61 × 60 set, its signal cells) against "
        "Filip's model with the fitted parameters and with Table 1's, from the simulation's Monte "
        "Carlo noise alone (analysis/metrics/verdict.h): z = (simulation − model)/σ per cell, χ² "
        "over the "
        "cells and the power difference against its σ; p is the smaller of the two tests' p, "
        "doubled; **differs** when p < 0.001, **agrees** when p >= 0.01, **undecided** between. "
        "The fit was made to these cells (its parameters lower χ² by about their number, far "
        "under the cells'); the model's own cubature error is not noise and is not in σ.\n\n"
        "| species | against | verdict | cells | RMS z | beyond 3σ | p | power, simulation / "
        "model − 1 |\n|---|---|---|---|---|---|---|---|\n";
    for (const SpeciesOutcome& o : result.species)
        for (const auto& [against, v] :
             {std::pair{"fit", &o.fit_verdict}, std::pair{"Table 1", &o.table1_verdict}})
            md += fmt::format(
                "| {} | {} | **{}** | {} | {:.2f} | {:.1f} % | {} | {:+.1f} % ± "
                "{:.1f} % |\n",
                o.species, against, v->verdict, v->cells, v->rms_z, 100.0 * v->beyond_3_sigma,
                p_value_text(v->p_value), 100.0 * v->power_difference,
                100.0 * v->power_difference_sigma);
    return md + "\n" + btf_noise_verdicts(s, result);
}

// After the species: Table 1 beside the fits, Fig. 6a, the records' index; then commit.
void finish(const Run& run, SpeciesResult& result, record::Hdf5Writer& h5, std::string& md) {
    const fs::path dir = run.ctx.out();
    std::vector<PlotJob> plots;
    md += fits_section(dir, result);
    md += in_plane_section(dir, result, plots);
    md += avian_section(dir, run, result);
    run_plots(plots, dir / "plots.csv");
    std::string joined;
    for (int p = 0; p < kFilip2024ParameterCount; ++p) {
        // Appended piecewise: GCC 12 warns (-Wrestrict, a false positive) on "" + std::string.
        if (!joined.empty()) joined += ',';
        joined += kFilip2024ParameterTable[p].name;
    }
    h5.set_attribute("/", "parameter_names", joined);
    h5.set_attribute("/", "study", std::string(run.ctx.text()));
    h5.commit();
    result.wall_seconds = run.ctx.clock().elapsed_s();
    md += fmt::format(
        "## Run\n\n{:.0f} s on {} threads. Records: `species.h5` (fits, albedo, in-plane L*), "
        "`fits.csv`, `in_plane_luminance.csv`, per species `brdf.h5` (simulation), `fit.h5` "
        "(fitted model), `in_plane.h5`, `btf.h5` (virtual_gonio/RECORD.md).\n",
        result.wall_seconds, omp_get_max_threads());
    md += "\n" + run.ctx.run_time_by_stage();
    // The verdicts open the report, under its title.
    const std::size_t title_end = md.find("\n\n") + 2;
    md.insert(title_end, verdict_block(run.s, result));
    write_text_file(dir / "report.md", md);
    result.output_dir = run.ctx.commit();
}

}  // namespace

SpeciesResult run_species_study(const std::string& study_text, const fs::path& source_name,
                                const fs::path& results_root, bool progress,
                                const RunLimits& limits) {
    StudyContext ctx(study_text, source_name, results_root, limits, progress);
    std::string name;
    Settings s = read_settings(ctx.file(), name, source_name);  // read
    ctx.begin(name);
    s.time_budget_s = ctx.time_budget_s(s.time_budget_s);
    s.target_relative_error = ctx.target_relative_error(s.target_relative_error);
    const std::vector<BuiltSpecies> built = build_all(s, ctx);  // build

    const fs::path out = ctx.out();
    SpeciesResult result;
    result.wavelengths_nm = s.wavelengths;
    for (double a : gonio::filip2024_in_plane_light_angles())
        result.in_plane_angles_deg.push_back(a / kDeg);
    const optics::WavelengthGrid grid(s.wavelengths);
    const optics::ReflectanceToXyz to_xyz(grid, optics::Illuminant::d65);
    const Luminance luminance(to_xyz, s.wavelengths.size());
    const std::vector<gonio::DirectionPair> pairs = gonio::filip2024_btf_pairs();
    const Run run{s, ctx, pairs, luminance, result.in_plane_angles_deg};

    std::string md = report_introduction(s, built, source_name);
    record::Hdf5Writer h5(out / "species.h5");
    write_species_h5_header(h5, result);
    for (std::size_t si = 0; si < s.species.size(); ++si) {  // measure, compare, report
        fs::create_directories(out / s.species[si].name);
        const Specimen x(s.species[si], si, built[si], out / s.species[si].name);
        result.species.push_back(run_one_species(run, x, h5, md));
    }
    finish(run, result, h5, md);
    return result;
}

void check_species_study(const std::string& study_text, const fs::path& source_name) {
    StudyContext ctx(study_text, source_name);
    std::string name;
    read_settings(ctx.file(), name, source_name);
}

SpeciesScene build_species_scene(const std::string& study_text, const fs::path& source_name,
                                 const std::string& species,
                                 const std::vector<double>& extra_wavelengths_nm) {
    StudyContext ctx(study_text, source_name);  // nothing is written: no begin()
    StudyFile* file = &ctx.file();
    std::string name;
    Settings s = read_settings(ctx.file(), name, source_name);
    std::vector<double> wavelengths = s.traced_wavelengths;
    wavelengths.insert(wavelengths.end(), extra_wavelengths_nm.begin(), extra_wavelengths_nm.end());
    std::sort(wavelengths.begin(), wavelengths.end());
    wavelengths.erase(std::unique(wavelengths.begin(), wavelengths.end()), wavelengths.end());
    for (std::size_t i = 0; i < s.species.size(); ++i) {
        const SpeciesSpec& sp = s.species[i];
        if (sp.name != species) continue;
        if (sp.medulla.spongy) {
            // The study's voxel limit, now over the extra wavelengths too.
            ParameterTable m = file->root().table("species").table(sp.name).table("materials");
            require_fine_voxels(m, "spongy_voxel_um", sp.medulla.structure.voxel_um, wavelengths);
        }
        const std::string where = fmt::format("{}: [species.{}]", source_name.string(), sp.name);
        BuiltSpecies b =
            build_species(sp, s.tolerance, where, spongy_volume_stream(ctx, i), wavelengths);
        SpeciesScene out;
        out.scene = std::move(b.scene);
        out.cell_x_um = sp.patch.barbule_pitch_um();
        out.cell_y_um = b.period_um;
        out.cell_y0_um = sp.barbs % 2 == 1 ? 0.0 : 0.5 * b.period_um;
        out.barb_width_um = sp.patch.barb.barb_width_um;
        out.wavelengths_nm = std::move(wavelengths);
        if (b.spongy) out.spongy_medium = b.spongy->medium;
        return out;
    }
    throw InputError(
        fmt::format("{}: species.run does not list '{}'", source_name.string(), species));
}

namespace {

// `plumage run`: the run, and the summary printed on stdout.
std::string run_from_command_line(const std::string& text, const fs::path& source,
                                  const fs::path& root, const RunLimits& limits) {
    const auto r = run_species_study(text, source, root, true, limits);
    std::string summary = fmt::format("plumage: wrote {} in {:.0f} s (open report.md)\n",
                                      r.output_dir.string(), r.wall_seconds);
    for (const auto& o : r.species) {
        summary += fmt::format(
            "  {}: Filip fit reduced chi2 {:.2f}, relative L1 {:.1f} % (Table 1: {:.1f} %), "
            "reciprocity chi2/dof {:.2f}\n",
            o.species, o.reduced_chi_square, 100.0 * o.fit_relative_l1,
            100.0 * o.table1_relative_l1,
            o.reciprocity_chi_square / std::max(1, o.reciprocity_dof));
    }
    return summary;
}

}  // namespace

StudyEntry species_study_entry() {
    return {"species", "the four Filip 2024 feathers built explicitly, measured and fitted",
            check_species_study, run_from_command_line};
}

}  // namespace plumage::studies
