#include "virtual_gonio/rgl_bsdf.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <exception>
#include <fstream>
#include <limits>
#include <numeric>
#include <random>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/relative_l1.h"
#include "common/require.h"
#include "sim/optics/colour.h"

static_assert(std::endian::native == std::endian::little,
              "the tensor file is little-endian; this code stores host bytes");

namespace plumage::gonio {
namespace {

constexpr char kMagic[12] = {'t', 'e', 'n', 's', 'o', 'r', '_', 'f', 'i', 'l', 'e', '\0'};
constexpr std::uint8_t kVersionMajor = 1, kVersionMinor = 0;
constexpr std::string_view kWhat = "rgl_bsdf";

// Bytes per element of each dtype code (0: not a dtype): 1 uint8, 2 int8, 3 uint16, 4 int16,
// 5 uint32, 6 int32, 7 uint64, 8 int64, 9 float16, 10 float32, 11 float64.
constexpr std::array<std::size_t, 12> kDtypeSize = {0, 1, 1, 2, 2, 4, 4, 8, 8, 2, 4, 8};
std::size_t dtype_size(std::uint8_t dtype) {
    return dtype < kDtypeSize.size() ? kDtypeSize[dtype] : 0;
}

// ---- the unit-square parameterisation of Dupuy & Jakob (Mitsuba's theta2u etc.) ----------
double theta_to_u(double theta) { return std::sqrt(theta * (2.0 / kPi)); }
double u_to_theta(double u) { return u * u * (kPi / 2.0); }
double phi_to_u(double phi) { return (phi + kPi) / kTwoPi; }
double u_to_phi(double u) { return (2.0 * u - 1.0) * kPi; }
// Elevation of a unit vector, stable near the pole (Mitsuba's `elevation`).
double elevation(const Vec3d& d) {
    const double dist = std::sqrt(d.x() * d.x() + d.y() * d.y() + (d.z() - 1.0) * (d.z() - 1.0));
    return 2.0 * std::asin(std::min(1.0, 0.5 * dist));
}
Vec3d spherical(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}
// x clamped to [lo, hi], NaN to lo (a table of extreme values must not make an index of NaN).
double clamp_or_low(double x, double lo, double hi) { return x > lo ? (x < hi ? x : hi) : lo; }
// |dω/du| of the unit square: dω = sin θ dθ dφ, θ = u_x² π/2, φ = (2u_y − 1)π.
double square_jacobian(double u_x) { return 2.0 * kPi * kPi * u_x * std::sin(u_to_theta(u_x)); }

// ---- little-endian byte I/O ------------------------------------------------------------
template <typename T>
void append(std::vector<std::uint8_t>& out, T value) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
    out.insert(out.end(), p, p + sizeof(T));
}

class ByteReader {
public:
    ByteReader(const std::vector<std::uint8_t>& bytes, const std::string& source)
        : bytes_(bytes), source_(source) {}
    template <typename T>
    T read(const std::string& what) {
        if (position_ + sizeof(T) > bytes_.size()) {
            throw InputError(fmt::format("{}: truncated tensor file: ends inside {} (at byte {})",
                                         source_, what, position_));
        }
        T value;
        std::memcpy(&value, bytes_.data() + position_, sizeof(T));
        position_ += sizeof(T);
        return value;
    }
    std::string read_string(std::size_t length, const std::string& what) {
        if (position_ + length > bytes_.size()) {
            throw InputError(fmt::format("{}: truncated tensor file: ends inside {} (at byte {})",
                                         source_, what, position_));
        }
        std::string s(reinterpret_cast<const char*>(bytes_.data() + position_), length);
        position_ += length;
        return s;
    }

private:
    const std::vector<std::uint8_t>& bytes_;
    const std::string& source_;
    std::size_t position_ = 0;
};

TensorField float_field(const std::vector<float>& values, std::vector<std::uint64_t> shape) {
    TensorField field;
    field.dtype = static_cast<std::uint8_t>(TensorDtype::float32);
    field.shape = std::move(shape);
    field.bytes.resize(values.size() * sizeof(float));
    std::memcpy(field.bytes.data(), values.data(), field.bytes.size());
    return field;
}

TensorField byte_field(const std::vector<std::uint8_t>& values) {
    TensorField field;
    field.dtype = static_cast<std::uint8_t>(TensorDtype::uint8);
    field.shape = {values.size()};
    field.bytes = values;
    return field;
}

}  // namespace

// ---- tensor file -----------------------------------------------------------------------------

void write_tensor_file(const std::filesystem::path& path, const TensorFields& fields) {
    std::vector<std::uint8_t> header(kMagic, kMagic + sizeof(kMagic));
    header.push_back(kVersionMajor);
    header.push_back(kVersionMinor);
    append<std::uint32_t>(header, static_cast<std::uint32_t>(fields.size()));
    std::size_t header_size = header.size();
    for (const auto& [name, field] : fields) {
        header_size += 2 + name.size() + 2 + 1 + 8 + 8 * field.shape.size();
    }
    auto align = [](std::size_t offset) { return (offset + 7) / 8 * 8; };
    std::size_t offset = align(header_size);
    std::vector<std::size_t> offsets;
    for (const auto& [name, field] : fields) {
        PLUMAGE_CHECK(name.size() <= 0xffff && field.shape.size() <= 0xffff,
                      "tensor field name or rank too large");
        const std::size_t count = std::accumulate(field.shape.begin(), field.shape.end(),
                                                  std::size_t{1}, std::multiplies<>());
        PLUMAGE_CHECK(
            count * dtype_size(field.dtype) == field.bytes.size(),
            fmt::format("tensor field '{}': {} bytes for its shape", name, field.bytes.size()));
        append<std::uint16_t>(header, static_cast<std::uint16_t>(name.size()));
        header.insert(header.end(), name.begin(), name.end());
        append<std::uint16_t>(header, static_cast<std::uint16_t>(field.shape.size()));
        append<std::uint8_t>(header, field.dtype);
        append<std::uint64_t>(header, offset);
        for (std::uint64_t extent : field.shape) append<std::uint64_t>(header, extent);
        offsets.push_back(offset);
        offset = align(offset + field.bytes.size());
    }
    PLUMAGE_CHECK(header.size() == header_size, "tensor file header size");

    std::filesystem::path temporary = path;
    temporary += fmt::format(".partial-{}", ::getpid());
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        if (!out) throw IoError(fmt::format("cannot create '{}'", temporary.string()));
        out.write(reinterpret_cast<const char*>(header.data()),
                  static_cast<std::streamsize>(header.size()));
        std::size_t written = header.size();
        std::size_t i = 0;
        const char zeros[8] = {};
        for (const auto& [name, field] : fields) {
            out.write(zeros, static_cast<std::streamsize>(offsets[i] - written));
            out.write(reinterpret_cast<const char*>(field.bytes.data()),
                      static_cast<std::streamsize>(field.bytes.size()));
            written = offsets[i] + field.bytes.size();
            ++i;
        }
        out.flush();
        if (!out) {
            out.close();
            std::error_code ignored;
            std::filesystem::remove(temporary, ignored);
            throw IoError(fmt::format("cannot write '{}'", path.string()));
        }
    }
    std::error_code error;
    std::filesystem::rename(temporary, path, error);
    if (error) {
        std::filesystem::remove(temporary, error);
        throw IoError(fmt::format("cannot rename the tensor file into place: '{}'", path.string()));
    }
}

