// Keratin indicator and permittivity contrast on the voxel grid (conventions in the
// header).
//
// Parameter table:
//  | name       | unit | valid range                                                |
//  |------------|------|------------------------------------------------------------|
//  | level_set  | —    | FloatGrid with plumage_voxels_per_side in [4, 512] and     |
//  |            |      | plumage_voxel_um > 0 metadata (geometry/spongy_volume.h)   |
//  | lambda_nm  | nm   | finite, > 0, in the materials' range                       |
//  | voxel_um   | µm   | <= λ / (4 n_max) (λ converted to µm)                       |
#include "sim/wave/volume/index_field.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/error.h"
#include "sim/wave/volume/effective_index.h"

namespace plumage::sim::wave {

double IndicatorField::filling_fraction() const {
    std::size_t count = 0;
    for (std::uint8_t v : keratin) count += v;
    return keratin.empty() ? 0.0 : static_cast<double>(count) / static_cast<double>(keratin.size());
}

std::vector<double> IndicatorField::as_doubles() const {
    return std::vector<double>(keratin.begin(), keratin.end());
}

IndicatorField sample_indicator(const openvdb::FloatGrid& level_set) {
    const auto n = level_set.getMetadata<openvdb::Int64Metadata>("plumage_voxels_per_side");
    const auto h = level_set.getMetadata<openvdb::DoubleMetadata>("plumage_voxel_um");
    if (!n || n->value() < 4 || n->value() > 512 || !h || !(h->value() > 0.0)) {
        throw InputError(fmt::format(
            "index field: level set '{}' has no valid plumage_voxels_per_side (4 to 512) and "
            "plumage_voxel_um (> 0) metadata: expected a volume written by make_channel_volume "
            "or make_sphere_volume; a grid from elsewhere needs both (Int64 and Double "
            "metadata): its periodic sample is taken as the index voxels [0, N)^3, N = "
            "plumage_voxels_per_side, of side plumage_voxel_um um",
            level_set.getName()));
    }
    IndicatorField field;
    field.voxels_per_side = static_cast<int>(n->value());
    field.voxel_um = h->value();
    const int nn = field.voxels_per_side;
    field.keratin.resize(static_cast<std::size_t>(nn) * nn * nn);
    auto accessor = level_set.getConstAccessor();
    std::size_t p = 0;
    for (int i = 0; i < nn; ++i) {
        for (int j = 0; j < nn; ++j) {
            for (int k = 0; k < nn; ++k) {
                field.keratin[p++] = accessor.getValue(openvdb::Coord(i, j, k)) < 0.0f ? 1 : 0;
            }
        }
    }
    return field;
}

void require_resolved(double voxel_um, double lambda_nm, double n_max) {
    const double limit_um = lambda_nm * 1e-3 / (4.0 * n_max);
    if (!(voxel_um <= limit_um)) {
        throw InputError(fmt::format(
            "wave medium: voxel_um = {} um is too coarse for lambda = {} nm: expected voxel_um "
            "<= lambda / (4 n_max) = {:.6g} um (n_max = {:.6g}), so that the grid's wavenumbers "
            "reach the backscattering q = 2 k n",
            voxel_um, lambda_nm, limit_um, n_max));
    }
}

ContrastField index_contrast(const IndicatorField& field, const optics::Material& keratin,
                             const optics::Material& air, double lambda_nm) {
    if (!(std::isfinite(lambda_nm) && lambda_nm > 0.0)) {
        throw InputError(fmt::format(
            "index field: lambda = {} nm: expected a finite wavelength > 0", lambda_nm));
    }
    const double f = field.filling_fraction();
    if (!(f > 0.0 && f < 1.0)) {
        throw InputError(fmt::format(
            "index field: keratin filling fraction f = {}: expected 0 < f < 1 (a volume without "
            "both components has no contrast and does not scatter)",
            f));
    }
    const std::complex<double> n_k = keratin.index(lambda_nm);
    const std::complex<double> n_a = air.index(lambda_nm);
    if (n_k == n_a) {
        throw InputError(fmt::format(
            "index field: {} and {} have the same index ({}, {}) at lambda = {} nm: expected "
            "an index contrast",
            keratin.name(), air.name(), n_k.real(), n_k.imag(), lambda_nm));
    }
    require_resolved(field.voxel_um, lambda_nm, std::max(n_k.real(), n_a.real()));
    ContrastField c;
    c.eps_keratin = n_k * n_k;
    c.eps_air = n_a * n_a;
    c.filling_fraction = f;
    c.eps_eff = bruggeman_permittivity(c.eps_keratin, c.eps_air, f);
    c.delta_eps.resize(field.keratin.size());
    const std::complex<double> dk = c.eps_keratin - c.eps_eff, da = c.eps_air - c.eps_eff;
    for (std::size_t p = 0; p < field.keratin.size(); ++p) {
        c.delta_eps[p] = field.keratin[p] ? dk : da;
    }
    return c;
}

}  // namespace plumage::sim::wave
