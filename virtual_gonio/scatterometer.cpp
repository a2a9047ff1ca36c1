#include "virtual_gonio/scatterometer.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iostream>
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
#include "virtual_gonio/pass_loop.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/record_provenance.h"

namespace plumage::gonio {
namespace {

constexpr std::uint64_t kChunk = 4096;
// Under MPI a pass's work items are dealt in this many blocks per rank (common/distributed.h),
// as the goniometer's: enough for a slow block not to hold up the pass.
constexpr std::size_t kBlocksPerRank = 4;

// The name that prefixes this file's input errors.
constexpr std::string_view kWhat = "scatterometer";

// Pixel index of a direction in the upper hemisphere (−1 if outside the image).
long pixel_of(const Vec3d& w, int n) {
    if (!(w.z() > 0.0)) return -1;
    const double r = std::acos(std::min(1.0, w.z())) / (0.5 * kPi);
    const double phi = std::atan2(w.y(), w.x());
    const double u = r * std::cos(phi), v = r * std::sin(phi);
    const int column = static_cast<int>(std::floor((u + 1.0) * 0.5 * n));
    const int row = static_cast<int>(std::floor((1.0 - v) * 0.5 * n));
    if (column < 0 || row < 0 || column >= n || row >= n) return -1;
    return static_cast<long>(row) * n + column;
}

// The cells of one pass's illumination directions: a rows × columns grid over the unit
// square with rows · columns = directions exactly (columns the largest divisor ≤ √directions),
// so that every part of the square has a cell and the jittered directions are unbiased for
// any count (a prime count stratifies u1 alone).
struct IlluminationGrid {
    std::uint64_t rows, columns;
};

IlluminationGrid illumination_grid(int directions) {
    const auto d = static_cast<std::uint64_t>(std::max(1, directions));
    auto columns = static_cast<std::uint64_t>(std::sqrt(static_cast<double>(d)));
    while (columns > 1 && d % columns != 0) --columns;
    columns = std::max<std::uint64_t>(1, columns);
    return {d / columns, columns};
}

// The illumination direction at (u1, u2) ∈ [0, 1)²: an area-preserving map onto the
// cosine-weighted hemisphere or cone (u1 radial, u2 azimuthal). e1, e2 complete the beam
// direction to a frame.
Vec3d illumination_direction(const ScatterometerConfig& config, const Vec3d& e1, const Vec3d& e2,
                             double u1, double u2) {
    const double g = 2.0 * kPi * u2;
    if (config.illumination == Illumination::hemisphere) {
        // Uniform radiance: cosine-weighted directions.
        const double r = std::sqrt(u1);
        return Vec3d(r * std::cos(g), r * std::sin(g), std::sqrt(std::max(1e-12, 1.0 - r * r)))
            .normalized();
    }
    // Uniform radiance within the cone: cosine-weighted about the cone's axis, up to its
    // edge (the patch-normal cosine differs by < 1 % over 8°; exact for a cone around the
    // normal).
    const double sin_max = std::sin(0.5 * config.cone_aperture_rad);
    const double sin_b = sin_max * std::sqrt(u1), cos_b = std::sqrt(1.0 - sin_b * sin_b);
    return cos_b * config.beam_direction + sin_b * (std::cos(g) * e1 + std::sin(g) * e2);
}

}  // namespace

void ScatterometerConfig::validate() const {
    require(std::abs(beam_direction.norm() - 1.0) < 1e-9 && beam_direction.z() > 0.0, kWhat,
            "beam_direction must be a unit vector above the patch (z > 0)");
    require(std::isfinite(cone_aperture_rad) && cone_aperture_rad > 0.0 && cone_aperture_rad < kPi,
            kWhat, fmt::format("cone aperture {} rad: expected (0, pi)", cone_aperture_rad));
    require(illumination != Illumination::cone ||
                std::acos(beam_direction.z()) + 0.5 * cone_aperture_rad < 0.5 * kPi,
            kWhat, "the illumination cone must stay above the patch plane");
    require(image_size >= 9 && image_size <= 4096, kWhat,
            fmt::format("image_size {}: expected 9..4096", image_size));
    require_wavelengths(wavelengths_nm, kWhat);
    require(std::isfinite(beam_radius_um) && beam_radius_um >= 0.0, kWhat,
            "beam radius must be >= 0 um");
    require(quanta_per_pass >= 1 && max_passes >= 1, kWhat,
            "quanta_per_pass and max_passes must be >= 1");
    require(std::isfinite(target_median_relative_error) && target_median_relative_error >= 0.0,
            kWhat, "target_median_relative_error must be >= 0");
    require(illumination_strata >= 1, kWhat,
            fmt::format("illumination_strata {}: expected >= 1", illumination_strata));
}

std::optional<Vec3d> Scatterogram::direction(int column, int row) const {
    const int n = config.image_size;
    const double u = (column + 0.5) * 2.0 / n - 1.0, v = 1.0 - (row + 0.5) * 2.0 / n;
    const double r = std::hypot(u, v);
    if (r > 1.0) return std::nullopt;
    const double theta = 0.5 * kPi * r, phi = std::atan2(v, u);
    return Vec3d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
}

namespace {

// The equidistant map's pixel solid angles, dω = (π/2) sin(πr/2)/r du dv (→ π²/4 at the
// centre); 0 outside the unit disc.
std::vector<double> pixel_solid_angles(int n) {
    std::vector<double> omega(static_cast<std::size_t>(n) * n, 0.0);
    const double pixel = 2.0 / n;
    for (int row = 0; row < n; ++row) {
        for (int column = 0; column < n; ++column) {
            const double u = (column + 0.5) * pixel - 1.0, v = 1.0 - (row + 0.5) * pixel;
            const double r = std::hypot(u, v);
            if (r > 1.0) continue;
            const double jacobian =
                r > 1e-12 ? 0.5 * kPi * std::sin(0.5 * kPi * r) / r : 0.25 * kPi * kPi;
            omega[static_cast<std::size_t>(row) * n + column] = jacobian * pixel * pixel;
        }
    }
    return omega;
}

struct Hit {
    long pixel;
    int lobe;
    double weight;
    std::size_t wavelength;
};

struct GroupSum {  // one group's weight (or a pair's difference) into one (pixel, λ) cell
    std::size_t cell;
    double weight;
};

// The sums over every pass so far, per (pixel, λ) cell: Σ of the quanta's weights / Ω, Σ of
// the squared group sums, per lobe; and the power below the patch, in total and per lobe.
struct Sums {
    std::vector<double> sum, sum_sq, lobe_sum, below, below_lobes;
};

// One pass's results per work item, added to the Sums in item order (thread-independent).
struct PassItems {
    std::vector<std::vector<Hit>> hits;
    std::vector<std::vector<GroupSum>> group_sums;
    std::vector<double> below;  // [item][λ][total, then per lobe]
};

// Quanta form groups that share their randomness beyond the quantum's own stream: under the
// beam each quantum is a group; under cone and hemisphere light a group is the quanta of one
// wavelength sent along one illumination direction. The standard error comes from the group
// sums (quanta that share a direction are correlated: counting them as independent would
// understate the error), see estimate() below.
struct QuantumGroups {
    bool directional;
    std::uint64_t directions, group, per_pass;
    IlluminationGrid grid;