TensorFields read_tensor_file(const std::filesystem::path& path) {
    const std::string source = path.string();
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(fmt::format("{}: cannot open the tensor file", source));
    std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                    std::istreambuf_iterator<char>());
    if (bytes.size() < sizeof(kMagic) + 2 + 4) {
        throw InputError(fmt::format(
            "{}: not a tensor file: {} bytes, shorter than its 18-byte header (truncated?)", source,
            bytes.size()));
    }
    if (std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
        throw InputError(fmt::format(
            "{}: not a tensor file: it does not start with \"tensor_file\\0\"", source));
    }
    ByteReader reader(bytes, source);
    reader.read_string(sizeof(kMagic), "the magic");
    const auto major = reader.read<std::uint8_t>("the version");
    const auto minor = reader.read<std::uint8_t>("the version");
    if (major != kVersionMajor || minor != kVersionMinor) {
        throw InputError(
            fmt::format("{}: tensor file version {}.{}: expected 1.0", source, major, minor));
    }
    const auto count = reader.read<std::uint32_t>("the field count");
    TensorFields fields;
    for (std::uint32_t k = 0; k < count; ++k) {
        const std::string what = fmt::format("the header of field #{}", k);
        const auto name_length = reader.read<std::uint16_t>(what);
        const std::string name = reader.read_string(name_length, what);
        const auto rank = reader.read<std::uint16_t>(what);
        TensorField field;
        field.dtype = reader.read<std::uint8_t>(what);
        const auto offset = reader.read<std::uint64_t>(what);
        const std::size_t element = dtype_size(field.dtype);
        if (element == 0) {
            throw InputError(
                fmt::format("{}: field '{}': unknown dtype code {}", source, name, field.dtype));
        }
        std::uint64_t size = element;
        for (std::uint16_t d = 0; d < rank; ++d) {
            const auto extent = reader.read<std::uint64_t>(what);
            if (extent != 0 && size > std::numeric_limits<std::uint64_t>::max() / extent) {
                throw InputError(fmt::format("{}: field '{}': shape too large", source, name));
            }
            size *= extent;
            field.shape.push_back(extent);
        }
        if (offset > bytes.size() || size > bytes.size() - offset) {
            throw InputError(fmt::format(
                "{}: field '{}': data [{}, {}) lies outside the file ({} bytes; truncated?)",
                source, name, offset, offset + size, bytes.size()));
        }
        field.bytes.assign(bytes.begin() + static_cast<std::ptrdiff_t>(offset),
                           bytes.begin() + static_cast<std::ptrdiff_t>(offset + size));
        if (!fields.emplace(name, std::move(field)).second) {
            throw InputError(fmt::format("{}: field '{}' appears twice", source, name));
        }
    }
    return fields;
}

// ---- BilinearWarp2D ------------------------------------------------------------------------

BilinearWarp2D::BilinearWarp2D(std::span<const float> data, int width, int height,
                               std::vector<std::vector<double>> params, bool normalize)
    : width_(width), height_(height), params_(std::move(params)) {
    PLUMAGE_CHECK(width >= 2 && height >= 2, "warp: resolution must be >= 2");
    PLUMAGE_CHECK(params_.size() <= 3, "warp: at most three parameters");
    std::size_t slices = 1;
    for (const auto& p : params_) {
        PLUMAGE_CHECK(!p.empty(), "warp: a parameter without nodes");
        slices *= p.size();
    }
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    PLUMAGE_CHECK(data.size() == slices * n, "warp: data size does not match its shape");
    data_.assign(data.begin(), data.end());
    if (!normalize) return;
    conditional_cdf_.resize(slices * n);
    marginal_cdf_.resize(slices * static_cast<std::size_t>(height));
    const std::size_t w = static_cast<std::size_t>(width), h = static_cast<std::size_t>(height);
    for (std::size_t s = 0; s < slices; ++s) {
        double* cond = conditional_cdf_.data() + s * n;
        double* marg = marginal_cdf_.data() + s * h;
        double* d = data_.data() + s * n;
        for (std::size_t y = 0; y < h; ++y) {  // trapezoids: exact for the linear interpolant
            cond[y * w] = 0.0;
            for (std::size_t x = 0; x + 1 < w; ++x) {
                cond[y * w + x + 1] = cond[y * w + x] + 0.5 * (d[y * w + x] + d[y * w + x + 1]);
            }
        }
        marg[0] = 0.0;
        for (std::size_t y = 0; y + 1 < h; ++y) {
            marg[y + 1] = marg[y] + 0.5 * (cond[y * w + w - 1] + cond[(y + 1) * w + w - 1]);
        }
        const double total = marg[h - 1];
        if (!(total > 0.0) || !std::isfinite(total)) {
            throw InputError(fmt::format(
                "warp: slice {} of a sampling table has no positive density (total {})", s, total));
        }
        for (std::size_t i = 0; i < n; ++i) {
            cond[i] /= total;
            d[i] /= total;
        }
        for (std::size_t i = 0; i < h; ++i) marg[i] /= total;
    }
}

BilinearWarp2D::Weights BilinearWarp2D::weights(std::span<const double> param) const {
    PLUMAGE_CHECK(param.size() == params_.size(), "warp: wrong number of parameters");
    Weights w;
    std::size_t stride = 1;
    for (int d = static_cast<int>(params_.size()) - 1; d >= 0; --d) {
        const auto& nodes = params_[static_cast<std::size_t>(d)];
        const std::size_t k = static_cast<std::size_t>(d);
        if (nodes.size() == 1) {
            w.weight[2 * k] = 1.0;
            w.weight[2 * k + 1] = 0.0;
            w.stride[k] = 0;
            continue;
        }
        // Mitsuba's find_interval: the last node strictly below the parameter, within
        // [0, n − 2]; the weight is clamped, so parameters outside the nodes use the end slice.
        const double p = param[k];
        const auto first_not_below = std::lower_bound(nodes.begin(), nodes.end(), p);
        const std::size_t i = static_cast<std::size_t>(
            std::clamp<std::ptrdiff_t>((first_not_below - nodes.begin()) - 1, 0,
                                       static_cast<std::ptrdiff_t>(nodes.size()) - 2));
        const double t = clamp_or_low((p - nodes[i]) / (nodes[i + 1] - nodes[i]), 0.0, 1.0);
        w.weight[2 * k] = 1.0 - t;
        w.weight[2 * k + 1] = t;
        w.stride[k] = stride;
        w.slice += stride * i;
        stride *= nodes.size();
    }
    return w;
}

double BilinearWarp2D::lookup(const std::vector<double>& table, std::size_t per_slice,
                              const Weights& w, std::size_t index) const {
    const std::size_t dims = params_.size();
    double sum = 0.0;
    for (std::size_t corner = 0; corner < (std::size_t{1} << dims); ++corner) {
        double weight = 1.0;
        std::size_t slice = w.slice;
        for (std::size_t d = 0; d < dims; ++d) {
            const std::size_t bit = (corner >> d) & 1u;
            weight *= w.weight[2 * d + bit];
            slice += bit * w.stride[d];
        }
        if (weight != 0.0) sum += weight * table[slice * per_slice + index];
    }
    return sum;
}

double BilinearWarp2D::eval(const Vec2& pos, std::span<const double> param) const {
    const Weights w = weights(param);
    const std::size_t n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
    const double px = clamp_or_low(pos.x(), 0.0, 1.0) * (width_ - 1);
    const double py = clamp_or_low(pos.y(), 0.0, 1.0) * (height_ - 1);
    const int ix = std::min(static_cast<int>(px), width_ - 2);
    const int iy = std::min(static_cast<int>(py), height_ - 2);
    const double tx = px - ix, ty = py - iy;
    const std::size_t i = static_cast<std::size_t>(iy) * static_cast<std::size_t>(width_) +
                          static_cast<std::size_t>(ix);
    const std::size_t row = static_cast<std::size_t>(width_);
    const double v00 = lookup(data_, n, w, i), v10 = lookup(data_, n, w, i + 1),
                 v01 = lookup(data_, n, w, i + row), v11 = lookup(data_, n, w, i + row + 1);
    const double value =
        (1.0 - ty) * ((1.0 - tx) * v00 + tx * v10) + ty * ((1.0 - tx) * v01 + tx * v11);
    return conditional_cdf_.empty() ? value : value * (width_ - 1) * (height_ - 1);
}

