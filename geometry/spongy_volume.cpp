#include "geometry/spongy_volume.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>
#include <new>
#include <random>
#include <system_error>

#include <fmt/format.h>
#include <openvdb/io/File.h>
#include <openvdb/tools/FastSweeping.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <unsupported/Eigen/FFT>

#include "common/constants.h"
#include "common/error.h"
#include "geometry/random_stream.h"

namespace plumage::geometry {
namespace {

using Complex = std::complex<double>;
constexpr int kMaxVoxelsPerSide = 512;  // 512³ complex doubles are 2 GiB already
constexpr const char* kGridName = "keratin";

// Metadata keys (the measurement functions need the box; the rest is provenance).
constexpr const char* kMetaVoxelsPerSide = "plumage_voxels_per_side";
constexpr const char* kMetaBox = "plumage_box_um";
constexpr const char* kMetaVoxel = "plumage_voxel_um";

// Random streams of one volume, kept apart so that adding a draw to one cannot shift
// another.
enum class Stream : std::uint32_t { channel_phases = 1, sphere_centres = 2 };

std::mt19937_64 random_stream(std::uint64_t seed, std::uint64_t item, Stream stream) {
    return detail::seeded_stream(seed, item, static_cast<std::uint32_t>(stream));
}

using detail::uniform01;

// ---------------------------------------------------------------------------------------
// Parameter checks. Each message names the parameter, its value and what was expected.

[[noreturn]] void reject(const char* volume, const char* key, double value,
                         const std::string& expected) {
    throw InputError(fmt::format("{} volume: {} = {}: expected {}", volume, key, value, expected));
}

void require_finite(const char* volume, const char* key, double value) {
    if (!std::isfinite(value)) reject(volume, key, value, "a finite number");
}

void require_fraction(const char* volume, double f) {
    require_finite(volume, "keratin_fraction", f);
    if (!(f > 0.0 && f < 1.0)) reject(volume, "keratin_fraction", f, "a value in (0, 1)");
}

// Checks the box, voxel and narrow band; returns N, the voxels per side.
int require_box(const char* volume, double box_um, double voxel_um, double half_width) {
    require_finite(volume, "voxel_um", voxel_um);
    if (!(voxel_um > 0.0)) reject(volume, "voxel_um", voxel_um, "a voxel size > 0 µm");
    require_finite(volume, "box_um", box_um);
    if (!(box_um > 0.0)) reject(volume, "box_um", box_um, "a box size > 0 µm");
    const double ratio = box_um / voxel_um;
    if (!(ratio <= kMaxVoxelsPerSide + 0.5)) {
        reject(volume, "box_um", box_um,
               fmt::format("at most {} voxels per side (voxel_um = {} gives {:.1f})",
                           kMaxVoxelsPerSide, voxel_um, ratio));
    }
    const double n = std::round(ratio);
    if (std::abs(ratio - n) > 1e-6 * n) {
        // The volume is periodic with period N h: a fractional voxel has no place in it.
        reject(
            volume, "box_um", box_um,
            fmt::format("a whole number of voxels (voxel_um = {} gives {:.4f})", voxel_um, ratio));
    }
    if (n < 4) {
        reject(volume, "box_um", box_um, fmt::format("at least 4 voxels per side (got {})", n));
    }
    require_finite(volume, "half_width_voxels", half_width);
    if (!(half_width >= 1.0 && half_width <= 16.0)) {
        reject(volume, "half_width_voxels", half_width,
               "a narrow-band half-width in [1, 16] voxels (volumeToMesh needs at least 1)");
    }
    return static_cast<int>(n);
}

// ---------------------------------------------------------------------------------------
// Dense periodic arrays of N³ voxels, k fastest.

struct Lattice {
    int n;
    std::size_t size() const { return static_cast<std::size_t>(n) * n * n; }
    std::size_t index(int i, int j, int k) const {
        return (static_cast<std::size_t>(i) * n + j) * n + k;
    }
    int wrap(int i) const { return ((i % n) + n) % n; }
    // Signed frequency of DFT index i: 0, 1, …, ⌊N/2⌋, −⌈N/2⌉ + 1, …, −1.
    int frequency(int i) const { return 2 * i <= n ? i : i - n; }
};

// DFT of the lines [first, last) along one axis of an N³ array (k fastest). A line is
// numbered by its two other indices, and visits data[base + m stride], m = 0 … N−1.
void transform_lines(std::vector<Complex>& data, std::size_t n, int axis, bool inverse,
                     std::size_t first, std::size_t last) {
    const std::size_t stride = axis == 0 ? n * n : axis == 1 ? n : 1;
    Eigen::FFT<double> fft;  // one per task: it caches plans and is not thread-safe
    std::vector<Complex> in(n), out(n);
    for (std::size_t line = first; line != last; ++line) {
        const std::size_t base = axis == 0   ? line
                                 : axis == 1 ? (line / n) * n * n + line % n
                                             : line * n;
        for (std::size_t m = 0; m < n; ++m) in[m] = data[base + m * stride];
        if (inverse) {
            fft.inv(out, in);
        } else {
            fft.fwd(out, in);
        }
        for (std::size_t m = 0; m < n; ++m) data[base + m * stride] = out[m];
    }
}

// In-place 3-D DFT, one axis at a time (Eigen's kissfft, any N). Forward unscaled;
// inverse scaled by 1/N³. Lines are independent, so the result does not depend on how
// TBB splits them.
void fft_3d(std::vector<Complex>& data, const Lattice& lattice, bool inverse) {
    const auto n = static_cast<std::size_t>(lattice.n);
    for (int axis = 0; axis < 3; ++axis) {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n * n, 64),
                          [&](const tbb::blocked_range<std::size_t>& lines) {
                              transform_lines(data, n, axis, inverse, lines.begin(), lines.end());
                          });
    }
}

