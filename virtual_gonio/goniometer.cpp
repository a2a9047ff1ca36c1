#include "virtual_gonio/goniometer.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iostream>
#include <map>
#include <numeric>
#include <optional>
#include <random>
#include <span>
#include <string_view>
#include <tuple>

#include <fmt/format.h>

#include "common/build_info.h"
#include "common/constants.h"
#include "common/cpu_time.h"
#include "common/distributed.h"
#include "common/error.h"
#include "common/gauss_legendre.h"
#include "common/require.h"
#include "common/seed.h"
#include "common/version.h"
#include "sim/scatterer/stratified.h"
#include "virtual_gonio/display_colour.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/record_provenance.h"

namespace plumage::gonio {
namespace {

constexpr std::uint64_t kChunk = 2048;  // quanta per work item: the unit of reduction order
// Detector-side walks per stratified block (play_connected_item); kChunk is a multiple of it.
constexpr std::uint64_t kConnectedBlock = 64;
// Under MPI a pass's items are dealt in this many blocks per rank (common/distributed.h): enough
// for a slow block not to hold up the pass, few enough that a block keeps a rank's threads busy.
constexpr std::size_t kBlocksPerRank = 4;

// The name that prefixes this file's input errors.
constexpr std::string_view kWhat = "goniometer";

std::string canonical(const GoniometerConfig& c, const std::string& scatterer,
                      Estimator estimator) {
    std::string s = fmt::format("{}|{}|{:.17g}|{:.17g}|{}|{}|{}|", scatterer, c.direction_set,
                                c.detector_half_angle_rad, c.beam_radius_um, c.seed,
                                c.quanta_per_pass, static_cast<int>(estimator));
    for (double l : c.wavelengths_nm) s += fmt::format("{:.17g},", l);
    // Options added later enter only when not at their default, so that the checkpoints of
    // runs made before them still resume.
    if (c.aperture != Aperture::view_cone) s += fmt::format("aperture={}|", to_string(c.aperture));
    if (c.share_wavelength_paths) s += "shared_paths|";
    if (c.split_paths) s += "split_paths|";
    if (c.split_paths && c.split_reflections) s += "split_reflections|";
    if (c.guided_fraction > 0.0) s += fmt::format("guided={:.17g}|", c.guided_fraction);
    if (c.guided_branches > 0) s += fmt::format("guided_branches={}|", c.guided_branches);
    // The balance heuristic's weights replaced the partition of the paths (2026-12-01): the
    // partition's checkpoints do not resume into it.
    if (c.connect_lights)
        s += fmt::format("connect_lights={},balance,stratified|", c.connected_walks_per_pass());
    for (const auto& p : c.pairs) {
        s += fmt::format("{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g};", p.wi.x(), p.wi.y(),
                         p.wi.z(), p.wo.x(), p.wo.y(), p.wo.z());
    }
    return s;
}

struct Group {  // pairs sharing one light direction (or one view direction: group_by_view)
    Vec3d wi;   // the direction they share (the view's, for group_by_view)
    std::vector<std::size_t> pairs;
};

// The pairs grouped by one of their directions (DirectionPair::wi or ::wo), in order of first use.
std::vector<Group> group_by(const std::vector<DirectionPair>& pairs,
                            Vec3d DirectionPair::*direction) {
    std::vector<Group> groups;
    std::map<std::array<double, 3>, std::size_t> index;
    for (std::size_t p = 0; p < pairs.size(); ++p) {
        const Vec3d& d = pairs[p].*direction;
        auto [it, inserted] =
            index.emplace(std::array<double, 3>{d.x(), d.y(), d.z()}, groups.size());
        if (inserted) groups.push_back({d, {}});
        groups[it->second].pairs.push_back(p);
    }
    return groups;
}

std::vector<Group> group_by_light(const std::vector<DirectionPair>& pairs) {
    return group_by(pairs, &DirectionPair::wi);
}

std::vector<Group> group_by_view(const std::vector<DirectionPair>& pairs) {
    return group_by(pairs, &DirectionPair::wo);
}

// A light direction's detector axes ordered by cos θ, to find the cones that may hold a
// direction without testing all of them: a cone of half-angle α about a holds d only if
// |θ_d − θ_a| <= α, so a.z lies within [cos(θ_d + α), cos(θ_d − α)] (clamped at the poles).
struct ConesByElevation {
    std::vector<std::size_t> order;  // detector indices, by increasing axis z
    std::vector<double> z;           // their axes' z, increasing
    double cos_alpha, sin_alpha;

    ConesByElevation(std::span<const Vec3d> axes, double alpha)
        : order(axes.size()), cos_alpha(std::cos(alpha)), sin_alpha(std::sin(alpha)) {
        std::iota(order.begin(), order.end(), std::size_t{0});
        std::stable_sort(order.begin(), order.end(),
                         [&](std::size_t a, std::size_t b) { return axes[a].z() < axes[b].z(); });
        for (std::size_t j : order) z.push_back(axes[j].z());
    }
    // [first, last) of `order` that may hold d (a superset: the caller tests each).
    std::pair<std::size_t, std::size_t> candidates(const Vec3d& d) const {
        constexpr double kMargin = 1e-9;  // round-off of the bounds; never drops a true hit
        const double dz = std::clamp(d.z(), -1.0, 1.0);
        const double sin_d = std::sqrt(std::max(0.0, 1.0 - dz * dz));
        // cos(θ_d ± α); past a pole (θ_d + α > π or θ_d − α < 0) the bound is that pole's.
        const bool below_south = sin_d * cos_alpha < -dz * sin_alpha;  // θ_d + α > π
        const bool past_north = sin_d * cos_alpha < dz * sin_alpha;    // θ_d − α < 0
        const double lo = below_south ? -1.0 : dz * cos_alpha - sin_d * sin_alpha - kMargin;
        const double hi = past_north ? 1.0 : dz * cos_alpha + sin_d * sin_alpha + kMargin;
        const auto first = std::lower_bound(z.begin(), z.end(), lo) - z.begin();
        const auto last = std::upper_bound(z.begin(), z.end(), hi) - z.begin();
        return {static_cast<std::size_t>(first), static_cast<std::size_t>(last)};
    }
};

// Accumulators of the photon estimator, per (pair, wavelength): Σx, Σx², and Σx per lobe.
struct Sums {
    std::vector<double> sum, sum_sq, lobe_sum, lobe_sum_sq;
};

// A work item of the photon estimator: quanta [first, first + count) of one light direction's
// group and one wavelength (or every wavelength, shared).
struct PhotonItem {
    std::size_t group, wavelength;  // connected: the view direction's group, wavelength 0
    std::uint64_t first, count;
    bool connected = false;  // detector-side walks (connect_lights), not photon quanta
};

// One quantum's escape: its branches (one without splitting) and their weights, branch-major
// with the item's wavelengths within a branch. Reused from quantum to quantum.
struct QuantumEscape {
    std::array<double, PathTracing::kMaxBranches * PathTracing::kMaxSharedWavelengths> weights{};
    std::array<SpectralScatterEvent, PathTracing::kMaxBranches> branches{};
    std::size_t count = 0;
};

// Where a view's detector-side walks start (goniometer.h, "connect_lights"): p(x) over the top
// plane, a piecewise-constant density on a grid mixed with a heavy-tailed density over the whole
// plane. The grid covers where the view's walks can see its lights' beams: each light's footprint
// ellipse widened by d and swept along the walk direction by the scene's depth (a capsule), for
// the view's axis and four directions on its cone's rim; a cell's density is the capsules' mean
// density at its centre. The grid part is drawn by inverting its CDF (rows, then the column within
// the row) from a point of the unit square, so that a block's stratified points
// (ScrambledSobolGroup) give stratified starts.
class ConnectedStarts {
public:
    static constexpr double kTail = 0.1;          // ε: the share of the heavy-tailed density
    static constexpr double kCellsPerRadius = 8;  // grid cells per beam radius

    // depth_um: the scene's depth below the entry plane (PathTracing::depth_um()).
    ConnectedStarts(const GoniometerConfig& c, const Group& view, double depth_um)
        : cell_um_(c.beam_radius_um / kCellsPerRadius),
          tail_scale_(2.0 * c.beam_radius_um + depth_um) {
        const std::vector<Swept> swept = swept_capsules(c, view, depth_um);
        place_grid(swept);
        const double total = rasterise(swept);
        build_cdfs(total);
    }

    // A start from one number of rng (the tail's share) and either the grid's point u of the
    // unit square or, for the tail, two more numbers of rng.
    Vec2 draw(const Vec2& u, Rng& rng) const {
        if (rng.uniform() < kTail) {
            // Radius by inverting the tail's radial CDF 1 − s/√(s² + ρ²).
            const double v = rng.uniform();
            const double radius =
                tail_scale_ * std::sqrt(std::max(0.0, 1.0 / ((1.0 - v) * (1.0 - v)) - 1.0));
            const double angle = 2.0 * kPi * rng.uniform();
            return {radius * std::cos(angle), radius * std::sin(angle)};
        }
        const auto [iy, fy] = invert(std::span(row_cdf_), u.y());
        const auto [ix, fx] =
            invert(std::span(column_cdf_).subspan(iy * (nx_ + 1), nx_ + 1), u.x());
        return origin_ +
               cell_um_ * Vec2(static_cast<double>(ix) + fx, static_cast<double>(iy) + fy);
    }