BilinearWarp2D::Result BilinearWarp2D::sample(const Vec2& u, std::span<const double> param,
                                              bool avoid_extrema) const {
    PLUMAGE_CHECK(!conditional_cdf_.empty(), "warp: sample() on a table built without CDFs");
    const Weights w = weights(param);
    const std::size_t W = static_cast<std::size_t>(width_), H = static_cast<std::size_t>(height_);
    const std::size_t n = W * H;
    const double eps = avoid_extrema ? 0x1p-24 : 0.0;  // Mitsuba's float Epsilon
    double sx = clamp_or_low(u.x(), eps, 1.0 - eps);
    double sy = clamp_or_low(u.y(), eps, 1.0 - eps);

    // Row: the last node of the blended marginal CDF below sy, within [0, H − 2].
    auto marginal = [&](std::size_t i) { return lookup(marginal_cdf_, H, w, i); };
    std::size_t lo = 0, hi = H - 1;  // invariant: marginal(lo) < sy (or lo = 0)
    while (hi - lo > 1) {
        const std::size_t mid = (lo + hi) / 2;
        (marginal(mid) < sy ? lo : hi) = mid;
    }
    const std::size_t row = lo;
    sy -= marginal(row);
    const double r0 = lookup(conditional_cdf_, n, w, row * W + W - 1);
    const double r1 = lookup(conditional_cdf_, n, w, (row + 1) * W + W - 1);
    if (std::abs(r0 - r1) < 1e-4 * (r0 + r1)) {
        sy = 2.0 * sy / (r0 + r1);
    } else {
        sy = (r0 - std::sqrt(std::max(0.0, r0 * r0 - 2.0 * sy * (r0 - r1)))) / (r0 - r1);
    }

    // Column, in the row interpolated at sy.
    sx *= (1.0 - sy) * r0 + sy * r1;
    auto conditional = [&](std::size_t i) {
        return (1.0 - sy) * lookup(conditional_cdf_, n, w, row * W + i) +
               sy * lookup(conditional_cdf_, n, w, (row + 1) * W + i);
    };
    lo = 0;
    hi = W - 1;
    while (hi - lo > 1) {
        const std::size_t mid = (lo + hi) / 2;
        (conditional(mid) < sx ? lo : hi) = mid;
    }
    const std::size_t col = lo;
    sx -= conditional(col);
    const std::size_t i = row * W + col;
    const double v00 = lookup(data_, n, w, i), v10 = lookup(data_, n, w, i + 1),
                 v01 = lookup(data_, n, w, i + W), v11 = lookup(data_, n, w, i + W + 1);
    const double c0 = (1.0 - sy) * v00 + sy * v01, c1 = (1.0 - sy) * v10 + sy * v11;
    const bool constant = std::abs(c0 - c1) < 1e-4 * (c0 + c1);
    sx = constant ? 2.0 * sx : c0 - std::sqrt(std::max(0.0, c0 * c0 - 2.0 * sx * (c0 - c1)));
    const double divisor = constant ? c0 + c1 : c0 - c1;
    if (divisor != 0.0) sx /= divisor;  // a cell of zero density: its left edge, as Mitsuba
    return {Vec2((static_cast<double>(col) + sx) / static_cast<double>(W - 1),
                 (static_cast<double>(row) + sy) / static_cast<double>(H - 1)),
            ((1.0 - sx) * c0 + sx * c1) * static_cast<double>((W - 1) * (H - 1))};
}

BilinearWarp2D::Result BilinearWarp2D::invert(const Vec2& point,
                                              std::span<const double> param) const {
    PLUMAGE_CHECK(!conditional_cdf_.empty(), "warp: invert() on a table built without CDFs");
    const Weights w = weights(param);
    const std::size_t W = static_cast<std::size_t>(width_), H = static_cast<std::size_t>(height_);
    const std::size_t n = W * H;
    double sx = clamp_or_low(point.x(), 0.0, 1.0) * static_cast<double>(W - 1);
    double sy = clamp_or_low(point.y(), 0.0, 1.0) * static_cast<double>(H - 1);
    const std::size_t px = std::min(static_cast<std::size_t>(sx), W - 2);
    const std::size_t py = std::min(static_cast<std::size_t>(sy), H - 2);
    sx -= static_cast<double>(px);
    sy -= static_cast<double>(py);
    const std::size_t i = py * W + px;
    const double v00 = lookup(data_, n, w, i), v10 = lookup(data_, n, w, i + 1),
                 v01 = lookup(data_, n, w, i + W), v11 = lookup(data_, n, w, i + W + 1);
    const double c0 = (1.0 - sy) * v00 + sy * v01, c1 = (1.0 - sy) * v10 + sy * v11;
    const double pdf = (1.0 - sx) * c0 + sx * c1;
    // x: the conditional CDF of the row interpolated at sy, up to sx.
    sx *= c0 + 0.5 * sx * (c1 - c0);
    sx +=
        (1.0 - sy) * lookup(conditional_cdf_, n, w, i) + sy * lookup(conditional_cdf_, n, w, i + W);
    const double r0 = lookup(conditional_cdf_, n, w, py * W + W - 1);
    const double r1 = lookup(conditional_cdf_, n, w, py * W + 2 * W - 1);
    sx /= (1.0 - sy) * r0 + sy * r1;
    // y: the marginal CDF up to sy.
    sy *= r0 + 0.5 * sy * (r1 - r0);
    sy += lookup(marginal_cdf_, H, w, py);
    return {Vec2(sx, sy), pdf * static_cast<double>((W - 1) * (H - 1))};
}

// ---- settings and tables -------------------------------------------------------------------

void RglBsdfSettings::validate() const {
    require(!wavelengths_nm.empty(), kWhat, "wavelengths_nm: expected at least one wavelength");
    for (std::size_t k = 0; k < wavelengths_nm.size(); ++k) {
        require(std::isfinite(wavelengths_nm[k]) && wavelengths_nm[k] > 0.0 &&
                    wavelengths_nm[k] < 10000.0 &&
                    (k == 0 || wavelengths_nm[k] > wavelengths_nm[k - 1]),
                kWhat, "wavelengths_nm", wavelengths_nm[k],
                "increasing wavelengths in (0, 10000) nm");
    }
    require(theta_i_count >= 2 && theta_i_count <= 256, kWhat, "theta_i_count", theta_i_count,
            "an integer in [2, 256]");
    require(theta_max_deg > 0.0 && theta_max_deg <= 89.0, kWhat, "theta_max_deg", theta_max_deg,
            "a value in (0, 89] degrees");
    require(phi_i_count == 1 || (phi_i_count >= 3 && phi_i_count <= 361), kWhat, "phi_i_count",
            phi_i_count, "1 (isotropic) or an integer in [3, 361]");
    require(sample_resolution >= 2 && sample_resolution <= 512, kWhat, "sample_resolution",
            sample_resolution, "an integer in [2, 512]");
    require(vndf_resolution >= 2 && vndf_resolution <= 1024, kWhat, "vndf_resolution",
            vndf_resolution, "an integer in [2, 1024]");
    require(ndf_resolution >= 2 && ndf_resolution <= 1024, kWhat, "ndf_resolution", ndf_resolution,
            "an integer in [2, 1024]");
    require(ndf_floor > 0.0 && ndf_floor <= 1.0, kWhat, "ndf_floor", ndf_floor,
            "a value in (0, 1]");
    require(model_ndf_share >= 0.0 && model_ndf_share <= 1.0, kWhat, "model_ndf_share",
            model_ndf_share, "a value in [0, 1]");
    require(ndf_iterations >= 0 && ndf_iterations <= 1000, kWhat, "ndf_iterations", ndf_iterations,
            "an integer in [0, 1000]");
}

