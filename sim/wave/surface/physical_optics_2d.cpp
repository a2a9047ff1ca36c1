// Physical optics far field of 2D cross-sections (physical_optics_2d.h has the derivation).
#include "sim/wave/surface/physical_optics_2d.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <exception>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/seed.h"
#include "sim/optics/multilayer.h"
#include "sim/optics/thin_film.h"

namespace plumage::sim::wave {
namespace {

using Vec = Eigen::Vector2d;
using Complex = std::complex<double>;

constexpr const char* kWhat = "physical optics 2D";

[[noreturn]] void refuse(const std::string& message) {
    throw InputError(fmt::format("{}: {}", kWhat, message));
}

double cross(const Vec& a, const Vec& b) { return a.x() * b.y() - a.y() * b.x(); }

// R(α): (x, z) ↦ (x cos α + z sin α, −x sin α + z cos α), rotation about +y (header).
Vec rotate(const Vec& v, double c, double s) {
    return {v.x() * c + v.y() * s, -v.x() * s + v.y() * c};
}

Vec direction(double theta) { return {std::sin(theta), std::cos(theta)}; }

// sin(x)/x for |x| <= 0.63 (guaranteed by step <= λ/10): Taylor to x¹⁰, error < 1e-12 there.
inline double sinc_small(double x) {
    const double x2 = x * x;
    return 1.0 + x2 * (-1.0 / 6.0 +
                       x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362880.0 +
                                                                       x2 * (-1.0 / 39916800.0)))));
}

void validate_stack(const SurfaceStack2d& stack, std::size_t curve) {
    if (!stack.substrate) refuse(fmt::format("curve {} has no substrate material", curve));
    for (const FilmLayer2d& film : stack.films) {
        if (!film.material) refuse(fmt::format("curve {} has a film without a material", curve));
        optics::require_thickness(film.thickness_um, fmt::format("{}: curve {}", kWhat, curve));
    }
}

}  // namespace

double physical_optics_step(double lambda_nm, double step_um) {
    if (!std::isfinite(lambda_nm) || lambda_nm <= 0.0)
        refuse(fmt::format("lambda_nm = {} must be finite and > 0", lambda_nm));
    const double limit = 1e-3 * lambda_nm / 10.0;
    if (step_um == 0.0) return limit;
    if (!std::isfinite(step_um) || step_um < 0.0 || step_um > limit * (1.0 + 1e-12))
        refuse(
            fmt::format("surface step {:.4g} µm exceeds the limit λ/10 = {:.4g} µm at λ = {:.4g} "
                        "nm (the Kirchhoff "
                        "integral's quadrature needs at least 10 samples per wavelength)",
                        step_um, limit, lambda_nm));
    return step_um;
}

