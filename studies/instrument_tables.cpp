#include "studies/instrument_tables.h"

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"

namespace plumage::studies {

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
            values.set(p.key, static_cast<double>(t.integer(
                                  p.key, static_cast<long>(p.default_value),
                                  static_cast<long>(p.min), static_cast<long>(p.max), what)));
        } else {
            values.set(p.key, t.number(p.key, p.default_value,
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