TensorFields RglBsdfTables::to_fields() const {
    const std::uint64_t n_phi = phi_i.size(), n_theta = theta_i.size(),
                        n_lambda = wavelengths.size();
    const std::uint64_t N = static_cast<std::uint64_t>(sample_resolution);
    TensorFields fields;
    fields["description"] =
        byte_field(std::vector<std::uint8_t>(description.begin(), description.end()));
    fields["jacobian"] = byte_field({static_cast<std::uint8_t>(jacobian ? 1 : 0)});
    fields["theta_i"] = float_field(theta_i, {n_theta});
    fields["phi_i"] = float_field(phi_i, {n_phi});
    fields["wavelengths"] = float_field(wavelengths, {n_lambda});
    const auto hd = static_cast<std::uint64_t>(ndf_height),
               wd = static_cast<std::uint64_t>(ndf_width);
    fields["ndf"] = float_field(ndf, {hd, wd});
    fields["sigma"] = float_field(sigma, {hd, wd});
    fields["vndf"] = float_field(vndf, {n_phi, n_theta, static_cast<std::uint64_t>(vndf_height),
                                        static_cast<std::uint64_t>(vndf_width)});
    fields["luminance"] = float_field(luminance, {n_phi, n_theta, N, N});
    fields["spectra"] = float_field(spectra, {n_phi, n_theta, n_lambda, N, N});
    return fields;
}

namespace {

const TensorField& require_field(const TensorFields& fields, const std::string& source,
                                 const std::string& name, TensorDtype dtype, std::size_t rank) {
    const auto it = fields.find(name);
    if (it == fields.end()) {
        throw InputError(
            fmt::format("{}: field '{}' is missing (a measured BRDF needs description, "
                        "jacobian, theta_i, phi_i, wavelengths, ndf, sigma, vndf, "
                        "luminance, spectra)",
                        source, name));
    }
    const TensorField& f = it->second;
    if (f.dtype != static_cast<std::uint8_t>(dtype)) {
        throw InputError(fmt::format("{}: field '{}': dtype code {}, expected {} ({})", source,
                                     name, f.dtype, static_cast<int>(dtype),
                                     dtype == TensorDtype::float32 ? "float32" : "uint8"));
    }
    if (f.shape.size() != rank) {
        throw InputError(fmt::format("{}: field '{}': rank {}, expected {}", source, name,
                                     f.shape.size(), rank));
    }
    return f;
}

std::vector<float> floats_of(const TensorField& f, const std::string& source,
                             const std::string& name) {
    std::vector<float> values(f.bytes.size() / sizeof(float));
    std::memcpy(values.data(), f.bytes.data(), values.size() * sizeof(float));
    for (std::size_t i = 0; i < values.size(); ++i) {
        if (!std::isfinite(values[i])) {
            throw InputError(
                fmt::format("{}: field '{}': element {} is not finite", source, name, i));
        }
    }
    return values;
}

void require_shape(bool ok, const std::string& source, const std::string& name,
                   const std::string& expected) {
    if (!ok) throw InputError(fmt::format("{}: field '{}': shape {}", source, name, expected));
}

}  // namespace

RglBsdfTables RglBsdfTables::from_fields(const TensorFields& fields, const std::string& source) {
    using enum TensorDtype;
    const auto& description = require_field(fields, source, "description", uint8, 1);
    const auto& jacobian = require_field(fields, source, "jacobian", uint8, 1);
    const auto& theta_i = require_field(fields, source, "theta_i", float32, 1);
    const auto& phi_i = require_field(fields, source, "phi_i", float32, 1);
    const auto& wavelengths = require_field(fields, source, "wavelengths", float32, 1);
    const auto& ndf = require_field(fields, source, "ndf", float32, 2);
    const auto& sigma = require_field(fields, source, "sigma", float32, 2);
    const auto& vndf = require_field(fields, source, "vndf", float32, 4);
    const auto& luminance = require_field(fields, source, "luminance", float32, 4);
    const auto& spectra = require_field(fields, source, "spectra", float32, 5);

    const std::uint64_t n_phi = phi_i.shape[0], n_theta = theta_i.shape[0],
                        n_lambda = wavelengths.shape[0];
    require_shape(jacobian.shape[0] == 1, source, "jacobian", "must be [1]");
    require_shape(n_phi >= 1 && n_theta >= 1 && n_lambda >= 1, source, "theta_i/phi_i/wavelengths",
                  "must have at least one node each");
    require_shape(ndf.shape[0] >= 2 && ndf.shape[1] >= 2, source, "ndf", "must be at least 2 x 2");
    require_shape(sigma.shape[0] >= 2 && sigma.shape[1] >= 2, source, "sigma",
                  "must be at least 2 x 2");
    require_shape(vndf.shape[0] == n_phi && vndf.shape[1] == n_theta && vndf.shape[2] >= 2 &&
                      vndf.shape[3] >= 2,
                  source, "vndf", "must be [n_phi_i, n_theta_i, >= 2, >= 2]");
    require_shape(spectra.shape[0] == n_phi && spectra.shape[1] == n_theta &&
                      spectra.shape[2] == n_lambda && spectra.shape[3] == spectra.shape[4] &&
                      spectra.shape[3] >= 2,
                  source, "spectra", "must be [n_phi_i, n_theta_i, n_wavelengths, N, N], N >= 2");
    require_shape(luminance.shape[0] == n_phi && luminance.shape[1] == n_theta &&
                      luminance.shape[2] == spectra.shape[3] &&
                      luminance.shape[3] == spectra.shape[4],
                  source, "luminance", "must be [n_phi_i, n_theta_i, N, N] as spectra's last two");
    // Our tables share one grid for ndf and sigma (the readers allow them to differ, we do not
    // write such files and keep one width/height).
    require_shape(sigma.shape == ndf.shape, source, "sigma", "must equal ndf's");

    RglBsdfTables t;
    t.description.assign(description.bytes.begin(), description.bytes.end());
    if (jacobian.bytes[0] > 1) {
        throw InputError(fmt::format("{}: field 'jacobian': value {}, expected 0 or 1", source,
                                     jacobian.bytes[0]));
    }
    t.jacobian = jacobian.bytes[0] == 1;
    t.theta_i = floats_of(theta_i, source, "theta_i");
    t.phi_i = floats_of(phi_i, source, "phi_i");
    t.wavelengths = floats_of(wavelengths, source, "wavelengths");
    for (const auto& [name, nodes] :
         {std::pair{"theta_i", &t.theta_i}, std::pair{"phi_i", &t.phi_i},
          std::pair{"wavelengths", &t.wavelengths}}) {
        for (std::size_t k = 1; k < nodes->size(); ++k) {
            if (!((*nodes)[k] > (*nodes)[k - 1])) {
                throw InputError(fmt::format("{}: field '{}': nodes must increase (element {})",
                                             source, name, k));
            }
        }
    }
    t.ndf_height = static_cast<int>(ndf.shape[0]);
    t.ndf_width = static_cast<int>(ndf.shape[1]);
    t.ndf = floats_of(ndf, source, "ndf");
    t.sigma = floats_of(sigma, source, "sigma");
    for (float v : t.ndf) {
        if (v < 0.0f) throw InputError(fmt::format("{}: field 'ndf': negative value", source));
    }
    for (float v : t.sigma) {
        if (!(v > 0.0f)) {
            throw InputError(fmt::format("{}: field 'sigma': values must be > 0", source));
        }
    }
    t.vndf_height = static_cast<int>(vndf.shape[2]);
    t.vndf_width = static_cast<int>(vndf.shape[3]);
    t.vndf = floats_of(vndf, source, "vndf");
    t.sample_resolution = static_cast<int>(spectra.shape[3]);
    t.luminance = floats_of(luminance, source, "luminance");
    t.spectra = floats_of(spectra, source, "spectra");
    for (float v : t.vndf) {
        if (v < 0.0f) throw InputError(fmt::format("{}: field 'vndf': negative value", source));
    }
    return t;
}