// ---------------------------------------------------------------------------------------
// Level-set construction from a dense periodic signed field.

struct PeriodicField {
    Lattice lattice;
    std::vector<double> phi;            // signed distance estimate, µm, < 0 in keratin
    std::vector<std::uint8_t> keratin;  // the voxel indicator χ
};

// Signed distance from the voxel centre x to the box [0, L]³ (negative inside).
double box_distance(const Vec3& x, double box_um) {
    const Vec3 q = (x - Vec3::Constant(0.5 * box_um)).cwiseAbs() - Vec3::Constant(0.5 * box_um);
    return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// The stored value: clamped to the band, and strictly signed as the indicator says (a
// value that rounds to ±0 in float would otherwise read as air).
float stored_value(double phi, bool keratin, double band, double voxel_um) {
    const auto tiny = static_cast<float>(1e-6 * voxel_um);
    auto value = static_cast<float>(std::clamp(phi, -band, band));
    if (keratin && !(value < 0.0f)) value = -tiny;
    if (!keratin && !(value > 0.0f)) value = tiny;
    return value;
}

openvdb::math::Transform::Ptr box_transform(double voxel_um) {
    auto transform = openvdb::math::Transform::createLinearTransform(voxel_um);
    transform->postTranslate(openvdb::Vec3d(0.5 * voxel_um));  // voxel centres at (i + ½) h
    return transform;
}

// The extended lattice: the box plus a margin on every side, wide enough for the box's
// own distance to reach the band.
struct ExtendedField {
    Lattice lattice;
    int margin;
    std::vector<double> value;          // clipped signed distance, µm
    std::vector<std::uint8_t> keratin;  // indicator; 0 outside the box
    openvdb::Coord coord(int i, int j, int k) const {
        return openvdb::Coord(i - margin, j - margin, k - margin);
    }
};

ExtendedField clip_to_box(const PeriodicField& field, double voxel_um, double half_width_voxels) {
    const Lattice& lat = field.lattice;
    const int n = lat.n;
    const double box_um = n * voxel_um;
    const int margin = static_cast<int>(std::ceil(half_width_voxels)) + 1;
    ExtendedField ext{Lattice{n + 2 * margin}, margin, {}, {}};
    ext.value.resize(ext.lattice.size());
    ext.keratin.resize(ext.lattice.size());
    for (int i = 0; i < ext.lattice.n; ++i) {
        for (int j = 0; j < ext.lattice.n; ++j) {
            for (int k = 0; k < ext.lattice.n; ++k) {
                const int gi = i - margin, gj = j - margin, gk = k - margin;
                const std::size_t p = lat.index(lat.wrap(gi), lat.wrap(gj), lat.wrap(gk));
                const bool inside = gi >= 0 && gi < n && gj >= 0 && gj < n && gk >= 0 && gk < n;
                // Clipped everywhere, not only outside: inside, d_box <= −h/2 keeps every
                // sign, but a deep (clamped) keratin value next to a face becomes −h/2, so
                // the cut surface interpolates to the face itself.
                const Vec3 centre = (Vec3(gi, gj, gk) + Vec3::Constant(0.5)) * voxel_um;
                const std::size_t e = ext.lattice.index(i, j, k);
                ext.value[e] = std::max(field.phi[p], box_distance(centre, box_um));
                ext.keratin[e] = inside && field.keratin[p];
            }
        }
    }
    return ext;
}

// Whether a voxel of the extended lattice is stored as active: |φ| < band, or a face
// neighbour has the other sign. Then every sign change lies between active voxels, each
// connected inactive region has one sign, and signedFloodFill gives it that sign.
bool is_active(const ExtendedField& ext, int i, int j, int k, double band) {
    const Lattice& lat = ext.lattice;
    const std::size_t p = lat.index(i, j, k);
    if (std::abs(ext.value[p]) < band) return true;
    const std::array<std::array<int, 3>, 6> faces = {
        {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k}, {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}}};
    for (const auto& f : faces) {
        if (f[0] < 0 || f[1] < 0 || f[2] < 0 || f[0] >= lat.n || f[1] >= lat.n || f[2] >= lat.n) {
            continue;
        }
        if (ext.keratin[lat.index(f[0], f[1], f[2])] != ext.keratin[p]) return true;
    }
    return false;
}

// The grid of the extended field: activity from ext.value, stored values from `values`
// (ext.value or a redistanced copy), signs from the indicator.
openvdb::FloatGrid::Ptr make_grid(const ExtendedField& ext, const std::vector<double>& values,
                                  double voxel_um, double band) {
    auto grid = openvdb::FloatGrid::create(static_cast<float>(band));
    grid->setTransform(box_transform(voxel_um));
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    grid->setName(kGridName);
    auto accessor = grid->getAccessor();
    for (int i = 0; i < ext.lattice.n; ++i) {
        for (int j = 0; j < ext.lattice.n; ++j) {
            for (int k = 0; k < ext.lattice.n; ++k) {
                if (!is_active(ext, i, j, k, band)) continue;
                const std::size_t p = ext.lattice.index(i, j, k);
                accessor.setValue(ext.coord(i, j, k),
                                  stored_value(values[p], ext.keratin[p], band, voxel_um));
            }
        }
    }
    openvdb::tools::signedFloodFill(grid->tree());
    return grid;
}