    // p(x): the same for every direction of the view's cone.
    double density(const Vec2& x) const {
        double grid = 0.0;
        const Vec2 g = (x - origin_) / cell_um_;
        if (g.x() >= 0.0 && g.y() >= 0.0 && g.x() < static_cast<double>(nx_) &&
            g.y() < static_cast<double>(ny_))
            grid = cell_density_[static_cast<std::size_t>(g.y()) * nx_ +
                                 static_cast<std::size_t>(g.x())];
        const double s2 = tail_scale_ * tail_scale_;
        const double tail = tail_scale_ / (2.0 * kPi * std::pow(s2 + x.squaredNorm(), 1.5));
        return (1.0 - kTail) * grid + kTail * tail;
    }

private:
    // A light's footprint ellipse (widened by d) swept along a segment: in the ellipse's unit
    // coordinates (the ellipse the unit disc), a capsule of radius 1 around the segment.
    struct Capsule {
        Vec2 along;   // unit, the light's azimuth on the plane
        double a, b;  // semi-axes along and across, µm
        Vec2 light_slope;
    };
    // A capsule swept for one direction: its segment (unit coordinates) and bounding box (µm).
    struct Swept {
        Capsule capsule;
        Vec2 segment, lo, hi;
    };

    // Each light's capsule swept for the view's axis and four directions on its cone's rim.
    static std::vector<Swept> swept_capsules(const GoniometerConfig& c, const Group& view,
                                             double depth_um) {
        const double r = c.beam_radius_um, d = r;  // d: room for the light's lateral travel
        std::vector<Vec3d> directions{view.wi};
        for (const auto& [d1, d2] : {std::pair{1.0, 0.0}, {-1.0, 0.0}, {0.0, 1.0}, {0.0, -1.0}})
            directions.push_back(
                cone_direction_by_projected_area(view.wi, c.detector_half_angle_rad, d1, d2));
        std::vector<Swept> swept;
        for (std::size_t p : view.pairs) {
            const Vec3d& wi = c.pairs[p].wi;
            const double across = std::hypot(wi.x(), wi.y());
            Capsule e;
            e.along = across > 0.0 ? Vec2(wi.x() / across, wi.y() / across) : Vec2(1.0, 0.0);
            e.a = r / wi.z() + d;  // the footprint's semi-axis along the light's azimuth, + d
            e.b = r + d;           // across, + d
            e.light_slope = Vec2(wi.x(), wi.y()) / wi.z();
            const Vec2 half(std::hypot(e.a * e.along.x(), e.b * e.along.y()),
                            std::hypot(e.a * e.along.y(), e.b * e.along.x()));
            for (const Vec3d& wo : directions) {
                const Vec2 shift = depth_um * (Vec2(wo.x(), wo.y()) / wo.z() - e.light_slope);
                swept.push_back({e, to_unit(e, shift), shift.cwiseMin(Vec2::Zero()) - half,
                                 shift.cwiseMax(Vec2::Zero()) + half});
            }
        }
        return swept;
    }

    // The grid over every swept capsule's box.
    void place_grid(const std::vector<Swept>& swept) {
        Vec2 lo = Vec2::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
        for (const Swept& w : swept) {
            lo = lo.cwiseMin(w.lo);
            hi = hi.cwiseMax(w.hi);
        }
        origin_ = lo;
        nx_ = std::max<std::size_t>(
            1, static_cast<std::size_t>(std::ceil((hi.x() - lo.x()) / cell_um_)));
        ny_ = std::max<std::size_t>(
            1, static_cast<std::size_t>(std::ceil((hi.y() - lo.y()) / cell_um_)));
    }

    // Each swept capsule's density added at the centres of the cells in its box; the sum of all.
    double rasterise(const std::vector<Swept>& swept) {
        cell_density_.assign(nx_ * ny_, 0.0);
        auto cell_of = [&](double x, std::size_t n) {
            return std::min(n - 1, static_cast<std::size_t>(std::max(0.0, x / cell_um_)));
        };
        double total = 0.0;
        for (const Swept& w : swept) {
            const Capsule& e = w.capsule;
            const double density = 1.0 / (e.a * e.b * (kPi + 2.0 * w.segment.norm()));
            const Vec2 from = w.lo - origin_, to = w.hi - origin_;
            for (std::size_t iy = cell_of(from.y(), ny_); iy <= cell_of(to.y(), ny_); ++iy)
                for (std::size_t ix = cell_of(from.x(), nx_); ix <= cell_of(to.x(), nx_); ++ix) {
                    const Vec2 x = origin_ + cell_um_ * Vec2(static_cast<double>(ix) + 0.5,
                                                             static_cast<double>(iy) + 0.5);
                    if (inside(w.segment, to_unit(e, x))) {
                        cell_density_[iy * nx_ + ix] += density;
                        total += density;
                    }
                }
        }
        return total;
    }

    // The cells normalised to a density (µm⁻²); the CDFs of the rows and of the columns within
    // each row.
    void build_cdfs(double total) {
        row_cdf_.assign(ny_ + 1, 0.0);
        column_cdf_.assign(ny_ * (nx_ + 1), 0.0);
        for (std::size_t iy = 0; iy < ny_; ++iy) {
            double row = 0.0;
            for (std::size_t ix = 0; ix < nx_; ++ix) {
                double& density = cell_density_[iy * nx_ + ix];
                density /= total * cell_um_ * cell_um_;
                row += density;
                column_cdf_[iy * (nx_ + 1) + ix + 1] = row;
            }
            for (std::size_t ix = 1; ix <= nx_; ++ix)
                if (row > 0.0) column_cdf_[iy * (nx_ + 1) + ix] /= row;
            row_cdf_[iy + 1] = row_cdf_[iy] + row;
        }
        const double rows = row_cdf_.back();  // 1 / h² up to round-off: made exactly 1
        for (double& v : row_cdf_) v /= rows;
    }
    static Vec2 to_unit(const Capsule& e, const Vec2& x) {
        return {x.dot(e.along) / e.a, (e.along.x() * x.y() - e.along.y() * x.x()) / e.b};
    }
    // Whether q (unit coordinates) lies within 1 of the segment from 0 to `segment`.
    static bool inside(const Vec2& segment, const Vec2& q) {
        const double length2 = segment.squaredNorm();
        const double t = length2 > 0.0 ? std::clamp(q.dot(segment) / length2, 0.0, 1.0) : 0.0;
        return (q - t * segment).squaredNorm() <= 1.0;
    }
    // The bin of a CDF (cdf[0] = 0, cdf.back() = 1) that holds u, and u's fraction within it.
    static std::pair<std::size_t, double> invert(std::span<const double> cdf, double u) {
        const std::size_t bins = cdf.size() - 1;
        std::size_t i =
            static_cast<std::size_t>(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin());
        i = std::clamp<std::size_t>(i, 1, bins) - 1;
        while (i + 1 < bins && !(cdf[i + 1] > cdf[i])) ++i;  // past empty bins
        const double width = cdf[i + 1] - cdf[i];
        return {i, width > 0.0 ? std::clamp((u - cdf[i]) / width, 0.0, 1.0) : 0.5};
    }

    Vec2 origin_;  // the grid's lower corner, µm
    double cell_um_;
    std::size_t nx_ = 0, ny_ = 0;
    std::vector<double> cell_density_;  // µm⁻², [iy · nx + ix]
    std::vector<double> row_cdf_;       // ny + 1
    std::vector<double> column_cdf_;    // per row, nx + 1
    double tail_scale_;
};

// The two strategies' weights (goniometer.h, "connect_lights"): the balance heuristic between
// the light side's quanta (n_L per light direction and pass) and the detector side's walks (n_D
// per view direction and pass) for a path whose one diffuse event the light reaches straight.
// Both make it; with ρ = p_L / p_D, the ratio of their densities for the same path,
//     w_L = n_L ρ / (n_L ρ + n_D),   w_D = n_D / (n_L ρ + n_D),
//     ρ = g cos θ_l · sin²α cos θ_v / (π r² p(x | ω)),
// the light side's g cos θ_l (SpectralScatterEvent::lit_diffuse_density) at the diffuse event,
// x and ω where the detector side's walk for the same path starts: for a light-side path its exit
// point and direction (a mounted sample turns both back into the instrument's frame alike).
class ConnectionWeights {
public:
    ConnectionWeights(const GoniometerConfig& c, const std::vector<Group>& views, double depth_um)
        : view_of_pair_(c.pairs.size(), 0),
          per_density_(std::pow(std::sin(c.detector_half_angle_rad), 2) /
                       (kPi * c.beam_radius_um * c.beam_radius_um)),
          walks_per_quantum_(static_cast<double>(c.connected_walks_per_pass()) /
                             static_cast<double>(c.quanta_per_pass)) {
        // The views' grids in parallel (0.4 s for the rock dove's 61 views on one core).
        std::vector<std::optional<ConnectedStarts>> built(views.size());
        const auto n = static_cast<std::ptrdiff_t>(views.size());
#pragma omp parallel for schedule(dynamic)
        for (std::ptrdiff_t v = 0; v < n; ++v)
            built[static_cast<std::size_t>(v)].emplace(c, views[static_cast<std::size_t>(v)],
                                                       depth_um);
        for (std::size_t v = 0; v < views.size(); ++v) {
            starts_.push_back(std::move(*built[v]));
            view_axis_z_.push_back(views[v].wi.z());
            for (std::size_t p : views[v].pairs) view_of_pair_[p] = v;
        }
    }

    const ConnectedStarts& starts(std::size_t view) const { return starts_[view]; }

    // ρ for a path with the light side's factor `lit` whose detector-side walk of `view` starts
    // at x with density p(x | ω).
    double ratio(double lit, std::size_t view, double start_density) const {
        return lit * per_density_ * view_axis_z_[view] / start_density;
    }
    // w_D for a connection with ρ.
    double detector_side(double rho) const {
        return walks_per_quantum_ / (rho + walks_per_quantum_);
    }
    // w_L for a light-side path entering the cone of `pair` (1 where only the light side makes it).
    double light_side(std::size_t pair, const SpectralScatterEvent& e) const {
        if (!(e.lit_diffuse_density > 0.0)) return 1.0;
        const std::size_t v = view_of_pair_[pair];
        const double rho = ratio(e.lit_diffuse_density, v, starts_[v].density(e.exit_position_um));
        return rho / (rho + walks_per_quantum_);
    }

private:
    std::vector<ConnectedStarts> starts_;
    std::vector<double> view_axis_z_;
    std::vector<std::size_t> view_of_pair_;
    double per_density_;        // sin²α / (π r²)
    double walks_per_quantum_;  // n_D / n_L
};

// The detectors of one light direction's group and the sums a quantum adds to, in play_item's
// layout: per wavelength of the item, Σx, Σx², then Σx and Σx² per lobe, in the group's pair
// order.
struct GroupDetectors {
    GroupDetectors(const GoniometerConfig& c, const Group& g, std::size_t lobes,
                   std::size_t wavelengths, const ConnectionWeights* connection_weights = nullptr)
        : config(c),
          group(g),
          m(g.pairs.size()),
          nlobes(lobes),
          item_wavelengths(wavelengths),
          stride(m * (2 + 2 * lobes)),
          cos_alpha(std::cos(c.detector_half_angle_rad)),
          projected(kPi * std::pow(std::sin(c.detector_half_angle_rad), 2)),
          axes(axes_of(c, g)),
          cones(axes, c.detector_half_angle_rad),
          weights(connection_weights) {}

