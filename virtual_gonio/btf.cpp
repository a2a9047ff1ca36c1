#include "virtual_gonio/btf.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
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
#include "sim/scatterer/stratified.h"
#include "virtual_gonio/display_colour.h"
#include "virtual_gonio/pass_loop.h"
#include "virtual_gonio/record/hdf5_file.h"
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
    require_wavelengths(wavelengths_nm, kWhat);
    require(std::isfinite(patch_size_um) && patch_size_um > 0.0, kWhat,
            "patch size must be > 0 um");
    require(pixels >= 1 && pixels <= 1024, kWhat,
            fmt::format("pixels = {}: expected 1..1024", pixels));
    require(detector_half_angle_rad > 0.0 && detector_half_angle_rad < 0.5, kWhat,
            "detector half-angle must be in (0, 0.5) rad");
    require(quanta_per_light >= 1, kWhat, "quanta_per_light must be >= 1");
    require(quanta_per_pixel >= 2, kWhat,
            "quanta_per_pixel must be >= 2 (a pixel's error is its quanta's sample variance)");
    const bool power_of_two = stratified_group >= 1 && stratified_group <= 4096 &&
                              (stratified_group & (stratified_group - 1)) == 0;
    require(power_of_two && quanta_per_pixel % stratified_group == 0 &&
                quanta_per_pixel / stratified_group >= 2,
            kWhat,
            fmt::format("stratified_group = {}: expected a power of two 1..4096 that divides "
                        "quanta_per_pixel ({}) at least twice (a pixel's error is the spread of "
                        "its groups)",
                        stratified_group, quanta_per_pixel));
    require(!split_reflections || estimator == BtfEstimator::detector, kWhat,
            "split_reflections needs estimator = \"detector\" (it splits the detector-side "
            "walks)");
    require(!split_aimed_reflections || estimator == BtfEstimator::detector, kWhat,
            "split_aimed_reflections needs estimator = \"detector\" (it splits the "
            "detector-side walks)");
    require(stratified_group == 1 || estimator == BtfEstimator::detector, kWhat,
            "stratified_group > 1 needs estimator = \"detector\" (it stratifies the pixel's "
            "quanta)");
    require(estimator != BtfEstimator::detector || aperture == Aperture::both_cones, kWhat,
            "estimator = \"detector\" needs aperture = \"both_cones\": a walk from the detector "
            "cannot reach a collimated light through mirror-like events");
    require(estimator != BtfEstimator::detector ||
                wavelengths_nm.size() <= PathTracing::kMaxSharedWavelengths,
            kWhat,
            fmt::format("{} wavelengths: the detector estimator shares one path among at most {}",
                        wavelengths_nm.size(), PathTracing::kMaxSharedWavelengths));
    require(max_passes >= 1 && max_passes <= 100000, kWhat,
            fmt::format("max_passes = {}: expected 1..100000", max_passes));
    require(max_passes == 1 || estimator == BtfEstimator::detector, kWhat,
            "max_passes > 1 needs estimator = \"detector\" (the forward estimator is one pass)");
    require(
        std::isfinite(target_pixel_error) && target_pixel_error >= 0.0 && target_pixel_error < 1.0,
        kWhat,
        fmt::format("target_pixel_error = {}: expected 0 (none) or a fraction in (0, 1)",
                    target_pixel_error));
    require(std::isfinite(max_time_s) && max_time_s >= 0.0, kWhat,
            fmt::format("max_time_s = {}: expected >= 0 s (0: no limit)", max_time_s));
    // The detector estimator's stream items (pass × pixels² + pixel) × quanta + q fit 64 bits.
    require(
        static_cast<double>(max_passes) * pixels * pixels * static_cast<double>(quanta_per_pixel) <
            0x1p63,
        kWhat, "max_passes × pixels² × quanta_per_pixel must stay below 2^63");
    for (std::size_t i = 0; i < pairs.size() && aperture == Aperture::both_cones; ++i) {
        require(pairs[i].wi.z() > std::sin(detector_half_angle_rad), kWhat,
                fmt::format("pair {}: under both_cones the light cone must be above the patch", i));
    }
}