// Builds the narrow-band level set of keratin ∩ box from a periodic field. With
// `redistance`, the band is recomputed by fast sweeping (openvdb::tools::sdfToSdf: the
// voxels next to the surface get their distance from the linearly interpolated
// crossings along the axes, the rest solve |∇φ| = 1); the topology stays that of the
// first field and the signs those of the indicator (sdfToSdf writes 0 for a voxel within
// round-off of the surface).
openvdb::FloatGrid::Ptr build_level_set(const PeriodicField& field, double voxel_um,
                                        double half_width_voxels, bool redistance) {
    const double band = half_width_voxels * voxel_um;
    const ExtendedField ext = clip_to_box(field, voxel_um, half_width_voxels);
    openvdb::FloatGrid::Ptr grid = make_grid(ext, ext.value, voxel_um, band);
    if (redistance) {
        const openvdb::FloatGrid::Ptr swept = openvdb::tools::sdfToSdf(*grid, 0.0f, 1);
        const auto swept_accessor = swept->getConstAccessor();
        std::vector<double> values = ext.value;
        for (int i = 0; i < ext.lattice.n; ++i) {
            for (int j = 0; j < ext.lattice.n; ++j) {
                for (int k = 0; k < ext.lattice.n; ++k) {
                    float v = 0.0f;
                    if (swept_accessor.probeValue(ext.coord(i, j, k), v) && std::isfinite(v)) {
                        values[ext.lattice.index(i, j, k)] = v;
                    }
                }
            }
        }
        grid = make_grid(ext, values, voxel_um, band);
    }

    const Lattice& lat = field.lattice;
    const auto accessor = grid->getConstAccessor();
    for (int i = 0; i < lat.n; ++i) {
        for (int j = 0; j < lat.n; ++j) {
            for (int k = 0; k < lat.n; ++k) {
                const bool stored_keratin = accessor.getValue(openvdb::Coord(i, j, k)) < 0.0f;
                PLUMAGE_CHECK(stored_keratin == (field.keratin[lat.index(i, j, k)] != 0),
                              fmt::format("level-set sign differs from the indicator at voxel ({}, "
                                          "{}, {})",
                                          i, j, k));
            }
        }
    }
    grid->insertMeta(kMetaVoxelsPerSide, openvdb::Int64Metadata(lat.n));
    grid->insertMeta(kMetaBox, openvdb::DoubleMetadata(lat.n * voxel_um));
    grid->insertMeta(kMetaVoxel, openvdb::DoubleMetadata(voxel_um));
    grid->insertMeta("plumage_units",
                     openvdb::StringMetadata("micrometres; negative inside keratin; box [0, "
                                             "box_um]^3 holds one period"));
    return grid;
}

void insert_provenance(openvdb::FloatGrid& grid, const char* morphology, double keratin_fraction,
                       std::uint64_t seed, std::uint64_t item) {
    grid.insertMeta("plumage_morphology", openvdb::StringMetadata(morphology));
    grid.insertMeta("plumage_requested_keratin_fraction",
                    openvdb::DoubleMetadata(keratin_fraction));
    // As text: OpenVDB has no unsigned 64-bit metadata.
    grid.insertMeta("plumage_seed", openvdb::StringMetadata(std::to_string(seed)));
    grid.insertMeta("plumage_item", openvdb::StringMetadata(std::to_string(item)));
}

struct BoxInfo {
    int voxels_per_side;
    double voxel_um;
};

BoxInfo box_of(const openvdb::FloatGrid& grid) {
    const auto n = grid.getMetadata<openvdb::Int64Metadata>(kMetaVoxelsPerSide);
    if (!n || n->value() < 1 || n->value() > kMaxVoxelsPerSide) {
        throw InputError(
            fmt::format("level set '{}' has no valid '{}' metadata: expected a volume written by "
                        "make_channel_volume or make_sphere_volume",
                        grid.getName(), kMetaVoxelsPerSide));
    }
    // The voxel size as written, not as the transform returns it: a transform read back
    // from a .vdb file can differ from the written one in the last bits.
    const auto voxel = grid.getMetadata<openvdb::DoubleMetadata>(kMetaVoxel);
    if (!voxel || !(voxel->value() > 0.0)) {
        throw InputError(
            fmt::format("level set '{}' has no valid '{}' metadata: expected a volume written by "
                        "make_channel_volume or make_sphere_volume",
                        grid.getName(), kMetaVoxel));
    }
    return {static_cast<int>(n->value()), voxel->value()};
}

// Indicator minus its mean, as complex numbers, from the stored level set.
std::vector<Complex> centred_indicator(const openvdb::FloatGrid& grid, const Lattice& lat) {
    std::vector<Complex> chi(lat.size());
    auto accessor = grid.getConstAccessor();
    std::size_t count = 0;
    for (int i = 0; i < lat.n; ++i) {
        for (int j = 0; j < lat.n; ++j) {
            for (int k = 0; k < lat.n; ++k) {
                const bool keratin = accessor.getValue(openvdb::Coord(i, j, k)) < 0.0f;
                chi[lat.index(i, j, k)] = keratin ? 1.0 : 0.0;
                count += keratin;
            }
        }
    }
    const double mean = static_cast<double>(count) / static_cast<double>(lat.size());
    for (Complex& c : chi) c -= mean;
    return chi;
}

// Vertex of the parabola through three points, or the middle one if they do not make a
// maximum.
double parabola_vertex(double x0, double y0, double x1, double y1, double x2, double y2) {
    const double denominator = (x0 - x1) * (x0 - x2) * (x1 - x2);
    const double a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / denominator;
    const double b =
        (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / denominator;
    if (!(a < 0.0)) return x1;
    return std::clamp(-b / (2.0 * a), x0, x2);
}

SpongyVolume finish(SpongyMorphology morphology, const PeriodicField& field, double voxel_um,
                    double half_width_voxels, bool redistance) {
    SpongyVolume volume;
    volume.morphology = morphology;
    volume.level_set = build_level_set(field, voxel_um, half_width_voxels, redistance);
    volume.voxels_per_side = field.lattice.n;
    volume.voxel_um = voxel_um;
    volume.box_um = field.lattice.n * voxel_um;
    volume.keratin_fraction = measure_keratin_fraction(*volume.level_set);
    volume.spectrum = measure_power_spectrum(*volume.level_set);
    return volume;
}

}  // namespace