namespace {

struct CurveTable {
    std::vector<double> t, s;  // fine parameter grid and cumulative chord length
};

CurveTable tabulate(const Curve2d& curve, int intervals) {
    CurveTable table;
    table.t.resize(intervals + 1);
    table.s.resize(intervals + 1);
    Vec previous = curve.point(curve.t0);
    table.t[0] = curve.t0;
    table.s[0] = 0.0;
    for (int m = 1; m <= intervals; ++m) {
        const double t = curve.t0 + (curve.t1 - curve.t0) * m / intervals;
        const Vec p = curve.point(t);
        table.t[m] = t;
        table.s[m] = table.s[m - 1] + (p - previous).norm();
        previous = p;
    }
    return table;
}

double parameter_at(const CurveTable& table, double s) {
    const auto it = std::upper_bound(table.s.begin(), table.s.end(), s);
    if (it == table.s.begin()) return table.t.front();
    if (it == table.s.end()) return table.t.back();
    const std::size_t m = static_cast<std::size_t>(it - table.s.begin());
    const double s0 = table.s[m - 1], s1 = table.s[m];
    const double f = s1 > s0 ? (s - s0) / (s1 - s0) : 0.0;
    return table.t[m - 1] + f * (table.t[m] - table.t[m - 1]);
}

std::vector<optics::StackLayer> stack_layers(const SurfaceStack2d& stack, double lambda_nm) {
    std::vector<optics::StackLayer> layers;
    layers.reserve(stack.films.size());
    for (const FilmLayer2d& film : stack.films)
        layers.push_back({film.material->index(lambda_nm), film.thickness_um});
    return layers;
}

double standard_normal(Rng& rng) {
    // Box–Muller, cosine branch only; 1 − u ∈ (0, 1] keeps the logarithm finite.
    const double u1 = 1.0 - rng.uniform(), u2 = rng.uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

}  // namespace

CrossSection2d flat_strip(double width_um, const SurfaceStack2d& stack) {
    if (!std::isfinite(width_um) || width_um <= 0.0)
        refuse(fmt::format("strip width {:.4g} µm must be finite and > 0", width_um));
    Curve2d curve;
    curve.point = [](double t) { return Vec(t, 0.0); };
    curve.normal = [](double) { return Vec(0.0, 1.0); };
    curve.t0 = -0.5 * width_um;
    curve.t1 = 0.5 * width_um;
    curve.stack = stack;
    return {{curve}};
}

CrossSection2d barbule_arc(const geometry::EllipticalArc& arc, double film_um, double gap_um) {
    if (!std::isfinite(gap_um) || gap_um < 0.0)
        refuse(fmt::format("air gap {:.4g} µm must be finite and >= 0", gap_um));
    Curve2d curve;
    curve.point = [arc](double phi) { return arc.point(phi); };
    curve.normal = [arc](double phi) { return arc.normal(phi); };
    curve.t0 = arc.phi0();
    curve.t1 = arc.phi1();
    curve.stack.films = {{optics::keratin(), film_um}, {optics::air(), gap_um}};
    curve.stack.substrate = optics::melanin();
    validate_stack(curve.stack, 0);
    return {{curve}};
}

CrossSection2d coated_ellipse(double a_x_um, double a_z_um, double shell_um) {
    if (!std::isfinite(shell_um) || shell_um < 0.0)
        refuse(fmt::format("shell thickness {:.4g} µm must be finite and >= 0", shell_um));
    const geometry::EllipticalArc core(a_x_um, a_z_um, -kPi, kPi);
    Curve2d curve;
    curve.point = [core, shell_um](double phi) {
        return Vec(core.point(phi) + shell_um * core.normal(phi));
    };
    curve.normal = [core](double phi) { return core.normal(phi); };
    curve.t0 = -kPi;
    curve.t1 = kPi;
    curve.stack.films = {{optics::keratin(), shell_um}};
    curve.stack.substrate = optics::melanin();
    return {{curve}};
}

namespace {

// Curve c of a cross-section cut into its pieces (sample_cross_section, for one curve).
SampledCrossSection2d sample_curve(const Curve2d& curve, std::size_t c, double step_um) {
    SampledCrossSection2d out;
    if (!curve.point || !curve.normal) refuse(fmt::format("curve {} has no point/normal", c));
    if (!(curve.t1 > curve.t0)) refuse(fmt::format("curve {}: t1 must exceed t0", c));
    validate_stack(curve.stack, c);
    constexpr int kMinIntervals = 4096;
    CurveTable table = tabulate(curve, kMinIntervals);
    double length = table.s.back();
    if (!(length >= step_um))
        refuse(
            fmt::format("curve {} is {:.4g} µm long, below the sampling step {:.4g} µm (a feature "
                        "shorter than the step cannot be resolved)",
                        c, length, step_um));
    const int pieces = static_cast<int>(std::ceil(length / step_um * (1.0 - 1e-12)));
    if (8 * pieces > kMinIntervals) {
        table = tabulate(curve, 8 * pieces);
        length = table.s.back();
    }
    // Smallest radius of curvature: arc length over normal turn on the fine grid.
    double min_radius = std::numeric_limits<double>::infinity();
    Vec n_prev = curve.normal(table.t[0]);
    for (std::size_t m = 1; m < table.t.size(); ++m) {
        const Vec n = curve.normal(table.t[m]);
        const double turn = std::abs(std::atan2(cross(n_prev, n), n_prev.dot(n)));
        if (turn > 0.0) min_radius = std::min(min_radius, (table.s[m] - table.s[m - 1]) / turn);
        n_prev = n;
    }
    if (min_radius < step_um)
        refuse(
            fmt::format("curve {}: radius of curvature {:.4g} µm is below the sampling step {:.4g} "
                        "µm (the locally planar stack and the quadrature need ρ >= step)",
                        c, min_radius, step_um));
    const double ds = length / pieces;
    for (int j = 0; j < pieces; ++j) {
        const double t_mid = parameter_at(table, (j + 0.5) * ds);
        SurfaceSample2d sample;
        sample.point = curve.point(t_mid);
        sample.normal = curve.normal(t_mid).normalized();
        sample.tangent = Vec(sample.normal.y(), -sample.normal.x());
        sample.ds_um = ds;
        sample.curve = static_cast<int>(c);
        out.samples.push_back(sample);
        out.chord_a.push_back(curve.point(parameter_at(table, j * ds)));
        out.chord_b.push_back(
            curve.point(j + 1 == pieces ? curve.t1 : parameter_at(table, (j + 1) * ds)));
    }
    return out;
}

}  // namespace

SampledCrossSection2d sample_cross_section(const CrossSection2d& section, double step_um) {
    if (!std::isfinite(step_um) || step_um <= 0.0)
        refuse(fmt::format("sampling step {:.4g} µm must be finite and > 0", step_um));
    if (section.curves.empty()) refuse("the cross-section has no curve");
    // The curves in parallel (a row's are many, each tabulated finely: serial, this stage was
    // a twentieth of a far field at two threads); the pieces in curve order, and the error of
    // the first curve that has one, as a serial loop would give.
    const std::size_t curves = section.curves.size();
    std::vector<SampledCrossSection2d> parts(curves);
    std::vector<std::exception_ptr> errors(curves);
#pragma omp parallel for schedule(dynamic)
    for (std::ptrdiff_t cs = 0; cs < static_cast<std::ptrdiff_t>(curves); ++cs) {
        const auto c = static_cast<std::size_t>(cs);
        try {
            parts[c] = sample_curve(section.curves[c], c, step_um);
        } catch (...) {
            errors[c] = std::current_exception();
        }
    }
    for (const std::exception_ptr& error : errors)
        if (error) std::rethrow_exception(error);
    SampledCrossSection2d out;
    for (SampledCrossSection2d& part : parts) {
        out.samples.insert(out.samples.end(), part.samples.begin(), part.samples.end());
        out.chord_a.insert(out.chord_a.end(), part.chord_a.begin(), part.chord_a.end());
        out.chord_b.insert(out.chord_b.end(), part.chord_b.begin(), part.chord_b.end());
    }
    return out;
}

namespace {
// Chords grouped kBlock at a time under bounding boxes (header: why not a grid).
constexpr std::size_t kBlock = 16;  // chords per box
constexpr double kInfinity = std::numeric_limits<double>::infinity();
}  // namespace

ChordIndex2d::ChordIndex2d(const SampledCrossSection2d& sampled) {
    const std::size_t n = sampled.samples.size();
    const std::size_t blocks = (n + kBlock - 1) / kBlock;
    const Vec empty = Vec::Constant(std::numeric_limits<double>::infinity());
    lo_.assign(blocks, empty);
    hi_.assign(blocks, -empty);
    for (std::size_t b = 0; b < blocks; ++b)
        for (std::size_t j = b * kBlock; j < std::min(n, (b + 1) * kBlock); ++j) {
            lo_[b] = lo_[b].cwiseMin(sampled.chord_a[j]).cwiseMin(sampled.chord_b[j]);
            hi_[b] = hi_[b].cwiseMax(sampled.chord_a[j]).cwiseMax(sampled.chord_b[j]);
        }
    // The chords as structure of arrays, padded to whole blocks with chords of no length (the
    // leaf test's denominator is 0 for them: never hit).
    const std::size_t padded = blocks * kBlock;
    ax_.assign(padded, 0.0);
    az_.assign(padded, 0.0);
    ex_.assign(padded, 0.0);
    ez_.assign(padded, 0.0);
    for (std::size_t j = 0; j < n; ++j) {
        ax_[j] = sampled.chord_a[j].x();
        az_[j] = sampled.chord_a[j].y();
        const Vec e = sampled.chord_b[j] - sampled.chord_a[j];
        ex_[j] = e.x();
        ez_[j] = e.y();
    }
    std::vector<std::size_t> order(blocks);
    for (std::size_t b = 0; b < blocks; ++b) order[b] = b;
    if (blocks > 0) build(order, 0, blocks);
}

// A node over order[from, to): a leaf for one block, else the two halves split at the median of
// the boxes' centres along the longer side of their bounds.
std::size_t ChordIndex2d::build(std::vector<std::size_t>& order, std::size_t from, std::size_t to) {
    const std::size_t index = nodes_.size();
    nodes_.emplace_back();
    Node node;
    node.lo = Vec::Constant(std::numeric_limits<double>::infinity());
    node.hi = -node.lo;
    for (std::size_t m = from; m < to; ++m) {
        node.lo = node.lo.cwiseMin(lo_[order[m]]);
        node.hi = node.hi.cwiseMax(hi_[order[m]]);
    }
    if (to - from == 1) {
        node.block = order[from];
    } else {
        const int axis = node.hi.x() - node.lo.x() >= node.hi.y() - node.lo.y() ? 0 : 1;
        const std::size_t mid = from + (to - from) / 2;
        std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(from),
                         order.begin() + static_cast<std::ptrdiff_t>(mid),
                         order.begin() + static_cast<std::ptrdiff_t>(to),
                         [&](std::size_t x, std::size_t y) {
                             const double cx = lo_[x][axis] + hi_[x][axis];
                             const double cy = lo_[y][axis] + hi_[y][axis];
                             return cx != cy ? cx < cy : x < y;
                         });
        node.left = build(order, from, mid);
        node.right = build(order, mid, to);
    }
    nodes_[index] = node;
    return index;
}