// ---- the reader ----------------------------------------------------------------------------

namespace {

std::vector<double> doubles(const std::vector<float>& v) { return {v.begin(), v.end()}; }

}  // namespace

RglBsdf::RglBsdf(RglBsdfTables tables) : tables_(std::move(tables)) {
    const auto& t = tables_;
    isotropic_ = t.phi_i.size() <= 2;
    if (!isotropic_) {
        const double reduction = std::rint(kTwoPi / (t.phi_i.back() - t.phi_i.front()));
        require(reduction == 1.0 || reduction == 2.0 || reduction == 4.0, kWhat,
                "phi_i: the azimuth nodes must span 2π, π or π/2 (Mitsuba's reductions 1, 2, 4)");
        reduction_ = static_cast<int>(reduction);
    }
    const std::vector<double> theta = doubles(t.theta_i), phi = doubles(t.phi_i),
                              lambda = doubles(t.wavelengths);
    ndf_ = BilinearWarp2D(t.ndf, t.ndf_width, t.ndf_height, {}, false);
    sigma_ = BilinearWarp2D(t.sigma, t.ndf_width, t.ndf_height, {}, false);
    // The warp knows a slice of a table, not which of the file's fields the table is.
    try {
        vndf_ = BilinearWarp2D(t.vndf, t.vndf_width, t.vndf_height, {phi, theta}, true);
    } catch (const InputError& e) {
        throw InputError(fmt::format("field 'vndf': {}", e.what()));
    }
    try {
        luminance_ = BilinearWarp2D(t.luminance, t.sample_resolution, t.sample_resolution,
                                    {phi, theta}, true);
    } catch (const InputError& e) {
        throw InputError(fmt::format("field 'luminance': {}", e.what()));
    }
    spectra_ = BilinearWarp2D(t.spectra, t.sample_resolution, t.sample_resolution,
                              {phi, theta, lambda}, false);
}

RglBsdf RglBsdf::read(const std::filesystem::path& path) {
    RglBsdfTables tables = RglBsdfTables::from_fields(read_tensor_file(path), path.string());
    try {
        return RglBsdf(std::move(tables));
    } catch (const InputError& e) {
        throw InputError(fmt::format("{}: {}", path.string(), e.what()));
    }
}

double RglBsdf::eval_mitsuba(const Vec3d& wi_in, const Vec3d& wo_in, double lambda_nm) const {
    if (!(wi_in.z() > 0.0 && wo_in.z() > 0.0)) return 0.0;
    const HalfVectorFrame h = half_vector_frame(wi_in, wo_in);
    const Vec2 u_wi(theta_to_u(h.theta_i), phi_to_u(h.phi_i));
    const double params[2] = {h.phi_i, h.theta_i};
    const Vec2 s = vndf_.invert(h.u_m, params).point;
    const double params_spectra[3] = {h.phi_i, h.theta_i, lambda_nm};
    double value = spectra_.eval(s, params_spectra);
    if (tables_.jacobian) value *= ndf_.eval(h.u_m) / (4.0 * sigma_.eval(u_wi));
    return value;
}

RglBsdf::HalfVectorFrame RglBsdf::half_vector_frame(const Vec3d& wi_in, const Vec3d& wo_in) const {
    HalfVectorFrame h;
    h.wi = wi_in;
    Vec3d wo = wo_in;
    fold(h.wi, wo);
    h.m = (h.wi + wo).normalized();
    h.theta_i = elevation(h.wi);
    h.phi_i = std::atan2(h.wi.y(), h.wi.x());
    const double theta_m = elevation(h.m), phi_m = std::atan2(h.m.y(), h.m.x());
    h.u_m = Vec2(theta_to_u(theta_m), phi_to_u(isotropic_ ? phi_m - h.phi_i : phi_m));
    h.u_m.y() -= std::floor(h.u_m.y());
    return h;
}

double RglBsdf::eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const {
    if (!(wi.z() > 0.0 && wo.z() > 0.0)) return 0.0;
    return eval_mitsuba(wo, wi, lambda_nm) / wi.z();
}

Vec2 RglBsdf::warp_sample(const Vec3d& wv, const Vec2& s) const {
    const double params[2] = {std::atan2(wv.y(), wv.x()), elevation(wv)};
    return vndf_.sample(s, params, false).point;
}

double RglBsdf::pdf_mitsuba(const Vec3d& wi_in, const Vec3d& wo_in) const {
    if (!(wi_in.z() > 0.0 && wo_in.z() > 0.0)) return 0.0;
    const HalfVectorFrame h = half_vector_frame(wi_in, wo_in);
    const double params[2] = {h.phi_i, h.theta_i};
    const auto [s, vndf_pdf] = vndf_.invert(h.u_m, params);
    const double sin_theta_m = std::sqrt(h.m.x() * h.m.x() + h.m.y() * h.m.y());
    const double jacobian =
        std::max(2.0 * kPi * kPi * h.u_m.x() * sin_theta_m, 1e-6) * 4.0 * h.wi.dot(h.m);
    return vndf_pdf * luminance_.eval(s, params) / jacobian;
}

void RglBsdf::fold(Vec3d& wi, Vec3d& wo) const {
    if (reduction_ < 2) return;  // folded layouts: mirror both directions into the stored wedge
    const double sy = wi.y() >= 0.0 ? -1.0 : 1.0;
    const double sx = reduction_ == 4 ? (wi.x() >= 0.0 ? -1.0 : 1.0) : sy;
    wi.x() *= sx;
    wi.y() *= sy;
    wo.x() *= sx;
    wo.y() *= sy;
}

// ---- the writer ----------------------------------------------------------------------------