// ---------------------------------------------------------------------------------------

namespace {

// The channel volume's checks (ChannelVolumeParams); returns the voxels per side.
int check_channel_params(const ChannelVolumeParams& params) {
    constexpr const char* kWhat = "channel";
    const int n = require_box(kWhat, params.box_um, params.voxel_um, params.half_width_voxels);
    require_fraction(kWhat, params.keratin_fraction);
    const double a = params.length_scale_um;
    const double h = params.voxel_um;
    const double box = n * h;
    require_finite(kWhat, "length_scale_um", a);
    if (!(a > 2.0 * h)) {
        reject(kWhat, "length_scale_um", a,
               fmt::format("> 2 × voxel_um = {} µm: with a <= 2 voxels the spectral peak k0 = 2π/a "
                           "is at or beyond the grid's Nyquist wavenumber π/voxel_um and cannot "
                           "be resolved",
                           2.0 * h));
    }
    if (!(box >= 2.0 * a)) {
        reject(kWhat, "length_scale_um", a,
               fmt::format("<= box_um / 2 = {} µm (box_um = {}): a box shorter than 2a holds less "
                           "than two periods, so k0 = 2π/a lies below the box's second "
                           "wavenumber 2·(2π/box_um) and the spectral peak cannot be located",
                           0.5 * box, box));
    }
    require_finite(kWhat, "shell_relative_width", params.shell_relative_width);
    if (!(params.shell_relative_width > 0.0 && params.shell_relative_width <= 1.0)) {
        reject(kWhat, "shell_relative_width", params.shell_relative_width,
               "a relative shell width σ_k/k0 in (0, 1]");
    }
    return n;
}

// The shell spectrum's Fourier coefficients (header comment), Hermitian.
std::vector<Complex> shell_spectrum(const ChannelVolumeParams& params, const Lattice& lat,
                                    double box) {
    const int n = lat.n;
    const std::size_t size = lat.size();
    const double a = params.length_scale_um;
    // Fourier coefficients: amplitude √S(|k|), random phase, c(−k) = conj c(k). The 8
    // self-conjugate modes (every index 0 or N/2: the mean and Nyquist corners) are
    // left 0, which also makes the field's mean 0.
    const double dk = kTwoPi / box;
    const double k0 = kTwoPi / a;
    const double sigma = params.shell_relative_width * k0;
    std::vector<Complex> field(size, Complex(0.0));
    std::mt19937_64 rng = random_stream(params.seed, params.item, Stream::channel_phases);
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            for (int k = 0; k < n; ++k) {
                const std::size_t p = lat.index(i, j, k);
                const std::size_t partner = lat.index(lat.wrap(-i), lat.wrap(-j), lat.wrap(-k));
                if (partner <= p) continue;  // set with its partner, or self-conjugate
                const double fi = lat.frequency(i), fj = lat.frequency(j), fk = lat.frequency(k);
                const double kk = dk * std::sqrt(fi * fi + fj * fj + fk * fk);
                const double phase = kTwoPi * uniform01(rng);
                const double amplitude = std::exp(-(kk - k0) * (kk - k0) / (4.0 * sigma * sigma));
                field[p] = std::polar(amplitude, phase);
                field[partner] = std::conj(field[p]);
            }
        }
    }
    return field;
}

// The threshold that makes exactly `keratin_voxels` of g keratin (g > threshold).
double keratin_threshold(const std::vector<double>& g, std::size_t keratin_voxels) {
    const std::size_t size = g.size();
    // Threshold between the (size − M)-th and the next value: exactly M keratin voxels.
    std::vector<double> sorted = g;
    const auto cut = sorted.begin() + static_cast<std::ptrdiff_t>(size - keratin_voxels);
    std::nth_element(sorted.begin(), cut, sorted.end());
    const double lowest_keratin = *cut;
    const double highest_air = *std::max_element(sorted.begin(), cut);
    const double threshold = 0.5 * (lowest_keratin + highest_air);

    return threshold;
}

// |∇g|² by spectral differentiation, ∂g/∂x_a = IFFT(i k_a ĝ): exact for this
// band-limited field, where central differences would underestimate it by
// sin(k h)/(k h) (5 % at a = 10 voxels). The Nyquist index of the differentiated axis
// gets 0: its ±k are one mode, and i k ĝ there would break the Hermitian symmetry.
std::vector<double> spectral_gradient_squared(const std::vector<Complex>& coefficients,
                                              const Lattice& lat, double dk) {
    const int n = lat.n;
    const std::size_t size = lat.size();
    std::vector<double> gradient_squared(size, 0.0);
    std::vector<Complex> derivative(size);
    for (int axis = 0; axis < 3; ++axis) {
        for (int i = 0; i < n; ++i) {
            for (int j = 0; j < n; ++j) {
                for (int k = 0; k < n; ++k) {
                    const int m = axis == 0 ? i : axis == 1 ? j : k;
                    const double k_axis = 2 * m == n ? 0.0 : dk * lat.frequency(m);
                    const std::size_t p = lat.index(i, j, k);
                    derivative[p] = coefficients[p] * Complex(0.0, k_axis);
                }
            }
        }
        fft_3d(derivative, lat, /*inverse=*/true);
        for (std::size_t p = 0; p < size; ++p)
            gradient_squared[p] += std::norm(derivative[p].real());
    }

    return gradient_squared;
}

}  // namespace