namespace {

// The entry distance of the ray o + t d into the box [lo, hi] over t in [0, t_max], or +inf
// when it misses (slab test; inv is 1/d per axis, infinite for an axis-parallel ray).
[[gnu::always_inline]] inline double enter_box(const Vec& o, const Vec& d, const Vec& inv,
                                               const Vec& lo, const Vec& hi, double t_max) {
    double t0 = 0.0, t1 = t_max;
    for (int axis = 0; axis < 2; ++axis) {
        if (d[axis] == 0.0) {
            if (o[axis] < lo[axis] || o[axis] > hi[axis]) return kInfinity;
            continue;
        }
        double ta = (lo[axis] - o[axis]) * inv[axis];
        double tb = (hi[axis] - o[axis]) * inv[axis];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
    }
    return t0 <= t1 ? t0 : kInfinity;
}

}  // namespace

// Depth first through the tree, the nearer child first, skipping every box that starts beyond
// the nearest hit so far (any hit will do for `blocked`).
template <bool kFirst>
std::optional<ChordIndex2d::Hit> ChordIndex2d::cast(const Eigen::Vector2d& o,
                                                    const Eigen::Vector2d& d,
                                                    std::size_t skip) const {
    const Vec inv(1.0 / d.x(), 1.0 / d.y());  // ±inf for an axis-parallel ray: handled there
    const double eps = 1e-9 * (1.0 + o.cwiseAbs().maxCoeff());
    std::optional<Hit> best;
    double reach = kInfinity;
    if (nodes_.empty()) return best;
    // Depth <= log2(blocks) + 1; not value-initialised (a kilobyte cleared per cast showed in
    // profiles).
    std::size_t stack_node[64];
    double stack_entry[64];
    std::size_t top = 0;
    const auto push = [&](std::size_t node, double entry) {
        stack_node[top] = node;
        stack_entry[top++] = entry;
    };
    push(0, enter_box(o, d, inv, nodes_[0].lo, nodes_[0].hi, reach));
    while (top > 0) {
        --top;
        const std::size_t index = stack_node[top];
        const double entry = stack_entry[top];
        if (entry == kInfinity || entry > reach) continue;  // missed, or beyond the nearest hit
        const Node& node = nodes_[index];
        if (node.block == kNoBlock) {
            const double tl =
                enter_box(o, d, inv, nodes_[node.left].lo, nodes_[node.left].hi, reach);
            const double tr =
                enter_box(o, d, inv, nodes_[node.right].lo, nodes_[node.right].hi, reach);
            // The farther one goes on the stack first, so the nearer is searched first.
            if (tl <= tr) {
                push(node.right, tr);
                push(node.left, tl);
            } else {
                push(node.left, tl);
                push(node.right, tr);
            }
            continue;
        }
        // The block's chords all at once, without branches (SIMD lanes): t along the ray and u
        // along the chord, +inf where the chord is missed, parallel or `skip`.
        const std::size_t base = node.block * kBlock;
        const double *ax = ax_.data() + base, *az = az_.data() + base;
        const double *ex = ex_.data() + base, *ez = ez_.data() + base;
        double t_hit[kBlock];
#pragma omp simd
        for (std::size_t i = 0; i < kBlock; ++i) {
            const double denom = d.x() * ez[i] - d.y() * ex[i];
            const double wx = ax[i] - o.x(), wz = az[i] - o.y();
            const double safe = denom == 0.0 ? 1.0 : denom;
            const double t = (wx * ez[i] - wz * ex[i]) / safe;
            const double u = (wx * d.y() - wz * d.x()) / safe;
            // & rather than &&: no branches in the lanes.
            const bool hit = (denom != 0.0) & (t > eps) & (u >= 0.0) & (u <= 1.0);
            t_hit[i] = hit ? t : kInfinity;
        }
        if (skip >= base && skip < base + kBlock) t_hit[skip - base] = kInfinity;
        for (std::size_t i = 0; i < kBlock; ++i) {
            if (!kFirst && t_hit[i] < kInfinity) return Hit{base + i, t_hit[i]};
            if (t_hit[i] < reach) {
                best = Hit{base + i, t_hit[i]};
                reach = t_hit[i];
            }
        }
    }
    return best;
}

