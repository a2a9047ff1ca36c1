#include "virtual_gonio/btf.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <string_view>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/cpu_time.h"
#include "common/distributed.h"
#include "common/error.h"
#include "common/interrupt.h"
#include "common/require.h"
#include "common/seed.h"
#include "virtual_gonio/display_colour.h"
#include "virtual_gonio/hdf5_file.h"
#include "virtual_gonio/record_provenance.h"

namespace plumage::gonio {
namespace {

constexpr std::uint64_t kChunk = 8192;

// The name that prefixes this file's input errors.
constexpr std::string_view kWhat = "btf";

}  // namespace

void BtfConfig::validate() const {
    require(!pairs.empty(), kWhat, "no direction pairs");
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        require(pairs[i].wi.z() > 0.0 && pairs[i].wo.z() > std::sin(detector_half_angle_rad), kWhat,
                fmt::format("pair {}: light and detector cone must be above the patch", i));
    }
    require(!wavelengths_nm.empty(), kWhat, "no wavelengths");
    require(std::isfinite(patch_size_um) && patch_size_um > 0.0, kWhat,
            "patch size must be > 0 um");
    require(pixels >= 1 && pixels <= 1024, kWhat,
            fmt::format("pixels = {}: expected 1..1024", pixels));
    require(detector_half_angle_rad > 0.0 && detector_half_angle_rad < 0.5, kWhat,
            "detector half-angle must be in (0, 0.5) rad");
    require(quanta_per_light >= 1, kWhat, "quanta_per_light must be >= 1");
}

namespace {

// Pair indices per distinct light direction, in order of first appearance. Pairs that share a
// light direction share its quanta: each quantum counts for every detector cone it enters (the
// 61 × 60 set costs 61 light directions, not 3660 pairs).
std::vector<std::vector<std::size_t>> pairs_by_light(const std::vector<DirectionPair>& pairs) {
    std::vector<std::vector<std::size_t>> lights;
    for (std::size_t p = 0; p < pairs.size(); ++p) {
        auto same = [&](const std::vector<std::size_t>& g) {
            return pairs[g.front()].wi == pairs[p].wi;
        };
        auto it = std::find_if(lights.begin(), lights.end(), same);
        if (it == lights.end()) {
            lights.push_back({p});
        } else {
            it->push_back(p);
        }
    }
    return lights;
}

// One quantum's contribution to one cell of the record.
struct Hit {
    std::size_t cell;
    double x;
};

// The camera's work items: chunks of kChunk quanta of one light direction at one wavelength,
// item = (light × wavelengths + wavelength) × chunks + chunk.
class BtfImaging {
public:
    BtfImaging(const Scatterer& scatterer, const BtfRecord& r,
               const std::vector<std::vector<std::size_t>>& lights)
        : scatterer_(scatterer),
          r_(r),
          c_(r.config),
          lights_(lights),
          nl_(c_.wavelengths_nm.size()),
          chunks_((c_.quanta_per_light + kChunk - 1) / kChunk),
          half_(0.5 * c_.patch_size_um),
          pixel_(c_.patch_size_um / c_.pixels),
          cos_alpha_(std::cos(c_.detector_half_angle_rad)),
          projected_(kPi * std::pow(std::sin(c_.detector_half_angle_rad), 2)) {}

    std::size_t items() const { return lights_.size() * nl_ * chunks_; }