SpongyVolume make_channel_volume(const ChannelVolumeParams& params) {
    const int n = check_channel_params(params);
    const double a = params.length_scale_um;
    const double h = params.voxel_um;
    const double box = n * h;

    openvdb::initialize();
    const Lattice lat{n};
    const std::size_t size = lat.size();
    const auto keratin_voxels =
        static_cast<std::size_t>(std::llround(params.keratin_fraction * static_cast<double>(size)));
    if (keratin_voxels == 0 || keratin_voxels == size) {
        reject(
            "channel", "keratin_fraction", params.keratin_fraction,
            fmt::format("a fraction that leaves both keratin and air among the {} voxels", size));
    }

    const std::vector<Complex> coefficients = shell_spectrum(params, lat, box);
    std::vector<Complex> field = coefficients;  // the coefficients are kept for the gradient
    fft_3d(field, lat, /*inverse=*/true);
    std::vector<double> g(size);
    double largest = 0.0, largest_imaginary = 0.0;
    for (std::size_t p = 0; p < size; ++p) {
        g[p] = field[p].real();
        largest = std::max(largest, std::abs(field[p].real()));
        largest_imaginary = std::max(largest_imaginary, std::abs(field[p].imag()));
    }
    PLUMAGE_CHECK(largest > 0.0 && largest_imaginary <= 1e-9 * largest,
                  "the Hermitian spectrum must give a real, non-zero field");
    const double threshold = keratin_threshold(g, keratin_voxels);
    const std::vector<double> gradient_squared =
        spectral_gradient_squared(coefficients, lat, kTwoPi / box);

    PeriodicField periodic{lat, std::vector<double>(size), std::vector<std::uint8_t>(size)};
    const double band = params.half_width_voxels * h;
    for (std::size_t p = 0; p < size; ++p) {
        const bool keratin = g[p] > threshold;
        const double phi = (threshold - g[p]) / std::sqrt(gradient_squared[p]);  // ±∞/NaN if flat
        periodic.keratin[p] = keratin;
        periodic.phi[p] = std::isfinite(phi) ? phi : (keratin ? -band : band);
    }
    SpongyVolume volume = finish(SpongyMorphology::channel, periodic, h, params.half_width_voxels,
                                 /*redistance=*/true);
    insert_provenance(*volume.level_set, "channel", params.keratin_fraction, params.seed,
                      params.item);
    volume.level_set->insertMeta("plumage_length_scale_um", openvdb::DoubleMetadata(a));
    volume.level_set->insertMeta("plumage_shell_relative_width",
                                 openvdb::DoubleMetadata(params.shell_relative_width));
    return volume;
}

namespace {

// The sphere volume's checks (SphereVolumeParams); returns the voxels per side.
int check_sphere_params(const SphereVolumeParams& params) {
    constexpr const char* kWhat = "sphere";
    const int n = require_box(kWhat, params.box_um, params.voxel_um, params.half_width_voxels);
    require_fraction(kWhat, params.keratin_fraction);
    const double r = params.sphere_radius_um;
    const double h = params.voxel_um;
    const double box = n * h;
    require_finite(kWhat, "sphere_radius_um", r);
    if (!(r > h)) {
        reject(kWhat, "sphere_radius_um", r,
               fmt::format("> voxel_um = {} µm: a sphere no wider than two voxels is not resolved "
                           "by the voxel indicator",
                           h));
    }
    if (!(r <= 0.25 * box)) {
        reject(kWhat, "sphere_radius_um", r,
               fmt::format("<= box_um / 4 = {} µm: a larger sphere would meet its own periodic "
                           "image",
                           0.25 * box));
    }
    require_finite(kWhat, "min_separation_diameters", params.min_separation_diameters);
    const double separation = params.min_separation_diameters * 2.0 * r;
    if (!(params.min_separation_diameters > 0.0 && params.min_separation_diameters <= 2.0)) {
        reject(kWhat, "min_separation_diameters", params.min_separation_diameters,
               "a minimum centre separation in (0, 2] sphere diameters");
    }
    if (!(separation <= 0.5 * box)) {
        reject(kWhat, "min_separation_diameters", params.min_separation_diameters,
               fmt::format("a separation 2 r × value = {} µm <= box_um / 2 = {} µm (the nearest-"
                           "image test needs it)",
                           separation, 0.5 * box));
    }
    if (params.max_attempts < 1) {
        reject(kWhat, "max_attempts", static_cast<double>(params.max_attempts), "at least 1");
    }
    return n;
}

// Visits the voxels whose centres lie within `reach` of c, with their distance to c,
// wrapping indices periodically. If reach > L/2 a voxel is visited once per image of
// c within reach, each time with that image's distance.
template <class Visit>
void for_voxels_near(const Lattice& lat, double h, const Vec3& c, double reach, Visit&& visit) {
    std::array<int, 3> lo, hi;
    for (int axis = 0; axis < 3; ++axis) {
        lo[axis] = static_cast<int>(std::ceil((c[axis] - reach) / h - 0.5));
        hi[axis] = static_cast<int>(std::floor((c[axis] + reach) / h - 0.5));
    }
    for (int i = lo[0]; i <= hi[0]; ++i) {
        const double dx = (i + 0.5) * h - c[0];
        for (int j = lo[1]; j <= hi[1]; ++j) {
            const double dy = (j + 0.5) * h - c[1];
            for (int k = lo[2]; k <= hi[2]; ++k) {
                const double dz = (k + 0.5) * h - c[2];
                const double distance = std::sqrt(dx * dx + dy * dy + dz * dz);
                if (distance <= reach) {
                    visit(lat.index(lat.wrap(i), lat.wrap(j), lat.wrap(k)), distance);
                }
            }
        }
    }
}

// The placed centres in a cell list, for the separation test: cells at least s wide, so only
// the 27 around a candidate can hold a centre closer than s. Fewer than 3 cells per side would
// visit the same cell twice: then one cell holds everything.
class CentreCells {
public:
    CentreCells(double box, double separation)
        : box_(box),
          separation_(separation),
          cells_(cell_count(box, separation)),
          lattice_{cells_},
          members_(lattice_.size()) {}