    explicit QuantumGroups(const ScatterometerConfig& c)
        : directional(c.illumination != Illumination::beam),
          directions(directional ? static_cast<std::uint64_t>(c.illumination_strata) : 1),
          group(directional ? (c.quanta_per_pass + directions - 1) / directions : 1),
          per_pass(directional ? directions * group : c.quanta_per_pass),
          grid(illumination_grid(c.illumination_strata)) {}
};

// The group's hits (out[from, end)) summed by cell, in cell order, into `into`.
void group_cells(const std::vector<Hit>& out, std::size_t from, std::size_t nl,
                 std::vector<GroupSum>& into) {
    into.clear();
    for (std::size_t h = from; h < out.size(); ++h)
        into.push_back(
            {static_cast<std::size_t>(out[h].pixel) * nl + out[h].wavelength, out[h].weight});
    std::stable_sort(into.begin(), into.end(),
                     [](const GroupSum& x, const GroupSum& y) { return x.cell < y.cell; });
    std::size_t kept = 0;
    for (std::size_t i = 0; i < into.size(); ++i) {
        if (kept > 0 && into[kept - 1].cell == into[i].cell)
            into[kept - 1].weight += into[i].weight;
        else
            into[kept++] = into[i];
    }
    into.resize(kept);
}

// Two cell-ordered group sums a and b merged into their difference a − b, appended to `sums`.
void append_difference(const std::vector<GroupSum>& a, const std::vector<GroupSum>& b,
                       std::vector<GroupSum>& sums) {
    std::size_t i = 0, j = 0;
    while (i < a.size() || j < b.size()) {
        if (j == b.size() || (i < a.size() && a[i].cell < b[j].cell)) {
            sums.push_back(a[i++]);
        } else if (i == a.size() || b[j].cell < a[i].cell) {
            sums.push_back({b[j].cell, -b[j].weight});
            ++j;
        } else {
            sums.push_back({a[i].cell, a[i].weight - b[j].weight});
            ++i, ++j;
        }
    }
}

// One pass's work items: under the beam, chunks of one wavelength's quanta; otherwise blocks
// of illumination directions, each direction's quanta for every wavelength in turn (a
// scatterer that prepares per incident direction prepares once for all wavelengths).
class PassWork {
public:
    // shared: one path per quantum for every wavelength; split: its first film's two branches.
    PassWork(const Scatterer& scatterer, const ScatterometerConfig& config,
             const std::vector<double>& solid_angle, std::size_t nlobes, const QuantumGroups& g,
             std::uint64_t pass, bool shared, bool split)
        : scatterer_(scatterer),
          config_(config),
          solid_angle_(solid_angle),
          g_(g),
          pass_(pass),
          nl_(config.wavelengths_nm.size()),
          nlobes_(nlobes),
          shared_(shared),
          split_(split),
          chunks_((config.quanta_per_pass + kChunk - 1) / kChunk),
          // Even, so that the pairs of directions below fall within one item.
          block_(2 * std::max<std::uint64_t>(1, kChunk / (2 * g.group * (shared ? 1 : nl_)))),
          jitter_seed_(derive_seed(config.seed, "scatterometer/illumination", pass)),
          shared_seed_(derive_seed(config.seed, g.directional ? "scatterometer/shared-directional"
                                                              : "scatterometer/shared")) {
        orthonormal_frame(config.beam_direction, e1_, e2_);
        for (std::size_t k = 0; k < nl_; ++k) {
            quantum_seeds_.push_back(derive_seed(config.seed, "scatterometer/quantum", k));
            beam_seeds_.push_back(derive_seed(config.seed, "scatterometer/beam-quantum", k));
        }
    }

