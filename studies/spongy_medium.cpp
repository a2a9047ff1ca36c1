#include "studies/spongy_medium.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "common/error.h"
#include "geometry/spongy_volume.h"
#include "sim/wave/index_field.h"
#include "sim/wave/power_spectrum.h"
#include "studies/study_file.h"

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

}  // namespace

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
                "backscattering (sim/wave/index_field.h)",
                table.location(key), table.path(), key, voxel_um, lambda, n, limit_um));
        }
    }
}

SpongyMedium build_spongy_medium(const SpongyMediumParams& params,
                                 const std::vector<double>& wavelengths_nm, std::string name) {
    params.validate();
    SpongyMedium out;
    out.wavelengths_nm = sorted_wavelengths(wavelengths_nm);
    geometry::ChannelVolumeParams p;
    p.length_scale_um = params.length_scale_um;
    p.shell_relative_width = params.shell_relative_width;
    p.keratin_fraction = params.keratin_fraction;
    p.box_um = params.box_um;
    p.voxel_um = params.voxel_um;
    p.seed = params.seed;
    const geometry::SpongyVolume volume = geometry::make_channel_volume(p);
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
        name = fmt::format("spongy f={} L={}um", params.keratin_fraction, params.length_scale_um);
    }
    out.medium = std::make_shared<const sim::ScatteringMedium>(
        std::move(tables), sim::AbsorptionSampling::weighted, std::move(name));
    return out;
}

}  // namespace plumage::studies