namespace {

// Quadrature over the hemisphere of unit-square midpoints: ∫ g(m) dm ≈ Σ w_j g(m_j).
struct HemisphereQuadrature {
    std::vector<Vec3d> m;
    std::vector<Vec2> u;
    std::vector<double> weight;
};

HemisphereQuadrature hemisphere_quadrature(int n_theta, int n_phi) {
    HemisphereQuadrature q;
    const double du_x = 1.0 / n_theta, du_y = 1.0 / n_phi;
    for (int b = 0; b < n_phi; ++b) {
        for (int a = 0; a < n_theta; ++a) {
            const Vec2 u((a + 0.5) * du_x, (b + 0.5) * du_y);
            q.u.push_back(u);
            q.m.push_back(spherical(u_to_theta(u.x()), u_to_phi(u.y())));
            q.weight.push_back(square_jacobian(u.x()) * du_x * du_y);
        }
    }
    return q;
}

// σ(ω) = ∫ D(m) ⟨ω, m⟩⁺ dm, D given at the quadrature nodes.
double projected_area(const HemisphereQuadrature& q, const std::vector<double>& d_at_nodes,
                      const Vec3d& w) {
    double sum = 0.0;
    for (std::size_t j = 0; j < q.m.size(); ++j) {
        const double c = w.dot(q.m[j]);
        if (c > 0.0) sum += q.weight[j] * d_at_nodes[j] * c;
    }
    return sum;
}

std::vector<double> at_nodes(const HemisphereQuadrature& q, const std::vector<float>& grid,
                             int width, int height) {
    const BilinearWarp2D interpolant(grid, width, height, {}, false);
    std::vector<double> out(q.u.size());
    for (std::size_t j = 0; j < q.u.size(); ++j) out[j] = interpolant.eval(q.u[j]);
    return out;
}

double cosine_normalisation(const HemisphereQuadrature& q, const std::vector<double>& d_at_nodes) {
    double sum = 0.0;
    for (std::size_t j = 0; j < q.m.size(); ++j) sum += q.weight[j] * d_at_nodes[j] * q.m[j].z();
    return sum;
}

// The first exception thrown inside an OpenMP loop (exceptions must not leave the region).
class FirstError {
public:
    template <typename Fn>
    void run(Fn&& fn) {
        if (failed_.load(std::memory_order_relaxed)) return;
        try {
            fn();
        } catch (...) {
#pragma omp critical(rgl_bsdf_first_error)
            if (!error_) error_ = std::current_exception();
            failed_ = true;
        }
    }
    void rethrow() const {
        if (error_) std::rethrow_exception(error_);
    }

private:
    std::atomic<bool> failed_{false};
    std::exception_ptr error_;
};

double checked(double value, const char* what, const Vec3d& wi, const Vec3d& wo, double lambda) {
    PLUMAGE_CHECK(std::isfinite(value) && value >= 0.0,
                  fmt::format("rgl_bsdf: {} f = {} at wi = ({}, {}, {}), wo = ({}, {}, {}), {} nm",
                              what, value, wi.x(), wi.y(), wi.z(), wo.x(), wo.y(), wo.z(), lambda));
    return value;
}

// d (normalised, ∫ d cos θ_m dm = 1) as the stored NDF: φ = ±π rows made one value, a fraction
// ndf_floor of the cosine NDF mixed in (see the header).
std::vector<float> floored_ndf(std::vector<double> d, const RglBsdfSettings& s, std::size_t W,
                               std::size_t H) {
    if (s.phi_i_count != 1) {  // φ = −π and φ = π are one direction: one value
        for (std::size_t a = 0; a < W; ++a) d[(H - 1) * W + a] = d[a];
    }
    std::vector<float> grid(W * H);
    for (std::size_t k = 0; k < W * H; ++k) {
        grid[k] = static_cast<float>((1.0 - s.ndf_floor) * d[k] + s.ndf_floor / kPi);
    }
    return grid;
}

// The model's own NDF (settings.model_ndf), each node its cell's solid-angle mean, normalised.
std::vector<double> model_ndf_grid(const RglBsdfSettings& s, int width, int height,
                                   const HemisphereQuadrature& q) {
    const std::size_t W = static_cast<std::size_t>(width), H = static_cast<std::size_t>(height);
    const bool isotropic = s.phi_i_count == 1;
    constexpr int kPoints = 8;
    const double du_x = 1.0 / static_cast<double>(W - 1), du_y = 1.0 / static_cast<double>(H - 1);
    std::vector<double> d(W * H, 0.0);
    FirstError error;
#pragma omp parallel for schedule(dynamic, 4)
    for (std::size_t k = 0; k < W * H; ++k) {
        error.run([&] {
            const double cx = static_cast<double>(k % W) * du_x;
            const double cy = static_cast<double>(k / W) * du_y;
            double sum = 0.0, weight = 0.0;
            for (int i = 0; i < kPoints; ++i) {
                const double ux = std::clamp(cx + ((i + 0.5) / kPoints - 0.5) * du_x, 0.0, 1.0);
                const double theta = std::min(u_to_theta(ux), 89.9 * kDeg);
                const double w_theta = std::max(square_jacobian(ux), 1e-12);
                for (int j = 0; j < kPoints; ++j) {
                    const double uy =
                        isotropic ? (j + 0.5) / kPoints : cy + ((j + 0.5) / kPoints - 0.5) * du_y;
                    const double value = s.model_ndf(spherical(theta, u_to_phi(uy)));
                    PLUMAGE_CHECK(
                        std::isfinite(value) && value >= 0.0,
                        fmt::format("rgl_bsdf: model NDF = {} at θ_m = {} rad", value, theta));
                    sum += w_theta * value;
                    weight += w_theta;
                }
            }
            d[k] = sum / weight;
        });
    }
    error.rethrow();
    std::vector<float> grid(d.begin(), d.end());
    const double norm = cosine_normalisation(q, at_nodes(q, grid, width, height));
    require(norm > 0.0, kWhat, "model_ndf: the model's NDF is zero over the upper hemisphere");
    for (double& v : d) v /= norm;
    return d;
}

// The NDF ([H][W], normalised) by Dupuy & Jakob's retro-reflection power iteration (see the
// header).
std::vector<double> estimate_ndf(const BrdfFunction& f, const RglBsdfSettings& s, int width,
                                 int height, const HemisphereQuadrature& q) {
    const std::size_t W = static_cast<std::size_t>(width), H = static_cast<std::size_t>(height);
    const bool isotropic = s.phi_i_count == 1;
    // Directions of the grid nodes; isotropic grids use φ = 0 for every row.
    std::vector<Vec3d> node(W * H);
    for (std::size_t b = 0; b < H; ++b) {
        for (std::size_t a = 0; a < W; ++a) {
            const double theta = u_to_theta(static_cast<double>(a) / static_cast<double>(W - 1));
            const double phi =
                isotropic ? 0.0 : u_to_phi(static_cast<double>(b) / static_cast<double>(H - 1));
            node[b * W + a] = spherical(theta, phi);
        }
    }
    // Retro-reflection, averaged over the wavelengths; the grazing row is evaluated at 89°
    // (models divide by cos θ), its weight cos θ = 0 removes it anyway.
    std::vector<double> retro(W * H, 0.0), cos_theta(W * H);
    const std::size_t distinct = isotropic ? W : W * H;
    FirstError error;
#pragma omp parallel for schedule(dynamic, 4)
    for (std::size_t k = 0; k < distinct; ++k) {
        error.run([&] {
            const double theta = std::min(elevation(node[k]), 89.0 * kDeg);
            const Vec3d w = spherical(theta, std::atan2(node[k].y(), node[k].x()));
            double sum = 0.0;
            for (double lambda : s.wavelengths_nm) {
                sum += checked(f(w, w, lambda), "retro-reflection", w, w, lambda);
            }
            retro[k] = sum / static_cast<double>(s.wavelengths_nm.size());
        });
    }
    error.rethrow();
    for (std::size_t k = distinct; k < W * H; ++k) retro[k] = retro[k % W];
    for (std::size_t k = 0; k < W * H; ++k) cos_theta[k] = node[k].z();

    std::vector<float> grid(W * H, static_cast<float>(1.0 / kPi));
    std::vector<double> d(W * H, 1.0 / kPi), sigma(W * H);
    for (int it = 0; it < s.ndf_iterations; ++it) {
        throw_if_interrupted("the NDF estimate of a .bsdf export");
        for (std::size_t k = 0; k < W * H; ++k) grid[k] = static_cast<float>(d[k]);
        const std::vector<double> d_nodes = at_nodes(q, grid, width, height);
#pragma omp parallel for schedule(static)
        for (std::size_t k = 0; k < distinct; ++k) sigma[k] = projected_area(q, d_nodes, node[k]);
        for (std::size_t k = distinct; k < W * H; ++k) sigma[k] = sigma[k % W];
        std::vector<double> next(W * H);
        for (std::size_t k = 0; k < W * H; ++k) next[k] = retro[k] * cos_theta[k] * sigma[k];
        std::vector<float> next_grid(next.begin(), next.end());
        const double norm = cosine_normalisation(q, at_nodes(q, next_grid, width, height));
        if (!(norm > 0.0)) {  // no retro-reflection at all: keep the cosine NDF
            std::fill(d.begin(), d.end(), 1.0 / kPi);
            break;
        }
        double change = 0.0, largest = 0.0;
        for (std::size_t k = 0; k < W * H; ++k) {
            change = std::max(change, std::abs(next[k] / norm - d[k]));
            largest = std::max(largest, next[k] / norm);
            d[k] = next[k] / norm;
        }
        if (change <= 1e-6 * largest) break;  // converged to well below float32's rounding
    }
    return d;
}

// The stored NDF: the retro-reflection estimate, the model's own NDF or a mixture, with the
// cosine NDF mixed in.
std::vector<float> ndf_grid(const BrdfFunction& f, const RglBsdfSettings& s, int width, int height,
                            const HemisphereQuadrature& q) {
    const std::size_t W = static_cast<std::size_t>(width), H = static_cast<std::size_t>(height);
    const double share = s.model_ndf ? s.model_ndf_share : 0.0;
    std::vector<double> d(W * H, 0.0);
    if (share < 1.0) d = estimate_ndf(f, s, width, height, q);
    if (share > 0.0) {
        const std::vector<double> model = model_ndf_grid(s, width, height, q);
        for (std::size_t k = 0; k < W * H; ++k) d[k] = (1.0 - share) * d[k] + share * model[k];
    }
    return floored_ndf(std::move(d), s, W, H);
}

std::vector<double> luminance_weights(const std::vector<double>& wavelengths) {
    std::vector<double> w(wavelengths.size(), 1.0);
    if (wavelengths.size() < 2) return w;
    double total = 0.0;
    for (std::size_t k = 0; k < wavelengths.size(); ++k) {
        w[k] = optics::colour_matching(wavelengths[k]).y;
        total += w[k];
    }
    if (!(total > 0.0)) std::fill(w.begin(), w.end(), 1.0);  // no visible wavelength
    return w;
}

}  // namespace