    static std::vector<Vec3d> axes_of(const GoniometerConfig& c, const Group& g) {
        std::vector<Vec3d> result;
        for (std::size_t p : g.pairs) result.push_back(c.pairs[p].wo);
        return result;
    }

    // Adds the quantum's branches to the sums of every detector one of them enters. Only the
    // detectors near a branch's elevation can hold it (the same sums, fewer tests).
    void add(const QuantumEscape& escape, std::vector<double>& acc) const {
        std::size_t near_first = m, near_last = 0;
        for (std::size_t b = 0; b < escape.count; ++b) {
            const auto [f, l] = cones.candidates(escape.branches[b].wo);
            near_first = std::min(near_first, f);
            near_last = std::max(near_last, l);
        }
        for (std::size_t s = near_first; s < near_last; ++s)
            add_to_detector(escape, cones.order[s], acc);
    }

    // Detector j (in the group's pair order): the sum of the branches that enter it (one,
    // without splitting), and per lobe the sum of those of that lobe, each then squared.
    void add_to_detector(const QuantumEscape& escape, std::size_t j,
                         std::vector<double>& acc) const {
        const Vec3d& wo = config.pairs[group.pairs[j]].wo;
        std::array<std::size_t, PathTracing::kMaxBranches> in{};
        std::size_t hits = 0;
        for (std::size_t b = 0; b < escape.count; ++b)
            if (!(escape.branches[b].wo.dot(wo) < cos_alpha)) in[hits++] = b;
        if (hits == 0) return;
        // Each branch's weight against the detector side's connections (connect_lights).
        std::array<double, PathTracing::kMaxBranches> mis;
        for (std::size_t h = 0; h < hits; ++h)
            mis[h] = weights ? weights->light_side(group.pairs[j], escape.branches[in[h]]) : 1.0;
        // Divided, not multiplied by a reciprocal: the same bits as before
        // spectral paths for the per-wavelength estimator.
        const double projected_wo = projected * wo.z();
        for (std::size_t k = 0; k < item_wavelengths; ++k) {
            double* a = acc.data() + k * stride;
            double x = 0.0;
            for (std::size_t h = 0; h < hits; ++h) {
                const double wk = escape.weights[in[h] * item_wavelengths + k];
                if (wk > 0.0) x += mis[h] * wk / projected_wo;
            }
            if (!(x > 0.0)) continue;
            a[j] += x;
            a[m + j] += x * x;
            add_lobes(escape, std::span(in.data(), hits), std::span(mis.data(), hits), k, j,
                      projected_wo, a);
        }
    }

    // Per lobe: the sum of the quantum's branches of each lobe among the hits.
    void add_lobes(const QuantumEscape& escape, std::span<const std::size_t> in,
                   std::span<const double> mis, std::size_t k, std::size_t j, double projected_wo,
                   double* a) const {
        const std::size_t hits = in.size();
        for (std::size_t h = 0; h < hits; ++h) {
            const int lobe = escape.branches[in[h]].lobe;
            if (lobe < 0 || static_cast<std::size_t>(lobe) >= nlobes) continue;
            bool first = true;  // of its lobe among the hits
            for (std::size_t g = 0; g < h; ++g)
                first = first && escape.branches[in[g]].lobe != lobe;
            if (!first) continue;
            double xl = 0.0;
            for (std::size_t g = h; g < hits; ++g) {
                const double wk = escape.weights[in[g] * item_wavelengths + k];
                if (escape.branches[in[g]].lobe == lobe && wk > 0.0)
                    xl += mis[g] * wk / projected_wo;
            }
            const auto l = static_cast<std::size_t>(lobe);
            a[(2 + l) * m + j] += xl;
            a[(2 + nlobes + l) * m + j] += xl * xl;
        }
    }

    const GoniometerConfig& config;
    const Group& group;
    std::size_t m, nlobes, item_wavelengths, stride;
    double cos_alpha, projected;  // projected: π sin²α, × cos θ_v per pair
    std::vector<Vec3d> axes;      // the detectors' axes, in the group's pair order
    ConesByElevation cones;
    const ConnectionWeights* weights;  // connect_lights: the light side's weights; else none
};

// A quantum's entry point: uniform over the beam's cross-section (e1, e2 span it), projected
// along ω_i onto the patch plane. Draws two numbers.
Vec2 beam_position(const GoniometerConfig& config, const Vec3d& wi, const Vec3d& e1,
                   const Vec3d& e2, Rng& rng) {
    const double radius = config.beam_radius_um * std::sqrt(rng.uniform());
    const double angle = 2.0 * kPi * rng.uniform();
    const Vec3d offset = radius * (std::cos(angle) * e1 + std::sin(angle) * e2);
    return Vec2(offset.x() - offset.z() * wi.x() / wi.z(),
                offset.y() - offset.z() * wi.y() / wi.z());
}

// A quantum's light direction: the group's, or under both_cones one by projected solid angle
// over the source cone (goniometer.h, "Aperture"; draws two numbers).
Vec3d quantum_light(const GoniometerConfig& config, const Vec3d& wi, Rng& rng) {
    if (config.aperture != Aperture::both_cones) return wi;
    return draw_cone_direction_by_projected_area(wi, config.detector_half_angle_rad, rng);
}

// Plays one quantum into escape (count 0: absorbed, or no weight): with branches, with one path
// for every wavelength (shared), or for the item's one wavelength.
void sample_quantum(const Scatterer& scatterer, const GoniometerConfig& config,
                    const PhotonItem& item, const Vec3d& wi, const Vec2& position, Rng& rng,
                    bool shared, bool branched, const BranchOptions& options,
                    QuantumEscape& escape) {
    const std::size_t nl = config.wavelengths_nm.size();
    escape.count = 0;
    if (branched) {
        escape.count = checked_path_tracing(scatterer).sample_spectral_branches(
            wi, config.wavelengths_nm, position, rng, options, escape.branches, escape.weights);
    } else if (shared) {
        const auto event = checked_path_tracing(scatterer).sample_spectral(
            wi, config.wavelengths_nm, position, rng, std::span<double>(escape.weights.data(), nl));
        if (!event) return;
        escape.branches[0] = *event;
        escape.count = 1;
    } else {
        const auto event =
            scatterer.sample(wi, config.wavelengths_nm[item.wavelength], position, rng);
        if (!event || !(event->weight > 0.0)) return;
        escape.branches[0] = {event->wo, event->lobe, event->exit_position_um};
        escape.weights[0] = event->weight;
        escape.count = 1;
    }
    const std::size_t item_wavelengths = shared ? nl : 1;
    for (std::size_t k = 0; k < escape.count * item_wavelengths; ++k)
        PLUMAGE_CHECK(std::isfinite(escape.weights[k]),
                      "non-finite quantum weight from " + scatterer.name());
}

// Plays one work item's quanta (one light direction; one wavelength, or all of them when the
// wavelengths share paths) into acc: per wavelength of the item, Σx, Σx², then Σx and Σx² per
// lobe, in the group's pair order. Its streams: see item_seed below.
// With branched (shared paths, split or guided) a quantum is the sum of its branches
// (sim/scatterer/scatterer.h): each cell's x is the sum of the branches that enter its cone, and
// per lobe the sum of those of that lobe, before they are squared.
void play_item(const Scatterer& scatterer, const GoniometerConfig& config,
               const std::vector<Group>& groups, const PhotonItem& item, std::size_t nlobes,
               bool shared, bool branched, const ConnectionWeights* connection_weights,
               std::vector<double>& acc) {
    const std::size_t nl = config.wavelengths_nm.size(), item_wavelengths = shared ? nl : 1;
    const Group& group = groups[item.group];
    const GroupDetectors detectors(config, group, nlobes, item_wavelengths, connection_weights);
    acc.assign(item_wavelengths * detectors.stride, 0.0);
    Vec3d e1, e2;
    orthonormal_frame(group.wi, e1, e2);
    // Quantum q of the item draws from Rng(item_seed, q) (common/seed.h): shared paths from
    // their own purpose, per light direction; separate ones per (light direction, wavelength).
    const std::uint64_t item_seed =
        shared ? derive_seed(config.seed, "goniometer/shared-quantum", item.group)
               : derive_seed(config.seed, "goniometer/quantum", item.group * nl + item.wavelength);
    BranchOptions options;
    options.split_first_film = config.split_paths;
    options.split_reflections = config.split_reflections;
    options.detector_axes = detectors.axes;
    options.detector_half_angle_rad = config.detector_half_angle_rad;
    options.guided_fraction = config.guided_fraction;
    options.guided_branches = config.guided_branches;
    options.connected_light_side = config.connect_lights;
    QuantumEscape escape;
    for (std::uint64_t q = item.first; q < item.first + item.count; ++q) {
        Rng rng(item_seed, q);
        const Vec2 position = beam_position(config, group.wi, e1, e2, rng);
        const Vec3d wi = quantum_light(config, group.wi, rng);
        sample_quantum(scatterer, config, item, wi, position, rng, shared, branched, options,
                       escape);
        detectors.add(escape, acc);
    }
}

// One detector-side walk's connections into the cells of its view (goniometer.h,
// "connect_lights"): x_j = w / (π r² p(x | ω)) for each connection that enters light j's footprint,
// summed per light and wavelength (and per lobe) over the walk, then added to play_item's layout.
class ConnectedCells final : public LightConnectionSink {
public:
    ConnectedCells(const GoniometerConfig& c, const Group& view, std::size_t lobes)
        : config_(c),
          view_(view),
          m_(view.pairs.size()),
          nl_(c.wavelengths_nm.size()),
          nlobes_(lobes),
          x_(m_ * nl_, 0.0),
          lobe_x_(m_ * lobes * nl_, 0.0),
          touched_(m_, 0) {}