    // The hits of item `it`'s quanta, in quantum order.
    void image_item(std::size_t it, std::vector<Hit>& hits) const {
        const std::size_t l = it / (nl_ * chunks_), k = (it / chunks_) % nl_;
        const std::uint64_t c = it % chunks_;
        const Vec3d& wi = c_.pairs[lights_[l].front()].wi;
        for (std::uint64_t q = c * kChunk; q < std::min(c_.quanta_per_light, (c + 1) * kChunk);
             ++q) {
            Rng rng(c_.seed, (static_cast<std::uint64_t>(l * nl_ + k) << 40) + q);
            image_quantum(wi, l, k, rng, hits);
        }
    }

private:
    // One quantum: uniform over the patch plane (what a wide, collimated beam deposits), its
    // exit point's pixel, and a hit for every detector cone of the light direction it enters.
    void image_quantum(const Vec3d& wi, std::size_t l, std::size_t k, Rng& rng,
                       std::vector<Hit>& hits) const {
        const Vec2 position((rng.uniform() - 0.5) * c_.patch_size_um,
                            (rng.uniform() - 0.5) * c_.patch_size_um);
        const auto event = scatterer_.sample(wi, c_.wavelengths_nm[k], position, rng);
        if (!event || !(event->weight > 0.0)) return;
        const Vec2& exit = event->exit_position_um;
        if (std::abs(exit.x()) >= half_ || std::abs(exit.y()) >= half_) return;
        const int n = c_.pixels;
        const int column = std::min(n - 1, static_cast<int>((exit.x() + half_) / pixel_));
        const int row = std::min(n - 1, static_cast<int>((half_ - exit.y()) / pixel_));
        for (const std::size_t p : lights_[l]) {
            const Vec3d& wo = c_.pairs[p].wo;
            if (event->wo.dot(wo) < cos_alpha_) continue;
            hits.push_back({r_.index(p, row, column, k), event->weight / (projected_ * wo.z())});
        }
    }

    const Scatterer& scatterer_;
    const BtfRecord& r_;
    const BtfConfig& c_;
    const std::vector<std::vector<std::size_t>>& lights_;
    std::size_t nl_;
    std::uint64_t chunks_;
    double half_, pixel_, cos_alpha_, projected_;
};

// The record's values and standard errors from the hits, summed in item order. Each pixel
// receives a fraction 1/n² of the quanta's entry area: the pixel's share.
void estimate_pixels(const std::vector<std::vector<Hit>>& hits, BtfRecord& r) {
    const BtfConfig& config = r.config;
    const int n = config.pixels;
    const std::size_t cells =
        config.pairs.size() * static_cast<std::size_t>(n) * n * config.wavelengths_nm.size();
    std::vector<double> sum(cells, 0.0), sum_sq(cells, 0.0);
    for (const auto& list : hits) {
        for (const Hit& h : list) {
            sum[h.cell] += h.x;
            sum_sq[h.cell] += h.x * h.x;
        }
    }
    const double per_pixel =
        static_cast<double>(config.quanta_per_light) / (static_cast<double>(n) * n);
    r.value.assign(cells, 0.0);
    r.standard_error.assign(cells, 0.0);
    for (std::size_t i = 0; i < cells; ++i) {
        const double mean = sum[i] / per_pixel;
        r.value[i] = mean;
        // Poisson-like: Var(Σx)/per_pixel² with Var(Σx) ≈ Σx² (sparse hits).
        r.standard_error[i] = std::sqrt(sum_sq[i]) / per_pixel;
    }
}

}  // namespace

BtfRecord measure_btf(const Scatterer& scatterer, const BtfConfig& config) {
    config.validate();
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = process_cpu_seconds();
    BtfRecord r;
    r.config = config;
    r.scatterer = scatterer.name();
    record_measurement_seed("btf", config.seed);  // common/seed.h: one root per measurement
    const std::vector<std::vector<std::size_t>> lights = pairs_by_light(r.config.pairs);
    const BtfImaging imaging(scatterer, r, lights);
    std::vector<std::vector<Hit>> hits(imaging.items());
    auto image_item = [&](std::size_t it) { imaging.image_item(it, hits[it]); };
    // Alone on every thread; under MPI dealt over the ranks, every item's hits back on every
    // rank (common/distributed.h). Either way they are summed in item order.
    distributed::ItemTransport transport;
    transport.pack = [&](std::size_t it, Bytes& out) { out.put_vector(hits[it]); };
    transport.unpack = [&](std::size_t it, Bytes& in) { hits[it] = in.get_vector<Hit>(); };
    if (!distributed::run_items(hits.size(), image_item, transport, &interrupt_flag()))
        throw Interrupted(fmt::format("interrupted while imaging the BTF of {}", r.scatterer));
    estimate_pixels(hits, r);
    r.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.cpu_time_s = process_cpu_seconds() - cpu_start;
    double signal = 0.0, error = 0.0;
    for (std::size_t i = 0; i < r.value.size(); ++i)
        signal += r.value[i], error += r.standard_error[i];
    r.convergence = {{1, r.wall_time_s, config.quanta_per_light,
                      signal > 0.0 ? error / signal : std::numeric_limits<double>::infinity()}};
    return r;
}

