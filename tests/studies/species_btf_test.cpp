// The BTF camera's detector-side estimator against its forward one on the species scenes
// (issue 38's acceptance 4): the patches the species study images, with every event the
// detector-side walk must reverse at once — the parrot's spongy medium and melanin barbules
// under films, the rooster's coherent films, the flamingo's pigmented keratin and the stork's
// white medulla under clear keratin, where the walk's guided branch aims through the cortex
// (sim/tracer.h, "Guided diffuse reflection"). Per wavelength a χ² over the pixels the forward
// walk resolves, and the largest |z| within the Šidák bound (tests/virtual_gonio/btf_agreement.h).
#include <string>

#include <gtest/gtest.h>

#include "common/constants.h"
#include "sim/tracer.h"
#include "studies/species_study.h"
#include "tests/test_util.h"
#include "tests/virtual_gonio/btf_agreement.h"
#include "virtual_gonio/btf.h"
#include "virtual_gonio/direction_sets.h"

namespace plumage::studies {
namespace {

const std::filesystem::path kQuick =
    std::filesystem::path(PLUMAGE_SOURCE_DIR) / "studies" / "species_quick.toml";

// Fig. 9's view (30°, azimuth 0°) under three of its lights (30° at azimuth 0°, 90° and 180°,
// the last the specular pair), at the camera's three wavelengths, over 120 µm.
gonio::BtfConfig figure9_corner(int pixels) {
    gonio::BtfConfig c;
    const Vec3d view = gonio::direction_from_angles(30.0 * kDeg, 0.0);
    for (double phi : {0.0, 90.0, 180.0})
        c.pairs.push_back({gonio::direction_from_angles(30.0 * kDeg, phi * kDeg), view});
    c.wavelengths_nm = {450.0, 550.0, 650.0};
    c.patch_size_um = 120.0;
    c.pixels = pixels;
    c.aperture = gonio::Aperture::both_cones;
    c.detector_half_angle_rad = 10.0 * kDeg;
    return c;
}

void expect_agreement_on(const std::string& species, int pixels, std::uint64_t per_light,
                         std::uint64_t per_pixel, int min_dof, bool split_reflections = false,
                         bool split_aimed_reflections = false) {
    const SpeciesScene s = build_species_scene(testing::read_text_file(kQuick), kQuick, species,
                                               {450.0, 550.0, 650.0});
    const sim::ExplicitScatterer tracer(s.scene);
    gonio::BtfConfig c = figure9_corner(pixels);
    c.split_reflections = split_reflections;
    c.split_aimed_reflections = split_aimed_reflections;
    gonio::expect_estimators_agree(tracer, c, per_light, per_pixel, species, min_dof);
}

TEST(SpeciesBtf, DetectorAgreesWithForwardOnTheParrot) {
    expect_agreement_on("parrot", 4, 400000, 200000, 12);
}
TEST(SpeciesBtf, DetectorAgreesWithForwardOnTheRooster) {
    expect_agreement_on("rooster", 2, 2000000, 20000, 4);
}
// The species study's setting (species.toml: split_reflections = true) on the rooster's films.
TEST(SpeciesBtf, DetectorWithSplitReflectionsAgreesWithForwardOnTheRooster) {
    expect_agreement_on("rooster", 2, 2000000, 20000, 4, true);
}
TEST(SpeciesBtf, DetectorAgreesWithForwardOnTheFlamingo) {
    expect_agreement_on("flamingo", 4, 400000, 20000, 12);
}
// The species study's setting (species.toml: split_aimed_reflections = true) on the flamingo's
// pigmented keratin and the stork's clear keratin, whose partial reflections it splits.
TEST(SpeciesBtf, DetectorWithAimedReflectionsAgreesWithForwardOnTheFlamingo) {
    expect_agreement_on("flamingo", 4, 400000, 20000, 12, true, true);
}
TEST(SpeciesBtf, DetectorWithAimedReflectionsAgreesWithForwardOnTheStork) {
    expect_agreement_on("stork", 4, 400000, 20000, 12, true, true);
}
TEST(SpeciesBtf, DetectorAgreesWithForwardOnTheStork) {
    expect_agreement_on("stork", 4, 400000, 20000, 12);
}

}  // namespace
}  // namespace plumage::studies
