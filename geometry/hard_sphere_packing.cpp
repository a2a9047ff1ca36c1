#include "geometry/hard_sphere_packing.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "geometry/random_stream.h"

namespace plumage::geometry {
namespace {

constexpr double kMaxFraction = 0.55;
constexpr double kStartFraction = 0.25;
constexpr std::int64_t kMaxCount = 10'000'000;
constexpr std::int64_t kMaxSweeps = 1'000'000'000;
constexpr double kGrowthMargin = 1e-12;  // σ grows to (1 − margin) d_min at least
constexpr double kGrowth = 4e-3;         // or by this relative step, with overlaps

// Random streams of one packing, kept apart so that adding a draw to one cannot shift
// another.
enum class Stream : std::uint32_t { initial = 1, moves = 2 };

std::mt19937_64 random_stream(std::uint64_t seed, std::uint64_t item, Stream stream) {
    return detail::seeded_stream(seed, item, static_cast<std::uint32_t>(stream));
}

using detail::uniform01;

[[noreturn]] void reject(const char* key, double value, const std::string& expected) {
    throw InputError(
        fmt::format("hard-sphere packing: {} = {}: expected {}", key, value, expected));
}

// Periodic centres with a cell list (cells of side >= the largest diameter used).
class Packing {
public:
    Packing(double box, double max_diameter, std::size_t count) : box_(box) {
        const auto fit = static_cast<int>(std::floor(box / max_diameter));
        const auto cap =
            static_cast<int>(std::ceil(std::cbrt(2.0 * static_cast<double>(count)))) + 1;
        cells_ = std::min(fit, cap);
        if (cells_ < 3) cells_ = 1;  // 27 neighbour cells must be distinct; else one cell
        members_.resize(static_cast<std::size_t>(cells_) * cells_ * cells_);
        centres_.reserve(count);
        cell_of_.reserve(count);
    }

    double box() const { return box_; }
    std::size_t size() const { return centres_.size(); }
    const std::vector<Eigen::Vector3d>& centres() const { return centres_; }

    double wrap(double x) const {
        x -= box_ * std::floor(x / box_);
        return x >= box_ || x < 0.0 ? 0.0 : x;  // −tiny + L rounds to L ≡ 0
    }
    double nearest_image(double d) const { return d - box_ * std::round(d / box_); }

    // Smallest squared distance from position x to any centre other than `skip` (or to
    // none: +inf), stopping early once it is below `stop`.
    double min_distance2(const Eigen::Vector3d& x, std::size_t skip, double stop) const {
        double best = std::numeric_limits<double>::infinity();
        const int ci = cell(x[0]), cj = cell(x[1]), ck = cell(x[2]);
        const int reach = cells_ == 1 ? 0 : 1;
        for (int di = -reach; di <= reach; ++di) {
            for (int dj = -reach; dj <= reach; ++dj) {
                for (int dk = -reach; dk <= reach; ++dk) {
                    for (std::size_t other : members_[index(ci + di, cj + dj, ck + dk)]) {
                        if (other == skip) continue;
                        const double dx = nearest_image(centres_[other][0] - x[0]);
                        const double dy = nearest_image(centres_[other][1] - x[1]);
                        const double dz = nearest_image(centres_[other][2] - x[2]);
                        best = std::min(best, dx * dx + dy * dy + dz * dz);
                        if (best < stop) return best;
                    }
                }
            }
        }
        return best;
    }

    // Σ (σ − d)² over the centres other than `skip` closer than σ to x.
    double overlap(const Eigen::Vector3d& x, std::size_t skip, double sigma) const {
        double sum = 0.0;
        const int ci = cell(x[0]), cj = cell(x[1]), ck = cell(x[2]);
        const int reach = cells_ == 1 ? 0 : 1;
        for (int di = -reach; di <= reach; ++di) {
            for (int dj = -reach; dj <= reach; ++dj) {
                for (int dk = -reach; dk <= reach; ++dk) {
                    for (std::size_t other : members_[index(ci + di, cj + dj, ck + dk)]) {
                        if (other == skip) continue;
                        const double dx = nearest_image(centres_[other][0] - x[0]);
                        const double dy = nearest_image(centres_[other][1] - x[1]);
                        const double dz = nearest_image(centres_[other][2] - x[2]);
                        const double d2 = dx * dx + dy * dy + dz * dz;
                        if (d2 < sigma * sigma) sum += std::pow(sigma - std::sqrt(d2), 2);
                    }
                }
            }
        }
        return sum;
    }