    // Whether a placed centre (nearest periodic image) lies closer than the separation to c.
    bool too_close(const std::vector<Vec3>& centres, const Vec3& c) const {
        const int ci = cell_of(c[0]), cj = cell_of(c[1]), ck = cell_of(c[2]);
        const int reach = cells_ == 1 ? 0 : 1;
        for (int di = -reach; di <= reach; ++di)
            for (int dj = -reach; dj <= reach; ++dj)
                for (int dk = -reach; dk <= reach; ++dk) {
                    const std::size_t cell = lattice_.index(
                        lattice_.wrap(ci + di), lattice_.wrap(cj + dj), lattice_.wrap(ck + dk));
                    for (std::uint32_t other : members_[cell]) {
                        const Vec3 d(nearest_image(centres[other][0] - c[0]),
                                     nearest_image(centres[other][1] - c[1]),
                                     nearest_image(centres[other][2] - c[2]));
                        if (d.squaredNorm() < separation_ * separation_) return true;
                    }
                }
        return false;
    }
    void add(const Vec3& c, std::size_t index) {
        members_[lattice_.index(cell_of(c[0]), cell_of(c[1]), cell_of(c[2]))].push_back(
            static_cast<std::uint32_t>(index));
    }

private:
    static int cell_count(double box, double separation) {
        const int cells = static_cast<int>(std::floor(box / separation));
        return cells < 3 ? 1 : cells;
    }
    int cell_of(double x) const {
        return std::min(cells_ - 1, static_cast<int>(x / box_ * cells_));
    }
    double nearest_image(double d) const { return d - box_ * std::round(d / box_); }

    double box_, separation_;
    int cells_;
    Lattice lattice_;
    std::vector<std::vector<std::uint32_t>> members_;
};

// Air spheres by random sequential addition (header comment) until `air_target` voxels are air:
// their centres, the voxels' air flags and count. InputError when max_attempts run out first.
std::vector<Vec3> place_air_spheres(const SphereVolumeParams& params, const Lattice& lat,
                                    std::size_t air_target, std::vector<std::uint8_t>& air) {
    const double r = params.sphere_radius_um;
    const double h = params.voxel_um;
    const double box = lat.n * h;
    const std::size_t size = lat.size();
    const double separation = params.min_separation_diameters * 2.0 * r;
    CentreCells cell_list(box, separation);

    std::vector<Vec3> centres;
    air.assign(size, 0);
    std::size_t air_count = 0;
    std::vector<std::size_t> new_voxels;

    std::mt19937_64 rng = random_stream(params.seed, params.item, Stream::sphere_centres);
    std::int64_t attempts = 0;
    bool reached = air_count >= air_target;
    while (!reached && attempts < params.max_attempts) {
        ++attempts;
        const double x = box * uniform01(rng), y = box * uniform01(rng), z = box * uniform01(rng);
        const Vec3 c(x, y, z);
        if (cell_list.too_close(centres, c)) continue;

        new_voxels.clear();
        for_voxels_near(lat, h, c, r, [&](std::size_t p, double distance) {
            if (distance < r && !air[p]) new_voxels.push_back(p);
        });
        // A voxel can be listed twice only through two images, impossible for r <= L/4.
        const std::size_t after = air_count + new_voxels.size();
        if (after >= air_target) {
            reached = true;
            // Keep the last sphere only if it brings the fraction closer to the target.
            if (after - air_target > air_target - air_count) break;
        }
        for (std::size_t p : new_voxels) air[p] = 1;
        air_count = after;
        cell_list.add(c, centres.size());
        centres.push_back(c);
    }
    if (!reached) {
        throw InputError(fmt::format(
            "sphere volume: keratin_fraction = {} (air volume fraction {}) is unreachable: random "
            "sequential addition of {} air spheres (sphere_radius_um = {}, "
            "min_separation_diameters = {}) reached an air fraction of {:.4f} (keratin_fraction "
            "{:.4f}) after max_attempts = {} attempts; expected a larger keratin_fraction, a "
            "smaller min_separation_diameters or more max_attempts",
            params.keratin_fraction, 1.0 - params.keratin_fraction, centres.size(), r,
            params.min_separation_diameters,
            static_cast<double>(air_count) / static_cast<double>(size),
            1.0 - static_cast<double>(air_count) / static_cast<double>(size), params.max_attempts));
    }

    return centres;
}

}  // namespace

SpongyVolume make_sphere_volume(const SphereVolumeParams& params) {
    const int n = check_sphere_params(params);
    const double r = params.sphere_radius_um;
    const double h = params.voxel_um;

    openvdb::initialize();
    const Lattice lat{n};
    const std::size_t size = lat.size();
    const auto air_target = static_cast<std::size_t>(
        std::llround((1.0 - params.keratin_fraction) * static_cast<double>(size)));
    if (air_target == 0 || air_target == size) {
        reject(
            "sphere", "keratin_fraction", params.keratin_fraction,
            fmt::format("a fraction that leaves both keratin and air among the {} voxels", size));
    }
    std::vector<std::uint8_t> air;
    std::vector<Vec3> centres = place_air_spheres(params, lat, air_target, air);

    // φ = max over spheres (and images) of r − |x − c|, starting from −band (deep keratin).
    const double band = params.half_width_voxels * h;
    PeriodicField periodic{lat, std::vector<double>(size, -band), std::vector<std::uint8_t>(size)};
    for (const Vec3& c : centres) {
        for_voxels_near(lat, h, c, r + band, [&](std::size_t p, double distance) {
            periodic.phi[p] = std::max(periodic.phi[p], r - distance);
        });
    }
    for (std::size_t p = 0; p < size; ++p) periodic.keratin[p] = !air[p];

    SpongyVolume volume = finish(SpongyMorphology::sphere, periodic, h, params.half_width_voxels,
                                 /*redistance=*/false);
    volume.air_sphere_centres_um = std::move(centres);
    insert_provenance(*volume.level_set, "sphere", params.keratin_fraction, params.seed,
                      params.item);
    volume.level_set->insertMeta("plumage_sphere_radius_um", openvdb::DoubleMetadata(r));
    volume.level_set->insertMeta("plumage_min_separation_diameters",
                                 openvdb::DoubleMetadata(params.min_separation_diameters));
    volume.level_set->insertMeta(
        "plumage_air_spheres",
        openvdb::Int64Metadata(static_cast<std::int64_t>(volume.air_sphere_centres_um.size())));
    return volume;
}