bool ChordIndex2d::blocked(const Eigen::Vector2d& o, const Eigen::Vector2d& d,
                           std::size_t skip) const {
    return cast<false>(o, d, skip).has_value();
}

std::optional<ChordIndex2d::Hit> ChordIndex2d::first_hit(const Eigen::Vector2d& o,
                                                         const Eigen::Vector2d& d,
                                                         std::size_t skip) const {
    return cast<true>(o, d, skip);
}

std::vector<unsigned char> illuminated(const SampledCrossSection2d& sampled,
                                       const Eigen::Vector2d& omega_i) {
    const std::size_t n = sampled.samples.size();
    const ChordIndex2d chords(sampled);
    std::vector<unsigned char> lit(n, 0);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t js = 0; js < static_cast<std::ptrdiff_t>(n); ++js) {
        const std::size_t j = static_cast<std::size_t>(js);
        const SurfaceSample2d& s = sampled.samples[j];
        if (!(s.normal.dot(omega_i) > 0.0)) continue;
        lit[j] = chords.blocked(s.point, omega_i, j) ? 0 : 1;
    }
    return lit;
}

std::vector<unsigned char> rays_unblocked(const SampledCrossSection2d& sampled,
                                          std::span<const std::size_t> from,
                                          std::span<const Eigen::Vector2d> directions) {
    if (from.size() != directions.size())
        refuse(fmt::format("{} ray origins but {} directions", from.size(), directions.size()));
    const ChordIndex2d chords(sampled);
    std::vector<unsigned char> open(from.size(), 0);
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t ms = 0; ms < static_cast<std::ptrdiff_t>(from.size()); ++ms) {
        const std::size_t m = static_cast<std::size_t>(ms);
        const std::size_t j = from[m];
        open[m] = chords.blocked(sampled.samples[j].point, directions[m], j) ? 0 : 1;
    }
    return open;
}