    // A walk whose x_j are w / (π r² p(x | ω)) · scale, weighed against the light side by
    // `weights` with ρ = lit_diffuse_density · rho_per_lit.
    void begin(double scale, const ConnectionWeights& weights, double rho_per_lit) {
        scale_ = scale;
        weights_ = &weights;
        rho_per_lit_ = rho_per_lit;
    }

    // In the beam: the entry point's offset from the beam's axis (through the origin) across ω_i
    // at most the beam's radius.
    bool accepts(std::size_t light, const Vec2& entry_position_um) const override {
        const Vec3d& wi = config_.pairs[view_.pairs[light]].wi;
        const Vec3d y(entry_position_um.x(), entry_position_um.y(), 0.0);
        const double along = y.dot(wi);
        const double r = config_.beam_radius_um;
        return y.squaredNorm() - along * along <= r * r;
    }

    void connect(const LightConnection& c) override {
        const std::size_t j = c.light;
        if (touched_[j] == 0) {
            touched_[j] = 1;
            list_.push_back(j);
        }
        const bool lobe_known = c.lobe >= 0 && static_cast<std::size_t>(c.lobe) < nlobes_;
        const double scale = scale_ * weights_->detector_side(c.lit_diffuse_density * rho_per_lit_);
        for (std::size_t k = 0; k < nl_; ++k) {
            const double v = c.weights[k] * scale;
            x_[j * nl_ + k] += v;
            if (lobe_known)
                lobe_x_[(j * nlobes_ + static_cast<std::size_t>(c.lobe)) * nl_ + k] += v;
        }
    }

    // A block of n walks' sums S added into acc, play_item's layout, as S and S² / n (so that the
    // blocks' spread gives the variance, estimate_from_halves); then cleared.
    void add_block_to(std::vector<double>& acc, double n) {
        const std::size_t stride = m_ * (2 + 2 * nlobes_);
        for (std::size_t j : list_) {
            for (std::size_t k = 0; k < nl_; ++k) {
                double* a = acc.data() + k * stride;
                double& x = x_[j * nl_ + k];
                a[j] += x;
                a[m_ + j] += x * x / n;
                x = 0.0;
                for (std::size_t l = 0; l < nlobes_; ++l) {
                    double& xl = lobe_x_[(j * nlobes_ + l) * nl_ + k];
                    a[(2 + l) * m_ + j] += xl;
                    a[(2 + nlobes_ + l) * m_ + j] += xl * xl / n;
                    xl = 0.0;
                }
            }
            touched_[j] = 0;
        }
        list_.clear();
    }

private:
    const GoniometerConfig& config_;
    const Group& view_;
    std::size_t m_, nl_, nlobes_;
    std::vector<double> x_, lobe_x_;  // [light][wavelength], [light][lobe][wavelength]
    std::vector<char> touched_;
    std::vector<std::size_t> list_;
    double scale_ = 0.0;
    const ConnectionWeights* weights_ = nullptr;
    double rho_per_lit_ = 0.0;
};

// Plays one connected item's detector-side walks (one view direction, every wavelength) into acc,
// play_item's layout in the view's pair order.
void play_connected_item(const Scatterer& scatterer, const GoniometerConfig& config,
                         const std::vector<Group>& views, const ConnectionWeights& weights,
                         const PhotonItem& item, std::size_t nlobes, std::vector<double>& acc) {
    const Group& view = views[item.group];
    const std::size_t m = view.pairs.size(), nl = config.wavelengths_nm.size();
    acc.assign(nl * m * (2 + 2 * nlobes), 0.0);
    std::vector<Vec3d> lights;
    for (std::size_t p : view.pairs) lights.push_back(config.pairs[p].wi);
    const PathTracing& paths = checked_path_tracing(scatterer);
    const ConnectedStarts& starts = weights.starts(item.group);
    ConnectedCells cells(config, view, nlobes);
    const double beam_area = kPi * config.beam_radius_um * config.beam_radius_um;
    const std::uint64_t seed = derive_seed(config.seed, "goniometer/connected-quantum", item.group);
    const std::uint64_t block_seed =
        derive_seed(config.seed, "goniometer/connected-block", item.group);
    for (std::uint64_t first = item.first; first < item.first + item.count;
         first += kConnectedBlock) {
        const std::uint64_t end = std::min(first + kConnectedBlock, item.first + item.count);
        // The block's stratified points (sim/scatterer/stratified.h): dimensions 0 and 1 the
        // grid's point, 2 and 3 the direction in the cone.
        Rng block_rng(block_seed, first);
        const ScrambledSobolGroup block(block_rng);
        for (std::uint64_t q = first; q < end; ++q) {
            Rng rng(seed, q);
            const auto i = static_cast<std::uint32_t>(q - first);
            // The direction by projected solid angle, then the start: f̂ = w / (π r² p(x)).
            const Vec3d wo = cone_direction_from_square(view.wi, config.detector_half_angle_rad,
                                                        block.uniform(i, 2), block.uniform(i, 3));
            const Vec2 start = starts.draw(Vec2(block.uniform(i, 0), block.uniform(i, 1)), rng);
            const double density = starts.density(start);
            cells.begin(1.0 / (beam_area * density), weights,
                        weights.ratio(1.0, item.group, density));
            paths.trace_connected(wo, config.wavelengths_nm, start, rng, lights, cells);
        }
        cells.add_block_to(acc, static_cast<double>(end - first));
    }
}

// A work item's partial sums (per wavelength of the item, in the group's pair order: Σx, Σx²,
// then Σx and Σx² per lobe) added into the run's sums; items are added in item order.
void add_item_sums(const std::vector<double>& partial, const Group& group, std::size_t wavelength,
                   std::size_t item_wavelengths, std::size_t nl, std::size_t nlobes, Sums& sums) {
    const std::size_t m = group.pairs.size(), cells = sums.sum.size();
    const std::size_t stride = m * (2 + 2 * nlobes);
    for (std::size_t k = 0; k < item_wavelengths; ++k) {
        const double* a = partial.data() + k * stride;
        for (std::size_t j = 0; j < m; ++j) {
            const std::size_t cell = group.pairs[j] * nl + wavelength + k;
            sums.sum[cell] += a[j];
            sums.sum_sq[cell] += a[m + j];
            for (std::size_t l = 0; l < nlobes; ++l) {
                sums.lobe_sum[l * cells + cell] += a[(2 + l) * m + j];
                sums.lobe_sum_sq[l * cells + cell] += a[(2 + nlobes + l) * m + j];
            }
        }
    }
}

// A cell's mean over `count` samples and the variance of that mean, from Σx and Σx².
std::pair<double, double> mean_and_variance(double sum, double sum_sq, double count) {
    const double mean = sum / count;
    return {mean, std::max(0.0, sum_sq / count - mean * mean) / std::max(1.0, count - 1.0)};
}

// The record's values and standard errors, total and per lobe, from the sums of n quanta per
// light direction and wavelength: the mean and the standard error of the mean.
void estimate_from_sums(const Sums& sums, std::uint64_t n, BrdfRecord& r) {
    const double dn = static_cast<double>(n);
    auto estimate = [&](const std::vector<double>& sum, const std::vector<double>& sum_sq,
                        std::vector<double>& value, std::vector<double>& error) {
        value.assign(sum.size(), 0.0);
        error.assign(sum.size(), 0.0);
        for (std::size_t i = 0; i < sum.size(); ++i) {
            const auto [mean, variance] = mean_and_variance(sum[i], sum_sq[i], dn);
            value[i] = mean;
            error[i] = std::sqrt(variance);
        }
    };
    estimate(sums.sum, sums.sum_sq, r.value, r.standard_error);
    estimate(sums.lobe_sum, sums.lobe_sum_sq, r.lobe_values, r.lobe_standard_error);
}

// The cells that carry signal (GoniometerConfig::signal_fraction): value >= fraction × the
// mean of the cells at the same wavelength, and > 0. Row-major [pair][wavelength], 1 or 0.
std::vector<std::uint8_t> signal_cells(const std::vector<double>& value, std::size_t nl,
                                       double fraction) {
    std::vector<double> mean(nl, 0.0);
    const std::size_t np = value.size() / nl;
    for (std::size_t i = 0; i < value.size(); ++i) mean[i % nl] += value[i];
    for (double& m : mean) m /= static_cast<double>(np);
    std::vector<std::uint8_t> mask(value.size(), 0);
    for (std::size_t i = 0; i < value.size(); ++i)
        mask[i] = value[i] > 0.0 && value[i] >= fraction * mean[i % nl];
    return mask;
}

// The same from two independent halves (connect_lights): the light side's sums of n quanta per
// light direction and the detector side's of n_connected walks in `blocks` stratified blocks per
// view direction (its Σx² holds Σ S_b² / n_b over the blocks' sums S_b of n_b walks); values add,
// and so do the variances of the means. The detector side's variance is the blocks' spread:
// Var(S_b) ≈ n_b σ², σ² estimated by Σ (S_b − n_b m)² / n_b / (B − 1), and the mean's is σ² / N.
void estimate_from_halves(const Sums& light, std::uint64_t n, const Sums& detector,
                          std::uint64_t n_connected, std::uint64_t blocks, BrdfRecord& r) {
    const double dn = static_cast<double>(n), dc = static_cast<double>(n_connected);
    const double spread_dof = static_cast<double>(blocks) - 1.0;
    auto combine = [&](const std::vector<double>& s1, const std::vector<double>& q1,
                       const std::vector<double>& s2, const std::vector<double>& q2,
                       std::vector<double>& value, std::vector<double>& error) {
        value.assign(s1.size(), 0.0);
        error.assign(s1.size(), 0.0);
        for (std::size_t i = 0; i < s1.size(); ++i) {
            const auto [m1, v1] = mean_and_variance(s1[i], q1[i], dn);
            const double m2 = s2[i] / dc;
            // One block alone says nothing of the spread.
            const double v2 = spread_dof > 0.0
                                  ? std::max(0.0, q2[i] - dc * m2 * m2) / (spread_dof * dc)
                                  : std::numeric_limits<double>::infinity();
            value[i] = m1 + m2;
            error[i] = std::sqrt(v1 + v2);
        }
    };
    combine(light.sum, light.sum_sq, detector.sum, detector.sum_sq, r.value, r.standard_error);
    combine(light.lobe_sum, light.lobe_sum_sq, detector.lobe_sum, detector.lobe_sum_sq,
            r.lobe_values, r.lobe_standard_error);
}

// Relative RMS standard error over the signal cells (see signal_cells).
double relative_rms(BrdfRecord& r) {
    r.signal_cells =
        signal_cells(r.value, r.config.wavelengths_nm.size(), r.config.signal_fraction);
    double acc = 0.0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < r.value.size(); ++i) {
        if (r.signal_cells[i] != 0) {
            acc += std::pow(r.standard_error[i] / r.value[i], 2);
            ++n;
        }
    }
    return n > 0 ? std::sqrt(acc / static_cast<double>(n))
                 : std::numeric_limits<double>::infinity();
}

}  // namespace