namespace {

// θ_i, φ_i and wavelength nodes, as float32.
void parameter_nodes(const RglBsdfSettings& settings, RglBsdfTables& t) {
    for (int k = 0; k < settings.theta_i_count; ++k) {
        t.theta_i.push_back(
            static_cast<float>(settings.theta_max_deg * kDeg * k / (settings.theta_i_count - 1)));
    }
    if (settings.phi_i_count == 1) {
        t.phi_i = {0.0f};
    } else {
        for (int k = 0; k < settings.phi_i_count; ++k) {
            t.phi_i.push_back(static_cast<float>(-kPi + kTwoPi * k / (settings.phi_i_count - 1)));
        }
        // float(±π) lies outside [−π, π]: a direction built from it comes back from atan2 at
        // the other end of the circle. The end nodes are rounded towards zero instead (3e-7
        // rad inside), so each node's direction reads back on its own node.
        t.phi_i.front() = std::nextafter(static_cast<float>(-kPi), 0.0f);
        t.phi_i.back() = std::nextafter(static_cast<float>(kPi), 0.0f);
    }
    for (double lambda : settings.wavelengths_nm) {
        t.wavelengths.push_back(static_cast<float>(lambda));
    }
}

// The NDF estimate and σ = ∫ D ⟨ω, m⟩⁺ dm of the stored NDF, on one grid (two identical φ rows
// when isotropic).
void ndf_and_sigma(const BrdfFunction& f, const RglBsdfSettings& settings, RglBsdfTables& t) {
    const bool isotropic = settings.phi_i_count == 1;
    t.ndf_width = settings.ndf_resolution;
    t.ndf_height = isotropic ? 2 : settings.ndf_resolution;
    const HemisphereQuadrature q =
        hemisphere_quadrature(std::max(64, 2 * t.ndf_width), std::max(64, 2 * t.ndf_height));
    t.ndf = ndf_grid(f, settings, t.ndf_width, t.ndf_height, q);
    const std::vector<double> d_nodes = at_nodes(q, t.ndf, t.ndf_width, t.ndf_height);
    const std::size_t W = static_cast<std::size_t>(t.ndf_width);
    const std::size_t H = static_cast<std::size_t>(t.ndf_height);
    t.sigma.resize(W * H);
#pragma omp parallel for schedule(static)
    for (std::size_t k = 0; k < W * H; ++k) {
        const std::size_t a = k % W, b = k / W;
        const double theta = u_to_theta(static_cast<double>(a) / static_cast<double>(W - 1));
        // Row H − 1 (φ = π) is row 0's direction (φ = −π): computed as that one.
        const double phi =
            isotropic
                ? 0.0
                : (b == H - 1 ? -kPi
                              : u_to_phi(static_cast<double>(b) / static_cast<double>(H - 1)));
        t.sigma[k] = static_cast<float>(projected_area(q, d_nodes, spherical(theta, phi)));
    }
}

// The slices of one parameter direction (θ_i node k, φ_i node p) and what they share.
struct SliceContext {
    const RglBsdfTables& t;
    bool isotropic;
    BilinearWarp2D ndf, sigma;
    explicit SliceContext(const RglBsdfTables& tables)
        : t(tables),
          isotropic(tables.phi_i.size() == 1),
          ndf(tables.ndf, tables.ndf_width, tables.ndf_height, {}, false),
          sigma(tables.sigma, tables.ndf_width, tables.ndf_height, {}, false) {}
    std::size_t n_theta() const { return t.theta_i.size(); }
    // Slices to compute: the last φ node repeats the first (same direction) when anisotropic.
    std::size_t computed() const { return (isotropic ? 1 : t.phi_i.size() - 1) * n_theta(); }
    double phi(std::size_t slice) const { return t.phi_i[slice / n_theta()]; }
    double theta(std::size_t slice) const { return t.theta_i[slice % n_theta()]; }
    Vec3d direction(std::size_t slice) const { return spherical(theta(slice), phi(slice)); }
    double sigma_of(std::size_t slice) const {
        return sigma.eval(Vec2(theta_to_u(theta(slice)), phi_to_u(phi(slice))));
    }
    // The half vector of a point u_m of the unit square (relative azimuth when isotropic).
    Vec3d half_vector(std::size_t slice, const Vec2& u_m) const {
        return spherical(u_to_theta(u_m.x()), u_to_phi(u_m.y()) + (isotropic ? phi(slice) : 0.0));
    }
    // Anisotropic tables: the φ = π slices are copies of the φ = −π ones.
    void repeat_first_phi(std::vector<float>& table, std::size_t per_slice) const {
        if (isotropic) return;
        const std::size_t block = n_theta() * per_slice;
        std::copy_n(table.begin(), block,
                    table.begin() + static_cast<std::ptrdiff_t>((t.phi_i.size() - 1) * block));
    }
};

// vndf: D(m) ⟨ω_v, m⟩⁺ J(u) / σ(ω_v) on the u_m nodes.
void vndf_tables(const RglBsdfSettings& settings, const SliceContext& c, RglBsdfTables& t) {
    t.vndf_width = t.vndf_height = settings.vndf_resolution;
    const std::size_t W = static_cast<std::size_t>(t.vndf_width), n = W * W;
    t.vndf.assign(t.phi_i.size() * c.n_theta() * n, 0.0f);
#pragma omp parallel for schedule(dynamic, 1)
    for (std::size_t slice = 0; slice < c.computed(); ++slice) {
        const Vec3d wv = c.direction(slice);
        const double sigma_v = c.sigma_of(slice);
        float* out = t.vndf.data() + slice * n;
        for (std::size_t i = 0; i < n; ++i) {
            const Vec2 u(static_cast<double>(i % W) / static_cast<double>(W - 1),
                         static_cast<double>(i / W) / static_cast<double>(W - 1));
            const double cosine = std::max(0.0, wv.dot(c.half_vector(slice, u)));
            out[i] = static_cast<float>(c.ndf.eval(u) * cosine * square_jacobian(u.x()) / sigma_v);
        }
    }
    c.repeat_first_phi(t.vndf, n);
}

// spectra and luminance of one slice on the sample square's nodes: the light direction is the
// reflection of ω_v about the warped half vector; spectra = q · 4σ / D (jacobian = 1).
void spectra_slice(const BrdfFunction& f, const RglBsdfSettings& settings, const SliceContext& c,
                   const BilinearWarp2D& vndf, const std::vector<double>& y_weight,
                   std::size_t slice, RglBsdfTables& t) {
    const std::size_t N = static_cast<std::size_t>(t.sample_resolution);
    const std::size_t n_lambda = t.wavelengths.size();
    const double y_total = std::accumulate(y_weight.begin(), y_weight.end(), 0.0);
    const Vec3d wv = c.direction(slice);
    const double params[2] = {c.phi(slice), c.theta(slice)};
    const double four_sigma = 4.0 * c.sigma_of(slice);
    float* spectra = t.spectra.data() + slice * n_lambda * N * N;
    float* luminance = t.luminance.data() + slice * N * N;
    float max_luminance = 0.0f;
    for (std::size_t i = 0; i < N * N; ++i) {
        const Vec2 s(static_cast<double>(i % N) / static_cast<double>(N - 1),
                     static_cast<double>(i / N) / static_cast<double>(N - 1));
        const Vec2 u_m = vndf.sample(s, params, false).point;
        const Vec3d m = c.half_vector(slice, u_m);
        const Vec3d wl = (2.0 * wv.dot(m) * m - wv).normalized();
        const double scale = four_sigma / c.ndf.eval(u_m);
        double lum = 0.0;
        for (std::size_t l = 0; l < n_lambda; ++l) {
            double value = 0.0;
            if (wl.z() > 0.0) {
                const double lambda = settings.wavelengths_nm[l];
                value = checked(f(wl, wv, lambda), "", wl, wv, lambda) * wl.z() * scale;
            }
            spectra[l * N * N + i] = static_cast<float>(value);
            lum += y_weight[l] * static_cast<double>(static_cast<float>(value));
        }
        luminance[i] = static_cast<float>(lum / y_total);
        max_luminance = std::max(max_luminance, luminance[i]);
    }
    const float floor = max_luminance > 0.0f ? 1e-3f * max_luminance : 1.0f;
    for (std::size_t i = 0; i < N * N; ++i) luminance[i] = std::max(luminance[i], floor);
}

void spectra_tables(const BrdfFunction& f, const RglBsdfSettings& settings, const SliceContext& c,
                    RglBsdfTables& t) {
    const BilinearWarp2D vndf(t.vndf, t.vndf_width, t.vndf_height,
                              {doubles(t.phi_i), doubles(t.theta_i)}, true);
    t.sample_resolution = settings.sample_resolution;
    const std::size_t n = static_cast<std::size_t>(t.sample_resolution * t.sample_resolution);
    const std::size_t slices = t.phi_i.size() * c.n_theta();
    t.spectra.assign(slices * t.wavelengths.size() * n, 0.0f);
    t.luminance.assign(slices * n, 0.0f);
    const std::vector<double> y_weight = luminance_weights(settings.wavelengths_nm);
    std::atomic<bool> stopped{false};
    std::atomic<std::size_t> done{0};
    const std::size_t total = c.computed();
    FirstError error;
#pragma omp parallel for schedule(dynamic, 1)
    for (std::size_t slice = 0; slice < total; ++slice) {
        if (stopped.load(std::memory_order_relaxed) || interrupt_requested()) {
            stopped = true;
            continue;
        }
        error.run([&] { spectra_slice(f, settings, c, vndf, y_weight, slice, t); });
        const std::size_t finished = ++done;
        // A line at each quarter (the spectra are nearly all of an export's time).
        if (settings.progress && finished < total &&
            4 * finished / total > 4 * (finished - 1) / total) {
#pragma omp critical(rgl_bsdf_progress)
            settings.progress(fmt::format("spectra: {} of {} view directions", finished, total));
        }
    }
    error.rethrow();
    if (stopped) throw_if_interrupted("finishing a .bsdf export");
    c.repeat_first_phi(t.spectra, t.wavelengths.size() * n);
    c.repeat_first_phi(t.luminance, n);
}

}  // namespace