    std::size_t items() const {
        if (g_.directional) return (g_.directions + block_ - 1) / block_;
        return shared_ ? chunks_ : nl_ * chunks_;
    }
    PassItems empty_items() const {
        const std::size_t n = items();
        return {std::vector<std::vector<Hit>>(n), std::vector<std::vector<GroupSum>>(n),
                std::vector<double>(n * nl_ * (nlobes_ + 1), 0.0)};
    }
    void run(std::size_t it, PassItems& out) const {
        if (g_.directional)
            directional_item(it, out);
        else
            beam_item(it, out);
    }

private:
    // A quantum's entry point: uniform over the spot's disc in the beam's cross-section (f1, f2
    // complete wi to a frame), projected on the patch; two numbers of rng.
    Vec2 entry_point(const Vec3d& wi, const Vec3d& f1, const Vec3d& f2, Rng& rng) const {
        const double radius = config_.beam_radius_um * std::sqrt(rng.uniform()),
                     angle = 2.0 * kPi * rng.uniform();
        const Vec3d offset = radius * (std::cos(angle) * f1 + std::sin(angle) * f2);
        return {offset.x() - offset.z() * wi.x() / wi.z(),
                offset.y() - offset.z() * wi.y() / wi.z()};
    }

    // One escape of weight w at wavelength k: into the light below the patch or a pixel's hits.
    void count_escape(const Vec3d& wo, int lobe, double w, std::size_t k, std::size_t it,
                      PassItems& items) const {
        if (!(w > 0.0)) return;
        PLUMAGE_CHECK(std::isfinite(w), "non-finite quantum weight from " + scatterer_.name());
        if (wo.z() <= 0.0) {
            double* below_k = &items.below[(it * nl_ + k) * (nlobes_ + 1)];
            below_k[0] += w;
            if (lobe >= 0 && static_cast<std::size_t>(lobe) < nlobes_)
                below_k[1 + static_cast<std::size_t>(lobe)] += w;
            return;
        }
        const long p = pixel_of(wo, config_.image_size);
        if (p >= 0 && solid_angle_[static_cast<std::size_t>(p)] > 0.0)
            items.hits[it].push_back({p, lobe, w, k});
    }

    // Plays one quantum along wi at wavelength k; its stream is rng.
    void play(const Vec3d& wi, const Vec3d& f1, const Vec3d& f2, std::size_t k, Rng& rng,
              std::size_t it, PassItems& items) const {
        const Vec2 position = entry_point(wi, f1, f2, rng);
        const auto event = scatterer_.sample(wi, config_.wavelengths_nm[k], position, rng);
        if (event) count_escape(event->wo, event->lobe, event->weight, k, it, items);
    }

    // Plays one shared quantum along wi for every wavelength (its branches, when split).
    void play_shared(const Vec3d& wi, const Vec3d& f1, const Vec3d& f2, Rng& rng, std::size_t it,
                     PassItems& items) const {
        const Vec2 position = entry_point(wi, f1, f2, rng);
        std::array<SpectralScatterEvent, PathTracing::kMaxBranches> events;
        // Not zeroed: every returned branch's weights are written (sim/scatterer/scatterer.h); 4 KB
        // a quantum.
        std::array<double, PathTracing::kMaxBranches * PathTracing::kMaxSharedWavelengths> weights;
        BranchOptions options;
        options.split_first_film = split_;
        const std::size_t count =
            checked_path_tracing(scatterer_)
                .sample_spectral_branches(
                    wi, config_.wavelengths_nm, position, rng, options, events,
                    std::span<double>(weights.data(), PathTracing::kMaxBranches * nl_));
        for (std::size_t b = 0; b < count; ++b)
            for (std::size_t k = 0; k < nl_; ++k)
                count_escape(events[b].wo, events[b].lobe, weights[b * nl_ + k], k, it, items);
    }