const char* to_string(Aperture aperture) {
    switch (aperture) {
        case Aperture::view_cone:
            return "view_cone";
        case Aperture::both_cones:
            return "both_cones";
    }
    return "?";
}

Aperture parse_aperture(std::string_view text, std::string_view key) {
    for (Aperture a : {Aperture::view_cone, Aperture::both_cones})
        if (text == to_string(a)) return a;
    throw InputError(fmt::format(
        "{} = \"{}\": expected \"view_cone\" (the detector cone around the view, light exact) or "
        "\"both_cones\" (light and detector cones of the same half-angle: reciprocal)",
        key, text));
}

Vec3d cone_direction_by_projected_area(const Vec3d& axis, double half_angle_rad, double d1,
                                       double d2) {
    // The cap's orthographic projection on the patch plane: centre cos α · axis_xy, semi-axis
    // sin α · cos θ along the axis's azimuth (radial) and sin α across it.
    const double rho = std::hypot(axis.x(), axis.y());
    const Vec2 radial = rho > 0.0 ? Vec2(axis.x() / rho, axis.y() / rho) : Vec2(1.0, 0.0);
    const Vec2 across(-radial.y(), radial.x());
    const double sin_a = std::sin(half_angle_rad), cos_a = std::cos(half_angle_rad);
    const Vec2 p = cos_a * axis.head<2>() + sin_a * (d1 * axis.z() * radial + d2 * across);
    return Vec3d(p.x(), p.y(), std::sqrt(std::max(0.0, 1.0 - p.squaredNorm())));
}

Vec3d cone_direction_from_square(const Vec3d& axis, double half_angle_rad, double u, double v) {
    const double disc_r = std::sqrt(u), disc_g = 2.0 * kPi * v;
    return cone_direction_by_projected_area(axis, half_angle_rad, disc_r * std::cos(disc_g),
                                            disc_r * std::sin(disc_g));
}

Vec3d draw_cone_direction_by_projected_area(const Vec3d& axis, double half_angle_rad, Rng& rng) {
    const double u = rng.uniform();
    return cone_direction_from_square(axis, half_angle_rad, u, rng.uniform());
}

void GoniometerConfig::validate() const {
    require(!pairs.empty(), kWhat, "no direction pairs: expected at least one (light, view) pair");
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        const auto& p = pairs[i];
        require(std::abs(p.wi.norm() - 1.0) < 1e-9 && std::abs(p.wo.norm() - 1.0) < 1e-9, kWhat,
                fmt::format("pair {}: light and view must be unit vectors", i));
        require(p.wi.z() > 0.0, kWhat,
                fmt::format("pair {}: the light must be above the patch (z > 0)", i));
        require(p.wo.z() > std::sin(detector_half_angle_rad), kWhat,
                fmt::format("pair {}: view direction at {:.2f} deg from the normal: its detector "
                            "cone must stay "
                            "above the patch plane",
                            i, std::acos(std::clamp(p.wo.z(), -1.0, 1.0)) * 180.0 / kPi));
        require(aperture != Aperture::both_cones || p.wi.z() > std::sin(detector_half_angle_rad),
                kWhat,
                fmt::format("pair {}: light direction at {:.2f} deg from the normal: with aperture "
                            "both_cones its source cone (half-angle {:.2f} deg) must stay above "
                            "the patch plane",
                            i, std::acos(std::clamp(p.wi.z(), -1.0, 1.0)) * 180.0 / kPi,
                            detector_half_angle_rad * 180.0 / kPi));
    }
    require_wavelengths(wavelengths_nm, kWhat);
    require(std::isfinite(detector_half_angle_rad) && detector_half_angle_rad > 0.0 &&
                detector_half_angle_rad < 0.5,
            kWhat,
            fmt::format("detector half-angle {} rad: expected (0, 0.5)", detector_half_angle_rad));
    require(std::isfinite(beam_radius_um) && beam_radius_um >= 0.0, kWhat,
            "beam radius must be finite and >= 0 um");
    require(quanta_per_pass >= 1, kWhat, "quanta_per_pass must be >= 1");
    require(max_passes >= 1, kWhat, "max_passes must be >= 1");
    require(time_budget_s > 0.0, kWhat, "time budget must be > 0 s");
    require(target_relative_error >= 0.0, kWhat, "target relative error must be >= 0");
    require(std::isfinite(signal_fraction) && signal_fraction >= 0.0 && signal_fraction < 1.0,
            kWhat, "signal_fraction", signal_fraction,
            "a fraction of the mean cell in [0, 1) (0: every cell with a positive value)");
    require(std::isfinite(guided_fraction) && guided_fraction >= 0.0 && guided_fraction < 1.0,
            kWhat, "guided_fraction", guided_fraction,
            "a share of the diffuse directions aimed at the detectors in [0, 1) (0: none)");
    require(guided_branches <= BranchOptions::kMaxGuidedBranches, kWhat,
            fmt::format("guided_branches = {}: expected 0..{}", guided_branches,
                        BranchOptions::kMaxGuidedBranches));
    require(guided_branches == 0 || guided_fraction == 0.0, kWhat,
            fmt::format("guided_fraction = {} and guided_branches = {}: both guide the first "
                        "diffuse event; set one of them (the other 0)",
                        guided_fraction, guided_branches));
    require(!connect_lights || (aperture == Aperture::view_cone && beam_radius_um > 0.0), kWhat,
            fmt::format("connect_lights with aperture {} and beam radius {} um: the connections "
                        "reach collimated lights (aperture view_cone) through a beam of some "
                        "width (beam_radius_um > 0)",
                        to_string(aperture), beam_radius_um));
    require(eval_rings >= 1 && eval_rings <= 64, kWhat,
            fmt::format("eval_rings = {}: expected 1..64", eval_rings));
    require(std::isfinite(eval_tolerance) && eval_tolerance >= 0.0 && eval_tolerance < 1.0, kWhat,
            fmt::format("eval_tolerance = {}: expected a fraction in [0, 1)", eval_tolerance));
    require(eval_tolerance == 0.0 || (eval_max_rings >= eval_rings && eval_max_rings <= 256), kWhat,
            fmt::format("eval_max_rings = {}: expected eval_rings ({}) .. 256", eval_max_rings,
                        eval_rings));
}

namespace {

// The eval estimator's cone averages. Cosine-weighted cone cubatures: points at area fraction u
// of the projected disc (sin²β = u sin²α), weight ∝ cos θ / cos β (dω = sin²α du dγ /
// (2 cos β)).
struct CubatureNode {
    double u, gamma, w;
};

// Product rule: Gauss–Legendre in u (area fraction of the projected disc), uniform in azimuth
// (rotated by half a step on alternate rings).
std::vector<CubatureNode> product_rule(int rings) {
    std::vector<CubatureNode> rule;
    const int azimuths = 2 * rings;
    const GaussLegendreRule gl = gauss_legendre(rings);  // on [−1, 1], mapped to [0, 1]
    for (int i = 0; i < rings; ++i) {
        const double x = gl.nodes[static_cast<std::size_t>(i)];
        const double weight = gl.weights[static_cast<std::size_t>(i)];
        for (int k = 0; k < azimuths; ++k)
            rule.push_back(
                {0.5 * (x + 1.0), 2.0 * kPi * (k + 0.5 * (i % 2)) / azimuths, 0.5 * weight});
    }
    return rule;
}

// Per-thread scratch: no allocation per pair or cubature in the loop (the model tables must
// scale with threads, and the allocator is shared).
struct CubatureScratch {
    explicit CubatureScratch(std::size_t nlobes)
        : per_lobe(nlobes), acc(nlobes), lobes(nlobes), fine(nlobes), coarse(nlobes) {}
    std::vector<double> per_lobe, acc, lobes, fine, coarse;
    std::vector<Vec3d> lights, views;  // both_cones: the rule's directions on each cone
};

class ConeCubature {
public:
    ConeCubature(const Scatterer& scatterer, const GoniometerConfig& c, std::size_t nlobes)
        : scatterer_(scatterer),
          c_(c),
          nlobes_(nlobes),
          alpha_(c.detector_half_angle_rad),
          s2_(std::pow(std::sin(alpha_), 2)),
          coarse_(product_rule(std::max(1, c.eval_rings / 2))),
          all_lobes_(nlobes >= 32 ? ~0u : (1u << nlobes) - 1u),
          lobes_apart_(c.eval_tolerance > 0.0 && nlobes >= 2 && nlobes <= 32 &&
                       scatterer.evaluates_lobes_apart()) {
        // rules_[0]: eval_rings; each next one doubles the rings (eval_tolerance > 0), up to
        // eval_max_rings.
        rules_.push_back(product_rule(std::max(1, c.eval_rings)));
        if (c.eval_tolerance > 0.0)
            for (int rings = 2 * c.eval_rings; rings <= c.eval_max_rings; rings *= 2)
                rules_.push_back(product_rule(rings));
    }