FarFieldKernel2d prepare_far_field(const CrossSection2d& section,
                                   const SampledCrossSection2d& sampled,
                                   const Incidence2d& incidence, FarFieldPart part, bool bisector) {
    if (!std::isfinite(incidence.theta_i_rad))
        refuse(fmt::format("theta_i = {:.4g} rad must be finite", incidence.theta_i_rad));
    if (!std::isfinite(incidence.cos_elevation) || !(incidence.cos_elevation > 0.0) ||
        incidence.cos_elevation > 1.0)
        refuse(fmt::format("cos_elevation = {:.4g} must be in (0, 1]", incidence.cos_elevation));
    const double limit = physical_optics_step(incidence.lambda_nm, 0.0);
    for (const SurfaceSample2d& s : sampled.samples)
        if (s.ds_um > limit * (1.0 + 1e-12)) physical_optics_step(incidence.lambda_nm, s.ds_um);
    FarFieldKernel2d kernel;
    kernel.k = 2.0 * kPi / (1e-3 * incidence.lambda_nm) * incidence.cos_elevation;
    kernel.wi = direction(incidence.theta_i_rad);
    kernel.lambda_nm = incidence.lambda_nm;
    kernel.cos_elevation = incidence.cos_elevation;
    kernel.polarisation = incidence.polarisation;
    const optics::Polarisation pol = incidence.polarisation == Polarisation2d::te
                                         ? optics::Polarisation::s
                                         : optics::Polarisation::p;
    for (std::size_t c = 0; c < section.curves.size(); ++c) {
        validate_stack(section.curves[c].stack, c);
        kernel.layers.push_back(stack_layers(section.curves[c].stack, incidence.lambda_nm));
        kernel.substrate.push_back(section.curves[c].stack.substrate->index(incidence.lambda_nm));
    }
    const Vec wi = kernel.wi;
    const std::vector<unsigned char> lit = illuminated(sampled, wi);
    // Lit samples, structure of arrays; a and b hold ds and the stack: amplitude = a ω_s·n + b.
    for (std::size_t j = 0; j < sampled.samples.size(); ++j) {
        if (!lit[j]) continue;
        const SurfaceSample2d& s = sampled.samples[j];
        const double ci = std::min(1.0, s.normal.dot(wi));
        Complex r = 0.0;
        if (part != FarFieldPart::shadow && !bisector) {
            const optics::StackIndices stack{1.0, kernel.layers[s.curve],
                                             kernel.substrate[s.curve]};
            r = optics::transfer_matrix_amplitudes(stack, incidence.lambda_nm,
                                                   ci * incidence.cos_elevation, pol)
                    .r;
        }
        Complex aj, bj;
        switch (part) {
            case FarFieldPart::total:
                aj = 1.0 + r;
                bj = -(1.0 - r) * ci;
                break;
            case FarFieldPart::reflected:
                aj = r;
                bj = r * ci;
                break;
            case FarFieldPart::shadow:
                aj = 1.0;
                bj = -ci;
                break;
        }
        kernel.px.push_back(s.point.x());
        kernel.pz.push_back(s.point.y());
        kernel.nx.push_back(s.normal.x());
        kernel.nz.push_back(s.normal.y());
        kernel.tx.push_back(s.tangent.x());
        kernel.tz.push_back(s.tangent.y());
        kernel.ds.push_back(s.ds_um);
        kernel.curve.push_back(s.curve);
        kernel.index.push_back(j);
        kernel.a.push_back(aj * s.ds_um);
        kernel.b.push_back(bj * s.ds_um);
    }
    return kernel;
}

