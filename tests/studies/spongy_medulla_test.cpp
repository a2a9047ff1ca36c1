// The parrot's spongy medulla, computed from its structure (studies/spongy_medium.h, sim/scene.h
// SpongyMedulla, the species study):
//  - the glue: a channel volume's first-Born medium at the wavelengths asked, exact there and
//    refused elsewhere; the voxel limit names file:line:col;
//  - the study file gives the spongy medulla structure keys only and refuses colour keys;
//  - energy: the parrot's barb patch made lossless (no melanin core, clear barbules) returns
//    every path with weight 1 at the shortest wavelengths (the strongest scattering) when the
//    tracer's max_events does not cut it; with the default bound the dropped share is
//    measured (the whole medulla is then optically thick), and the study's parrot loses
//    almost nothing;
//  - colour: the parrot's patch as the species study builds it is blue (CIELAB hue of its
//    albedo spectrum at normal incidence in the blue band, chroma far above a grey's 0 given
//    the Monte Carlo error), and so is the bare barb (the medulla's reflectance through the
//    cortex), whose peak wavelength is reported.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <sstream>

#include <fmt/format.h>

#include <gtest/gtest.h>

#include "common/error.h"
#include "common/seed.h"
#include "sim/albedo.h"
#include "sim/optics/colour.h"
#include "sim/optics/material.h"
#include "sim/optics/spectrum.h"
#include "sim/scatterer/period_cell_entry.h"
#include "sim/scatterer/random.h"
#include "sim/tracer.h"
#include "studies/species_study.h"
#include "studies/spongy_medium.h"
#include "studies/study_file.h"
#include "tests/test_util.h"