    // Smallest pair distance over the whole packing (neighbours within a cell's reach; a
    // pair farther apart than the cell side does not limit the growth below it).
    double min_pair_distance() const {
        double best = std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i < centres_.size(); ++i) {
            best = std::min(best, min_distance2(centres_[i], i, 0.0));
        }
        return std::sqrt(best);
    }

    void add(const Eigen::Vector3d& x) {
        const std::size_t c = cell_index(x);
        members_[c].push_back(centres_.size());
        cell_of_.push_back(c);
        centres_.push_back(x);
    }

    void move(std::size_t i, const Eigen::Vector3d& x) {
        const std::size_t c = cell_index(x);
        if (c != cell_of_[i]) {
            auto& old = members_[cell_of_[i]];
            *std::find(old.begin(), old.end(), i) = old.back();
            old.pop_back();
            members_[c].push_back(i);
            cell_of_[i] = c;
        }
        centres_[i] = x;
    }

private:
    int cell(double x) const { return std::min(cells_ - 1, static_cast<int>(x / box_ * cells_)); }
    std::size_t index(int i, int j, int k) const {
        auto w = [this](int v) { return ((v % cells_) + cells_) % cells_; };
        return (static_cast<std::size_t>(w(i)) * cells_ + w(j)) * cells_ + w(k);
    }
    std::size_t cell_index(const Eigen::Vector3d& x) const {
        return index(cell(x[0]), cell(x[1]), cell(x[2]));
    }

    double box_;
    int cells_ = 1;
    std::vector<Eigen::Vector3d> centres_;
    std::vector<std::size_t> cell_of_;
    std::vector<std::vector<std::size_t>> members_;
};

// One sweep of N trial moves at diameter sigma and step delta; returns the accepted count.
// A move of a sphere without overlaps is rejected if it would create one (hard core); a
// sphere that overlaps (only during compression, after a growth step) may move if its
// summed squared overlap Σ (σ − d)² does not increase.
std::int64_t sweep(Packing& packing, std::mt19937_64& rng, double sigma, double delta,
                   bool overlapping) {
    const std::size_t n = packing.size();
    const double sigma2 = sigma * sigma;
    std::int64_t accepted = 0;
    for (std::size_t t = 0; t < n; ++t) {
        const auto i =
            std::min(n - 1, static_cast<std::size_t>(uniform01(rng) * static_cast<double>(n)));
        Eigen::Vector3d x = packing.centres()[i];
        for (int a = 0; a < 3; ++a) {
            x[a] = packing.wrap(x[a] + delta * (2.0 * uniform01(rng) - 1.0));
        }
        const double before = overlapping ? packing.overlap(packing.centres()[i], i, sigma) : 0.0;
        if (before == 0.0) {
            if (packing.min_distance2(x, i, sigma2) < sigma2) continue;
        } else if (packing.overlap(x, i, sigma) > before) {
            continue;
        }
        packing.move(i, x);
        ++accepted;
    }
    return accepted;
}

void validate(const HardSpherePackingParams& params) {
    const double phi = params.volume_fraction;
    const double box = params.box_um;
    if (!(params.count >= 2 && params.count <= kMaxCount)) {
        reject("count", static_cast<double>(params.count),
               fmt::format("a number of spheres in [2, {}]", kMaxCount));
    }
    if (!(std::isfinite(box) && box > 0.0)) reject("box_um", box, "a finite box side > 0 µm");
    if (!(std::isfinite(phi) && phi > 0.0 && phi <= kMaxFraction)) {
        reject("volume_fraction", phi,
               "a value in (0, 0.55] (beyond ~0.55 compression crystallises or jams)");
    }
    if (!(params.equilibration_sweeps >= 0 && params.equilibration_sweeps <= kMaxSweeps)) {
        reject("equilibration_sweeps", static_cast<double>(params.equilibration_sweeps),
               "a number of sweeps in [0, 10^9]");
    }
    if (!(params.max_compression_sweeps >= 1 && params.max_compression_sweeps <= kMaxSweeps)) {
        reject("max_compression_sweeps", static_cast<double>(params.max_compression_sweeps),
               "a number of sweeps in [1, 10^9]");
    }
}

// 1. Random sequential addition of n spheres of diameter sigma.
void add_randomly(Packing& packing, const HardSpherePackingParams& params, std::size_t n,
                  double sigma) {
    const double box = params.box_um;
    std::mt19937_64 rng = random_stream(params.seed, params.item, Stream::initial);
    const std::int64_t max_attempts = 100'000 * static_cast<std::int64_t>(n);
    std::int64_t attempts = 0;
    while (packing.size() < n) {
        PLUMAGE_CHECK(
            ++attempts <= max_attempts,
            fmt::format("random sequential addition at phi = {} placed only {} of "
                        "{} spheres",
                        std::min(params.volume_fraction, kStartFraction), packing.size(), n));
        const Eigen::Vector3d x(box * uniform01(rng), box * uniform01(rng), box * uniform01(rng));
        if (packing.min_distance2(x, n, sigma * sigma) < sigma * sigma) continue;
        packing.add(x);
    }
}

}  // namespace