std::complex<double> far_field_at(const FarFieldKernel2d& kernel, double theta_s_rad) {
    const Vec ws = direction(theta_s_rad);
    const Vec wi = kernel.wi;
    const double k = kernel.k;
    const double qx = wi.x() + ws.x(), qz = wi.y() + ws.y();
    double re = 0.0, im = 0.0;
    const std::size_t n = kernel.px.size();
    for (std::size_t j = 0; j < n; ++j) {
        const double sn = kernel.nx[j] * ws.x() + kernel.nz[j] * ws.y();
        const double phase = -k * (qx * kernel.px[j] + qz * kernel.pz[j]);
        const double w =
            sinc_small(0.5 * k * (qx * kernel.tx[j] + qz * kernel.tz[j]) * kernel.ds[j]);
        const double ar = (kernel.a[j].real() * sn + kernel.b[j].real()) * w;
        const double ai = (kernel.a[j].imag() * sn + kernel.b[j].imag()) * w;
        const double c = std::cos(phase), s = std::sin(phase);
        re += ar * c - ai * s;
        im += ar * s + ai * c;
    }
    return {re, im};
}

void far_field_pair(const FarFieldKernel2d& first, const FarFieldKernel2d& second,
                    std::span<const double> theta_s_rad, std::vector<std::complex<double>>& u_first,
                    std::vector<std::complex<double>>& u_second) {
    if (first.px != second.px || first.pz != second.pz || first.k != second.k ||
        first.wi != second.wi)
        refuse("a far-field pair needs two kernels on the same lit samples, k and incidence");
    u_first.assign(theta_s_rad.size(), 0.0);
    u_second.assign(theta_s_rad.size(), 0.0);
    const Vec wi = first.wi;
    const double k = first.k;
    const std::size_t n = first.px.size();
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t is = 0; is < static_cast<std::ptrdiff_t>(theta_s_rad.size()); ++is) {
        const Vec ws = direction(theta_s_rad[static_cast<std::size_t>(is)]);
        const double qx = wi.x() + ws.x(), qz = wi.y() + ws.y();
        double re1 = 0.0, im1 = 0.0, re2 = 0.0, im2 = 0.0;
        for (std::size_t j = 0; j < n; ++j) {
            const double sn = first.nx[j] * ws.x() + first.nz[j] * ws.y();
            const double phase = -k * (qx * first.px[j] + qz * first.pz[j]);
            const double w =
                sinc_small(0.5 * k * (qx * first.tx[j] + qz * first.tz[j]) * first.ds[j]);
            const double c = std::cos(phase), s = std::sin(phase);
            const double ar1 = (first.a[j].real() * sn + first.b[j].real()) * w;
            const double ai1 = (first.a[j].imag() * sn + first.b[j].imag()) * w;
            const double ar2 = (second.a[j].real() * sn + second.b[j].real()) * w;
            const double ai2 = (second.a[j].imag() * sn + second.b[j].imag()) * w;
            re1 += ar1 * c - ai1 * s;
            im1 += ar1 * s + ai1 * c;
            re2 += ar2 * c - ai2 * s;
            im2 += ar2 * s + ai2 * c;
        }
        u_first[static_cast<std::size_t>(is)] = {re1, im1};
        u_second[static_cast<std::size_t>(is)] = {re2, im2};
    }
}