const char* to_string(BtfEstimator estimator) {
    return estimator == BtfEstimator::detector ? "detector" : "forward";
}

BtfEstimator parse_btf_estimator(const std::string& text) {
    for (BtfEstimator e : {BtfEstimator::forward, BtfEstimator::detector})
        if (text == to_string(e)) return e;
    throw InputError(fmt::format(
        "btf: estimator = \"{}\": expected \"forward\" (from the light) or \"detector\" "
        "(from each pixel, with aperture = \"both_cones\")",
        text));
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
        const std::uint64_t seed = derive_seed(c_.seed, "btf/forward", l * nl_ + k);
        for (std::uint64_t q = c * kChunk; q < std::min(c_.quanta_per_light, (c + 1) * kChunk);
             ++q) {
            Rng rng(seed, q);
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
        // Under both_cones each quantum its own light direction, two more uniforms of its stream.
        Vec3d light = wi;
        if (c_.aperture == Aperture::both_cones)
            light = draw_cone_direction_by_projected_area(wi, c_.detector_half_angle_rad, rng);
        const auto event = scatterer_.sample(light, c_.wavelengths_nm[k], position, rng);
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

// Pair indices per distinct view direction, in order of first appearance: a view's quanta
// serve every light of its pairs.
std::vector<std::vector<std::size_t>> pairs_by_view(const std::vector<DirectionPair>& pairs) {
    std::vector<DirectionPair> swapped(pairs.size());
    for (std::size_t p = 0; p < pairs.size(); ++p) swapped[p] = {pairs[p].wo, pairs[p].wi};
    return pairs_by_light(swapped);
}

// The detector estimator's work items: one image row of one view direction, item = view ×
// pixels + row. An item's cells (its view's pairs × that row × every column and wavelength)
// belong to no other item, so it sums straight into the record: value receives Σx and
// standard_error Σx² until finish_detector_pixels().
class BtfDetectorImaging {
public:
    BtfDetectorImaging(const Scatterer& scatterer, BtfRecord& r,
                       const std::vector<std::vector<std::size_t>>& views)
        : scatterer_(scatterer),
          r_(r),
          c_(r.config),
          views_(views),
          nl_(c_.wavelengths_nm.size()),
          half_(0.5 * c_.patch_size_um),
          pixel_(c_.patch_size_um / c_.pixels),
          cos_alpha_(std::cos(c_.detector_half_angle_rad)),
          projected_(kPi * std::pow(std::sin(c_.detector_half_angle_rad), 2)),
          seeds_(views.size()),
          strata_seeds_(views.size()) {
        for (std::size_t v = 0; v < views.size(); ++v) {
            seeds_[v] = derive_seed(c_.seed, "btf/detector", v);
            strata_seeds_[v] = derive_seed(c_.seed, "btf/detector-strata", v);
        }
    }

    std::size_t items() const { return views_.size() * static_cast<std::size_t>(c_.pixels); }
    // The pass the next items belong to: its quanta are its own streams.
    void start_pass(int pass) { pass_ = static_cast<std::uint64_t>(pass); }

    void image_item(std::size_t it) {
        const std::size_t v = it / static_cast<std::size_t>(c_.pixels);
        const int row = static_cast<int>(it % static_cast<std::size_t>(c_.pixels));
        const std::vector<std::size_t>& pairs = views_[v];
        std::vector<Vec3d> lights;
        for (const std::size_t p : pairs) lights.push_back(c_.pairs[p].wi);
        BranchOptions options;
        options.adjoint = true;
        options.split_first_film = true;
        options.detector_axes = lights;
        options.detector_half_angle_rad = c_.detector_half_angle_rad;
        options.guided_branches = 1;
        options.split_reflections = c_.split_reflections;
        options.split_aimed_reflections = c_.split_aimed_reflections;
        std::vector<double> acc(pairs.size() * nl_), group_sum(pairs.size() * nl_);
        const std::uint64_t group = c_.stratified_group, groups = c_.quanta_per_pixel / group;
        for (int column = 0; column < c_.pixels; ++column) {
            const auto side = static_cast<std::uint64_t>(c_.pixels);
            const std::uint64_t pixel = (pass_ * side + static_cast<std::uint64_t>(row)) * side +
                                        static_cast<std::uint64_t>(column);
            for (std::uint64_t g = 0; g < groups; ++g) {
                std::fill(group_sum.begin(), group_sum.end(), 0.0);
                std::optional<ScrambledSobolGroup> strata;
                if (group > 1) {
                    Rng strata_rng(strata_seeds_[v], pixel * groups + g);
                    strata.emplace(strata_rng);
                }
                for (std::uint64_t i = 0; i < group; ++i) {
                    Rng rng(seeds_[v], pixel * c_.quanta_per_pixel + g * group + i);
                    std::fill(acc.begin(), acc.end(), 0.0);
                    const Start start = strata ? stratified_start(row, column, *strata,
                                                                  static_cast<std::uint32_t>(i))
                                               : draw_start(row, column, rng);
                    trace_quantum(c_.pairs[pairs.front()].wo, start, options, rng, acc);
                    for (std::size_t x = 0; x < acc.size(); ++x) group_sum[x] += acc[x];
                }
                for (std::size_t j = 0; j < pairs.size(); ++j) {
                    for (std::size_t k = 0; k < nl_; ++k) {
                        const double x = group_sum[j * nl_ + k];
                        if (x == 0.0) continue;
                        const std::size_t i = r_.index(pairs[j], row, column, k);
                        r_.value[i] += x;
                        r_.standard_error[i] += x * x;
                    }
                }
            }
            if (interrupt_requested()) return;
        }
    }

    // The item's cells, for the transport between ranks.
    template <class F>
    void for_each_cell(std::size_t it, F&& f) const {
        const std::size_t v = it / static_cast<std::size_t>(c_.pixels);
        const int row = static_cast<int>(it % static_cast<std::size_t>(c_.pixels));
        for (const std::size_t p : views_[v])
            for (int column = 0; column < c_.pixels; ++column)
                for (std::size_t k = 0; k < nl_; ++k) f(r_.index(p, row, column, k));
    }

private:
    // Where a quantum starts: a point of the pixel's square and four uniforms' worth of the view
    // cone (a point of the unit disc, radius² and angle).
    struct Start {
        double x, y, radius_squared, turn;
    };
    static Start draw_start(int row, int column, Rng& rng) {
        Start s{};
        s.x = column + rng.uniform();
        s.y = row + rng.uniform();
        s.radius_squared = rng.uniform();
        s.turn = rng.uniform();
        return s;
    }
    static Start stratified_start(int row, int column, const ScrambledSobolGroup& strata,
                                  std::uint32_t i) {
        return {column + strata.uniform(i, 0), row + strata.uniform(i, 1), strata.uniform(i, 2),
                strata.uniform(i, 3)};
    }

    // One quantum from its start in a pixel towards the view cone's direction: its branches'
    // weights over Π_i for every light cone they enter through the patch, into acc[light · nλ + k].
    void trace_quantum(const Vec3d& view, const Start& start, const BranchOptions& options,
                       Rng& rng, std::vector<double>& acc) const {
        const Vec2 position(-half_ + start.x * pixel_, half_ - start.y * pixel_);
        const Vec3d wo = cone_direction_from_square(view, c_.detector_half_angle_rad,
                                                    start.radius_squared, start.turn);
        std::array<SpectralScatterEvent, PathTracing::kMaxBranches> events;
        // Not zeroed: every returned branch's weights are written (sim/scatterer/scatterer.h); 4 KB
        // a quantum.
        std::array<double, PathTracing::kMaxBranches * PathTracing::kMaxSharedWavelengths> weights;
        const std::size_t count =
            checked_path_tracing(scatterer_)
                .sample_spectral_branches(
                    wo, c_.wavelengths_nm, position, rng, options, events,
                    std::span<double>(weights.data(), PathTracing::kMaxBranches * nl_));
        for (std::size_t b = 0; b < count; ++b) {
            const Vec2& entry = events[b].exit_position_um;
            if (std::abs(entry.x()) >= half_ || std::abs(entry.y()) >= half_) continue;
            for (std::size_t j = 0; j < options.detector_axes.size(); ++j) {
                const Vec3d& light = options.detector_axes[j];
                if (events[b].wo.dot(light) < cos_alpha_) continue;
                const double scale = 1.0 / (projected_ * light.z());
                for (std::size_t k = 0; k < nl_; ++k)
                    acc[j * nl_ + k] += weights[b * nl_ + k] * scale;
            }
        }
    }

    const Scatterer& scatterer_;
    BtfRecord& r_;
    const BtfConfig& c_;
    const std::vector<std::vector<std::size_t>>& views_;
    std::size_t nl_;
    double half_, pixel_, cos_alpha_, projected_;
    std::vector<std::uint64_t> seeds_, strata_seeds_;
    std::uint64_t pass_ = 0;
};

// Σσ / Σf over every cell: the convergence rows' error (BtfRecord).
double power_weighted_error(const BtfRecord& r) {
    double signal = 0.0, error = 0.0;
    for (std::size_t i = 0; i < r.value.size(); ++i)
        signal += r.value[i], error += r.standard_error[i];
    return signal > 0.0 ? error / signal : std::numeric_limits<double>::infinity();
}

// Σx, Σx² per cell over its groups' sums x (of `group` quanta each) → the mean per quantum and
// its standard error from the spread of the pixel's n / group independent group means.
void finish_detector_pixels(BtfRecord& r, double n, double group) {
    const double groups = n / group;
    for (std::size_t i = 0; i < r.value.size(); ++i) {
        const double mean = r.value[i] / n;
        const double group_mean_sq = r.standard_error[i] / (group * group * groups);
        const double variance =
            std::max(0.0, group_mean_sq - mean * mean) * groups / (groups - 1.0);
        r.value[i] = mean;
        r.standard_error[i] = std::sqrt(variance / groups);
    }
}

// The forward estimator over every item (alone on every thread; under MPI dealt over the ranks,
// every item's hits back on every rank, common/distributed.h), summed in item order.
void measure_forward(const Scatterer& scatterer, BtfRecord& r, const std::atomic<bool>* interrupt) {
    const std::vector<std::vector<std::size_t>> lights = pairs_by_light(r.config.pairs);
    const BtfImaging imaging(scatterer, r, lights);
    std::vector<std::vector<Hit>> hits(imaging.items());
    auto image_item = [&](std::size_t it) { imaging.image_item(it, hits[it]); };
    distributed::ItemTransport transport;
    transport.pack = [&](std::size_t it, Bytes& out) { out.put_vector(hits[it]); };
    transport.unpack = [&](std::size_t it, Bytes& in) { hits[it] = in.get_vector<Hit>(); };
    if (!distributed::run_items(hits.size(), image_item, transport, interrupt))
        throw Interrupted(fmt::format("interrupted while imaging the BTF of {}", r.scatterer));
    estimate_pixels(hits, r);
}

// The detector estimator on the pass loop (virtual_gonio/pass_loop.h): items write disjoint
// cells, so any order gives the same bits. value and standard_error hold Σx and Σx² over all
// passes so far; each pass's estimate is finished on a copy, the last one kept.
class BtfDetectorPasses final : public PassMeasurement {
public:
    BtfDetectorPasses(const Scatterer& scatterer, BtfRecord& r)
        : r_(r), views_(pairs_by_view(r.config.pairs)), imaging_(scatterer, r, views_) {}

    std::size_t start_pass(int pass) override {
        imaging_.start_pass(pass);
        return imaging_.items();
    }
    void run_item(std::size_t it) override { imaging_.image_item(it); }
    void pack(std::size_t it, Bytes& out) const override {
        std::vector<double> slice;
        imaging_.for_each_cell(it, [&](std::size_t i) {
            slice.push_back(r_.value[i]);
            slice.push_back(r_.standard_error[i]);
        });
        out.put_vector(slice);
    }
    void unpack(std::size_t it, Bytes& in) override {
        const std::vector<double> slice = in.get_vector<double>();
        std::size_t at = 0;
        imaging_.for_each_cell(it, [&](std::size_t i) {
            r_.value[i] = slice[at++];
            r_.standard_error[i] = slice[at++];
        });
    }
    void add_pass() override {}  // the items added into the record's cells themselves
    PassEstimate estimate(int passes) override {
        PassEstimate e;
        e.quanta = static_cast<std::uint64_t>(passes) * r_.config.quanta_per_pixel;
        estimate_ = r_;
        finish_detector_pixels(estimate_, static_cast<double>(e.quanta),
                               static_cast<double>(r_.config.stratified_group));
        e.relative_error = power_weighted_error(estimate_);
        e.pixel_error = median_lit_pixel_error(estimate_);
        return e;
    }
    std::vector<CheckpointSum> checkpoint_sums() override {
        return {{"sum", &r_.value}, {"sum_sq", &r_.standard_error}};
    }
    // The last pass's estimate into the record.
    void finish() {
        r_.value = std::move(estimate_.value);
        r_.standard_error = std::move(estimate_.standard_error);
    }

private:
    BtfRecord& r_;
    const std::vector<std::vector<std::size_t>> views_;
    BtfDetectorImaging imaging_;
    BtfRecord estimate_;
};

// Everything that decides the detector estimator's sums: what its checkpoint is made from.
std::string canonical(const BtfConfig& c, const std::string& scatterer) {
    std::string s =
        fmt::format("{}|{:.17g}|{}|{:.17g}|{}|{}|{}|", scatterer, c.patch_size_um, c.pixels,
                    c.detector_half_angle_rad, c.quanta_per_pixel, c.seed, to_string(c.aperture));
    // Independent quanta keep the canonical text they had before groups existed, so that their
    // checkpoints still resume.
    if (c.stratified_group != 1) s += fmt::format("group {}|", c.stratified_group);
    if (c.split_reflections) s += "split_reflections|";
    if (c.split_aimed_reflections) s += "split_aimed_reflections|";
    for (double l : c.wavelengths_nm) s += fmt::format("{:.17g},", l);
    for (const auto& p : c.pairs) {
        s += fmt::format("{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g};", p.wi.x(), p.wi.y(),
                         p.wi.z(), p.wo.x(), p.wo.y(), p.wo.z());
    }
    return s;
}

void measure_from_detector(const Scatterer& scatterer, BtfRecord& r, const RunControl& control,
                           const std::function<double()>& elapsed_s) {
    const PathTracing* paths = scatterer.path_tracing();
    if (paths == nullptr || !paths->can_trace_adjoint()) {
        throw InputError(fmt::format(
            "btf: estimator = \"detector\" needs a scatterer with a detector-side walk (the "
            "ray tracer); {} has none: use estimator = \"forward\"",
            r.scatterer));
    }
    const BtfConfig& c = r.config;
    const std::size_t cells =
        c.pairs.size() * static_cast<std::size_t>(c.pixels) * c.pixels * c.wavelengths_nm.size();
    r.value.assign(cells, 0.0);
    r.standard_error.assign(cells, 0.0);
    BtfDetectorPasses passes(scatterer, r);
    StopRule rule;  // BtfConfig's: no target on the power-weighted error
    rule.max_passes = c.max_passes;
    rule.target_pixel_error = c.target_pixel_error;
    if (c.max_time_s > 0.0) rule.time_budget_s = c.max_time_s;
    rule.budget_holds_next_pass = true;
    PassLoopControl loop;
    loop.interrupt = control.interrupt;
    if (control.progress) loop.progress = fmt::format("{}: BTF", r.scatterer);
    loop.quanta_per = "pixel";
    loop.on_pass = control.on_pass;
    loop.checkpoint = control.checkpoint;
    if (!control.checkpoint.empty()) {
        loop.identity = checkpoint_identity(c.config_text, canonical(c, r.scatterer),
                                            control.checkpoint_inputs);
    }
    PassLoopState state;
    run_passes(passes, rule, loop, elapsed_s, state);
    if (state.interrupted) {
        throw Interrupted(fmt::format(
            "interrupted while imaging the BTF of {} after {} completed passes{}", r.scatterer,
            state.passes,
            control.checkpoint.empty() ? ""
                                       : fmt::format(" (kept in {}: the same command resumes)",
                                                     control.checkpoint.string())));
    }
    passes.finish();
    r.convergence = std::move(state.rows);
}

}  // namespace

BtfRecord measure_btf(const Scatterer& scatterer, const BtfConfig& config, bool progress) {
    RunControl control;
    control.progress = progress;
    return measure_btf(scatterer, config, control);
}

BtfRecord measure_btf(const Scatterer& scatterer, const BtfConfig& config,
                      const RunControl& control) {
    config.validate();
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = process_cpu_seconds();
    BtfRecord r;
    r.config = config;
    r.scatterer = scatterer.name();
    record_measurement_seed("btf", config.seed);  // common/seed.h: one root per measurement
    if (config.estimator == BtfEstimator::detector) {
        measure_from_detector(scatterer, r, control, [&] {
            return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        });
    } else {
        measure_forward(scatterer, r, control.interrupt);
    }
    r.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.cpu_time_s = process_cpu_seconds() - cpu_start;
    if (config.estimator == BtfEstimator::forward)
        r.convergence = {{1, r.wall_time_s, config.quanta_per_light, power_weighted_error(r)}};
    return r;
}

double median_lit_pixel_error(const BtfRecord& r, std::span<const std::size_t> pairs,
                              double lit_fraction) {
    const int n = r.config.pixels;
    const std::size_t nl = r.config.wavelengths_nm.size();
    std::vector<std::size_t> all(r.config.pairs.size());
    for (std::size_t p = 0; p < all.size(); ++p) all[p] = p;
    std::vector<double> relative;
    for (const std::size_t p : pairs.empty() ? std::span<const std::size_t>(all) : pairs) {
        for (std::size_t k = 0; k < nl; ++k) {
            double peak = 0.0;
            for (int row = 0; row < n; ++row)
                for (int column = 0; column < n; ++column)
                    peak = std::max(peak, r.value[r.index(p, row, column, k)]);
            for (int row = 0; row < n; ++row) {
                for (int column = 0; column < n; ++column) {
                    const std::size_t i = r.index(p, row, column, k);
                    if (peak > 0.0 && r.value[i] > lit_fraction * peak)
                        relative.push_back(r.standard_error[i] / r.value[i]);
                }
            }
        }
    }
    if (relative.empty()) return std::numeric_limits<double>::infinity();
    const auto middle = relative.begin() + static_cast<std::ptrdiff_t>(relative.size() / 2);
    std::nth_element(relative.begin(), middle, relative.end());
    return *middle;
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
    h5.set_attribute("/instrument", "aperture", to_string(c.aperture));
    h5.set_attribute("/instrument", "estimator", to_string(c.estimator));
    if (c.estimator == BtfEstimator::detector) {
        // Per pass; the passes taken are /convergence's rows.
        h5.set_attribute("/instrument", "quanta_per_view_and_pixel",
                         static_cast<double>(c.quanta_per_pixel));
        h5.set_attribute("/instrument", "stratified_group",
                         static_cast<double>(c.stratified_group));
        if (c.split_reflections) {
            h5.set_attribute("/instrument", "path_splitting",
                             "first film and the reflected branch's next film: each walk split at "
                             "its first film event, the reflected branch again at its next event "
                             "if that is a film (sim/tracer.h)");
        }
        if (c.split_aimed_reflections) {
            h5.set_attribute(
                "/instrument", "aimed_reflection_splitting",
                "at a bare interface whose mirror direction lies within a light's "
                "cone, both sides traced: the reflected one as a branch (sim/tracer.h)");
        }
        h5.set_attribute("/instrument", "max_passes", static_cast<double>(c.max_passes));
        h5.set_attribute("/instrument", "target_pixel_error", c.target_pixel_error);
        h5.set_attribute("/instrument", "max_time_s", c.max_time_s);
    } else {
        h5.set_attribute("/instrument", "quanta_per_light_and_wavelength",
                         static_cast<double>(c.quanta_per_light));
    }
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
    write_convergence(
        h5, r.convergence,
        convergence_attributes(c.estimator == BtfEstimator::detector
                                   ? "pass, wall_time_s, quanta_per_view_and_pixel, "
                                     "power_weighted_relative_error"
                                   : "pass, wall_time_s, quanta_per_light_and_wavelength, "
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