    // A chunk of quanta along the beam (of one wavelength, or of all on shared paths), each
    // quantum its own group.
    void beam_item(std::size_t it, PassItems& items) const {
        const std::size_t k = shared_ ? 0 : it / chunks_;
        const std::uint64_t c = it % chunks_;
        const Vec3d& wi = config_.beam_direction;
        Vec3d f1, f2;
        orthonormal_frame(wi, f1, f2);
        const std::uint64_t first = pass_ * config_.quanta_per_pass + c * kChunk;
        const std::uint64_t count = std::min(kChunk, config_.quanta_per_pass - c * kChunk);
        std::vector<GroupSum> cells;
        for (std::uint64_t q = first; q < first + count; ++q) {
            const std::size_t from = items.hits[it].size();
            if (shared_) {
                Rng rng(shared_seed_, q);
                play_shared(wi, f1, f2, rng, it, items);
            } else {
                Rng rng(beam_seeds_[k], q);
                play(wi, f1, f2, k, rng, it, items);
            }
            group_cells(items.hits[it], from, nl_, cells);
            items.group_sums[it].insert(items.group_sums[it].end(), cells.begin(), cells.end());
        }
    }

    // A block of illumination directions. Directions 2j and 2j + 1 (neighbouring cells) form a
    // pair; the item's group sums receive, per wavelength and cell, the difference of the
    // pair's group sums (a direction without a partner, the last of an odd count, its own sum:
    // conservative).
    void directional_item(std::size_t it, PassItems& items) const {
        std::vector<std::vector<GroupSum>> even(nl_);
        std::vector<GroupSum> cells;
        std::vector<GroupSum>& sums = items.group_sums[it];
        const std::uint64_t end = std::min(g_.directions, (it + 1) * block_);
        for (std::uint64_t d = it * block_; d < end; ++d) {
            // Direction d of this pass: jittered within its cell of the grid over the unit
            // square, which maps area-preservingly onto the illumination.
            Rng jitter(jitter_seed_, d);
            const double u1 = (static_cast<double>(d / g_.grid.columns) + jitter.uniform()) /
                              static_cast<double>(g_.grid.rows);
            const double u2 = (static_cast<double>(d % g_.grid.columns) + jitter.uniform()) /
                              static_cast<double>(g_.grid.columns);
            const Vec3d wi = illumination_direction(config_, e1_, e2_, u1, u2);
            Vec3d f1, f2;
            orthonormal_frame(wi, f1, f2);
            if (shared_) {
                // One group for every wavelength: its cells hold each λ apart.
                const std::size_t from = items.hits[it].size();
                for (std::uint64_t q = 0; q < g_.group; ++q) {
                    Rng rng(shared_seed_, ((pass_ * g_.directions) + d) * g_.group + q);
                    play_shared(wi, f1, f2, rng, it, items);
                }
                pair_up(d, items.hits[it], from, even[0], cells, sums);
                continue;
            }
            for (std::size_t k = 0; k < nl_; ++k) {
                const std::size_t from = items.hits[it].size();
                for (std::uint64_t q = 0; q < g_.group; ++q) {
                    Rng rng(quantum_seeds_[k], ((pass_ * g_.directions) + d) * g_.group + q);
                    play(wi, f1, f2, k, rng, it, items);
                }
                pair_up(d, items.hits[it], from, even[k], cells, sums);
            }
        }
    }

    // Direction d's group (hits[from …)): kept in `even` for an even d (its own sum when it is
    // the last), or its difference from direction d − 1's appended to the sums.
    void pair_up(std::uint64_t d, const std::vector<Hit>& hits, std::size_t from,
                 std::vector<GroupSum>& even, std::vector<GroupSum>& cells,
                 std::vector<GroupSum>& sums) const {
        if (d % 2 == 0) {
            group_cells(hits, from, nl_, even);
            if (d + 1 == g_.directions) sums.insert(sums.end(), even.begin(), even.end());
            return;
        }
        group_cells(hits, from, nl_, cells);
        append_difference(even, cells, sums);
    }