    // A cell's value and stated error (GoniometerConfig::eval_tolerance); scratch.lobes holds
    // its lobes.
    std::pair<double, double> cell(const DirectionPair& p, double lambda,
                                   CubatureScratch& scratch) const {
        if (lobes_apart_) return cell_by_lobe(p, lambda, scratch);
        double fine_value = average(p, lambda, rules_[0], all_lobes_, scratch, true);
        double coarse_value = average(p, lambda, coarse_, all_lobes_, scratch, false);
        // Adaptive: done when the last two doublings both moved the value by at most half the
        // tolerance (one agreement can be chance: a 4- and an 8-ring rule can miss the same
        // narrow feature of Huang's R lobe alike).
        bool previous_settled = false;
        for (std::size_t level = 1; level < rules_.size(); ++level) {
            const bool now_settled = settled(fine_value, coarse_value);
            if (now_settled && previous_settled) break;
            previous_settled = now_settled;
            coarse_value = fine_value;
            fine_value = average(p, lambda, rules_[level], all_lobes_, scratch, true);
        }
        return {fine_value, std::abs(fine_value - coarse_value)};
    }

private:
    bool settled(double fine, double coarse) const {
        return std::abs(fine - coarse) <= 0.5 * c_.eval_tolerance * std::abs(fine);
    }

    // The same rule lobe by lobe, for scatterers whose value is the sum of their lobes and that
    // evaluate a lobe alone (Scatterer::evaluates_lobes_apart): each lobe doubles its rings
    // until its own last two doublings moved it by at most half the tolerance of ITS value, and
    // the lobes that have settled are no longer evaluated. Huang's R lobe has sharp edges that
    // can take 64 rings where its smooth TRT lobe, a quadrature per direction and 20 times the
    // cost, settles at 8. Each lobe's bound |Δ_l| <= tol/2 · |f_l| sums to the cell's tol/2 ·
    // |f| (the lobes are not negative), so the stated error (Σ |Δ_l|) and the guarantee are the
    // rule's above.
    std::pair<double, double> cell_by_lobe(const DirectionPair& p, double lambda,
                                           CubatureScratch& scratch) const {
        std::vector<double>& fine = scratch.fine;
        std::vector<double>& coarse = scratch.coarse;
        average(p, lambda, rules_[0], all_lobes_, scratch, true);
        fine = scratch.lobes;
        average(p, lambda, coarse_, all_lobes_, scratch, true);
        coarse = scratch.lobes;
        std::uint32_t active = all_lobes_, previous_settled = 0;
        for (std::size_t level = 1; level < rules_.size() && active != 0; ++level) {
            for (std::size_t l = 0; l < nlobes_; ++l) {
                const std::uint32_t bit = 1u << l;
                if (!(active & bit) || !settled(fine[l], coarse[l])) {
                    previous_settled &= ~bit;
                    continue;
                }
                if (previous_settled & bit) active &= ~bit;
                previous_settled |= bit;
            }
            if (active == 0) break;
            average(p, lambda, rules_[level], active, scratch, true);
            for (std::size_t l = 0; l < nlobes_; ++l) {
                if (!(active & (1u << l))) continue;
                coarse[l] = fine[l];
                fine[l] = scratch.lobes[l];
            }
        }
        double value = 0.0, error = 0.0;
        for (std::size_t l = 0; l < nlobes_; ++l) {
            value += fine[l];
            error += std::abs(fine[l] - coarse[l]);
            scratch.lobes[l] = fine[l];
        }
        return {value, error};
    }

    // The rule's average of the lobes in `wanted` (all: eval(), the value; otherwise
    // eval_lobes()); keep_lobes: each lobe's into scratch.lobes (the others' entries unchanged).
    double average(const DirectionPair& p, double lambda, const std::vector<CubatureNode>& rule,
                   std::uint32_t wanted, CubatureScratch& scratch, bool keep_lobes) const {
        std::fill(scratch.acc.begin(), scratch.acc.end(), 0.0);
        double num = 0.0, den = 0.0;
        const auto add = [&](const Vec3d& wi, const Vec3d& wo, double weight) {
            num += weight * (wanted == all_lobes_
                                 ? scatterer_.eval(wi, wo, lambda, scratch.per_lobe)
                                 : scatterer_.eval_lobes(wi, wo, lambda, wanted, scratch.per_lobe));
            for (std::size_t l = 0; l < nlobes_; ++l)
                scratch.acc[l] += weight * scratch.per_lobe[l];
            den += weight;
        };
        if (c_.aperture == Aperture::both_cones)
            both_cones(p, rule, scratch, add);
        else
            view_cone(p, rule, add);
        if (keep_lobes)
            for (std::size_t l = 0; l < nlobes_; ++l)
                if ((wanted >> l) & 1u) scratch.lobes[l] = scratch.acc[l] / den;
        return num / den;
    }

    // both_cones: the rule on the unit disc (u = r², γ), mapped onto each cone's projected
    // ellipse; the map is affine, so the disc weights are projected-solid-angle weights.
    template <class Add>
    void both_cones(const DirectionPair& p, const std::vector<CubatureNode>& rule,
                    CubatureScratch& scratch, const Add& add) const {
        scratch.lights.clear();
        scratch.views.clear();
        for (const CubatureNode& n : rule) {
            const double radius = std::sqrt(n.u), d1 = radius * std::cos(n.gamma),
                         d2 = radius * std::sin(n.gamma);
            scratch.lights.push_back(cone_direction_by_projected_area(p.wi, alpha_, d1, d2));
            scratch.views.push_back(cone_direction_by_projected_area(p.wo, alpha_, d1, d2));
        }
        for (std::size_t i = 0; i < rule.size(); ++i)
            for (std::size_t j = 0; j < rule.size(); ++j)
                add(scratch.lights[i], scratch.views[j], rule[i].w * rule[j].w);
    }

    template <class Add>
    void view_cone(const DirectionPair& p, const std::vector<CubatureNode>& rule,
                   const Add& add) const {
        Vec3d e1, e2;
        orthonormal_frame(p.wo, e1, e2);
        for (const CubatureNode& n : rule) {
            const double sin_b = std::sqrt(n.u * s2_), cos_b = std::sqrt(1.0 - n.u * s2_);
            const Vec3d w =
                cos_b * p.wo + sin_b * (std::cos(n.gamma) * e1 + std::sin(n.gamma) * e2);
            add(p.wi, w, n.w * w.z() / cos_b);
        }
    }