RglBsdfTables tabulate_rgl_bsdf(const BrdfFunction& f, const RglBsdfSettings& settings) {
    settings.validate();
    RglBsdfTables t;
    t.description = settings.description;
    t.jacobian = true;
    parameter_nodes(settings, t);
    const auto say = [&](const std::string& step) {
        if (settings.progress) settings.progress(step);
    };
    say(fmt::format("NDF and sigma ({} × {}, {})", settings.ndf_resolution,
                    settings.phi_i_count == 1 ? 2 : settings.ndf_resolution,
                    settings.model_ndf ? "the model's own NDF" : "retro-reflection estimate"));
    ndf_and_sigma(f, settings, t);
    const SliceContext context(t);
    say(fmt::format("vndf ({} view directions, {}²)", context.computed(),
                    settings.vndf_resolution));
    vndf_tables(settings, context, t);
    say(fmt::format("spectra ({} view directions × {}² × {} wavelengths)", context.computed(),
                    settings.sample_resolution, settings.wavelengths_nm.size()));
    spectra_tables(f, settings, context, t);
    return t;
}

RglBsdfTables tabulate_rgl_bsdf(const Scatterer& scatterer, const RglBsdfSettings& settings) {
    require(scatterer.can_evaluate(), kWhat,
            fmt::format("model '{}' cannot evaluate its BSDF (only analytic models can be "
                        "tabulated; measure a simulation into a record instead)",
                        scatterer.name()));
    return tabulate_rgl_bsdf([&scatterer](const Vec3d& wi, const Vec3d& wo,
                                          double lambda) { return scatterer.eval(wi, wo, lambda); },
                             settings);
}

void write_rgl_bsdf(const std::filesystem::path& path, const RglBsdfTables& tables) {
    write_tensor_file(path, tables.to_fields());
}

// ---- between-node accuracy -----------------------------------------------------------------

namespace {

// Uniform in solid angle over θ ≤ θ_max.
Vec3d uniform_direction(std::mt19937_64& rng, double cos_max) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const double cos_theta = 1.0 - unit(rng) * (1.0 - cos_max);
    return spherical(std::acos(cos_theta), kTwoPi * unit(rng));
}

double quantile(std::vector<double> values, double q) {
    if (values.empty()) return 0.0;
    const std::size_t k = std::min(
        values.size() - 1, static_cast<std::size_t>(q * static_cast<double>(values.size())));
    std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
    return values[k];
}

}  // namespace

InterpolationError interpolation_error(const BrdfFunction& f, const RglBsdf& file, int pairs,
                                       double theta_max_deg, std::uint64_t seed) {
    PLUMAGE_CHECK(pairs > 0 && theta_max_deg > 0.0 && theta_max_deg < 90.0,
                  "interpolation_error: pairs > 0 and θ_max in (0, 90) degrees");
    const std::vector<float>& lambdas = file.tables().wavelengths;
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const double cos_max = std::cos(theta_max_deg * kDeg);
    const std::size_t n = static_cast<std::size_t>(pairs);
    std::vector<Vec3d> wi(n), wo(n);
    std::vector<double> lambda(n), truth(n), read(n);
    for (std::size_t k = 0; k < n; ++k) {
        wi[k] = uniform_direction(rng, cos_max);
        wo[k] = uniform_direction(rng, cos_max);
        lambda[k] = lambdas.front() + unit(rng) * (lambdas.back() - lambdas.front());
    }
    FirstError error;
#pragma omp parallel for schedule(dynamic, 16)
    for (std::size_t k = 0; k < n; ++k) {
        error.run([&] {
            truth[k] = checked(f(wi[k], wo[k], lambda[k]), "", wi[k], wo[k], lambda[k]);
            read[k] = file.eval(wi[k], wo[k], lambda[k]);
        });
    }
    error.rethrow();
    InterpolationError e;
    e.pairs = pairs;
    std::vector<double> relative;
    RelativeL1 weighted;
    for (std::size_t k = 0; k < n; ++k) {
        weighted.add(read[k], truth[k], wi[k].z());
        if (!(truth[k] > 0.0)) continue;
        relative.push_back(std::abs(read[k] / truth[k] - 1.0));
        e.worst = std::max(e.worst, read[k] > 0.0 ? std::max(read[k] / truth[k], truth[k] / read[k])
                                                  : std::numeric_limits<double>::infinity());
    }
    e.positive = static_cast<int>(relative.size());
    e.median = quantile(relative, 0.5);
    e.p95 = quantile(relative, 0.95);
    e.weighted = weighted.value();
    return e;
}

}  // namespace plumage::gonio