    const Scatterer& scatterer_;
    const ScatterometerConfig& config_;
    const std::vector<double>& solid_angle_;
    const QuantumGroups& g_;
    std::uint64_t pass_;
    std::size_t nl_, nlobes_;
    bool shared_, split_;
    std::uint64_t chunks_, block_, jitter_seed_, shared_seed_;
    Vec3d e1_, e2_;
    std::vector<std::uint64_t> quantum_seeds_, beam_seeds_;
};

// The pass's items added to the sums, in item order.
void add_items(const PassItems& items, const std::vector<double>& solid_angle, std::size_t nl,
               std::size_t nlobes, Sums& t) {
    const std::size_t np = solid_angle.size();
    for (std::size_t it = 0; it < items.hits.size(); ++it) {
        for (std::size_t k = 0; k < nl; ++k) {
            const double* below_k = &items.below[(it * nl + k) * (nlobes + 1)];
            t.below[k] += below_k[0];
            for (std::size_t l = 0; l < nlobes; ++l) t.below_lobes[l * nl + k] += below_k[1 + l];
        }
        for (const Hit& h : items.hits[it]) {
            const std::size_t cell = static_cast<std::size_t>(h.pixel) * nl + h.wavelength;
            const double x = h.weight / solid_angle[static_cast<std::size_t>(h.pixel)];
            t.sum[cell] += x;
            if (h.lobe >= 0 && static_cast<std::size_t>(h.lobe) < nlobes)
                t.lobe_sum[static_cast<std::size_t>(h.lobe) * np * nl + cell] += x;
        }
        for (const GroupSum& g : items.group_sums[it]) {
            const double x = g.weight / solid_angle[g.cell / nl];
            t.sum_sq[g.cell] += x * x;
        }
    }
}

// The image, its standard errors and the light below from the sums after s.passes passes;
// returns the power-weighted relative error Σ Ω σ / Σ Ω I (bright pixels dominate).
double estimate(const Sums& t, const QuantumGroups& g, Scatterogram& s) {
    const std::size_t np = s.pixels(), nl = s.config.wavelengths_nm.size();
    // Per wavelength: quanta and independent groups of them (see QuantumGroups).
    const double quanta = static_cast<double>(s.passes) * static_cast<double>(g.per_pass);
    const double groups = quanta / static_cast<double>(g.group);
    const double group_sq = static_cast<double>(g.group) * static_cast<double>(g.group);
    s.intensity.assign(np * nl, 0.0);
    s.standard_error.assign(np * nl, 0.0);
    s.lobe_intensity.assign(t.lobe_sum.size(), 0.0);
    double power = 0.0, variance = 0.0;
    for (std::size_t i = 0; i < np * nl; ++i) {
        const double mean = t.sum[i] / quanta;
        s.intensity[i] = mean;
        // Beam: the spread of the quanta about the mean. Cone and hemisphere: each pair of
        // neighbouring directions' (G_a − G_b)² estimates the variance of G_a + G_b, with
        // G = group sum / group (Cochran's collapsed strata: unbiased where neighbouring
        // cells have equal means, otherwise an overestimate); Var = Σ (G_a − G_b)² / J².
        const double var = g.directional ? t.sum_sq[i] / (group_sq * groups * groups)
                                         : std::max(0.0, t.sum_sq[i] / groups - mean * mean) /
                                               std::max(1.0, groups - 1.0);
        s.standard_error[i] = std::sqrt(var);
        power += mean * s.solid_angle_sr[i / nl];
        variance += s.standard_error[i] * s.solid_angle_sr[i / nl];
    }
    for (std::size_t i = 0; i < t.lobe_sum.size(); ++i)
        s.lobe_intensity[i] = t.lobe_sum[i] / quanta;
    s.transmitted.assign(nl, 0.0);
    for (std::size_t k = 0; k < nl; ++k) s.transmitted[k] = t.below[k] / quanta;
    s.transmitted_lobes.assign(t.below_lobes.size(), 0.0);
    for (std::size_t i = 0; i < t.below_lobes.size(); ++i)
        s.transmitted_lobes[i] = t.below_lobes[i] / quanta;
    s.quanta = static_cast<std::uint64_t>(quanta);
    return power > 0.0 ? variance / power : 1.0;
}

// The scatterometer on the pass loop (virtual_gonio/pass_loop.h): a pass's PassWork items, added
// to the sums in item order, the image estimated from them after every pass.
class ScatterometerPasses final : public PassMeasurement {
public:
    ScatterometerPasses(const Scatterer& scatterer, Scatterogram& s, bool one_path)
        : scatterer_(scatterer),
          s_(s),
          groups_(s.config),
          nl_(s.config.wavelengths_nm.size()),
          nlobes_(s.lobes.size()),
          one_path_(one_path) {
        const std::size_t np = s.pixels();
        sums_ = Sums{std::vector<double>(np * nl_, 0.0), std::vector<double>(np * nl_, 0.0),
                     std::vector<double>(nlobes_ * np * nl_, 0.0), std::vector<double>(nl_, 0.0),
                     std::vector<double>(nlobes_ * nl_, 0.0)};
    }

    std::size_t start_pass(int pass) override {
        work_.emplace(scatterer_, s_.config, s_.solid_angle_sr, nlobes_, groups_,
                      static_cast<std::uint64_t>(pass), one_path_, s_.paths_split);
        items_ = work_->empty_items();
        stride_ = items_.below.size() / work_->items();  // below, per item
        return work_->items();
    }
    void run_item(std::size_t it) override { work_->run(it, items_); }
    void pack(std::size_t it, Bytes& out) const override {
        out.put_vector(items_.hits[it]);
        out.put_vector(items_.group_sums[it]);
        out.put_vector(std::vector<double>(items_.below.begin() + it * stride_,
                                           items_.below.begin() + (it + 1) * stride_));
    }
    void unpack(std::size_t it, Bytes& in) override {
        items_.hits[it] = in.get_vector<Hit>();
        items_.group_sums[it] = in.get_vector<GroupSum>();
        const auto below = in.get_vector<double>();
        std::copy(below.begin(), below.end(), items_.below.begin() + it * stride_);
    }
    void add_pass() override { add_items(items_, s_.solid_angle_sr, nl_, nlobes_, sums_); }
    PassEstimate estimate(int passes) override {
        s_.passes = passes;
        PassEstimate e;
        e.relative_error = gonio::estimate(sums_, groups_, s_);
        e.quanta = s_.quanta;
        if (s_.config.target_median_relative_error > 0.0)  // the per-pixel rule (header)
            e.pixel_error = median_relative_standard_error(s_, 0.01);
        return e;
    }

