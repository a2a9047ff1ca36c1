#include "studies/spongy_medium.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "common/error.h"
#include "geometry/spongy_volume.h"
#include "sim/wave/volume/effective_index.h"
#include "sim/wave/volume/index_field.h"
#include "sim/wave/volume/power_spectrum.h"
#include "sim/wave/volume/structure_factor.h"
#include "studies/spongy_reference.h"  // generated: the routes against 3D full wave
#include "studies/study_file.h"
#include "studies/text_files.h"

namespace plumage::studies {
namespace {

// Keratin's published dispersion range (sim/optics/material.h).
constexpr double kMinLambdaNm = 300.0, kMaxLambdaNm = 1000.0;

std::vector<double> sorted_wavelengths(const std::vector<double>& wavelengths_nm) {
    if (wavelengths_nm.empty()) {
        throw InputError("spongy medium: no wavelengths: expected at least one");
    }
    for (const double l : wavelengths_nm) {
        if (!std::isfinite(l) || l < kMinLambdaNm || l > kMaxLambdaNm) {
            throw InputError(fmt::format(
                "spongy medium: wavelength {} nm: expected a finite value in [{}, {}] nm", l,
                kMinLambdaNm, kMaxLambdaNm));
        }
    }
    std::vector<double> out = wavelengths_nm;
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

void validate_spheres(const SpongyMediumParams& p) {
    if (!std::isfinite(p.sphere_radius_um) || !(p.sphere_radius_um > p.voxel_um) ||
        p.sphere_radius_um > p.box_um / 4.0) {
        throw InputError(fmt::format(
            "spongy medium: sphere_radius_um = {}: expected above one voxel ({} um) and at most a "
            "quarter of the box ({} um)",
            p.sphere_radius_um, p.voxel_um, p.box_um / 4.0));
    }
    if (!std::isfinite(p.min_separation_diameters) || !(p.min_separation_diameters > 0.0) ||
        p.min_separation_diameters > 2.0) {
        throw InputError(
            fmt::format("spongy medium: min_separation_diameters = {}: expected a value in (0, 2]",
                        p.min_separation_diameters));
    }
}

}  // namespace

geometry::SpongyVolume make_spongy_volume(const SpongyMediumParams& params) {
    params.validate();
    if (params.morphology == geometry::SpongyMorphology::sphere) {
        geometry::SphereVolumeParams p;
        p.sphere_radius_um = params.sphere_radius_um;
        p.min_separation_diameters = params.min_separation_diameters;
        p.keratin_fraction = params.keratin_fraction;
        p.box_um = params.box_um;
        p.voxel_um = params.voxel_um;
        p.seed = params.seed;
        return geometry::make_sphere_volume(p);
    }
    geometry::ChannelVolumeParams p;
    p.length_scale_um = params.length_scale_um;
    p.shell_relative_width = params.shell_relative_width;
    p.keratin_fraction = params.keratin_fraction;
    p.box_um = params.box_um;
    p.voxel_um = params.voxel_um;
    p.seed = params.seed;
    return geometry::make_channel_volume(p);
}

namespace {

// The sphere route on a packing's centres: S(q) measured in the box up to beyond the largest
// 2 k0 n (keratin's n bounds n_eff), then Mie × S(q) at every wavelength.
void add_sphere_route(const SpongyMediumParams& params, const geometry::SpongyVolume& volume,
                      SpongyMedium& out) {
    const double a = params.sphere_radius_um, box = volume.box_um;
    const auto& centres = volume.air_sphere_centres_um;
    out.sphere_fraction = static_cast<double>(centres.size()) * 4.0 * std::numbers::pi / 3.0 * a *
                          a * a / (box * box * box);
    double q_max = 0.0;
    for (const double lambda : out.wavelengths_nm) {
        q_max = std::max(
            q_max, 4.0 * std::numbers::pi * params.keratin->index(lambda).real() / (lambda * 1e-3));
    }
    const sim::wave::MeasuredStructureFactor sq =
        sim::wave::measure_structure_factor(centres, box, q_max + 2.0 * std::numbers::pi / box);
    auto structure = [&sq](double q) { return sq.at(q); };
    const double density = static_cast<double>(centres.size()) / (box * box * box);
    std::vector<sim::MediumTable> tables;
    for (const double lambda : out.wavelengths_nm) {
        out.sphere_tables.push_back(sim::wave::sphere_medium(a, density, *optics::air(),
                                                             *params.keratin, structure, lambda));
        tables.push_back(sim::medium_table(out.sphere_tables.back()));
    }
    out.sphere_medium = std::make_shared<const sim::ScatteringMedium>(
        std::move(tables), sim::AbsorptionSampling::weighted,
        fmt::format("sphere route a={}um phi={:.3f}", a, out.sphere_fraction));
}

}  // namespace

RouteRefusal sphere_route_refusal(const SpongyMediumParams& params, double polydispersity) {
    if (params.morphology != geometry::SpongyMorphology::sphere) {
        return {"morphology",
                "\"channel\": a channel network is not a sphere packing; the sphere route "
                "(Mie x S(q)) needs \"spheres\""};
    }
    if (params.min_separation_diameters < 1.0) {
        return {"min_separation_diameters",
                fmt::format("{}: the spheres overlap, so the volume is not a packing of separate "
                            "spheres; the sphere route needs at least 1 (disjoint spheres)",
                            params.min_separation_diameters)};
    }
    const double phi = 1.0 - params.keratin_fraction;
    if (!(phi > 0.0 && phi <= kSphereRouteMaxFraction)) {
        return {"keratin_fraction",
                fmt::format("{} (air-sphere fraction phi = {:.3g}): the sphere route "
                            "needs phi in (0, {}], keratin fractions >= {} (random sequential "
                            "addition of disjoint spheres jams near phi = 0.38)",
                            params.keratin_fraction, phi, kSphereRouteMaxFraction,
                            1.0 - kSphereRouteMaxFraction)};
    }
    if (polydispersity != 0.0) {
        return {"polydispersity",
                fmt::format("{}: the sphere route accepts 0 only (the generated packings and "
                            "the route's single Mie term are monodisperse)",
                            polydispersity)};
    }
    return {};
}

void SpongyMediumParams::validate() const {
    if (!keratin) throw InputError("spongy medium: keratin material is null: expected one");
    if (!std::isfinite(voxel_um) || !(voxel_um > 0.0)) {
        throw InputError(
            fmt::format("spongy medium: voxel_um = {}: expected finite and > 0", voxel_um));
    }
    const double n = box_um / voxel_um;
    if (!std::isfinite(n) || std::abs(n - std::round(n)) > 1e-6 * n || n < 4 || n > 512) {
        throw InputError(fmt::format(
            "spongy medium: box_um = {}: expected a whole number of voxels ({} um), 4 to 512 "
            "per side; it is {:.4f}",
            box_um, voxel_um, n));
    }
    if (!std::isfinite(keratin_fraction) || keratin_fraction < 0.1 || keratin_fraction > 0.9) {
        throw InputError(
            fmt::format("spongy medium: keratin_fraction = {}: expected a value in [0.1, 0.9]",
                        keratin_fraction));
    }
    if (morphology == geometry::SpongyMorphology::sphere) {
        validate_spheres(*this);
        return;
    }
    if (!std::isfinite(length_scale_um) || !(length_scale_um > 2.0 * voxel_um) ||
        length_scale_um > box_um / 4.0) {
        throw InputError(fmt::format(
            "spongy medium: length_scale_um = {}: expected above 2 voxels ({} um) and at most a "
            "quarter of the box ({} um)",
            length_scale_um, 2.0 * voxel_um, box_um / 4.0));
    }
    if (!std::isfinite(shell_relative_width) || !(shell_relative_width > 0.0) ||
        shell_relative_width > 1.0) {
        throw InputError(
            fmt::format("spongy medium: shell_relative_width = {}: expected a value in (0, 1]",
                        shell_relative_width));
    }
}

double finest_voxel_limit_um(const std::vector<double>& wavelengths_nm,
                             const optics::Material& keratin) {
    double limit = std::numeric_limits<double>::infinity();
    for (const double lambda : sorted_wavelengths(wavelengths_nm)) {
        limit = std::min(limit, lambda * 1e-3 / (4.0 * keratin.index(lambda).real()));
    }
    return limit;
}

void require_fine_voxels(ParameterTable& table, std::string_view key, double voxel_um,
                         const std::vector<double>& wavelengths_nm,
                         const optics::Material& keratin) {
    for (const double lambda : sorted_wavelengths(wavelengths_nm)) {
        const double n = keratin.index(lambda).real();
        const double limit_um = lambda * 1e-3 / (4.0 * n);
        if (voxel_um > limit_um) {
            throw InputError(fmt::format(
                "{}: {}.{} = {}: voxels coarser than lambda/(4 n_keratin) = {} nm / (4 x {:.4f}) "
                "= {:.4f} um at the shortest wavelength traced; the grid would not resolve "
                "backscattering (sim/wave/volume/index_field.h)",
                table.location(key), table.path(), key, voxel_um, lambda, n, limit_um));
        }
    }
}

SpongyMedium build_spongy_medium(const SpongyMediumParams& params,
                                 const std::vector<double>& wavelengths_nm, std::string name) {
    params.validate();
    SpongyMedium out;
    out.wavelengths_nm = sorted_wavelengths(wavelengths_nm);
    const geometry::SpongyVolume volume = make_spongy_volume(params);
    const sim::wave::IndicatorField field = sim::wave::sample_indicator(*volume.level_set);
    const auto spectrum = sim::wave::PowerSpectrum::measure_3d(
        field.as_doubles(), field.voxels_per_side, field.voxel_um);
    const sim::wave::RadialSpectrum radial = spectrum.radial();
    out.measured_fraction = field.filling_fraction();
    out.measured_scale_um = 2.0 * std::numbers::pi / radial.peak_q_per_um;
    out.isotropy = radial.isotropy_eigenvalue_ratio;
    std::vector<sim::MediumTable> tables;
    for (const double lambda : out.wavelengths_nm) {
        out.tables.push_back(
            sim::wave::born_medium(spectrum, *params.keratin, *optics::air(), lambda));
        tables.push_back(sim::medium_table(out.tables.back()));
    }
    if (name.empty()) {
        name = params.morphology == geometry::SpongyMorphology::sphere
                   ? fmt::format("spongy spheres f={} a={}um", params.keratin_fraction,
                                 params.sphere_radius_um)
                   : fmt::format("spongy f={} L={}um", params.keratin_fraction,
                                 params.length_scale_um);
    }
    if (sphere_route_refusal(params, 0.0).reason.empty()) add_sphere_route(params, volume, out);
    out.medium = std::make_shared<const sim::ScatteringMedium>(
        std::move(tables), sim::AbsorptionSampling::weighted, std::move(name));
    return out;
}

double spongy_band_tolerance(double keratin_index) { return keratin_index >= 1.5 ? 0.15 : 0.10; }

std::string RouteFullWaveCheck::verdict() const {
    if (!passes) return "misses";
    return validated() ? "passes" : "within its floors only";
}

std::vector<RouteFullWaveCheck> routes_against_full_wave() {
    const auto rows = embedded_csv_rows(kSpongyRouteCheck);
    std::vector<RouteFullWaveCheck> out;
    for (std::size_t i = 1; i < rows.size(); ++i) {
        const auto& r = rows[i];
        if (r.size() != 15)
            throw InvariantError(
                fmt::format("spongy route check: row {} has {} cells, not 15", i + 1, r.size()));
        auto it = std::find_if(out.begin(), out.end(), [&](const RouteFullWaveCheck& e) {
            return e.structure == r[0] && e.keratin_index == r[1] && e.route == r[2];
        });
        if (it == out.end()) {
            out.push_back({r[0], r[1], r[2], r[3], std::stod(r[4]), std::stod(r[5]),
                           std::stod(r[14]), r[6] == "1", 0, "", 0.0, 0.0, std::stod(r[13])});
            it = out.end() - 1;
        }
        const double d = std::stod(r[11]), floor = std::stod(r[12]);
        if (floor <= spongy_band_tolerance(std::stod(r[1]))) ++it->decided_bands;
        if (it->worst_band.empty() || std::abs(d) > std::abs(it->worst_difference)) {
            it->worst_difference = d;
            it->worst_floor = std::stod(r[12]);
            it->worst_band = r[7] + "–" + r[8];
        }
    }
    return out;
}

std::vector<SpongyReferenceStructure> spongy_reference_structures() {
    return {{"channel", 0.5, 0.19, "Λ"},
            {"air_spheres", 0.5, 0.1, "a"},
            {"keratin_spheres", 0.5, 0.1, "a"}};
}

double spongy_size_parameter(double lambda_nm, double n_eff, double length_um) {
    return 2.0 * std::numbers::pi * n_eff * length_um / (lambda_nm * 1e-3);
}

std::vector<RouteValidatedCase> route_validated_cases(const std::string& route) {
    // The reference's wavelength range: its bands' ends (route_check.csv).
    const auto rows = embedded_csv_rows(kSpongyRouteCheck);
    double lambda_lo = std::numeric_limits<double>::infinity(), lambda_hi = 0.0;
    for (std::size_t i = 1; i < rows.size(); ++i) {
        lambda_lo = std::min(lambda_lo, std::stod(rows[i][7]));
        lambda_hi = std::max(lambda_hi, std::stod(rows[i][8]));
    }
    std::vector<RouteValidatedCase> out;
    for (const RouteFullWaveCheck& c : routes_against_full_wave()) {
        if (c.route != route || !c.validated()) continue;
        for (const SpongyReferenceStructure& r : spongy_reference_structures()) {
            if (r.name != c.structure) continue;
            const double n = std::stod(c.keratin_index);
            const double n_eff =
                sim::wave::bruggeman_index({n, 0.0}, {1.0, 0.0}, r.keratin_fraction).real();
            out.push_back({c.structure, n, r.keratin_fraction, r.length_um,
                           std::string(r.length_name), n_eff,
                           spongy_size_parameter(lambda_hi, n_eff, r.length_um),
                           spongy_size_parameter(lambda_lo, n_eff, r.length_um)});
        }
    }
    return out;
}

std::string outside_validated_range(const std::vector<RouteValidatedCase>& validated,
                                    std::string_view structure, double keratin_fraction,
                                    double length_um, double lambda_nm, double keratin_index) {
    const RouteValidatedCase* nearest = nullptr;
    for (const RouteValidatedCase& v : validated)
        if (v.structure == structure &&
            (nearest == nullptr || std::abs(v.keratin_index - keratin_index) <
                                       std::abs(nearest->keratin_index - keratin_index)))
            nearest = &v;
    if (nearest == nullptr)
        return fmt::format("the route is not validated on {}", spongy_structure_label(structure));
    std::string out;
    const auto add = [&out](const std::string& reason) {
        out += (out.empty() ? "" : "; ") + reason;
    };
    if (std::abs(keratin_fraction - nearest->keratin_fraction) > 0.02)
        add(fmt::format("keratin fraction {:.2f} against the validated {}", keratin_fraction,
                        nearest->keratin_fraction));
    if (std::abs(keratin_index - nearest->keratin_index) > 0.05)
        add(fmt::format("keratin n {:.3f} against the validated {}", keratin_index,
                        nearest->keratin_index));
    const double x = spongy_size_parameter(lambda_nm, nearest->n_eff, length_um);
    // a relative 1e-9: the validated range's own ends are inside
    if (x < nearest->size_parameter_lo * (1.0 - 1e-9) ||
        x > nearest->size_parameter_hi * (1.0 + 1e-9))
        add(fmt::format("size parameter {:.2f} at {:.0f} nm outside the validated {:.2f}–{:.2f}", x,
                        lambda_nm, nearest->size_parameter_lo, nearest->size_parameter_hi));
    return out;
}

std::string spongy_structure_label(std::string_view structure) {
    if (structure == "channel") return "channel networks";
    if (structure == "air_spheres") return "air spheres in keratin";
    if (structure == "keratin_spheres") return "keratin spheres in air";
    return std::string(structure);
}

std::string spongy_route_label(const std::string& route) {
    if (route == "born") return "first Born";
    if (route == "sphere") return "sphere (Mie x S(q))";
    if (route == "strong_keratin_host") return "strong contrast, keratin host";
    if (route == "strong_air_host") return "strong contrast, air host";
    if (route == "strong_self_consistent") return "strong contrast, self-consistent";
    return route;
}

std::string routes_against_full_wave_text(MediumRoute route, std::string_view structure) {
    const std::string mine = route == MediumRoute::sphere ? "sphere" : "born";
    std::string t =
        "## The routes against 3D full wave\n\n"
        "Each route on the structures of the suite's 3D full-wave reference "
        "(tests/reference/spongy_3d: 2 µm slabs, periodic over 1.2 µm, of channel-type volumes "
        "at f = 0.5 and Λ = 0.19 µm and of hard-sphere packings at φ = 0.5 with diameter 0.2 "
        "µm, air spheres in keratin and keratin spheres in air; keratin a constant n; several "
        "realisations each; full wave by the suite's Meep level). Compared: the diffuse "
        "(non-specular) reflectance at normal incidence, the part the medium decides; passes = "
        "its peak within 10 nm and every 50-nm band mean within 15 % (10 % at n < 1.5), each "
        "beyond its floor, and at least one band's floor within that tolerance (else: within "
        "its floors only, a comparison that could not have seen a miss): for a band, three "
        "standard errors of realisation and Monte Carlo noise, full wave's grid difference and "
        "the power its run left unaccounted for; for the peak, three jackknife standard errors "
        "over the realisations (a single 1.2 µm period's spectrum jumps from one wavelength to "
        "the next, so a flat spectrum's peak is poorly fixed). The specular part is the slab's "
        "faces (coherent fringes in full wave, "
        "incoherent here) and is not what the route is about. The strong-contrast rows resum "
        "first Born to all orders in the contrast at the two-point level "
        "(sim/wave/volume/strong_contrast.h), with keratin or air as the expansion's host or "
        "self-consistently (Bruggeman's medium as host, first Born's weak-contrast limit). No "
        "study uses them: where first Born misses (keratin spheres in air, not a feather's "
        "structure) only the keratin-host form passes, it misses the channel network, and no "
        "rule known before the comparison picks the host. The reference's own limit: one normal "
        "incidence on one 1.2 µm period reflects into a few dozen diffraction orders, which see "
        "the sample's spectrum near the z axis rather than the isotropic medium the routes "
        "describe; computed at first Born this sampling bias is as large as the differences "
        "judged, and at keratin n = 1.10 it is the whole of first Born's miss on the channel "
        "network (tests/reference/spongy_3d/README.md). At n = 1.10 the floors are 63–330 % "
        "(three realisations scatter, and runs whose field never decays leave power "
        "unaccounted for), so no route's pass there can be told from a miss. The verdicts are "
        "the raw comparison.\n\n"
        "| structure | keratin n | route | realisations | diffuse-R peak nm, full wave / route "
        "(floor) | worst band nm: difference (floor) | verdict |\n|---|---|---|---|---|---|---|\n";
    for (const RouteFullWaveCheck& e : routes_against_full_wave()) {
        if (!structure.empty() && e.structure != structure) continue;
        t += fmt::format(
            "| {} | {} | {}{} | {} | {:.0f} / {:.0f} ({:.0f}) | {}: {:+.0f} % ({:.0f} %) | {} "
            "|\n",
            e.structure, e.keratin_index, spongy_route_label(e.route),
            e.route == mine ? " (this study's)" : "", e.realisations, e.full_wave_peak_nm,
            e.route_peak_nm, e.peak_floor_nm, e.worst_band, 100.0 * e.worst_difference,
            100.0 * e.worst_floor, e.validated() ? "**passes**" : e.verdict());
    }
    return t + "\n";
}

}  // namespace plumage::studies