HardSpherePacking make_hard_sphere_packing(const HardSpherePackingParams& params) {
    validate(params);
    const double phi = params.volume_fraction;
    const double box = params.box_um;
    const auto n = static_cast<std::size_t>(params.count);
    const double volume = box * box * box;
    const double target = std::cbrt(6.0 * phi * volume / (kPi * static_cast<double>(n)));
    if (!(target <= 0.5 * box)) {
        reject("count", static_cast<double>(params.count),
               fmt::format("enough spheres for a diameter <= L/2 at volume_fraction {} (got "
                           "sigma = {:.4g} um in a {:.4g} um box; need N >= 48 phi / pi = {:.2f})",
                           phi, target, box, 48.0 * phi / kPi));
    }

    // 1. Random sequential addition at φ₀ = min(φ, 0.25).
    double sigma = target * std::cbrt(std::min(phi, kStartFraction) / phi);
    Packing packing(box, target, n);
    add_randomly(packing, params, n, sigma);

    // 2. Compression: sweeps alternating with growth to just below the minimum distance.
    std::mt19937_64 rng = random_stream(params.seed, params.item, Stream::moves);
    double delta = 0.1 * sigma;
    HardSpherePacking out;
    std::int64_t last_accepted = 0;
    bool overlapping = false;
    while (sigma < target || overlapping) {
        if (out.compression_sweeps >= params.max_compression_sweeps) {
            const double reached =
                static_cast<double>(n) * kPi * sigma * sigma * sigma / (6.0 * volume);
            throw InputError(fmt::format(
                "hard-sphere packing: volume_fraction = {}: compression reached only {:.4f} "
                "after max_compression_sweeps = {} sweeps (N = {})",
                phi, overlapping ? 0.0 : reached, params.max_compression_sweeps, n));
        }
        last_accepted = sweep(packing, rng, sigma, delta, overlapping);
        ++out.compression_sweeps;
        const double distance = packing.min_pair_distance();
        overlapping = distance < sigma;
        if (!overlapping && sigma < target) {
            // Grow by kGrowth, or further if the closest pair allows it; overlaps the
            // growth creates are removed by the next sweeps before the next growth.
            sigma = std::min(target,
                             std::max((1.0 - kGrowthMargin) * distance, sigma * (1.0 + kGrowth)));
            overlapping = distance < sigma;
        }
        const double acceptance = static_cast<double>(last_accepted) / static_cast<double>(n);
        if (acceptance > 0.45) delta = std::min(delta * 1.05, 0.25 * box);
        if (acceptance < 0.35) delta /= 1.05;
    }

    // 3. Equilibration at the target with a frozen step.
    std::int64_t accepted = 0;
    for (std::int64_t s = 0; s < params.equilibration_sweeps; ++s) {
        accepted += sweep(packing, rng, sigma, delta, false);
    }
    out.equilibration_sweeps = params.equilibration_sweeps;
    out.acceptance_ratio =
        params.equilibration_sweeps > 0
            ? static_cast<double>(accepted) /
                  (static_cast<double>(n) * static_cast<double>(params.equilibration_sweeps))
            : static_cast<double>(last_accepted) / static_cast<double>(n);

    out.centres_um = packing.centres();
    out.box_um = box;
    out.diameter_um = sigma;
    out.volume_fraction = static_cast<double>(n) * kPi * sigma * sigma * sigma / (6.0 * volume);
    out.min_distance_um = packing.min_pair_distance();
    out.step_um = delta;
    PLUMAGE_CHECK(out.min_distance_um >= sigma, "no two hard spheres overlap");
    return out;
}

}  // namespace plumage::geometry
