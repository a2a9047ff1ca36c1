#include "studies/instrument_tables.h"

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "virtual_gonio/direction_sets.h"

namespace plumage::studies {

gonio::GoniometerConfig read_goniometer_table(ParameterTable& t, gonio::GoniometerConfig c,
                                              const GoniometerKeys& keys) {
    if (!keys.direction_sets.empty()) {
        c.direction_set =
            t.string("direction_set", c.direction_set, keys.direction_sets, "direction set");
        if (c.direction_set == "filip2024_btf") c.pairs = gonio::filip2024_btf_pairs();
        if (c.direction_set == "filip2024_in_plane") c.pairs = gonio::filip2024_in_plane_pairs();
    }
    c.detector_half_angle_rad = t.angle_deg("detector_half_angle_deg", c.detector_half_angle_rad,
                                            {0.0, keys.max_detector_half_angle_deg, true, false},
                                            "detector cone half-angle");
    c.quanta_per_pass = static_cast<std::uint64_t>(
        t.integer("quanta_per_pass", static_cast<long>(c.quanta_per_pass), 100, 100000000,
                  "quanta per light direction, wavelength and pass"));
    c.max_passes = static_cast<int>(t.integer("passes", c.max_passes, 1, 1000, "passes (at most)"));
    if (keys.beam_radius)
        c.beam_radius_um =
            t.number("beam_radius_um", c.beam_radius_um, positive(), "beam radius, um");
    if (keys.aperture) {
        c.aperture = gonio::parse_aperture(
            t.string("aperture", gonio::to_string(c.aperture), {"view_cone", "both_cones"},
                     "what a BRDF cell averages: the detector cone alone, or light and detector "
                     "cones (reciprocal)"),
            t.location("aperture"));
    }
    if (!keys.path_options) return c;
    c.share_wavelength_paths =
        t.boolean("share_wavelength_paths", c.share_wavelength_paths,
                  "trace one path per quantum for all wavelengths (true) or one per wavelength");
    c.split_paths = t.boolean("split_paths", c.split_paths,
                              "split each shared path at its first film into its reflected and "
                              "transmitted branches (true) or choose one");
    c.split_reflections =
        t.boolean("split_reflections", c.split_reflections,
                  "with split_paths: split the reflected branch again at its next film (true)");
    c.guided_fraction = t.number("guided_fraction", c.guided_fraction, {0.0, 1.0, false, true},
                                 "share of the diffuse directions aimed at the detector cones");
    c.guided_branches = static_cast<std::size_t>(
        t.integer("guided_branches", static_cast<long>(c.guided_branches), 0, 3,
                  "directions aimed at the detector cones beside the cosine one at each path's "
                  "first diffuse event"));
    if (c.guided_branches > 0 && c.guided_fraction > 0.0) {
        throw InputError(fmt::format(
            "{}: {}.guided_branches = {} with guided_fraction = {}: both guide the first diffuse "
            "event; set one of them (the other 0)",
            t.location("guided_branches"), t.path(), c.guided_branches, c.guided_fraction));
    }
    c.connect_lights =
        t.boolean("connect_lights", c.connect_lights,
                  "connect detector-side walks to the lights at their first diffuse event "
                  "(true), weighed against the quanta by the balance heuristic");
    c.connected_quanta_per_pass = static_cast<std::uint64_t>(t.integer(
        "connected_quanta_per_pass", static_cast<long>(c.connected_quanta_per_pass), 0, 100000000,
        "detector-side walks per view direction and pass (0: quanta_per_pass)"));
    return c;
}

ScatterometerTable read_scatterometer_table(ParameterTable& t, ScatterometerTable s,
                                            const ScatterometerKeys& keys) {
    gonio::ScatterometerConfig& c = s.config;
    c.image_size = static_cast<int>(
        t.integer("image_size", c.image_size, 17, 1025, "pixels across the scatterogram"));
    c.quanta_per_pass = static_cast<std::uint64_t>(
        t.integer("quanta_per_pass", static_cast<long>(c.quanta_per_pass), 1000, 100000000,
                  "quanta per wavelength and pass"));
    c.max_passes = static_cast<int>(t.integer("passes", c.max_passes, 1, 1000, "passes (at most)"));
    s.beam_incidence_rad = t.angle_deg("beam_incidence_deg", s.beam_incidence_rad,
                                       between(0.0, 80.0), "beam polar angle");
    s.beam_azimuth_rad = t.angle_deg("beam_azimuth_deg", s.beam_azimuth_rad, between(-360.0, 360.0),
                                     fmt::format("beam azimuth from {}", keys.azimuth_from));
    c.beam_direction = gonio::direction_from_angles(s.beam_incidence_rad, s.beam_azimuth_rad);
    c.beam_radius_um = t.number("beam_radius_um", c.beam_radius_um, positive(), "beam radius, um");
    if (keys.illumination_strata) {
        c.illumination_strata =
            static_cast<int>(t.integer("illumination_strata", c.illumination_strata, 1, 65536,
                                       "illumination directions per pass"));
    }
    if (keys.cone_aperture) {
        c.cone_aperture_rad =
            t.angle_deg("cone_aperture_deg", c.cone_aperture_rad, {0.0, 90.0, true, false},
                        "full aperture of the illumination cone");
    }
    if (keys.path_options) {
        c.share_wavelength_paths =
            t.boolean("share_wavelength_paths", c.share_wavelength_paths,
                      "one traced path per quantum for every wavelength (every scatterogram)");
        c.split_paths = t.boolean("split_paths", c.split_paths,
                                  "split each shared path at its first film event");
    }
    return s;
}

gonio::BtfConfig read_btf_camera(ParameterTable& t, gonio::BtfConfig c) {
    c.pixels = static_cast<int>(t.integer("pixels", c.pixels, 1, 1024, "BTF pixels per side"));
    c.patch_size_um =
        t.number("patch_size_um", c.patch_size_um, positive(), "side of the imaged square, um");
    c.detector_half_angle_rad =
        t.angle_deg("detector_half_angle_deg", c.detector_half_angle_rad, {0.0, 30.0, true, false},
                    "BTF detector cone half-angle");
    c.aperture = gonio::parse_aperture(
        t.string("aperture", gonio::to_string(c.aperture), {"view_cone", "both_cones"},
                 "what a BTF pixel averages: the detector cone alone (collimated light), or "
                 "light and detector cones"),
        t.location("aperture"));
    c.estimator = gonio::parse_btf_estimator(t.string(
        "estimator", gonio::to_string(c.estimator), {"forward", "detector"},
        "BTF estimator: from the light, or from each pixel (needs aperture = \"both_cones\")"));
    c.quanta_per_light = static_cast<std::uint64_t>(
        t.integer("quanta_per_light", static_cast<long>(c.quanta_per_light), 100, 1000000000,
                  "BTF forward estimator: quanta per light direction and wavelength"));
    c.quanta_per_pixel = static_cast<std::uint64_t>(
        t.integer("quanta_per_pixel", static_cast<long>(c.quanta_per_pixel), 2, 1000000000,
                  "BTF detector estimator: quanta per view direction, pixel and pass"));
    c.stratified_group = static_cast<std::uint64_t>(
        t.integer("stratified_group", static_cast<long>(c.stratified_group), 1, 4096,
                  "BTF detector estimator: quanta per stratified group (a power of two dividing "
                  "quanta_per_pixel; 1: independent quanta)"));
    c.split_reflections =
        t.boolean("split_reflections", c.split_reflections,
                  "BTF detector estimator: split each walk's reflected branch again at its next "
                  "film (true)");
    c.split_aimed_reflections = t.boolean(
        "split_aimed_reflections", c.split_aimed_reflections,
        "BTF detector estimator: trace both sides of a bare interface whose mirror direction lies "
        "within a light's cone (true)");
    c.max_passes = static_cast<int>(t.integer(
        "max_passes", c.max_passes, 1, 100000,
        "BTF detector estimator: passes at most (stop rule: target_pixel_error, max_time_s)"));
    c.target_pixel_error =
        t.number("target_pixel_error", c.target_pixel_error, {0.0, 1.0, false, true},
                 "BTF detector estimator: stop at this median per-pixel error over the lit "
                 "pixels (0: none)");
    c.max_time_s = t.number("max_time_s", c.max_time_s, non_negative(),
                            "BTF detector estimator: no pass that would end after this (s; 0: "
                            "no limit)");
    if (c.max_passes > 1 && c.estimator != gonio::BtfEstimator::detector) {
        throw InputError(fmt::format(
            "{}: [btf] max_passes = {} needs estimator = \"detector\" (the forward estimator "
            "is one pass)",
            t.location("max_passes"), c.max_passes));
    }
    const std::uint64_t group = c.stratified_group;
    if ((group & (group - 1)) != 0 || c.quanta_per_pixel % group != 0 ||
        c.quanta_per_pixel / group < 2) {
        throw InputError(fmt::format(
            "{}: [btf] stratified_group = {}: expected a power of two that divides "
            "quanta_per_pixel ({}) at least twice (a pixel's error is the spread of its groups)",
            t.location("stratified_group"), group, c.quanta_per_pixel));
    }
    if (group > 1 && c.estimator != gonio::BtfEstimator::detector) {
        throw InputError(fmt::format(
            "{}: [btf] stratified_group = {} needs estimator = \"detector\" (it stratifies each "
            "pixel's quanta)",
            t.location("stratified_group"), group));
    }
    if (c.estimator == gonio::BtfEstimator::detector && c.aperture != gonio::Aperture::both_cones) {
        throw InputError(fmt::format(
            "{}: [btf] estimator = \"detector\" needs aperture = \"both_cones\" (a walk from "
            "the detector cannot reach a collimated light through mirror-like events)",
            t.location("estimator")));
    }
    return c;
}

gonio::InstrumentValues read_instrument_table(ParameterTable& t, const gonio::InstrumentEntry& e,
                                              const gonio::MeasurementSetting& setting) {
    gonio::InstrumentValues values;
    for (const gonio::InstrumentParameter& p : e.parameters) {
        const std::string what = fmt::format("{} ({})", p.meaning, p.unit);
        if (p.integer) {
            values.set(p.name, static_cast<double>(t.integer(
                                   p.name, static_cast<long>(p.default_value),
                                   static_cast<long>(p.min), static_cast<long>(p.max), what)));
        } else {
            values.set(p.name, t.number(p.name, p.default_value,
                                        {p.min, p.max, p.min_open, p.max_open}, what));
        }
    }
    try {
        e.check(values, setting);
    } catch (const InputError& error) {
        throw InputError(fmt::format("{}: [{}]: {}", t.location(), e.table, error.what()));
    }
    return values;
}

}  // namespace plumage::studies