namespace plumage::studies {
namespace {

namespace fs = std::filesystem;

std::string read(const fs::path& p) {
    std::ifstream in(p);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

const fs::path kQuick = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "species_quick.toml";
const fs::path kFull = fs::path(PLUMAGE_SOURCE_DIR) / "studies" / "species.toml";

void replace_once(std::string& text, const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
}

// 1-based line of the first occurrence of `what`.
int line_of(const std::string& text, const std::string& what) {
    const auto at = text.find(what);
    return 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
}

TEST(SpongyMedium, BornMediumAtTheWavelengthsAskedAndNowhereElse) {
    SpongyMediumParams p;
    p.box_um = 1.6;  // 64³ voxels of 0.025 µm, as the quick study
    p.seed = 5;
    const SpongyMedium m = build_spongy_medium(p, {550.0, 450.0, 450.0, 650.0});
    ASSERT_EQ(m.wavelengths_nm, (std::vector<double>{450.0, 550.0, 650.0}));
    ASSERT_EQ(m.tables.size(), 3u);
    // The generated volume has the structure asked for (geometry/spongy_volume.h: Λ within
    // about 1 %, f exact to a voxel).
    EXPECT_NEAR(m.measured_scale_um, p.length_scale_um, 0.03 * p.length_scale_um);
    EXPECT_NEAR(m.measured_fraction, p.keratin_fraction, 1.0 / (64.0 * 64.0 * 64.0));
    for (const auto& t : m.tables) {
        SCOPED_TRACE(t.lambda_nm);
        EXPECT_EQ(m.medium->scattering_coefficient_per_um(t.lambda_nm), t.mu_s_per_um);
        EXPECT_EQ(m.medium->effective_index(t.lambda_nm), t.n_eff.real());
        EXPECT_EQ(t.mu_a_per_um, 0.0);  // keratin and air are lossless
        EXPECT_GT(t.n_eff.real(), 1.0);
        EXPECT_LT(t.n_eff.real(), optics::keratin()->index(t.lambda_nm).real());
    }
    // Short wavelengths meet the structure's spectral peak: μ_s falls towards the red.
    EXPECT_GT(m.tables[0].mu_s_per_um, 2.0 * m.tables[1].mu_s_per_um);
    EXPECT_GT(m.tables[1].mu_s_per_um, 2.0 * m.tables[2].mu_s_per_um);
    // Outside its tables the medium refuses (sim/scattering_medium.h).
    EXPECT_THROW(m.medium->active(440.0), InputError);
    // The voxel limit λ/(4 n_keratin) at the shortest wavelength.
    const double n400 = optics::keratin()->index(400.0).real();
    EXPECT_DOUBLE_EQ(finest_voxel_limit_um({700.0, 400.0}), 0.4 / (4.0 * n400));
    SpongyMediumParams bad = p;
    bad.keratin_fraction = 0.95;
    EXPECT_NE(testing::input_error_message([&] {
                  build_spongy_medium(bad, {450.0});
              }).find("keratin_fraction = 0.95"),
              std::string::npos);
    bad = p;
    bad.box_um = 1.61;
    EXPECT_THROW(build_spongy_medium(bad, {450.0}), InputError);
    EXPECT_THROW(build_spongy_medium(p, {}), InputError);
}

// Where first Born was validated against 3D full wave (route_check.csv): the channel network at
// keratin n = 1.55, f = 0.5, Λ = 0.19 µm, 400–700 nm, among others. A medium of that structure
// at 550 nm is inside; each departure is named, and a route with no passing structure (or a
// structure it never passed on) is outside whatever the numbers.
TEST(SpongyMedium, ValidatedRangeNamesEachDeparture) {
    const auto born = route_validated_cases("born");
    const auto channel = std::find_if(born.begin(), born.end(), [](const auto& v) {
        return v.structure == "channel" && v.keratin_index == 1.55;
    });
    ASSERT_NE(channel, born.end());
    // x = k0 n_eff Λ over 700…400 nm with Bruggeman's n_eff(1.55, air, f = 0.5)
    const double n_eff = channel->n_eff;
    EXPECT_NEAR(n_eff, 1.265, 0.005);
    EXPECT_NEAR(channel->size_parameter_lo, 2.0 * std::numbers::pi * n_eff * 0.19 / 0.7, 1e-9);
    EXPECT_NEAR(channel->size_parameter_hi, 2.0 * std::numbers::pi * n_eff * 0.19 / 0.4, 1e-9);
    EXPECT_EQ(outside_validated_range(born, "channel", 0.5, 0.19, 550.0, 1.56), "");
    EXPECT_EQ(outside_validated_range(born, "channel", 0.5, 0.19, 400.0, 1.55), "");  // its end
    const std::string fraction = outside_validated_range(born, "channel", 0.4, 0.19, 550.0, 1.55);
    EXPECT_NE(fraction.find("keratin fraction 0.40"), std::string::npos) << fraction;
    const std::string index = outside_validated_range(born, "channel", 0.5, 0.19, 550.0, 1.33);
    EXPECT_NE(index.find("keratin n 1.330"), std::string::npos) << index;
    const std::string size = outside_validated_range(born, "channel", 0.5, 0.19, 380.0, 1.55);
    EXPECT_NE(size.find("size parameter"), std::string::npos) << size;
    EXPECT_EQ(fraction.find("size parameter"), std::string::npos) << fraction;
    const std::string none = outside_validated_range({}, "channel", 0.5, 0.19, 550.0, 1.55);
    EXPECT_NE(none.find("not validated on channel networks"), std::string::npos) << none;
}

TEST(SpeciesSpongyMedulla, StudyFilesGiveStructureOnlyAndRefuseColourKeys) {
    for (const fs::path& path : {kQuick, kFull}) {
        SCOPED_TRACE(path.string());
        const std::string text = read(path);
        // The parrot's materials table, up to the next table.
        const auto start = text.find("[species.parrot.materials]");
        ASSERT_NE(start, std::string::npos);
        const std::string table = text.substr(start, text.find("\n[", start + 1) - start);
        EXPECT_NE(table.find("medulla = \"spongy\""), std::string::npos);
        EXPECT_NE(table.find("spongy_length_scale_um"), std::string::npos);
        EXPECT_NE(table.find("spongy_keratin_fraction"), std::string::npos);
        std::istringstream lines(table);
        for (std::string line; std::getline(lines, line);) {
            const std::string key = line.substr(0, line.find('='));
            for (const char* colour : {"albedo", "colour", "color", "band", "peak", "hue"}) {
                EXPECT_EQ(key.find(colour), std::string::npos) << line;
            }
        }
        check_species_study(text, path);  // and it reads
    }
    const std::string base = read(kQuick);
    auto message = [](const std::string& text) {
        return testing::input_error_message([&] { check_species_study(text, "bad.toml"); });
    };
    const std::string spongy_line = "medulla = \"spongy\"";
    for (const char* key : {"medulla_albedo = 0.9", "medulla_base_albedo = 0.04",
                            "spongy_band_width_nm = 30", "spongy_spacing_um = 0.184"}) {
        std::string text = base;
        replace_once(text, spongy_line, spongy_line + "\n" + key);
        const int line = line_of(text, key);
        const std::string m = message(text);
        const std::string name = std::string(key).substr(0, std::string(key).find(' '));
        EXPECT_NE(m.find(fmt::format("bad.toml:{}:", line)), std::string::npos) << m;
        EXPECT_NE(m.find(name), std::string::npos) << m;
        EXPECT_NE(m.find("takes no colour or albedo parameter"), std::string::npos) << m;
    }
    // Voxels too coarse for the shortest traced wavelength (450 nm: 0.072 µm); 0.08 µm keeps
    // Λ = 0.19 µm above two voxels and the 1.6 µm box a whole number of them.
    std::string coarse = base;
    replace_once(coarse, spongy_line, spongy_line + "\nspongy_voxel_um = 0.08");
    EXPECT_NE(message(coarse).find(fmt::format("bad.toml:{}:", line_of(coarse, "spongy_voxel_um"))),
              std::string::npos)
        << message(coarse);
    EXPECT_NE(message(coarse).find("lambda/(4 n_keratin)"), std::string::npos);
    // Structure keys belong to a spongy medulla only.
    std::string white = base;
    replace_once(white, "medulla_albedo = 0.8", "medulla_albedo = 0.8\nspongy_core_scale = 0.5");
    EXPECT_NE(message(white).find("applies only to medulla = \"spongy\""), std::string::npos)
        << message(white);
    std::string core = base;
    replace_once(core, "spongy_core_scale = 0.85", "spongy_core_scale = 1.0");
    EXPECT_NE(message(core).find("spongy_core_scale"), std::string::npos) << message(core);
}

// Lossless: keratin and air only (Cauchy keratin, k = 0; μ_a = 0), no melanin core, clear
// barbules. With no bound on a path's events every path must leave with weight exactly 1
// (weighted absorption sampling multiplies by ω = μ_s/μ_t = 1; Fresnel events choose, they do
// not weight). The whole 70 µm medulla is then optically thick at 400 nm (μ_s ≈ 0.6 µm⁻¹),
// and with the tracer's default max_events (1000) some paths are dropped: the test measures
// that loss, and that of the study's parrot (melanin core at 0.85: a 5–6 µm shell).
TEST(SpeciesSpongyMedulla, LosslessParrotBarbConservesEnergyPerPath) {
    const std::string quick = read(kQuick);
    std::string text = quick;
    replace_once(text, "spongy_core_scale = 0.85", "spongy_core_scale = 0");
    replace_once(text, "barbule_core = \"melanin\"\ncortex_film_um = 1.0\ncortex_coherent = false",
                 "barbule_core = \"keratin\"");
    replace_once(text, "run = \"parrot, rooster, flamingo, stork\"", "run = \"parrot\"");
    const SpeciesScene s = build_species_scene(text, kQuick, "parrot", {400.0});
    ASSERT_TRUE(s.spongy_medium);
    sim::TracerOptions unbounded;
    unbounded.max_events = 1'000'000;
    const sim::ExplicitScatterer tracer(s.scene, unbounded), bounded(s.scene);
    std::string parrot_text = quick;
    replace_once(parrot_text, "run = \"parrot, rooster, flamingo, stork\"", "run = \"parrot\"");
    const sim::ExplicitScatterer parrot(
        build_species_scene(parrot_text, kQuick, "parrot", {400.0}).scene);
    const PeriodCellEntry cell(std::make_shared<const sim::ExplicitScatterer>(s.scene), s.cell_x_um,
                               s.cell_y_um, s.cell_y0_um);
    constexpr int kPaths = 3000;
    for (const double lambda : {400.0, 450.0}) {
        SCOPED_TRACE(lambda);
        int scattered = 0, most_scatters = 0, dropped = 0, parrot_dropped = 0, mismatched = 0;
        int guided = 0;
        double up = 0.0;
        for (int i = 0; i < kPaths; ++i) {
            const auto stream = derive_seed(7, "spongy_medulla_test/energy");
            Rng rng(stream, static_cast<std::uint64_t>(i));
            const Vec2 entry = cell.draw_entry(rng);
            Rng rng_bounded = rng, rng_parrot = rng;
            const sim::PathResult path = tracer.trace({0.0, 0.0, 1.0}, lambda, entry, rng);
            // A lossless barbule fibre (the clear keratin core here) is a light guide too: a skew
            // ray on a whispering-gallery orbit of its elliptical section, reflected totally at
            // its flat end faces as well, never leaves, whatever the bound on events. Such a
            // path never meets the medium; it is counted, not lost (bounded below).
            if (!path.event && path.reached_max_events && path.medium_scatters == 0) {
                ++guided;
                Rng skip = rng_bounded;
                dropped += bounded.trace({0.0, 0.0, 1.0}, lambda, entry, skip).reached_max_events;
                continue;
            }
            ASSERT_TRUE(path.event.has_value())
                << "path " << i << " lost: events " << path.events << ", scatters "
                << path.medium_scatters << ", max events " << path.reached_max_events
                << ", roulette " << path.ended_by_roulette;
            ASSERT_NEAR(path.event->weight, 1.0, 1e-12) << "path " << i;
            mismatched += path.medium_mismatches > 0;
            scattered += path.medium_scatters > 0;
            most_scatters = std::max(most_scatters, path.medium_scatters);
            up += path.event->wo.z() > 0.0 ? 1.0 : 0.0;
            dropped +=
                bounded.trace({0.0, 0.0, 1.0}, lambda, entry, rng_bounded).reached_max_events;
            parrot_dropped +=
                parrot.trace({0.0, 0.0, 1.0}, lambda, entry, rng_parrot).reached_max_events;
        }
        // The medulla is reached and scatters (the barb covers a third of the cell); paths
        // meeting a surface from the side they did not travel in stay rare (see the colour
        // test below: a collision within ~1e-5 µm of the medulla surface).
        EXPECT_GT(scattered, kPaths / 10);
        EXPECT_LE(mismatched, kPaths / 1000);
        // The default bound drops the lossless barb's longest diffusion paths: measured 11 and
        // 4 of 3000 at 400 and 450 nm (0.4 %, 0.1 % of the power); bounded here at 1 %. The
        // study's parrot (a 5–6 µm shell around the core) needs few scatterings, but its cortex
        // wall is a light guide: keratin between air (TIR above 40°) and n_eff ≈ 1.27 (above
        // 55°) keeps skew rays of the smooth elliptical tube bouncing along the barb, as a
        // faceted sphere traps rays in tracer_test.cpp; measured 1 of 3000 at each
        // wavelength, bounded at 1 in 1000.
        EXPECT_LT(dropped, kPaths / 100);
        EXPECT_LE(parrot_dropped, kPaths / 1000);
        EXPECT_LE(guided, kPaths / 1000);  // measured 0 and 1 of 3000 (400, 450 nm)
        RecordProperty("most_medium_scatters_" + std::to_string(static_cast<int>(lambda)),
                       most_scatters);
        std::cout << lambda << " nm: " << scattered << " of " << kPaths
                  << " paths scattered in the medulla, at most " << most_scatters
                  << " scatterings on a path; reflected " << up / kPaths << "; with max_events "
                  << bounded.options().max_events << " " << dropped
                  << " dropped (lossless, no core), " << parrot_dropped << " (the parrot); "
                  << guided << " guided by a barbule for 10^6 events\n";
    }
}

struct Colour {
    double hue_deg = 0.0, chroma = 0.0, hue_sigma = 0.0, chroma_sigma = 0.0;
    std::array<int, 3> srgb8{};
};

// CIELAB (D65, CIE 1931 2°) of a reflectance spectrum, with the spread of hue and chroma over
// parametric bootstrap replicates R_k + σ_k z_k (as the spongy study's peak).
Colour colour_of(const std::vector<double>& wl, const std::vector<double>& r,
                 const std::vector<double>& se) {
    const optics::ReflectanceToXyz to_xyz(optics::WavelengthGrid(wl), optics::Illuminant::d65);
    auto lab = [&](const std::vector<double>& x) {
        return optics::lab_from_xyz(to_xyz(x), to_xyz.white());
    };
    Colour c;
    const optics::Lab l = lab(r);
    c.hue_deg = optics::hue_angle_deg(l);
    c.chroma = optics::chroma(l);
    const optics::Rgb rgb = optics::linear_srgb_from_xyz(to_xyz(r));
    for (std::size_t k = 0; k < 3; ++k)
        c.srgb8[k] = static_cast<int>(std::lround(255.0 * optics::srgb_encode(rgb[k])));
    Rng rng(derive_seed(11, "spongy_medulla_test/bootstrap"), 0);
    double sh = 0.0, shh = 0.0, sc = 0.0, scc = 0.0;
    constexpr int kReplicates = 400;
    std::vector<double> x(r.size());
    for (int b = 0; b < kReplicates; ++b) {
        for (std::size_t k = 0; k < r.size(); ++k) {
            const double u1 = 1.0 - rng.uniform(), u2 = rng.uniform();
            x[k] = r[k] +
                   se[k] * std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
        }
        const optics::Lab lb = lab(x);
        const double h = optics::hue_angle_deg(lb), ch = optics::chroma(lb);
        sh += h;
        shh += h * h;
        sc += ch;
        scc += ch * ch;
    }
    c.hue_sigma = std::sqrt(std::max(0.0, shh / kReplicates - std::pow(sh / kReplicates, 2)));
    c.chroma_sigma = std::sqrt(std::max(0.0, scc / kReplicates - std::pow(sc / kReplicates, 2)));
    return c;
}

// The spongy study's CIELAB "blue" band (studies/spongy_study.cpp hue_name): 225° <= h < 290°
// (cyan/teal below, violet above; sRGB's blue primary is at 306°).
constexpr double kBlueFrom = 225.0, kBlueTo = 290.0;

TEST(SpeciesSpongyMedulla, ParrotIsBlueFromTheMediumAlone) {
    std::string text = read(kQuick);
    replace_once(text, "run = \"parrot, rooster, flamingo, stork\"", "run = \"parrot\"");
    std::vector<double> wl;
    for (double l = 400.0; l <= 700.0 + 1e-9; l += 20.0) wl.push_back(l);
    const SpeciesScene s = build_species_scene(text, kQuick, "parrot", wl);
    // A grey (flat) spectrum has chroma 0 on this grid: the reference the blue stands against.
    EXPECT_LT(
        colour_of(wl, std::vector<double>(wl.size(), 0.2), std::vector<double>(wl.size(), 0.0))
            .chroma,
        1e-9);

    // The barb without barbules: the medulla seen through the cortex, lit over the barb's
    // central half.
    sim::SceneDescription bare = s.scene;
    bare.instances.erase(std::remove_if(bare.instances.begin(), bare.instances.end(),
                                        [](const sim::Instance& i) { return i.unit != 0; }),
                         bare.instances.end());
    struct Case {
        const char* name;
        std::shared_ptr<const sim::ExplicitScatterer> tracer;
        double cell_y;
        std::uint64_t quanta;
    };
    const Case cases[] = {
        {"patch", std::make_shared<const sim::ExplicitScatterer>(s.scene), s.cell_y_um, 40000},
        {"bare barb", std::make_shared<const sim::ExplicitScatterer>(bare), 0.5 * s.barb_width_um,
         40000},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        const PeriodCellEntry cell(c.tracer, s.cell_x_um, c.cell_y, s.cell_y0_um);
        std::vector<double> r, se;
        for (std::size_t k = 0; k < wl.size(); ++k) {
            const sim::AlbedoEstimate e = sim::measure_albedo(
                *c.tracer, cell, {0.0, 0.0, 1.0}, wl[k], c.quanta,
                derive_seed(3, std::string("spongy_medulla_test/") + c.name, k));
            r.push_back(e.albedo);
            se.push_back(e.standard_error);
            // A scattering point within ~1e-5 µm of the medulla surface can land on its far
            // side (sim/tracer.cpp moves the origin to the collision without the spawn
            // offset), and the next segment then starts on the wrong side: measured 2.5e-5 to
            // 1.25e-4 of the paths; a 1e-3 bound keeps it a rarity.
            EXPECT_LT(e.mismatched_paths, 1e-3);
        }
        const Colour col = colour_of(wl, r, se);
        const std::size_t peak =
            static_cast<std::size_t>(std::max_element(r.begin(), r.end()) - r.begin());
        std::string spectrum;
        for (std::size_t k = 0; k < wl.size(); ++k)
            spectrum += fmt::format(" {:.0f}:{:.4f}±{:.4f}", wl[k], r[k], se[k]);
        std::cout << c.name << ": hue " << col.hue_deg << " ± " << col.hue_sigma << " deg, chroma "
                  << col.chroma << " ± " << col.chroma_sigma << ", sRGB "
                  << fmt::format("#{:02x}{:02x}{:02x}", col.srgb8[0], col.srgb8[1], col.srgb8[2])
                  << ", largest albedo at " << wl[peak] << " nm\n  albedo" << spectrum << "\n";
        RecordProperty(std::string(c.name) + "_hue_deg", std::to_string(col.hue_deg));
        RecordProperty(std::string(c.name) + "_chroma", std::to_string(col.chroma));
        // Blue: the hue's 4σ interval inside the band; the chroma 10σ above a grey's 0 and
        // above 10 CIELAB units (several just-noticeable differences, ΔE ≈ 2.3 each).
        EXPECT_GE(col.hue_deg - 4.0 * col.hue_sigma, kBlueFrom);
        EXPECT_LT(col.hue_deg + 4.0 * col.hue_sigma, kBlueTo);
        EXPECT_GT(col.chroma, 10.0 * col.chroma_sigma);
        EXPECT_GT(col.chroma, 10.0);
    }
}

}  // namespace
}  // namespace plumage::studies