// ---------------------------------------------------------------------------------------

double measure_keratin_fraction(const openvdb::FloatGrid& level_set) {
    const BoxInfo info = box_of(level_set);
    const Lattice lat{info.voxels_per_side};
    auto accessor = level_set.getConstAccessor();
    std::size_t count = 0;
    for (int i = 0; i < lat.n; ++i) {
        for (int j = 0; j < lat.n; ++j) {
            for (int k = 0; k < lat.n; ++k) {
                count += accessor.getValue(openvdb::Coord(i, j, k)) < 0.0f;
            }
        }
    }
    return static_cast<double>(count) / static_cast<double>(lat.size());
}

std::function<bool(const Eigen::Vector3d&)> periodic_keratin_test(
    const openvdb::FloatGrid& level_set) {
    const BoxInfo info = box_of(level_set);
    const int n = info.voxels_per_side;
    const double h = info.voxel_um;
    auto accessor = level_set.getConstAccessor();
    auto phi = std::make_shared<std::vector<float>>(static_cast<std::size_t>(n) * n * n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k)
                (*phi)[(static_cast<std::size_t>(i) * n + j) * n + k] =
                    accessor.getValue(openvdb::Coord(i, j, k));
    return [phi, n, h](const Eigen::Vector3d& p) {
        // voxel centres at (i + ½) h: the point in voxel-centre units, wrapped into the period
        std::array<int, 3> lo{};
        std::array<double, 3> t{};
        for (int a = 0; a < 3; ++a) {
            const double u = p[a] / h - 0.5;
            const double f = std::floor(u);
            t[a] = u - f;
            lo[a] = static_cast<int>(((static_cast<long long>(f) % n) + n) % n);
        }
        double value = 0.0;
        for (int c = 0; c < 8; ++c) {
            double w = 1.0;
            std::array<int, 3> at{};
            for (int a = 0; a < 3; ++a) {
                const int up = (c >> a) & 1;
                w *= up ? t[a] : 1.0 - t[a];
                at[a] = (lo[a] + up) % n;
            }
            value += w * (*phi)[(static_cast<std::size_t>(at[0]) * n + at[1]) * n + at[2]];
        }
        return value < 0.0;
    };
}

RadialPowerSpectrum measure_power_spectrum(const openvdb::FloatGrid& level_set) {
    const BoxInfo info = box_of(level_set);
    const Lattice lat{info.voxels_per_side};
    const int n = lat.n;
    const double h = info.voxel_um;
    const double box = n * h;
    std::vector<Complex> chi = centred_indicator(level_set, lat);
    fft_3d(chi, lat, /*inverse=*/false);

    // S(k) = |h³ Σ (χ − f) e^{−ik·x}|² / L³ = h³ |DFT|² / N³.
    const double scale = h * h * h / static_cast<double>(lat.size());
    const double dk = kTwoPi / box;
    const int shells = n / 2;
    std::vector<double> power(shells + 1, 0.0), wavenumber(shells + 1, 0.0);
    std::vector<std::size_t> modes(shells + 1, 0);
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            for (int k = 0; k < n; ++k) {
                const double fi = lat.frequency(i), fj = lat.frequency(j), fk = lat.frequency(k);
                const double radius = std::sqrt(fi * fi + fj * fj + fk * fk);
                const auto shell = static_cast<int>(std::lround(radius));
                if (shell < 1 || shell > shells) continue;
                power[shell] += scale * std::norm(chi[lat.index(i, j, k)]);
                wavenumber[shell] += radius * dk;
                ++modes[shell];
            }
        }
    }
    RadialPowerSpectrum spectrum;
    spectrum.shell_width_per_um = dk;
    for (int s = 1; s <= shells; ++s) {
        PLUMAGE_CHECK(modes[s] > 0, "every shell up to N/2 holds wavevectors");
        spectrum.wavenumber_per_um.push_back(wavenumber[s] / static_cast<double>(modes[s]));
        spectrum.power_um3.push_back(power[s] / static_cast<double>(modes[s]));
        spectrum.modes.push_back(modes[s]);
    }
    const auto& x = spectrum.wavenumber_per_um;
    const auto& y = spectrum.power_um3;
    const auto peak = static_cast<std::size_t>(std::max_element(y.begin(), y.end()) - y.begin());
    spectrum.peak_wavenumber_per_um =
        (peak == 0 || peak + 1 == y.size())
            ? x[peak]
            : parabola_vertex(x[peak - 1], y[peak - 1], x[peak], y[peak], x[peak + 1], y[peak + 1]);
    spectrum.peak_length_um = kTwoPi / spectrum.peak_wavenumber_per_um;
    return spectrum;
}

// ---------------------------------------------------------------------------------------