    const Scatterer& scatterer_;
    const GoniometerConfig& c_;
    std::size_t nlobes_;
    double alpha_, s2_;
    std::vector<std::vector<CubatureNode>> rules_;
    std::vector<CubatureNode> coarse_;
    std::uint32_t all_lobes_;  // bit k: lobe k
    bool lobes_apart_;         // cell_by_lobe
};

BrdfRecord measure_by_eval(const Scatterer& scatterer, const GoniometerConfig& c, BrdfRecord r,
                           std::chrono::steady_clock::time_point start) {
    const std::size_t nl = c.wavelengths_nm.size(), nlobes = r.lobes.size();
    const ConeCubature cubature(scatterer, c, nlobes);
    r.value.assign(c.pairs.size() * nl, 0.0);
    r.standard_error.assign(c.pairs.size() * nl, 0.0);
    r.lobe_values.assign(nlobes * c.pairs.size() * nl, 0.0);
    r.lobe_standard_error.assign(nlobes * c.pairs.size() * nl, 0.0);
    std::atomic<bool> abandoned{false};
#pragma omp parallel
    {
        CubatureScratch scratch(nlobes);
#pragma omp for schedule(dynamic, 4)
        for (std::size_t p = 0; p < c.pairs.size(); ++p) {
            if (abandoned.load(std::memory_order_relaxed)) continue;
            if (interrupt_requested()) {
                abandoned.store(true);
                continue;
            }
            for (std::size_t k = 0; k < nl; ++k) {
                const auto [fine_value, error] =
                    cubature.cell(c.pairs[p], c.wavelengths_nm[k], scratch);
                r.value[p * nl + k] = fine_value;
                r.standard_error[p * nl + k] = error;
                for (std::size_t l = 0; l < nlobes; ++l)
                    r.lobe_values[(l * c.pairs.size() + p) * nl + k] = scratch.lobes[l];
            }
        }
    }
    if (abandoned.load()) {
        throw Interrupted(fmt::format("interrupted while evaluating the BRDF of {}", r.scatterer));
    }
    r.passes = 1;
    r.quanta = 0;
    r.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.convergence.push_back({1, r.wall_time_s, 0, relative_rms(r)});
    return r;
}

// The record before any measurement: what is measured, and which of the configuration's options
// this scatterer can take (goniometer.h).
BrdfRecord new_record(const Scatterer& scatterer, const GoniometerConfig& config) {
    BrdfRecord r;
    r.config = config;
    r.scatterer = scatterer.name();
    r.lobes = scatterer.lobe_names();
    r.threads = omp_get_max_threads();
    r.detector_solid_angle_sr = 2.0 * kPi * (1.0 - std::cos(config.detector_half_angle_rad));
    const PathTracing* paths = scatterer.path_tracing();
    const bool can_split = paths != nullptr && paths->can_split_paths();
    r.wavelength_paths_shared = config.share_wavelength_paths && paths != nullptr &&
                                config.wavelengths_nm.size() > 1 &&
                                config.wavelengths_nm.size() <= PathTracing::kMaxSharedWavelengths;
    // Branches need one path for all the item's wavelengths: shared paths, or one wavelength.
    const bool one_path = r.wavelength_paths_shared || config.wavelengths_nm.size() == 1;
    r.paths_split = one_path && config.split_paths && can_split;
    r.reflections_split = r.paths_split && config.split_reflections;
    r.diffuse_guided =
        one_path && (config.guided_fraction > 0.0 || config.guided_branches > 0) && can_split;
    if (config.connect_lights) {
        const bool can_connect = paths != nullptr && paths->can_connect_lights() && can_split;
        if (!can_connect || !one_path) {
            throw InputError(fmt::format(
                "goniometer: connect_lights needs a scatterer that connects detector-side walks to "
                "the lights (the explicit tracer) and one path for all wavelengths "
                "(share_wavelength_paths, or one wavelength); {} {}",
                scatterer.name(),
                can_connect ? "does not share its wavelengths' paths here"
                            : "cannot connect to lights"));
        }
        r.lights_connected = true;
    }
    r.estimator_used = config.estimator == Estimator::automatic
                           ? (scatterer.can_evaluate() ? Estimator::eval : Estimator::photon)
                           : config.estimator;
    return r;
}

// The photon estimator's clocks since this run started (a resumed run adds the time of the
// passes before the resume: PassLoopState::resumed_wall_s, resumed_cpu_s).
struct PhotonRun {
    std::chrono::steady_clock::time_point start;
    double cpu_start = 0.0;
};

// One pass's work items, (group, wavelength, chunk) in the order they are reduced.
std::vector<PhotonItem> pass_items(const GoniometerConfig& config, std::size_t groups,
                                   std::size_t wavelength_items, int pass) {
    const std::uint64_t chunks = (config.quanta_per_pass + kChunk - 1) / kChunk;
    std::vector<PhotonItem> items;
    for (std::size_t g = 0; g < groups; ++g)
        for (std::size_t k = 0; k < wavelength_items; ++k)
            for (std::uint64_t c = 0; c < chunks; ++c) {
                const std::uint64_t first =
                    static_cast<std::uint64_t>(pass) * config.quanta_per_pass + c * kChunk;
                items.push_back(
                    {g, k, first, std::min(kChunk, config.quanta_per_pass - c * kChunk)});
            }
    return items;
}

// A pass's connected items (connect_lights), (view, chunk), after the photon items.
void add_connected_items(const GoniometerConfig& config, std::size_t views, int pass,
                         std::vector<PhotonItem>& items) {
    const std::uint64_t n = config.connected_walks_per_pass(), chunks = (n + kChunk - 1) / kChunk;
    for (std::size_t v = 0; v < views; ++v)
        for (std::uint64_t c = 0; c < chunks; ++c) {
            const std::uint64_t first = static_cast<std::uint64_t>(pass) * n + c * kChunk;
            items.push_back({v, 0, first, std::min(kChunk, n - c * kChunk), true});
        }
}

// The photon estimator on the pass loop (virtual_gonio/pass_loop.h): a pass's items play their
// quanta into per-item partial sums, added to the sums in item order.
class PhotonPasses final : public PassMeasurement {
public:
    PhotonPasses(const Scatterer& scatterer, BrdfRecord& r, const PhotonRun& run,
                 const PassLoopState& state)
        : scatterer_(scatterer),
          r_(r),
          run_(run),
          state_(state),
          groups_(group_by_light(r.config.pairs)),
          nl_(r.config.wavelengths_nm.size()),
          nlobes_(r.lobes.size()),
          // Spectral path sharing (goniometer.h): one item, one path per quantum for every λ.
          item_wavelengths_(r.wavelength_paths_shared ? nl_ : 1) {
        const std::size_t cells = r.config.pairs.size() * nl_;
        sums_ = Sums{std::vector<double>(cells, 0.0), std::vector<double>(cells, 0.0),
                     std::vector<double>(nlobes_ * cells, 0.0),
                     std::vector<double>(nlobes_ * cells, 0.0)};
        if (r.lights_connected) {
            views_ = group_by_view(r.config.pairs);
            connection_weights_.emplace(r.config, views_,
                                        checked_path_tracing(scatterer).depth_um());
            connected_sums_ = sums_;
        }
    }

    std::size_t start_pass(int pass) override {
        items_ = pass_items(r_.config, groups_.size(), nl_ / item_wavelengths_, pass);
        if (r_.lights_connected) add_connected_items(r_.config, views_.size(), pass, items_);
        partial_.assign(items_.size(), {});
        return items_.size();
    }
    void run_item(std::size_t it) override {
        if (items_[it].connected) {
            play_connected_item(scatterer_, r_.config, views_, *connection_weights_, items_[it],
                                nlobes_, partial_[it]);
            return;
        }
        play_item(scatterer_, r_.config, groups_, items_[it], nlobes_, r_.wavelength_paths_shared,
                  r_.paths_split || r_.diffuse_guided || r_.lights_connected,
                  connection_weights_ ? &*connection_weights_ : nullptr, partial_[it]);
    }
    void pack(std::size_t it, Bytes& out) const override { out.put_vector(partial_[it]); }
    void unpack(std::size_t it, Bytes& in) override { partial_[it] = in.get_vector<double>(); }
    void add_pass() override {
        for (std::size_t it = 0; it < items_.size(); ++it) {
            if (items_[it].connected) {
                add_item_sums(partial_[it], views_[items_[it].group], 0, nl_, nl_, nlobes_,
                              connected_sums_);
            } else {
                add_item_sums(partial_[it], groups_[items_[it].group], items_[it].wavelength,
                              item_wavelengths_, nl_, nlobes_, sums_);
            }
        }
    }
    // The record's values from the sums of `passes` passes, and its clocks.
    PassEstimate estimate(int passes) override {
        const std::uint64_t n = static_cast<std::uint64_t>(passes) * r_.config.quanta_per_pass;
        if (r_.lights_connected) {
            const std::uint64_t walks = r_.config.connected_walks_per_pass();
            const auto p = static_cast<std::uint64_t>(passes);
            // kChunk is a multiple of the block, so a pass's blocks are ⌈walks / block⌉.
            estimate_from_halves(sums_, n, connected_sums_, p * walks,
                                 p * ((walks + kConnectedBlock - 1) / kConnectedBlock), r_);
        } else {
            estimate_from_sums(sums_, n, r_);
        }
        r_.passes = passes;
        r_.quanta = n;
        r_.wall_time_s =
            state_.resumed_wall_s +
            std::chrono::duration<double>(std::chrono::steady_clock::now() - run_.start).count();
        r_.cpu_time_s = state_.resumed_cpu_s + (process_cpu_seconds() - run_.cpu_start);
        PassEstimate e;
        e.quanta = n;
        e.relative_error = relative_rms(r_);
        return e;
    }
    std::vector<CheckpointSum> checkpoint_sums() override {
        std::vector<CheckpointSum> parts{{"sum", &sums_.sum},
                                         {"sum_sq", &sums_.sum_sq},
                                         {"lobe_sum", &sums_.lobe_sum},
                                         {"lobe_sum_sq", &sums_.lobe_sum_sq}};
        if (r_.lights_connected) {
            parts.push_back({"connected_sum", &connected_sums_.sum});
            parts.push_back({"connected_sum_sq", &connected_sums_.sum_sq});
            parts.push_back({"connected_lobe_sum", &connected_sums_.lobe_sum});
            parts.push_back({"connected_lobe_sum_sq", &connected_sums_.lobe_sum_sq});
        }
        return parts;
    }

private:
    const Scatterer& scatterer_;
    BrdfRecord& r_;
    const PhotonRun& run_;
    const PassLoopState& state_;
    const std::vector<Group> groups_;
    std::size_t nl_, nlobes_, item_wavelengths_;
    Sums sums_;
    std::vector<Group> views_;  // connect_lights: the pairs of each view direction
    std::optional<ConnectionWeights> connection_weights_;  // connect_lights: the two sides'
    Sums connected_sums_;                                  // connect_lights: the detector side's
    std::vector<PhotonItem> items_;
    std::vector<std::vector<double>> partial_;  // per item, in group pair order
};

// The photon estimator (goniometer.h): passes of quanta_per_pass quanta per light direction and
// wavelength until the stop rule, each pass checkpointed and reported.
BrdfRecord measure_by_photons(const Scatterer& scatterer, const RunControl& control, BrdfRecord r,
                              const PhotonRun& run) {
    const GoniometerConfig& config = r.config;
    record_measurement_seed("goniometer", config.seed);  // common/seed.h: one root per measurement
    PassLoopState state;
    PhotonPasses passes(scatterer, r, run, state);
    StopRule rule;
    rule.max_passes = config.max_passes;
    rule.target_error = config.target_relative_error;
    rule.time_budget_s = config.time_budget_s;
    PassLoopControl loop;
    loop.interrupt = control.interrupt;
    if (control.progress) loop.progress = r.scatterer;
    loop.quanta_per = "direction";
    loop.blocks_per_rank = kBlocksPerRank;
    loop.checkpoint = control.checkpoint;
    if (!control.checkpoint.empty()) {
        loop.identity = checkpoint_identity(config.config_text,
                                            canonical(config, r.scatterer, r.estimator_used),
                                            control.checkpoint_inputs);
    }
    loop.after_pass = [&] {
        if (!control.on_pass_record) return;
        r.convergence = state.rows;
        control.on_pass_record(r);
    };
    loop.on_pass = control.on_pass;
    auto elapsed = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - run.start).count();
    };
    run_passes(passes, rule, loop, elapsed, state);
    r.convergence = std::move(state.rows);
    r.interrupted = state.interrupted;  // the checkpoint holds the last completed pass
    if (r.interrupted && control.checkpoint.empty()) {
        // Without a checkpoint nobody keeps the completed passes: a partial record must not
        // flow on into figures and comparisons as if it were the measurement.
        throw Interrupted(
            fmt::format("interrupted while measuring the BRDF of {} (pass {} of at most {})",
                        r.scatterer, r.passes + 1, config.max_passes));
    }
    return r;
}

}  // namespace