record::RgbImage btf_image(const BtfRecord& r, std::size_t pair, double exposure) {
    const int n = r.config.pixels;
    const std::size_t nl = r.config.wavelengths_nm.size();
    const SpectrumToDisplay display(r.config.wavelengths_nm);
    std::vector<optics::Xyz> xyz(static_cast<std::size_t>(n) * n);
    double peak = 0.0;
    for (int row = 0; row < n; ++row) {
        for (int column = 0; column < n; ++column) {
            auto& c = xyz[static_cast<std::size_t>(row) * n + column];
            c = display.xyz(
                std::span<const double>(r.value.data() + r.index(pair, row, column, 0), nl));
            peak = std::max(peak, c.y);
        }
    }
    if (exposure <= 0.0) exposure = peak > 0.0 ? 1.0 / peak : 1.0;
    record::RgbImage image(n, n);
    for (int row = 0; row < n; ++row) {
        for (int column = 0; column < n; ++column) {
            const auto rgb =
                display_bytes(xyz[static_cast<std::size_t>(row) * n + column], exposure);
            image.set(column, row, rgb[0], rgb[1], rgb[2]);
        }
    }
    return image;
}

void write_btf_record(const BtfRecord& r, const std::filesystem::path& path) {
    const auto& c = r.config;
    const std::uint64_t np = c.pairs.size(), n = static_cast<std::uint64_t>(c.pixels),
                        nl = c.wavelengths_nm.size();
    record::Hdf5Writer h5(path);
    using Dims = std::vector<std::uint64_t>;
    std::vector<double> light, view;
    for (const auto& p : c.pairs) {
        light.insert(light.end(), {p.wi.x(), p.wi.y(), p.wi.z()});
        view.insert(view.end(), {p.wo.x(), p.wo.y(), p.wo.z()});
    }
    h5.set_attribute("/", "format", "plumage record 1 (virtual_gonio/RECORD.md)");
    h5.write(
        "instrument/light_directions", std::span<const double>(light), Dims{np, 3},
        {{"units", "1"},
         {"description", "unit vectors towards the light, patch frame (+z normal, +x barb axis)"}});
    h5.write("instrument/view_directions", std::span<const double>(view), Dims{np, 3},
             {{"units", "1"}, {"description", "unit vectors towards the camera, patch frame"}});
    write_polarisation(h5);
    h5.set_attribute("/instrument", "kind", "btf_camera");
    h5.set_attribute("/instrument", "patch_size_um", c.patch_size_um);
    h5.set_attribute("/instrument", "detector_half_angle_deg",
                     c.detector_half_angle_rad * 180.0 / kPi);
    h5.set_attribute("/instrument", "image",
                     "rectified to the patch plane: column along +x, row 0 at +y");
    h5.write("wavelength_nm", std::span<const double>(c.wavelengths_nm), Dims{nl},
             {{"units", "nm"}, {"description", "vacuum wavelengths of the measurement"}});
    h5.write(
        "btf/value", std::span<const double>(r.value), Dims{np, n, n, nl},
        {{"units", "1/sr"}, {"description", "per-pixel BRDF, [pair, row, column, wavelength]"}});
    h5.write("btf/standard_error", std::span<const double>(r.standard_error), Dims{np, n, n, nl},
             {{"units", "1/sr"},
              {"description",
               "Monte Carlo standard error of btf/value, [pair, row, column, wavelength]"}});
    write_convergence(h5, r.convergence,
                      convergence_attributes("pass, wall_time_s, quanta_per_light_and_wavelength, "
                                             "power_weighted_relative_error"));
    write_provenance(h5, {.scatterer = r.scatterer,
                          .seed = c.seed,
                          .threads = omp_get_max_threads(),
                          .wall_time_s = r.wall_time_s,
                          .cpu_time_s = r.cpu_time_s,
                          .config = c.config_text});
    h5.commit();
}

}  // namespace plumage::gonio