void save_level_set(const openvdb::FloatGrid& level_set, const std::filesystem::path& path) {
    openvdb::initialize();
    // A shallow copy (shared tree, own metadata) so that a missing name can be set.
    auto grid = std::const_pointer_cast<openvdb::FloatGrid>(level_set.copy());
    if (grid->getName().empty()) grid->setName(kGridName);
    std::filesystem::path temporary = path;
    temporary += fmt::format(".partial-{}", ::getpid());
    try {
        openvdb::io::File file(temporary.string());
        file.write(openvdb::GridCPtrVec{grid});
        file.close();
    } catch (const openvdb::Exception& e) {
        std::error_code ignored;
        std::filesystem::remove(temporary, ignored);
        throw IoError(fmt::format("cannot write level set '{}' to '{}': {}", grid->getName(),
                                  temporary.string(), e.what()));
    }
    std::error_code error;
    std::filesystem::rename(temporary, path, error);
    if (error) {
        std::filesystem::remove(temporary, error);
        throw IoError(fmt::format("cannot rename '{}' into place as '{}'", temporary.string(),
                                  path.string()));
    }
}

openvdb::FloatGrid::Ptr load_level_set(const std::filesystem::path& path,
                                       const std::string& grid_name) {
    openvdb::initialize();
    std::error_code error;
    if (!std::filesystem::is_regular_file(path, error)) {
        throw InputError(
            fmt::format("level set file '{}' (grid '{}'): no such file", path.string(), grid_name));
    }
    openvdb::io::File file(path.string());
    openvdb::GridBase::Ptr base;
    try {
        file.open();
        if (!file.hasGrid(grid_name)) {
            std::string held;
            const openvdb::GridPtrVecPtr grids = file.readAllGridMetadata();
            for (const auto& g : *grids) {
                held +=
                    fmt::format("{}'{}' ({})", held.empty() ? "" : ", ", g->getName(), g->type());
            }
            file.close();
            throw InputError(fmt::format(
                "level set file '{}' has no grid named '{}' (it holds {}): expected a FloatGrid "
                "level set of that name",
                path.string(), grid_name, held.empty() ? "no grids" : held));
        }
        base = file.readGrid(grid_name);
        file.close();
    } catch (const openvdb::Exception& e) {
        throw InputError(
            fmt::format("level set file '{}' (grid '{}') is not a readable .vdb file: {}",
                        path.string(), grid_name, e.what()));
    } catch (const std::bad_alloc&) {
        // OpenVDB 10 allocates whatever size a file's compressed block claims
        // (io::bloscFromStream): a damaged file asks for tens of GB. Name the file, not
        // "std::bad_alloc" (found by fuzz/fuzz_vdb.cpp: fuzz/regressions/asan_aborts/).
        throw InputError(fmt::format(
            "level set file '{}' (grid '{}') claims more memory than there is: damaged, or too "
            "large for this machine",
            path.string(), grid_name));
    }
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    if (!grid) {
        throw InputError(
            fmt::format("grid '{}' in '{}' is of type {}: expected a FloatGrid ({}) level set",
                        grid_name, path.string(), base->type(), openvdb::FloatGrid::gridType()));
    }
    if (grid->getGridClass() != openvdb::GRID_LEVEL_SET) {
        throw InputError(fmt::format(
            "grid '{}' in '{}' has grid class '{}': expected a level set (class '{}')", grid_name,
            path.string(), openvdb::GridBase::gridClassToString(grid->getGridClass()),
            openvdb::GridBase::gridClassToString(openvdb::GRID_LEVEL_SET)));
    }
    const openvdb::math::Transform& transform = grid->transform();
    if (!transform.isLinear() || !transform.hasUniformScale()) {
        throw InputError(fmt::format(
            "grid '{}' in '{}' has non-uniform or non-linear voxels: expected cubic voxels (a "
            "level set in world units needs one voxel size)",
            grid_name, path.string()));
    }
    return grid;
}

// ---------------------------------------------------------------------------------------

TriangleMesh level_set_to_mesh(const openvdb::FloatGrid& level_set, double adaptivity) {
    if (!(adaptivity >= 0.0 && adaptivity <= 1.0)) {
        throw InputError(fmt::format(
            "level_set_to_mesh: adaptivity = {}: expected a value in [0, 1]", adaptivity));
    }
    if (level_set.getGridClass() != openvdb::GRID_LEVEL_SET) {
        throw InputError(fmt::format(
            "level_set_to_mesh: grid '{}' has class '{}': expected a level set",
            level_set.getName(), openvdb::GridBase::gridClassToString(level_set.getGridClass())));
    }
    openvdb::initialize();
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(level_set, points, triangles, quads, /*isovalue=*/0.0, adaptivity);

    TriangleMesh mesh;
    mesh.positions.reserve(points.size());
    for (const openvdb::Vec3s& p : points) mesh.positions.emplace_back(p[0], p[1], p[2]);
    mesh.triangles.reserve(triangles.size() + 2 * quads.size());
    auto add = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        if (a != b && b != c && c != a) mesh.triangles.push_back({a, b, c});
    };
    // Reversed: OpenVDB's polygons face the negative side.
    for (const openvdb::Vec3I& t : triangles) add(t[0], t[2], t[1]);
    for (const openvdb::Vec4I& q : quads) {
        // The reversed quad is (q0, q3, q2, q1); split along its shorter diagonal.
        const auto& p = mesh.positions;
        if ((p[q[0]] - p[q[2]]).squaredNorm() <= (p[q[1]] - p[q[3]]).squaredNorm()) {
            add(q[0], q[3], q[2]);
            add(q[0], q[2], q[1]);
        } else {
            add(q[3], q[2], q[1]);
            add(q[3], q[1], q[0]);
        }
    }
    return mesh;
}

}  // namespace plumage::geometry