std::vector<std::complex<double>> far_field_integral(const CrossSection2d& section,
                                                     const SampledCrossSection2d& sampled,
                                                     const Incidence2d& incidence,
                                                     std::span<const double> theta_s_rad,
                                                     const PhysicalOpticsOptions& options) {
    const FarFieldPart part = options.part;
    const bool bisector = options.fresnel == FresnelAngle::bisector;
    const bool visibility = options.outgoing_visibility;
    if (bisector && part != FarFieldPart::reflected)
        refuse("the bisector Fresnel angle applies to the reflected part only");
    if (visibility && part != FarFieldPart::reflected)
        refuse(
            "outgoing visibility applies to the reflected part only (the shadow-forming wave "
            "leaves through the body by construction)");
    for (double th : theta_s_rad)
        if (!std::isfinite(th)) refuse(fmt::format("theta_s = {:.4g} rad must be finite", th));
    const FarFieldKernel2d kernel = prepare_far_field(section, sampled, incidence, part, bisector);
    std::vector<Complex> out(theta_s_rad.size());
    if (bisector || visibility) {
        const optics::Polarisation pol = incidence.polarisation == Polarisation2d::te
                                             ? optics::Polarisation::s
                                             : optics::Polarisation::p;
        const std::optional<ChordIndex2d> chords =
            visibility ? std::optional<ChordIndex2d>(sampled) : std::nullopt;
        const Vec wi = kernel.wi;
        const double k = kernel.k;
        const std::size_t n = kernel.px.size();
#pragma omp parallel for schedule(static)
        for (std::ptrdiff_t is = 0; is < static_cast<std::ptrdiff_t>(theta_s_rad.size()); ++is) {
            const Vec ws = direction(theta_s_rad[static_cast<std::size_t>(is)]);
            const Vec q = wi + ws;
            const double qn = q.norm();
            Complex sum = 0.0;
            // The bisector r: the stack's r at the local angle of a facet whose normal is
            // h = (ω_i + ω_s)/|ω_i + ω_s|, cos θ_local = ω_i·h = |ω_i + ω_s|/2 (in 3D with the
            // conical elevation ε, where ω_s,y = −ω_i,y: cos ε |ω_i + ω_s|/2). The same for every
            // sample of a curve, so once per curve and angle.
            std::vector<Complex> r_bisector;
            if (bisector && qn > 0.0)
                for (std::size_t c = 0; c < kernel.layers.size(); ++c)
                    r_bisector.push_back(optics::transfer_matrix_amplitudes(
                                             {1.0, kernel.layers[c], kernel.substrate[c]},
                                             incidence.lambda_nm,
                                             std::min(1.0, 0.5 * qn) * kernel.cos_elevation, pol)
                                             .r);
            if (qn > 0.0) {
                for (std::size_t j = 0; j < n; ++j) {
                    // Both variants drop samples facing away from ω_s (hidden by their own body).
                    const double cs = kernel.nx[j] * ws.x() + kernel.nz[j] * ws.y();
                    if (!(cs > 0.0)) continue;
                    if (visibility &&
                        chords->blocked(Vec(kernel.px[j], kernel.pz[j]), ws, kernel.index[j]))
                        continue;
                    const double ci = kernel.nx[j] * wi.x() + kernel.nz[j] * wi.y();
                    Complex amplitude;
                    if (bisector) {
                        amplitude = r_bisector[static_cast<std::size_t>(kernel.curve[j])] *
                                    ((ci + cs) * kernel.ds[j]);
                    } else {
                        amplitude = kernel.a[j] * cs + kernel.b[j];
                    }
                    const double phase = -k * (q.x() * kernel.px[j] + q.y() * kernel.pz[j]);
                    const double w = sinc_small(
                        0.5 * k * (q.x() * kernel.tx[j] + q.y() * kernel.tz[j]) * kernel.ds[j]);
                    sum += amplitude * w * std::polar(1.0, phase);
                }
            }
            out[static_cast<std::size_t>(is)] = sum;
        }
        return out;
    }
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t is = 0; is < static_cast<std::ptrdiff_t>(theta_s_rad.size()); ++is)
        out[static_cast<std::size_t>(is)] =
            far_field_at(kernel, theta_s_rad[static_cast<std::size_t>(is)]);
    return out;
}