BrdfRecord measure_brdf(const Scatterer& scatterer, const GoniometerConfig& config,
                        const RunControl& control) {
    config.validate();
    PhotonRun run;
    run.start = std::chrono::steady_clock::now();
    run.cpu_start = process_cpu_seconds();
    BrdfRecord r = new_record(scatterer, config);
    if (r.estimator_used == Estimator::eval) {
        if (!scatterer.can_evaluate()) {
            throw InputError(fmt::format(
                "goniometer: estimator 'eval' needs a scatterer that evaluates f; {} does "
                "not (use 'photon')",
                scatterer.name()));
        }
        BrdfRecord evaluated = measure_by_eval(scatterer, config, std::move(r), run.start);
        evaluated.cpu_time_s = process_cpu_seconds() - run.cpu_start;
        return evaluated;
    }
    return measure_by_photons(scatterer, control, std::move(r), run);
}

record::RgbImage brdf_fingerprint(const BrdfRecord& r, int lights, int views, int block,
                                  double exposure) {
    const std::size_t nl = r.config.wavelengths_nm.size();
    PLUMAGE_CHECK(
        lights > 0 && views > 0 && block > 0 &&
            static_cast<std::size_t>(lights) * static_cast<std::size_t>(views) ==
                r.config.pairs.size(),
        fmt::format("fingerprint {} x {} of {} pairs", lights, views, r.config.pairs.size()));
    const SpectrumToDisplay display(r.config.wavelengths_nm);
    std::vector<optics::Xyz> xyz(r.config.pairs.size());
    double peak = 0.0;
    for (std::size_t p = 0; p < xyz.size(); ++p) {
        xyz[p] = display.xyz(std::span<const double>(r.value.data() + p * nl, nl));
        peak = std::max(peak, xyz[p].y);
    }
    if (exposure <= 0.0) exposure = peak > 0.0 ? 1.0 / peak : 1.0;
    record::RgbImage image(views * block, lights * block);
    for (int l = 0; l < lights; ++l) {
        for (int v = 0; v < views; ++v) {
            const auto rgb = display_bytes(xyz[static_cast<std::size_t>(l) * views + v], exposure);
            for (int dy = 0; dy < block; ++dy)
                for (int dx = 0; dx < block; ++dx)
                    image.set(v * block + dx, l * block + dy, rgb[0], rgb[1], rgb[2]);
        }
    }
    return image;
}

namespace {

using Dims = std::vector<std::uint64_t>;

// The pairs' light and view directions (unit vectors, patch frame) and their angles in degrees.
void write_directions(record::Hdf5Writer& h5, const GoniometerConfig& c) {
    const std::size_t np = c.pairs.size();
    std::vector<double> light, view, angles;
    for (const auto& p : c.pairs) {
        light.insert(light.end(), {p.wi.x(), p.wi.y(), p.wi.z()});
        view.insert(view.end(), {p.wo.x(), p.wo.y(), p.wo.z()});
        auto deg = [](double v) { return v * 180.0 / kPi; };
        angles.insert(angles.end(),
                      {deg(std::acos(p.wi.z())), deg(std::atan2(p.wi.y(), p.wi.x())),
                       deg(std::acos(p.wo.z())), deg(std::atan2(p.wo.y(), p.wo.x()))});
    }
    h5.write(
        "instrument/light_directions", std::span<const double>(light), Dims{np, 3},
        {{"units", "1"},
         {"description", "unit vectors towards the light, patch frame (+z normal, +x barb axis)"}});
    h5.write("instrument/view_directions", std::span<const double>(view), Dims{np, 3},
             {{"units", "1"},
              {"description", "unit vectors towards the detector centres, patch frame"}});
    h5.write("instrument/angles_deg", std::span<const double>(angles), Dims{np, 4},
             {{"units", "deg"},
              {"description", "theta_light, phi_light, theta_view, phi_view (phi from +x)"}});
}

// What the instrument was: kind, direction set, detector, beam, aperture and estimator options.
void write_instrument(record::Hdf5Writer& h5, const BrdfRecord& r) {
    const auto& c = r.config;
    h5.set_attribute("/instrument", "kind", "goniometer");
    h5.set_attribute("/instrument", "direction_set", c.direction_set);
    h5.set_attribute("/instrument", "detector_half_angle_deg",
                     c.detector_half_angle_rad * 180.0 / kPi);
    h5.set_attribute("/instrument", "detector_solid_angle_sr", r.detector_solid_angle_sr);
    h5.set_attribute("/instrument", "beam_radius_um", c.beam_radius_um);
    if (c.signal_fraction > 0.0)
        h5.set_attribute("/instrument", "signal_fraction", c.signal_fraction);
    h5.set_attribute(
        "/instrument", "aperture",
        c.aperture == Aperture::both_cones
            ? "both_cones: the light from a cone of the detector's half-angle around the light "
              "direction and the detector cone around the view, both cosine-weighted; f averaged "
              "over both, symmetric under light <-> view (virtual_gonio/goniometer.h)"
            : "view_cone: the light exactly along the light direction, f averaged over the "
              "detector cone around the view, cosine-weighted (virtual_gonio/goniometer.h)");
    if (r.estimator_used == Estimator::photon) {
        write_path_options(h5, r.wavelength_paths_shared, r.paths_split, r.reflections_split);
        if (r.lights_connected) {
            h5.set_attribute(
                "/instrument", "connected_lights",
                "detector-side walks connected to the lights at their first diffuse "
                "event, weighed against the photon quanta that make the same paths by "
                "the balance heuristic; their starts stratified in blocks of 64, whose "
                "spread gives the standard error (virtual_gonio/goniometer.h, "
                "connect_lights)");
            h5.set_attribute("/instrument", "connected_quanta_per_pass",
                             static_cast<double>(c.connected_walks_per_pass()));
        }
        if (r.diffuse_guided) {
            h5.set_attribute("/instrument", "diffuse_guided_fraction", c.guided_fraction);
            h5.set_attribute("/instrument", "diffuse_guided_branches",
                             static_cast<double>(c.guided_branches));
        }
    }
    h5.set_attribute("/instrument", "estimator",
                     r.estimator_used == Estimator::eval ? "eval" : "photon");
}

// The BRDF per pair and wavelength, its errors, the signal cells, and each lobe's part.
void write_brdf_values(record::Hdf5Writer& h5, const BrdfRecord& r) {
    const auto& c = r.config;
    const std::size_t np = c.pairs.size(), nl = c.wavelengths_nm.size();
    h5.write(
        "brdf/value", std::span<const double>(r.value), Dims{np, nl},
        {{"units", "1/sr"},
         {"description", c.aperture == Aperture::both_cones
                             ? "BRDF averaged over each pair's source and detector cones (both "
                               "cosine-weighted, instrument@aperture), [pair, wavelength]"
                             : "BRDF averaged over each detector cone (cosine-weighted), [pair, "
                               "wavelength]"}});
    if (c.signal_fraction > 0.0 && r.signal_cells.size() == r.value.size()) {
        h5.write("brdf/signal_cells", std::span<const std::uint8_t>(r.signal_cells), Dims{np, nl},
                 {{"units", "1"},
                  {"description",
                   fmt::format("1: the cell counts in /convergence's estimated relative RMS "
                               "error (value > 0 and value >= {} x the mean of the cells at its "
                               "wavelength, instrument@signal_fraction), [pair, wavelength]",
                               c.signal_fraction)}});
    }
    h5.write(
        "brdf/standard_error", std::span<const double>(r.standard_error), Dims{np, nl},
        {{"units", "1/sr"},
         {"description", r.estimator_used == Estimator::eval
                             ? "cubature error estimate of brdf/value, [pair, wavelength]"
                             : "Monte Carlo standard error of brdf/value, [pair, wavelength]"}});
    for (std::size_t l = 0; l < r.lobes.size(); ++l) {
        h5.write(
            "brdf/lobes/" + r.lobes[l],
            std::span<const double>(r.lobe_values.data() + l * np * nl, np * nl), Dims{np, nl},
            {{"units", "1/sr"},
             {"description",
              fmt::format("the {} lobe's part of brdf/value, [pair, wavelength]", r.lobes[l])}});
        if (r.lobe_standard_error.size() == r.lobe_values.size()) {
            h5.write("brdf/lobe_standard_errors/" + r.lobes[l],
                     std::span<const double>(r.lobe_standard_error.data() + l * np * nl, np * nl),
                     Dims{np, nl},
                     {{"units", "1/sr"},
                      {"description", fmt::format("standard error of brdf/lobes/{}, [pair, "
                                                  "wavelength]",
                                                  r.lobes[l])}});
        }
    }
}

}  // namespace

void write_brdf_record(const BrdfRecord& r, const std::filesystem::path& path) {
    const auto& c = r.config;
    const std::size_t nl = c.wavelengths_nm.size();
    record::Hdf5Writer h5(path);
    h5.set_attribute("/", "format", "plumage record 1 (virtual_gonio/RECORD.md)");
    write_directions(h5, c);
    write_instrument(h5, r);
    write_polarisation(h5);
    h5.write("wavelength_nm", std::span<const double>(c.wavelengths_nm), Dims{nl},
             {{"units", "nm"}, {"description", "vacuum wavelengths of the measurement"}});
    write_brdf_values(h5, r);
    write_convergence(h5, r.convergence,
                      convergence_attributes("pass, wall_time_s, "
                                             "quanta_per_direction_and_wavelength, "
                                             "estimated_relative_rms_error"));
    write_provenance(h5, {.scatterer = r.scatterer,
                          .seed = c.seed,
                          .threads = r.threads,
                          .wall_time_s = r.wall_time_s,
                          .cpu_time_s = r.cpu_time_s,
                          .config = c.config_text});
    h5.commit();
}

}  // namespace plumage::gonio