    std::vector<CheckpointSum> checkpoint_sums() override {
        return {{"sum", &sums_.sum},
                {"sum_sq", &sums_.sum_sq},
                {"lobe_sum", &sums_.lobe_sum},
                {"below", &sums_.below},
                {"below_lobes", &sums_.below_lobes}};
    }

private:
    const Scatterer& scatterer_;
    Scatterogram& s_;
    const QuantumGroups groups_;
    std::size_t nl_, nlobes_;
    bool one_path_;
    Sums sums_;
    std::optional<PassWork> work_;
    PassItems items_;
    std::size_t stride_ = 0;
};

// Everything that decides the sums: what a checkpoint is made from.
std::string canonical(const ScatterometerConfig& c, const std::string& scatterer) {
    std::string s = fmt::format("{}|{}|{:.17g},{:.17g},{:.17g}|{:.17g}|{}|{:.17g}|{}|{}|{}|{}|{}|",
                                scatterer, static_cast<int>(c.illumination), c.beam_direction.x(),
                                c.beam_direction.y(), c.beam_direction.z(), c.cone_aperture_rad,
                                c.image_size, c.beam_radius_um, c.seed, c.quanta_per_pass,
                                c.illumination_strata, c.share_wavelength_paths, c.split_paths);
    for (double l : c.wavelengths_nm) s += fmt::format("{:.17g},", l);
    return s;
}

}  // namespace

Scatterogram measure_scatterogram(const Scatterer& scatterer, const ScatterometerConfig& config,
                                  const RunControl& control) {
    config.validate();
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = process_cpu_seconds();
    Scatterogram s;
    s.config = config;
    s.scatterer = scatterer.name();
    s.lobes = scatterer.lobe_names();
    s.solid_angle_sr = pixel_solid_angles(config.image_size);
    record_measurement_seed("scatterometer", config.seed);  // common/seed.h: one root each
    const std::size_t nl = config.wavelengths_nm.size();
    const PathTracing* paths = scatterer.path_tracing();
    s.wavelength_paths_shared = config.share_wavelength_paths && paths != nullptr &&
                                nl <= PathTracing::kMaxSharedWavelengths;
    s.paths_split = config.split_paths && paths != nullptr && paths->can_split_paths() &&
                    (s.wavelength_paths_shared || nl == 1);
    // Splitting rides on the shared walk (one wavelength is a shared walk of one).
    ScatterometerPasses passes(scatterer, s, s.wavelength_paths_shared || s.paths_split);
    StopRule rule;
    rule.max_passes = config.max_passes;
    rule.target_error = config.target_relative_error;
    rule.target_pixel_error = config.target_median_relative_error;
    rule.time_budget_s = config.time_budget_s;
    PassLoopControl loop;
    loop.interrupt = control.interrupt;
    if (control.progress) loop.progress = fmt::format("scatterogram of {}", s.scatterer);
    loop.quanta_per = "wavelength";
    loop.blocks_per_rank = kBlocksPerRank;
    loop.on_pass = control.on_pass;
    loop.checkpoint = control.checkpoint;
    if (!control.checkpoint.empty()) {
        loop.identity = checkpoint_identity(config.config_text, canonical(config, s.scatterer),
                                            control.checkpoint_inputs);
    }
    auto elapsed = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    PassLoopState state;
    run_passes(passes, rule, loop, elapsed, state);
    if (state.interrupted) {
        // A partial image must not flow on; a checkpoint keeps the completed passes.
        throw Interrupted(fmt::format(
            "interrupted while measuring the scatterogram of {} (pass {} of at most {}){}",
            s.scatterer, state.passes + 1, config.max_passes,
            control.checkpoint.empty()
                ? ""
                : fmt::format("; {} completed passes kept in {}: the same command resumes",
                              state.passes, control.checkpoint.string())));
    }
    s.convergence = std::move(state.rows);
    s.wall_time_s = state.resumed_wall_s + elapsed();
    s.cpu_time_s = state.resumed_cpu_s + process_cpu_seconds() - cpu_start;
    return s;
}

namespace {

std::vector<optics::Xyz> pixel_colours(const Scatterogram& s) {
    const SpectrumToDisplay display(s.config.wavelengths_nm);
    const std::size_t nl = s.config.wavelengths_nm.size();
    std::vector<optics::Xyz> xyz(s.pixels(), optics::Xyz{0.0, 0.0, 0.0});
    for (std::size_t p = 0; p < s.pixels(); ++p) {
        if (s.solid_angle_sr[p] > 0.0)
            xyz[p] = display.xyz(std::span<const double>(s.intensity.data() + p * nl, nl));
    }
    return xyz;
}

std::uint8_t byte(double v) {
    return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
}

void draw_rings(record::RgbImage& image) {
    const int n = image.width;
    for (double deg : {5.0, 30.0, 60.0, 90.0}) {
        const double r = deg / 90.0 * 0.5 * n;
        const int steps = static_cast<int>(8 * r) + 16;
        for (int i = 0; i < steps; ++i) {
            const double a = 2.0 * kPi * i / steps, b = 2.0 * kPi * (i + 1) / steps;
            image.draw_line(0.5 * n + r * std::cos(a), 0.5 * n - r * std::sin(a),
                            0.5 * n + r * std::cos(b), 0.5 * n - r * std::sin(b), {128, 128, 128});
        }
    }
}

}  // namespace

record::RgbImage scatterogram_srgb(const Scatterogram& s, double exposure, bool rings) {
    const std::vector<optics::Xyz> xyz = pixel_colours(s);
    if (exposure <= 0.0) {
        double peak = 0.0;
        for (const auto& c : xyz) peak = std::max(peak, c.y);
        exposure = peak > 0.0 ? 1.0 / peak : 1.0;
    }
    const int n = s.config.image_size;
    record::RgbImage image(n, n);
    for (std::size_t p = 0; p < s.pixels(); ++p) {
        const auto rgb = display_bytes(xyz[p], exposure);
        image.set(static_cast<int>(p % n), static_cast<int>(p / n), rgb[0], rgb[1], rgb[2]);
    }
    if (rings) draw_rings(image);
    return image;
}

record::RgbImage scatterogram_difference(const Scatterogram& a, const Scatterogram& b) {
    PLUMAGE_CHECK(a.pixels() == b.pixels() && a.config.wavelengths_nm == b.config.wavelengths_nm,
                  "scatterograms differ in size or wavelengths");
    const std::vector<optics::Xyz> xa = pixel_colours(a), xb = pixel_colours(b);
    double peak = 1e-300;
    for (const auto& c : xa) peak = std::max(peak, c.y);
    const int n = a.config.image_size;
    record::RgbImage image(n, n);
    for (std::size_t p = 0; p < a.pixels(); ++p) {
        const std::uint8_t g = byte(std::abs(xa[p].y - xb[p].y) / peak);
        image.set(static_cast<int>(p % n), static_cast<int>(p / n), g, g, g);
    }
    draw_rings(image);
    return image;
}

double scatterogram_peak_luminance(const Scatterogram& s) {
    double peak = 0.0;
    for (const auto& c : pixel_colours(s)) peak = std::max(peak, c.y);
    return peak;
}

double median_relative_standard_error(const Scatterogram& s, double signal_fraction) {
    const std::size_t nl = s.config.wavelengths_nm.size();
    if (s.intensity.size() != s.pixels() * nl || s.standard_error.size() != s.intensity.size())
        return std::numeric_limits<double>::quiet_NaN();
    std::vector<double> peak(nl, 0.0), relative;
    for (std::size_t p = 0; p < s.pixels(); ++p) {
        if (!(s.solid_angle_sr[p] > 0.0)) continue;
        for (std::size_t k = 0; k < nl; ++k) peak[k] = std::max(peak[k], s.intensity[p * nl + k]);
    }
    for (std::size_t p = 0; p < s.pixels(); ++p) {
        if (!(s.solid_angle_sr[p] > 0.0)) continue;
        for (std::size_t k = 0; k < nl; ++k) {
            const double value = s.intensity[p * nl + k];
            if (value > 0.0 && value > signal_fraction * peak[k])
                relative.push_back(s.standard_error[p * nl + k] / value);
        }
    }
    if (relative.empty()) return std::numeric_limits<double>::quiet_NaN();
    // The lower median for an even count: a value that occurs, no interpolation.
    const auto middle = relative.begin() + static_cast<std::ptrdiff_t>((relative.size() - 1) / 2);
    std::nth_element(relative.begin(), middle, relative.end());
    return *middle;
}

namespace {

using Dims = std::vector<std::uint64_t>;

// What the instrument was: kind, illumination, beam, paths and the image's mapping.
void write_scatterometer(record::Hdf5Writer& h5, const Scatterogram& s) {
    const ScatterometerConfig& c = s.config;
    h5.create_group("instrument");
    h5.set_attribute("/instrument", "kind", "imaging_scatterometer");
    h5.set_attribute("/instrument", "illumination",
                     c.illumination == Illumination::beam   ? "beam"
                     : c.illumination == Illumination::cone ? "cone"
                                                            : "hemisphere");
    h5.set_attribute("/instrument", "beam_direction",
                     fmt::format("{:.9f} {:.9f} {:.9f}", c.beam_direction.x(), c.beam_direction.y(),
                                 c.beam_direction.z()));
    h5.set_attribute("/instrument", "cone_aperture_deg", c.cone_aperture_rad * 180.0 / kPi);
    h5.set_attribute("/instrument", "beam_radius_um", c.beam_radius_um);
    write_path_options(h5, s.wavelength_paths_shared, s.paths_split);
    h5.set_attribute("/instrument", "mapping",
                     "azimuthal equidistant: theta = 90 deg * hypot(u, v), phi = atan2(v, u) from "
                     "+x; row 0 at the top");
}

// Each pixel's direction written out, so that a reader needs no code for the mapping.
void write_pixel_directions(record::Hdf5Writer& h5, const Scatterogram& s) {
    const auto& c = s.config;
    const std::uint64_t n = static_cast<std::uint64_t>(c.image_size);
    std::vector<double> directions(static_cast<std::size_t>(n * n * 3),
                                   std::numeric_limits<double>::quiet_NaN());
    for (int row = 0; row < c.image_size; ++row) {
        for (int column = 0; column < c.image_size; ++column) {
            const auto w = s.direction(column, row);
            if (!w) continue;
            const std::size_t at = (static_cast<std::size_t>(row) * n + column) * 3;
            directions[at] = w->x();
            directions[at + 1] = w->y();
            directions[at + 2] = w->z();
        }
    }
    h5.write("image/directions", std::span<const double>(directions), Dims{n, n, 3},
             {{"units", "1"},
              {"description",
               "unit vector of each pixel centre away from the patch, patch frame (+z normal, "
               "+x barb axis), [row, column, xyz]; NaN outside the disc (/instrument@mapping)"}});
}

// The image: each pixel's solid angle, intensity, standard error and each lobe's part.
void write_image(record::Hdf5Writer& h5, const Scatterogram& s) {
    const std::uint64_t n = static_cast<std::uint64_t>(s.config.image_size),
                        nl = s.config.wavelengths_nm.size();
    h5.write("image/solid_angle_sr", std::span<const double>(s.solid_angle_sr), Dims{n, n},
             {{"units", "sr"},
              {"description", "solid angle each pixel spans, [row, column]; 0 outside the disc"}});
    h5.write(
        "image/intensity", std::span<const double>(s.intensity), Dims{n, n, nl},
        {{"units", "1/sr"},
         {"description", "radiant intensity per unit incident power, [row, column, wavelength]"}});
    h5.write("image/standard_error", std::span<const double>(s.standard_error), Dims{n, n, nl},
             {{"units", "1/sr"},
              {"description",
               "Monte Carlo standard error of image/intensity, [row, column, wavelength]"}});
    for (std::size_t l = 0; l < s.lobes.size(); ++l) {
        h5.write("image/lobes/" + s.lobes[l],
                 std::span<const double>(s.lobe_intensity.data() + l * n * n * nl, n * n * nl),
                 Dims{n, n, nl},
                 {{"units", "1/sr"},
                  {"description", fmt::format("the {} lobe's part of image/intensity, [row, "
                                              "column, wavelength]",
                                              s.lobes[l])}});
    }
}

// The power that leaves below the patch, in total and per lobe.
void write_transmitted(record::Hdf5Writer& h5, const Scatterogram& s) {
    const std::uint64_t nl = s.config.wavelengths_nm.size();
    h5.write("transmitted_fraction", std::span<const double>(s.transmitted), Dims{nl},
             {{"units", "1"},
              {"description", "fraction of the incident power leaving below the patch"}});
    for (std::size_t l = 0; l < s.lobes.size(); ++l) {
        h5.write("transmitted_lobes/" + s.lobes[l],
                 std::span<const double>(s.transmitted_lobes.data() + l * nl, nl), Dims{nl},
                 {{"units", "1"},
                  {"description",
                   fmt::format("the {} lobe's part of transmitted_fraction", s.lobes[l])}});
    }
}

}  // namespace

void write_scatterogram_record(const Scatterogram& s, const std::filesystem::path& path) {
    const auto& c = s.config;
    const std::uint64_t nl = c.wavelengths_nm.size();
    record::Hdf5Writer h5(path);
    h5.set_attribute("/", "format", "plumage record 1 (virtual_gonio/RECORD.md)");
    write_scatterometer(h5, s);
    write_polarisation(h5);
    h5.write("wavelength_nm", std::span<const double>(c.wavelengths_nm), Dims{nl},
             {{"units", "nm"}, {"description", "vacuum wavelengths of the measurement"}});
    write_pixel_directions(h5, s);
    write_image(h5, s);
    write_transmitted(h5, s);
    write_convergence(
        h5, s.convergence,
        convergence_attributes(
            "pass, wall_time_s, quanta_per_wavelength, power_weighted_relative_error"));
    write_provenance(h5, {.scatterer = s.scatterer,
                          .seed = c.seed,
                          .threads = omp_get_max_threads(),
                          .wall_time_s = s.wall_time_s,
                          .cpu_time_s = s.cpu_time_s,
                          .config = c.config_text});
    h5.commit();
}

}  // namespace plumage::gonio