namespace {

void validate_row(const Row2d& row) {
    if (row.count < 1) refuse(fmt::format("row count {} must be >= 1", row.count));
    if (row.realisations < 1) refuse(fmt::format("realisations {} must be >= 1", row.realisations));
    if (!std::isfinite(row.spacing_um) || row.spacing_um < 0.0)
        refuse(fmt::format("row spacing {:.4g} µm must be finite and >= 0", row.spacing_um));
    if (!std::isfinite(row.tilt_rad))
        refuse(fmt::format("tilt {:.4g} rad must be finite", row.tilt_rad));
    if (!std::isfinite(row.jitter_position_um) || row.jitter_position_um < 0.0)
        refuse(fmt::format("position jitter {:.4g} µm must be finite and >= 0",
                           row.jitter_position_um));
    if (!std::isfinite(row.jitter_rotation_rad) || row.jitter_rotation_rad < 0.0)
        refuse(fmt::format("rotation jitter {:.4g} rad must be finite and >= 0",
                           row.jitter_rotation_rad));
    const double dir_norm = row.direction.norm();
    if (!std::isfinite(dir_norm) || dir_norm == 0.0)
        refuse("row direction must be a non-zero vector");
}

bool row_is_jittered(const Row2d& row) {
    return row.jitter_position_um > 0.0 || row.jitter_rotation_rad > 0.0;
}

}  // namespace

SampledCrossSection2d place_row(const Row2d& row, const SampledCrossSection2d& cell,
                                int realisation) {
    validate_row(row);
    const Vec u = row.direction.normalized();
    const bool jittered = row_is_jittered(row);
    const std::uint64_t stream_seed = derive_seed(row.seed, "wave/physical_optics_2d/jitter",
                                                  static_cast<std::uint64_t>(realisation));
    SampledCrossSection2d placed;
    const std::size_t per_cell = cell.samples.size();
    placed.samples.reserve(per_cell * row.count);
    placed.chord_a.reserve(per_cell * row.count);
    placed.chord_b.reserve(per_cell * row.count);
    for (int c = 0; c < row.count; ++c) {
        double angle = row.tilt_rad;
        Vec centre = (c - 0.5 * (row.count - 1)) * row.spacing_um * u;
        if (jittered) {
            Rng rng(stream_seed, static_cast<std::uint64_t>(c));
            const double dx = standard_normal(rng), dz = standard_normal(rng);
            const double dphi = standard_normal(rng);
            centre += row.jitter_position_um * Vec(dx, dz);
            angle += row.jitter_rotation_rad * dphi;
        }
        const double cs = std::cos(angle), sn = std::sin(angle);
        for (std::size_t j = 0; j < per_cell; ++j) {
            SurfaceSample2d s = cell.samples[j];
            s.point = rotate(s.point, cs, sn) + centre;
            s.normal = rotate(s.normal, cs, sn);
            s.tangent = rotate(s.tangent, cs, sn);
            placed.samples.push_back(s);
            placed.chord_a.push_back(rotate(cell.chord_a[j], cs, sn) + centre);
            placed.chord_b.push_back(rotate(cell.chord_b[j], cs, sn) + centre);
        }
    }
    return placed;
}

std::vector<double> scattering_width(const Row2d& row, const Incidence2d& incidence,
                                     std::span<const double> theta_s_rad,
                                     const PhysicalOpticsOptions& options) {
    const double step = physical_optics_step(incidence.lambda_nm, options.step_um);
    validate_row(row);
    const SampledCrossSection2d cell = sample_cross_section(row.cell, step);
    const double k = 2.0 * kPi / (1e-3 * incidence.lambda_nm) * incidence.cos_elevation;
    std::vector<double> sigma(theta_s_rad.size(), 0.0);
    const int realisations = row_is_jittered(row) ? row.realisations : 1;  // identical rows
    for (int m = 0; m < realisations; ++m) {
        const std::vector<Complex> field =
            far_field_integral(row.cell, place_row(row, cell, m), incidence, theta_s_rad, options);
        for (std::size_t i = 0; i < sigma.size(); ++i) sigma[i] += std::norm(field[i]);
    }
    const double scale = k / (8.0 * kPi) / realisations;
    for (double& s : sigma) s *= scale;
    return sigma;
}

std::vector<double> scattering_width(const CrossSection2d& section, const Incidence2d& incidence,
                                     std::span<const double> theta_s_rad,
                                     const PhysicalOpticsOptions& options) {
    Row2d row;
    row.cell = section;
    return scattering_width(row, incidence, theta_s_rad, options);
}

}  // namespace plumage::sim::wave
