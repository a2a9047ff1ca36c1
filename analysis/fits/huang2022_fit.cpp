#include "analysis/fits/huang2022_fit.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <optional>
#include <string_view>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/NonLinearOptimization>

#include "analysis/fits/bounded_parameters.h"
#include "analysis/fits/least_squares.h"
#include "analysis/fits/levenberg_marquardt.h"
#include "common/constants.h"
#include "common/error.h"
#include "common/gauss_legendre.h"
#include "common/interrupt.h"
#include "common/require.h"

namespace plumage::analysis {
namespace {

// The logistic is kept this far from 0 and 1 so that open bounds (θ_d > 0, |μ| < π/2, w > 0)
// stay open in floating point.
constexpr double kLogisticFloor = 1e-15;
// H (no upper bound) is reported at_bound below kAtBoundFraction (bounded_parameters.h).
// A requested wavelength matches the record's within this (nm).
constexpr double kWavelengthMatch = 1e-6;

// The name that prefixes this file's input errors.
constexpr std::string_view kWhat = "Huang 2022 fit";

[[noreturn]] void fail(const std::string& what) {
    throw InputError(std::string(kWhat) + ": " + what);
}

// Logistic ranges: b, d_um, θ_d, μ from the model's table (analysis/models/huang2022.h), and the
// arc's width w = φ1 − φ0.
constexpr BoundedRange range_of(int index) {
    return {kHuang2022ParameterTable[index].min, kHuang2022ParameterTable[index].max};
}
constexpr BoundedRange kRangeB = range_of(kHuangB);
constexpr BoundedRange kRangeD = range_of(kHuangD);
constexpr BoundedRange kRangeThetaD = range_of(kHuangThetaD);
constexpr BoundedRange kRangeMu = range_of(kHuangMu);
constexpr BoundedRange kRangeWidth{0.0, 2.0 * kPi};

// The logistic of bounded_parameters.h, kept kLogisticFloor from 0 and 1 (Filip's fit does
// not clamp: its ranges are closed). p = min + (max − min) · logistic(u) here, not
// BoundedRange::parameter's division: the two round differently.
double logistic(double u) {
    return std::clamp(1.0 / (1.0 + std::exp(-u)), kLogisticFloor, 1.0 - kLogisticFloor);
}

// The optimiser's variables u ↔ the parameters p (see the header). φ0 precedes φ1 in the index
// order, so φ1 = φ0 + w can use the current φ0.
struct ParameterMap {
    std::array<double, kHuang2022ParameterCount> base{};  // fixed parameters' values
    std::array<bool, kHuang2022ParameterCount> is_free{};
    std::vector<int> free;

    // Which variable carries the arc's width: φ1's when φ1 is free, else φ0's.
    bool carries_width(int index) const {
        return index == kHuangPhi1 || (index == kHuangPhi0 && !is_free[kHuangPhi1]);
    }
    static const BoundedRange* logistic_range(int index) {
        switch (index) {
            case kHuangB:
                return &kRangeB;
            case kHuangD:
                return &kRangeD;
            case kHuangThetaD:
                return &kRangeThetaD;
            case kHuangMu:
                return &kRangeMu;
            default:
                return nullptr;
        }
    }

    std::array<double, kHuang2022ParameterCount> parameters(const Eigen::VectorXd& u) const {
        auto v = base;
        for (std::size_t j = 0; j < free.size(); ++j) {
            const int i = free[j];
            const double x = u[static_cast<Eigen::Index>(j)];
            if (const BoundedRange* r = logistic_range(i)) {
                v[i] = r->min + (r->max - r->min) * logistic(x);
            } else if (i == kHuangH) {
                v[i] = std::exp(std::clamp(x, -700.0, 700.0));
            } else if (carries_width(i)) {
                // Below 2π by a margin that the sum φ0 + w cannot round away: the logistic
                // reaches 1 in floating point, and an arc of exactly 2π is not a valid one.
                const double w =
                    std::min(kRangeWidth.max * logistic(x), kRangeWidth.max * (1.0 - 1e-12));
                if (i == kHuangPhi1) {
                    v[i] = v[kHuangPhi0] + w;
                } else {
                    v[i] = v[kHuangPhi1] - w;
                }
            } else {
                v[i] = x;  // φ0 while φ1 is free
            }
        }
        return v;
    }

    Eigen::VectorXd variables(const std::array<double, kHuang2022ParameterCount>& v) const {
        Eigen::VectorXd u(static_cast<Eigen::Index>(free.size()));
        for (std::size_t j = 0; j < free.size(); ++j) {
            const int i = free[j];
            double x = v[i];
            if (const BoundedRange* r = logistic_range(i)) {
                x = r->variable(v[i]);
            } else if (i == kHuangH) {
                x = std::log(v[i]);
            } else if (carries_width(i)) {
                x = kRangeWidth.variable(v[kHuangPhi1] - v[kHuangPhi0]);
            }
            u[static_cast<Eigen::Index>(j)] = x;
        }
        return u;
    }

    // M = ∂p/∂u over the free parameters (rows p, columns u).
    Eigen::MatrixXd derivative(const Eigen::VectorXd& u) const {
        const auto n = static_cast<Eigen::Index>(free.size());
        Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n, n);
        for (Eigen::Index j = 0; j < n; ++j) {
            const int i = free[static_cast<std::size_t>(j)];
            const double s = logistic(u[j]);
            if (const BoundedRange* r = logistic_range(i)) {
                m(j, j) = (r->max - r->min) * s * (1.0 - s);
            } else if (i == kHuangH) {
                m(j, j) = std::exp(std::clamp(u[j], -700.0, 700.0));
            } else if (carries_width(i)) {
                const double dw = kRangeWidth.max * s * (1.0 - s);
                m(j, j) = i == kHuangPhi1 ? dw : -dw;
                if (i == kHuangPhi1 && is_free[kHuangPhi0]) {
                    const auto phi0_slot =
                        std::find(free.begin(), free.end(), kHuangPhi0) - free.begin();
                    m(j, static_cast<Eigen::Index>(phi0_slot)) = 1.0;  // φ1 = φ0 + w
                }
            } else {
                m(j, j) = 1.0;
            }
        }
        return m;
    }

    bool at_bound(int index, const std::array<double, kHuang2022ParameterCount>& v) const {
        if (!is_free[index]) return false;
        if (const BoundedRange* r = logistic_range(index)) return r->near_bound(v[index]);
        if (index == kHuangH) return v[index] < kAtBoundFraction;
        if (carries_width(index)) return kRangeWidth.near_bound(v[kHuangPhi1] - v[kHuangPhi0]);
        return false;
    }
};

// Illumination directions and weights (summing to 1), see the header.
std::vector<std::pair<Vec3d, double>> illumination_nodes(const gonio::ScatterometerConfig& config,
                                                         int radial, int azimuthal) {
    if (config.illumination == gonio::Illumination::beam) return {{config.beam_direction, 1.0}};
    const bool cone = config.illumination == gonio::Illumination::cone;
    const Vec3d axis = cone ? config.beam_direction : Vec3d::UnitZ();
    const double radius = cone ? std::sin(0.5 * config.cone_aperture_rad) : 1.0;
    const Vec3d e1 =
        (std::abs(axis.z()) < 0.9 ? Vec3d::UnitZ() : Vec3d::UnitX()).cross(axis).normalized();
    const Vec3d e2 = axis.cross(e1);
    std::vector<std::pair<Vec3d, double>> nodes;
    // Gauss–Legendre in the disc's area fraction, mapped from [−1, 1] to [0, 1], innermost first.
    const GaussLegendreRule rule = gauss_legendre(radial);
    for (std::size_t i = rule.nodes.size(); i-- > 0;) {
        const double fraction = 0.5 * (rule.nodes[i] + 1.0), weight = 0.5 * rule.weights[i];
        const double r = radius * std::sqrt(fraction);
        const double along = std::sqrt(std::max(0.0, 1.0 - r * r));
        for (int j = 0; j < azimuthal; ++j) {
            const double g = 2.0 * kPi * (j + 0.5) / azimuthal;
            const Vec3d wi =
                (along * axis + r * (std::cos(g) * e1 + std::sin(g) * e2)).normalized();
            PLUMAGE_CHECK(wi.z() > 0.0, "illumination node below the patch");
            nodes.emplace_back(wi, weight / azimuthal);
        }
    }
    return nodes;
}

// The forward model's layout: the image, the pixels fitted (used) and, per used pixel and
// chosen wavelength, the observation it feeds (−1: none).
struct Layout {
    int n = 0;                           // image size
    std::vector<double> wavelengths_nm;  // chosen; the first is the reference for R's support
    std::vector<std::pair<Vec3d, double>> illumination;
    std::vector<std::size_t> disc;            // image pixels whose centre is inside the disc
    std::vector<std::size_t> used;            // image pixels fitted
    std::vector<double> centre_weight;        // per used pixel: J(centre) · area / Ω_pixel
    std::vector<double> omega;                // per used pixel: Ω_pixel (sr)
    std::vector<bool> force_edge;             // per used pixel: integrate by lines regardless
    std::vector<std::ptrdiff_t> observation;  // [used pixel][wavelength]
    std::size_t observations = 0;
    int edge_lines = 0;
    int edge_bisections = 0;
};

// Direction of image-plane point (u, v), or nullopt beyond the rim; jacobian = dω / (du dv).
std::optional<Vec3d> image_direction(double u, double v, double& jacobian) {
    const double r = std::hypot(u, v);
    if (r > 1.0) return std::nullopt;
    const double theta = 0.5 * kPi * r, phi = std::atan2(v, u);
    jacobian = r > 1e-12 ? 0.5 * kPi * std::sin(theta) / r : 0.25 * kPi * kPi;
    return Vec3d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
}

// Whether pixel (row, column)'s whole square lies inside the disc (r <= 1 at its farthest
// corner).
bool inside_rim(int n, int row, int column) {
    const double pixel = 2.0 / n;
    const double u0 = column * pixel - 1.0, v0 = 1.0 - row * pixel;
    const double u = std::max(std::abs(u0), std::abs(u0 + pixel));
    const double v = std::max(std::abs(v0), std::abs(v0 - pixel));
    return std::hypot(u, v) <= 1.0;
}

// Composite Simpson weights on [0, 1] for m (odd) equally spaced nodes.
std::vector<double> simpson_weights(int m) {
    std::vector<double> w(static_cast<std::size_t>(m), 0.0);
    const double h = 1.0 / (m - 1);
    for (int i = 0; i < m; ++i) {
        w[static_cast<std::size_t>(i)] =
            (i == 0 || i == m - 1) ? h / 3.0 : (i % 2 == 1 ? 4.0 * h / 3.0 : 2.0 * h / 3.0);
    }
    return w;
}

// R's support at the reference wavelength: −1 beyond the rim, 0 no R, 1 R > 0. The support is
// geometric (NDF box, arc, visibility), the same at every wavelength.
struct SupportProbe {
    const Huang2022Bsdf& model;
    const Vec3d& wi;
    double lambda_nm;
    int operator()(double u, double v) const {
        double jacobian = 0.0;
        const auto wo = image_direction(u, v, jacobian);
        if (!wo) return -1;
        std::array<double, 3> lobes{};
        model.eval(wi, *wo, lambda_nm, lobes);
        return lobes[Huang2022Bsdf::kR] > 0.0 ? 1 : 0;
    }
};

// Where the support changes between t_lo (status `first`) and t_hi along a segment of the
// pixel, by bisection.
template <typename Status>
double locate_change(const Status& status_at, double lo, double hi, int first, int bisections) {
    for (int b = 0; b < bisections; ++b) {
        const double mid = 0.5 * (lo + hi);
        (status_at(mid) == first ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// Cubature points of an edge pixel (see the header). Support nodes on an m × m grid of the
// pixel's square (m = edge_lines, corners included). Lines run along the direction with more
// support changes; each line is cut where the support changes (bisection from its m nodes) into
// segments integrated by their midpoint. Across the lines: composite Simpson on the m grid lines,
// or, when the support also changes across (a corner of the R band, where a visibility end meets
// the NDF's θ_d edge), the across range is cut where the grid rows change support (bisection)
// and each piece gets 2-point Gauss–Legendre lines. Weights include J · cos θ_o / Ω_pixel.
class EdgePixelCubature {
public:
    EdgePixelCubature(const SupportProbe& support, int n, int row, int column, int lines,
                      int bisections)
        : support_(support),
          pixel_(2.0 / n),
          u0_(column * pixel_ - 1.0),
          v0_(1.0 - row * pixel_),
          lines_(lines),
          m_(static_cast<std::size_t>(lines)),
          bisections_(bisections),
          grid_(m_ * m_) {
        for (std::size_t i = 0; i < m_; ++i) {
            for (std::size_t j = 0; j < m_; ++j)
                grid_[i * m_ + j] = status_ac(node_position(i), node_position(j));
        }
        for (std::size_t i = 0; i < m_; ++i) {
            for (std::size_t j = 0; j + 1 < m_; ++j) {
                along_c_ += grid_[i * m_ + j] != grid_[i * m_ + j + 1];
                along_a_ += grid_[j * m_ + i] != grid_[(j + 1) * m_ + i];
            }
        }
        lines_along_c_ = along_c_ >= along_a_;
    }

    void points(double omega, std::vector<std::pair<Vec3d, double>>& out) const {
        out.clear();
        std::vector<int> nodes(m_);
        std::vector<double> cuts;
        for (const Line& line : across_lines()) line_points(line, omega, nodes, cuts, out);
    }

private:
    // The lines: across position, weight, and the grid column if it is one.
    struct Line {
        double x, weight;
        std::ptrdiff_t grid_index;
    };

    double node_position(std::size_t k) const { return static_cast<double>(k) / (lines_ - 1); }
    // Local (a, c) ∈ [0, 1]²: u = u0 + a·pixel, v = v0 − c·pixel.
    int status_ac(double a, double c) const { return support_(u0_ + pixel_ * a, v0_ - pixel_ * c); }
    // Lines at fixed x (the across coordinate), cut along t; (x, t) = (a, c) or (c, a).
    int status_xt(double x, double t) const {
        return lines_along_c_ ? status_ac(x, t) : status_ac(t, x);
    }
    int grid_xt(std::size_t x, std::size_t t) const {
        return lines_along_c_ ? grid_[x * m_ + t] : grid_[t * m_ + x];
    }

    // Simpson on the grid lines, or Gauss–Legendre pieces between the across changes.
    std::vector<Line> across_lines() const {
        std::vector<Line> line_set;
        if ((lines_along_c_ ? along_a_ : along_c_) == 0) {
            const std::vector<double> w = simpson_weights(lines_);
            for (std::size_t i = 0; i < m_; ++i)
                line_set.push_back({node_position(i), w[i], static_cast<std::ptrdiff_t>(i)});
            return line_set;
        }
        std::vector<double> across_cuts = {0.0, 1.0};
        for (std::size_t t = 0; t < m_; ++t) {
            for (std::size_t x = 0; x + 1 < m_; ++x) {
                const int first = grid_xt(x, t);
                if (first == grid_xt(x + 1, t)) continue;
                const double fixed_t = node_position(t);
                across_cuts.push_back(
                    locate_change([&](double xx) { return status_xt(xx, fixed_t); },
                                  node_position(x), node_position(x + 1), first, bisections_));
            }
        }
        std::sort(across_cuts.begin(), across_cuts.end());
        constexpr double kGauss = 0.28867513459481287;  // 1 / (2√3)
        for (std::size_t k = 0; k + 1 < across_cuts.size(); ++k) {
            const double lo = across_cuts[k], hi = across_cuts[k + 1], length = hi - lo;
            if (!(length > 0.0)) continue;
            const double mid = 0.5 * (lo + hi);
            line_set.push_back({mid - kGauss * length, 0.5 * length, -1});
            line_set.push_back({mid + kGauss * length, 0.5 * length, -1});
        }
        return line_set;
    }

    // One line cut where the support changes, each segment by its midpoint.
    void line_points(const Line& line, double omega, std::vector<int>& nodes,
                     std::vector<double>& cuts, std::vector<std::pair<Vec3d, double>>& out) const {
        for (std::size_t t = 0; t < m_; ++t) {
            nodes[t] = line.grid_index >= 0 ? grid_xt(static_cast<std::size_t>(line.grid_index), t)
                                            : status_xt(line.x, node_position(t));
        }
        cuts.assign(1, 0.0);
        for (std::size_t t = 0; t + 1 < m_; ++t) {
            if (nodes[t] == nodes[t + 1]) continue;
            cuts.push_back(locate_change([&](double tt) { return status_xt(line.x, tt); },
                                         node_position(t), node_position(t + 1), nodes[t],
                                         bisections_));
        }
        cuts.push_back(1.0);
        for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
            const double length = cuts[k + 1] - cuts[k];
            if (!(length > 0.0)) continue;
            const double t = 0.5 * (cuts[k] + cuts[k + 1]);
            const double a = lines_along_c_ ? line.x : t, c = lines_along_c_ ? t : line.x;
            double jacobian = 0.0;
            const auto wo = image_direction(u0_ + pixel_ * a, v0_ - pixel_ * c, jacobian);
            if (!wo) continue;  // beyond the rim: no quanta land there
            out.emplace_back(*wo,
                             line.weight * length * pixel_ * pixel_ * jacobian * wo->z() / omega);
        }
    }

    const SupportProbe& support_;
    double pixel_, u0_, v0_;
    int lines_;
    std::size_t m_;
    int bisections_;
    std::vector<int> grid_;  // [a index][c index]
    int along_c_ = 0, along_a_ = 0;
    bool lines_along_c_ = true;
};

void edge_pixel_points(const SupportProbe& support, int n, int row, int column, int lines,
                       int bisections, double omega, std::vector<std::pair<Vec3d, double>>& out) {
    EdgePixelCubature(support, n, row, column, lines, bisections).points(omega, out);
}

// Predictions for every observation of the layout (indexed by observation). Each pixel is
// computed by one thread in a fixed order: the result does not depend on the thread count.
// `working`, when given, is called with the number of illumination directions done, between
// directions and, from the first thread, between pixels: a hemisphere record of many pixels
// and wavelengths takes seconds per direction, and its caller reports progress by time.
class ModelImage {
public:
    ModelImage(const Huang2022Params& params, const Layout& layout, int threads,
               std::vector<double>& out, const std::function<void(std::size_t)>& working)
        : model_(params),
          layout_(layout),
          threads_(threads),
          out_(out),
          working_(working),
          n_(layout.n),
          pixel_(2.0 / layout.n),
          nw_(layout.wavelengths_nm.size()),
          reference_(layout.wavelengths_nm.front()),
          status_(static_cast<std::size_t>(n_) * n_, -1),
          centre_value_(static_cast<std::size_t>(n_) * n_, 0.0),
          edge_(layout.used.size(), false) {
        out_.assign(layout.observations, 0.0);
    }

    void run() {
        for (const auto& node : layout_.illumination) {
            if (working_) working_(directions_);
            throw_if_interrupted("the next illumination direction of the Huang 2022 model image");
            // Plain variables, not a structured binding: OpenMP regions use them, and clang
            // before 16 cannot capture bindings there.
            const Vec3d& wi = node.first;
            const double node_weight = node.second;
            centres(wi);
            mark_edges();
            edge_pixels(wi, node_weight, SupportProbe{model_, wi, reference_});
            centre_pixels(wi, node_weight);
            ++directions_;
        }
        throw_if_interrupted("the end of the Huang 2022 model image");
    }

private:
    // Work is skipped once Ctrl-C is pressed (common/interrupt.h); the node loop then throws.
    template <class Body>
    void guarded(Body&& body) {
        if (interrupt_requested()) return;
        if (working_ && omp_get_thread_num() == 0) working_(directions_);
        try {
            body();
        } catch (...) {
#pragma omp critical(huang2022_fit_error)
            if (!error_) error_ = std::current_exception();
        }
    }
    void rethrow() const {
        if (error_) std::rethrow_exception(error_);
    }
    std::pair<double, double> centre_of(std::size_t p) const {
        const int row = static_cast<int>(p / n_), column = static_cast<int>(p % n_);
        return std::pair{(column + 0.5) * pixel_ - 1.0, 1.0 - (row + 0.5) * pixel_};
    }

    // A: every disc pixel's centre at the reference wavelength: R's support and f cos θ_o.
    void centres(const Vec3d& wi) {
        const auto disc_count = static_cast<std::ptrdiff_t>(layout_.disc.size());
#pragma omp parallel for schedule(dynamic, 16) num_threads(threads_)
        for (std::ptrdiff_t k = 0; k < disc_count; ++k) {
            guarded([&] {
                const std::size_t p = layout_.disc[static_cast<std::size_t>(k)];
                const auto [u, v] = centre_of(p);
                double jacobian = 0.0;
                const Vec3d wo = *image_direction(u, v, jacobian);
                std::array<double, 3> lobes{};
                centre_value_[p] = model_.eval(wi, wo, reference_, lobes) * wo.z();
                status_[p] = lobes[Huang2022Bsdf::kR] > 0.0 ? 1 : 0;
            });
        }
        rethrow();
    }

    // B: a used pixel is an edge pixel when R's support differs between its centre and a
    // neighbour's (any edge lies between two such centres), or when forced (the rim).
    void mark_edges() {
        for (std::size_t i = 0; i < layout_.used.size(); ++i) {
            const std::size_t p = layout_.used[i];
            const int row = static_cast<int>(p / n_), column = static_cast<int>(p % n_);
            bool differs = layout_.force_edge[i];
            for (int dr = -1; dr <= 1 && !differs; ++dr) {
                for (int dc = -1; dc <= 1 && !differs; ++dc) {
                    const int r2 = row + dr, c2 = column + dc;
                    if (r2 < 0 || c2 < 0 || r2 >= n_ || c2 >= n_) continue;
                    const int s = status_[static_cast<std::size_t>(r2) * n_ + c2];
                    differs = s >= 0 && s != status_[p];
                }
            }
            edge_[i] = differs;
        }
    }

    // C: edge pixels by lines.
    void edge_pixels(const Vec3d& wi, double node_weight, const SupportProbe& support) {
        const auto used_count = static_cast<std::ptrdiff_t>(layout_.used.size());
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads_)
        for (std::ptrdiff_t k = 0; k < used_count; ++k) {
            const auto i = static_cast<std::size_t>(k);
            if (!edge_[i]) continue;
            guarded([&] {
                const std::size_t p = layout_.used[i];
                thread_local std::vector<std::pair<Vec3d, double>> points;
                edge_pixel_points(support, n_, static_cast<int>(p / n_), static_cast<int>(p % n_),
                                  layout_.edge_lines, layout_.edge_bisections, layout_.omega[i],
                                  points);
                for (std::size_t w = 0; w < nw_; ++w) {
                    const std::ptrdiff_t o = layout_.observation[i * nw_ + w];
                    if (o < 0) continue;
                    double sum = 0.0;
                    for (const auto& [wo, weight] : points) {
                        sum += weight * model_.eval(wi, wo, layout_.wavelengths_nm[w]);
                    }
                    out_[static_cast<std::size_t>(o)] += node_weight * sum;
                }
            });
        }
        rethrow();
    }

    // D: the other pixels by their centre (A's value at the reference wavelength).
    void centre_pixels(const Vec3d& wi, double node_weight) {
        const auto used_count = static_cast<std::ptrdiff_t>(layout_.used.size());
        for (std::size_t w = 0; w < nw_; ++w) {
#pragma omp parallel for schedule(dynamic, 16) num_threads(threads_)
            for (std::ptrdiff_t k = 0; k < used_count; ++k) {
                const auto i = static_cast<std::size_t>(k);
                const std::ptrdiff_t o = layout_.observation[i * nw_ + w];
                if (edge_[i] || o < 0) continue;
                guarded([&] {
                    const std::size_t p = layout_.used[i];
                    double value = centre_value_[p];
                    if (w != 0) {
                        const auto [u, v] = centre_of(p);
                        double jacobian = 0.0;
                        const Vec3d wo = *image_direction(u, v, jacobian);
                        value = model_.eval(wi, wo, layout_.wavelengths_nm[w]) * wo.z();
                    }
                    out_[static_cast<std::size_t>(o)] +=
                        node_weight * layout_.centre_weight[i] * value;
                });
            }
            rethrow();
        }
    }

    const Huang2022Bsdf model_;
    const Layout& layout_;
    int threads_;
    std::vector<double>& out_;
    const std::function<void(std::size_t)>& working_;
    int n_;
    double pixel_;
    std::size_t nw_;
    double reference_;
    std::vector<int> status_;
    std::vector<double> centre_value_;
    std::vector<bool> edge_;
    std::exception_ptr error_;
    std::size_t directions_ = 0;
};

void predict(const Huang2022Params& params, const Layout& layout, int threads,
             std::vector<double>& out, const std::function<void(std::size_t)>& working = {}) {
    ModelImage(params, layout, threads, out, working).run();
}

void validate_options(const HuangFitOptions& o) {
    require(o.edge_lines >= 3 && o.edge_lines <= 15 && o.edge_lines % 2 == 1 &&
                o.edge_bisections >= 0 && o.edge_bisections <= 30,
            kWhat,
            fmt::format("edge_lines = {}, edge_bisections = {}: expected an odd number in 3..15 "
                        "and 0..30",
                        o.edge_lines, o.edge_bisections));
    require(o.pixel_stride >= 1 && o.pixel_stride <= 64, kWhat,
            fmt::format("pixel_stride = {}: expected 1..64", o.pixel_stride));
    require(
        std::isfinite(o.max_relative_error) && o.max_relative_error > 0.0, kWhat,
        fmt::format("max_relative_error = {}: expected a finite value > 0", o.max_relative_error));
    require(o.global_starts >= 0 && o.global_starts <= 75, kWhat,
            fmt::format("global_starts = {}: expected 0 to 75", o.global_starts));
    require(std::isfinite(o.relative_error_floor) && o.relative_error_floor >= 0.0, kWhat,
            fmt::format("relative_error_floor = {}: expected a finite value >= 0",
                        o.relative_error_floor));
    require(o.illumination_nodes_radial >= 1 && o.illumination_nodes_radial <= 64 &&
                o.illumination_nodes_azimuthal >= 1 && o.illumination_nodes_azimuthal <= 256,
            kWhat,
            fmt::format("illumination_nodes_radial = {}, illumination_nodes_azimuthal = {}: "
                        "expected 1..64 and 1..256",
                        o.illumination_nodes_radial, o.illumination_nodes_azimuthal));
    require(std::isfinite(o.finite_difference_step) && o.finite_difference_step > 0.0 &&
                o.finite_difference_step <= 1.0,
            kWhat,
            fmt::format("finite_difference_step = {}: expected a value in (0, 1]",
                        o.finite_difference_step));
    require(o.max_function_evaluations >= 1 && std::isfinite(o.relative_tolerance) &&
                o.relative_tolerance > 0.0,
            kWhat,
            fmt::format("max_function_evaluations = {}, relative_tolerance = {}: expected >= 1 "
                        "and > 0",
                        o.max_function_evaluations, o.relative_tolerance));
    require(o.threads >= 0, kWhat,
            fmt::format("threads = {}: expected >= 0 (0: OpenMP's default)", o.threads));
}

int thread_count(const HuangFitOptions& o) {
    return o.threads > 0 ? o.threads : std::max(1, omp_get_max_threads());
}

// The image's geometry shared by the fit and huang2022_scatterogram: the disc's pixels.
void set_image(Layout& layout, const gonio::ScatterometerConfig& config,
               const HuangFitOptions& options) {
    layout.n = config.image_size;
    layout.edge_lines = options.edge_lines;
    layout.edge_bisections = options.edge_bisections;
    const double pixel = 2.0 / layout.n;
    for (int row = 0; row < layout.n; ++row) {
        for (int column = 0; column < layout.n; ++column) {
            if (std::hypot((column + 0.5) * pixel - 1.0, 1.0 - (row + 0.5) * pixel) <= 1.0)
                layout.disc.push_back(static_cast<std::size_t>(row) * layout.n + column);
        }
    }
    layout.illumination = illumination_nodes(config, options.illumination_nodes_radial,
                                             options.illumination_nodes_azimuthal);
}

// Adds a used pixel; its observations are set by the caller.
void add_used(Layout& layout, std::size_t p, double omega, bool force_edge) {
    const double pixel = 2.0 / layout.n;
    const int row = static_cast<int>(p / layout.n), column = static_cast<int>(p % layout.n);
    double jacobian = 0.0;
    PLUMAGE_CHECK(
        image_direction((column + 0.5) * pixel - 1.0, 1.0 - (row + 0.5) * pixel, jacobian),
        "a used pixel's centre lies inside the disc");
    layout.used.push_back(p);
    layout.omega.push_back(omega);
    layout.centre_weight.push_back(jacobian * pixel * pixel / omega);
    layout.force_edge.push_back(force_edge);
    layout.observation.resize(layout.used.size() * layout.wavelengths_nm.size(), -1);
}

struct Problem {
    Layout layout;
    std::vector<double> data;           // per observation
    std::vector<double> inverse_sigma;  // per observation
};

// The record's shape and values, before anything is fitted to it.
void validate_record(const gonio::Scatterogram& s) {
    const int n = s.config.image_size;
    const std::size_t nl = s.config.wavelengths_nm.size();
    if (n <= 0 || nl == 0 || s.intensity.empty()) {
        fail(
            fmt::format("the scatterogram is empty ({} × {} pixels, {} wavelengths, {} values): "
                        "expected a measured record",
                        n, n, nl, s.intensity.size()));
    }
    s.config.validate();
    const std::size_t np = s.pixels();
    if (s.intensity.size() != np * nl || s.standard_error.size() != np * nl ||
        s.solid_angle_sr.size() != np) {
        fail(
            fmt::format("intensity has {} values, standard_error {}, solid_angle_sr {}: expected "
                        "{} ({} × {} pixels × {} wavelengths), the same, and {}",
                        s.intensity.size(), s.standard_error.size(), s.solid_angle_sr.size(),
                        np * nl, n, n, nl, np));
    }
    for (std::size_t i = 0; i < np * nl; ++i) {
        if (!(std::isfinite(s.intensity[i]) && std::isfinite(s.standard_error[i]) &&
              s.standard_error[i] >= 0.0)) {
            fail(
                fmt::format("pixel {} (row {}, column {}), wavelength {} nm: intensity = {}, "
                            "standard_error = {}: expected a finite intensity (negative ones "
                            "are allowed: background-subtracted data) and a finite standard "
                            "error >= 0",
                            i / nl, i / nl / n, i / nl % n, s.config.wavelengths_nm[i % nl],
                            s.intensity[i], s.standard_error[i]));
        }
    }
    for (std::size_t p = 0; p < np; ++p) {
        if (!(std::isfinite(s.solid_angle_sr[p]) && s.solid_angle_sr[p] >= 0.0)) {
            fail(fmt::format("pixel {}: solid_angle_sr = {}: expected a finite value >= 0", p,
                             s.solid_angle_sr[p]));
        }
    }
}

// The fitted wavelengths as indices into the record: all, or the options' list.
std::vector<std::size_t> chosen_wavelengths(const gonio::Scatterogram& s,
                                            const HuangFitOptions& options) {
    const std::size_t nl = s.config.wavelengths_nm.size();
    std::vector<std::size_t> chosen;
    if (options.wavelengths_nm.empty()) {
        for (std::size_t k = 0; k < nl; ++k) chosen.push_back(k);
    } else {
        for (double lambda : options.wavelengths_nm) {
            std::size_t k = 0;
            while (k < nl && !(std::abs(s.config.wavelengths_nm[k] - lambda) <= kWavelengthMatch))
                ++k;
            if (k == nl) {
                fail(fmt::format("wavelength {} nm: expected one of the record's ({} nm)", lambda,
                                 fmt::join(s.config.wavelengths_nm, ", ")));
            }
            if (std::find(chosen.begin(), chosen.end(), k) != chosen.end())
                fail(fmt::format("wavelength {} nm is listed twice", lambda));
            chosen.push_back(k);
        }
    }
    return chosen;
}

Problem prepare(const gonio::Scatterogram& s, const HuangFitOptions& options) {
    validate_record(s);
    const int n = s.config.image_size;
    const std::size_t nl = s.config.wavelengths_nm.size();
    const std::vector<std::size_t> chosen = chosen_wavelengths(s, options);
    Problem problem;
    Layout& layout = problem.layout;
    for (std::size_t k : chosen) layout.wavelengths_nm.push_back(s.config.wavelengths_nm[k]);
    set_image(layout, s.config, options);
    const std::size_t nw = chosen.size();
    for (std::size_t p : layout.disc) {
        const int row = static_cast<int>(p / n), column = static_cast<int>(p % n);
        if ((row + column) % options.pixel_stride != 0 || !inside_rim(n, row, column) ||
            !(s.solid_angle_sr[p] > 0.0)) {
            continue;
        }
        std::vector<std::ptrdiff_t> observations(nw, -1);
        bool any = false;
        for (std::size_t w = 0; w < nw; ++w) {
            const std::size_t cell = p * nl + chosen[w];
            const double value = s.intensity[cell], se = s.standard_error[cell];
            const bool signal = value > 0.0 && se <= options.max_relative_error * value;
            if (!signal && !(options.every_pixel_with_sigma && se > 0.0)) continue;
            const double sigma =
                std::hypot(se, options.relative_error_floor * std::max(value, 0.0));
            if (!(sigma > 0.0)) continue;
            observations[w] = static_cast<std::ptrdiff_t>(layout.observations++);
            problem.data.push_back(value);
            problem.inverse_sigma.push_back(1.0 / sigma);
            any = true;
        }
        if (!any) continue;
        add_used(layout, p, s.solid_angle_sr[p], false);
        std::copy(observations.begin(), observations.end(),
                  layout.observation.end() - static_cast<std::ptrdiff_t>(nw));
    }
    return problem;
}

// The functor interface of Eigen's LevenbergMarquardt: weighted residuals, and their Jacobian in
// u by central differences (df returns the number of residual evaluations it made, which the
// optimiser adds to nfev).
struct Residuals {
    const Problem& problem;
    const ParameterMap& map;
    double step;
    int threads;
    const HuangFitOptions& options;
    std::chrono::steady_clock::time_point start;
    mutable int evaluations = 0;
    mutable int jacobians = 0;
    mutable std::vector<double> prediction;

    int values() const { return static_cast<int>(problem.data.size()); }

    int operator()(const Eigen::VectorXd& u, Eigen::VectorXd& r) const {
        std::function<void(std::size_t)> working;
        if (options.progress) {
            working = [this](std::size_t done) {
                HuangFitProgress p = report(0.0);
                p.within_evaluation = true;
                p.directions_done = done;
                options.progress(p);
            };
        }
        predict(huang2022_params(map.parameters(u)), problem.layout, threads, prediction, working);
        ++evaluations;
        for (std::size_t k = 0; k < problem.data.size(); ++k) {
            r[static_cast<Eigen::Index>(k)] =
                (prediction[k] - problem.data[k]) * problem.inverse_sigma[k];
        }
        if (options.progress) options.progress(report(r.squaredNorm()));
        return 0;
    }

    HuangFitProgress report(double chi_square) const {
        HuangFitProgress p;
        p.evaluations = evaluations;
        p.max_evaluations = options.max_function_evaluations;
        p.free_parameters = static_cast<int>(map.free.size());
        p.observations = problem.layout.observations;
        p.pixels = problem.layout.used.size();
        p.illumination_directions = problem.layout.illumination.size();
        p.elapsed_s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        p.chi_square = chi_square;
        return p;
    }

    int df(const Eigen::VectorXd& u, Eigen::MatrixXd& jacobian) const {
        Eigen::VectorXd plus(values()), minus(values());
        for (Eigen::Index j = 0; j < u.size(); ++j) {
            Eigen::VectorXd shifted = u;
            shifted[j] = u[j] + step;
            (*this)(shifted, plus);
            shifted[j] = u[j] - step;
            (*this)(shifted, minus);
            jacobian.col(j) = (plus - minus) / (2.0 * step);
        }
        ++jacobians;
        return static_cast<int>(2 * u.size());
    }
};

// The parameters' covariance and standard errors at the optimum u from the residuals'
// Jacobian in u: covariance_u = s² (J_uᵀJ_u)⁻¹ (least_squares_covariance), then M covariance_u Mᵀ.
void set_covariance(HuangFitResult& result, const Eigen::MatrixXd& jacobian,
                    const ParameterMap& map, const Eigen::VectorXd& u) {
    const int n_free = static_cast<int>(map.free.size());
    result.covariance =
        Eigen::MatrixXd::Constant(n_free, n_free, std::numeric_limits<double>::quiet_NaN());
    if (!jacobian.allFinite()) return;
    const std::optional<Eigen::MatrixXd> covariance_u =
        least_squares_covariance(normal_matrix(jacobian), result.reduced_chi_square);
    if (!covariance_u) return;
    const Eigen::MatrixXd m = map.derivative(u);
    result.covariance = m * *covariance_u * m.transpose();
    result.covariance_available = true;
    for (int j = 0; j < n_free; ++j)
        result.standard_errors[map.free[j]] = std::sqrt(result.covariance(j, j));
}

}  // namespace

std::array<double, kHuang2022ParameterCount> huang2022_values(const Huang2022Params& p) {
    return {p.b, p.phi0, p.phi1, p.H, p.d_um, p.theta_d, p.mu};
}

Huang2022Params huang2022_params(const std::array<double, kHuang2022ParameterCount>& v) {
    Huang2022Params p;
    p.b = v[kHuangB];
    p.phi0 = v[kHuangPhi0];
    p.phi1 = v[kHuangPhi1];
    p.H = v[kHuangH];
    p.d_um = v[kHuangD];
    p.theta_d = v[kHuangThetaD];
    p.mu = v[kHuangMu];
    return p;
}

gonio::Scatterogram huang2022_scatterogram(const Huang2022Params& params,
                                           const gonio::ScatterometerConfig& config,
                                           const HuangFitOptions& options) {
    config.validate();
    validate_options(options);
    gonio::Scatterogram s;
    s.config = config;
    s.scatterer = "huang2022";
    const int n = config.image_size;
    const std::size_t np = s.pixels(), nl = config.wavelengths_nm.size();
    Layout layout;
    layout.wavelengths_nm = config.wavelengths_nm;
    set_image(layout, config, options);
    s.solid_angle_sr.assign(np, 0.0);
    const double pixel = 2.0 / n;
    for (std::size_t p : layout.disc) {
        const int row = static_cast<int>(p / n), column = static_cast<int>(p % n);
        const double r = std::hypot((column + 0.5) * pixel - 1.0, 1.0 - (row + 0.5) * pixel);
        // As measure_scatterogram: Ω = (π/2) sin(πr/2)/r · (2/N)², the centre's Jacobian.
        s.solid_angle_sr[p] =
            (r > 1e-12 ? 0.5 * kPi * std::sin(0.5 * kPi * r) / r : 0.25 * kPi * kPi) * pixel *
            pixel;
        // Pixels across the rim are integrated by lines (the rim is an edge of the image).
        add_used(layout, p, s.solid_angle_sr[p], !inside_rim(n, row, column));
        for (std::size_t w = 0; w < nl; ++w) {
            layout.observation[(layout.used.size() - 1) * nl + w] =
                static_cast<std::ptrdiff_t>(p * nl + w);
        }
    }
    layout.observations = np * nl;
    predict(params, layout, thread_count(options), s.intensity);
    s.standard_error.assign(np * nl, 0.0);
    return s;
}

double huang2022_fit_chi_square(const gonio::Scatterogram& data, const Huang2022Params& params,
                                const HuangFitOptions& options) {
    validate_options(options);
    const Huang2022Bsdf validated(params);
    const Problem problem = prepare(data, options);
    std::vector<double> prediction;
    predict(params, problem.layout, thread_count(options), prediction);
    double sum = 0.0;
    for (std::size_t k = 0; k < prediction.size(); ++k) {
        const double r = (prediction[k] - problem.data[k]) * problem.inverse_sigma[k];
        sum += r * r;
    }
    return sum;
}

namespace {

using HuangValues = std::array<double, kHuang2022ParameterCount>;

// One Levenberg–Marquardt run from `start` (the fixed parameters' values included).
HuangFitResult local_fit(const Problem& problem, ParameterMap map, const HuangValues& start,
                         const HuangFitOptions& options) {
    map.base = start;
    const int n_free = static_cast<int>(map.free.size());
    const int n_obs = static_cast<int>(problem.data.size());
    const int threads = thread_count(options);
    Eigen::VectorXd u = map.variables(map.base);
    Residuals residuals{problem, map,     options.finite_difference_step,
                        threads, options, std::chrono::steady_clock::now(),
                        0,       0,       {}};
    Eigen::LevenbergMarquardt<Residuals> lm(residuals);
    lm.parameters.maxfev = options.max_function_evaluations;
    lm.parameters.ftol = options.relative_tolerance;
    lm.parameters.xtol = options.relative_tolerance;
    const auto status = lm.minimize(u);

    HuangFitResult result;
    result.iterations = residuals.jacobians;
    result.converged = converged(status);
    result.termination = describe(status);
    result.values = map.parameters(u);
    result.parameters = huang2022_params(result.values);
    result.free_parameters = map.free;
    result.observations = n_obs;
    result.pixels = static_cast<int>(problem.layout.used.size());
    result.wavelengths_nm = problem.layout.wavelengths_nm;
    result.degrees_of_freedom = n_obs - n_free;

    // Residuals and the Jacobian in u at the optimum.
    Eigen::VectorXd r(n_obs);
    residuals(u, r);
    double plain_sum = 0.0;
    for (int k = 0; k < n_obs; ++k) {
        const double d = r[k] / problem.inverse_sigma[static_cast<std::size_t>(k)];
        plain_sum += d * d;
    }
    result.residual_rms = std::sqrt(plain_sum / n_obs);
    result.chi_square = r.squaredNorm();
    result.reduced_chi_square = result.chi_square / result.degrees_of_freedom;
    Eigen::MatrixXd jacobian(n_obs, n_free);
    residuals.df(u, jacobian);
    result.function_evaluations = residuals.evaluations;
    for (int i = 0; i < kHuang2022ParameterCount; ++i) {
        result.standard_errors[i] = std::numeric_limits<double>::quiet_NaN();
        result.at_bound[i] = map.at_bound(i, result.values);
    }
    set_covariance(result, jacobian, map, u);
    return result;
}

// Σ r² of the problem at `values` (one residual evaluation).
// The global stage's evaluations, reported to options.progress as the local runs' are (the
// first one with its cost, then from inside slow ones), so that a fit is never silent.
struct StageEvaluator {
    const Problem& problem;
    const HuangFitOptions& options;
    int free_parameters;
    std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
    int evaluations = 0;

    HuangFitProgress report(double chi_square) const {
        HuangFitProgress p;
        p.evaluations = evaluations;
        p.max_evaluations = options.max_function_evaluations;
        p.free_parameters = free_parameters;
        p.observations = problem.layout.observations;
        p.pixels = problem.layout.used.size();
        p.illumination_directions = problem.layout.illumination.size();
        p.elapsed_s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        p.chi_square = chi_square;
        return p;
    }

    // Σ r² at `values`: one residual evaluation (Ctrl-C polled inside, as in every one).
    double operator()(const HuangValues& values) {
        std::function<void(std::size_t)> working;
        if (options.progress) {
            working = [this](std::size_t done) {
                HuangFitProgress p = report(0.0);
                p.within_evaluation = true;
                p.directions_done = done;
                options.progress(p);
            };
        }
        std::vector<double> prediction;
        predict(huang2022_params(values), problem.layout, thread_count(options), prediction,
                working);
        double sum = 0.0;
        for (std::size_t k = 0; k < problem.data.size(); ++k) {
            const double r = (prediction[k] - problem.data[k]) * problem.inverse_sigma[k];
            sum += r * r;
        }
        ++evaluations;
        if (options.progress) options.progress(report(sum));
        return sum;
    }
};

// The global stage's grid (header): film thickness × tilt × spacing, each free one over its
// grid, a fixed one at its start.
std::vector<HuangValues> huang_grid(const HuangValues& start, const ParameterMap& map) {
    constexpr std::array<double, 5> kD = {0.3, 0.45, 0.6, 0.75, 0.9};
    constexpr std::array<double, 5> kMu = {-0.6, -0.3, 0.0, 0.3, 0.6};
    constexpr std::array<double, 3> kH = {1.0, 1.25, 1.5};
    std::vector<HuangValues> grid;
    for (double d : kD) {
        for (double mu : kMu) {
            for (double h : kH) {
                HuangValues v = start;
                if (map.is_free[kHuangD]) v[kHuangD] = d;
                if (map.is_free[kHuangMu]) v[kHuangMu] = mu;
                if (map.is_free[kHuangH]) v[kHuangH] = h;
                if (std::find(grid.begin(), grid.end(), v) == grid.end()) grid.push_back(v);
            }
        }
    }
    return grid;
}

// The starts of the local stage: the caller's start, then the global_starts grid points of
// lowest χ² (ties: grid order). Ctrl-C is polled between grid points.
std::vector<HuangValues> huang_starts(const Problem& problem, const ParameterMap& map,
                                      const HuangValues& start, const HuangFitOptions& options) {
    std::vector<HuangValues> starts = {start};
    if (options.global_starts == 0) return starts;
    std::vector<std::pair<double, HuangValues>> ranked;
    StageEvaluator chi_square_at{problem, options, static_cast<int>(map.free.size())};
    for (const HuangValues& v : huang_grid(start, map)) {
        throw_if_interrupted("the Huang 2022 fit's global stage");
        ranked.emplace_back(chi_square_at(v), v);
    }
    std::stable_sort(ranked.begin(), ranked.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (std::size_t k = 0; k < ranked.size() && static_cast<int>(k) < options.global_starts; ++k)
        starts.push_back(ranked[k].second);
    return starts;
}

// Scans from a local optimum, the others held: d over film orders (0.2–1.2 µm), b and θ_d over
// their plausible ranges, and (H, μ) together (their valley: the R band's position). Returns the
// scanned point of lowest χ² when it is below `chi_square` by more than 1, else nothing.
std::optional<HuangValues> scan_for_better(const Problem& problem, const ParameterMap& map,
                                           const HuangValues& at, double chi_square,
                                           const HuangFitOptions& options) {
    std::vector<HuangValues> points;
    auto scan = [&](int index, double first, double last, int count) {
        if (!map.is_free[index]) return;
        for (int k = 0; k < count; ++k) {
            HuangValues v = at;
            v[index] = first + (last - first) * k / (count - 1);
            points.push_back(v);
        }
    };
    scan(kHuangD, 0.2, 1.2, 21);
    scan(kHuangB, 0.1, 0.6, 11);
    scan(kHuangThetaD, 0.02, 0.2, 10);
    if (map.is_free[kHuangH] && map.is_free[kHuangMu]) {
        for (int i = 0; i < 10; ++i) {
            for (int j = 0; j < 9; ++j) {
                HuangValues v = at;
                v[kHuangH] = 0.8 + 0.2 * i;
                v[kHuangMu] = -0.8 + 0.2 * j;
                points.push_back(v);
            }
        }
    }
    std::optional<HuangValues> better;
    double lowest = chi_square - 1.0;
    StageEvaluator chi_square_at{problem, options, static_cast<int>(map.free.size())};
    for (const HuangValues& v : points) {
        throw_if_interrupted("the Huang 2022 fit's scans");
        const double c = chi_square_at(v);
        if (c < lowest) {
            lowest = c;
            better = v;
        }
    }
    return better;
}

ParameterMap free_parameters(const HuangFitOptions& options) {
    ParameterMap map;
    map.is_free.fill(true);
    for (const std::string& name : options.fixed) {
        const auto it =
            std::find(kHuang2022ParameterNames.begin(), kHuang2022ParameterNames.end(), name);
        if (it == kHuang2022ParameterNames.end()) {
            fail(fmt::format("fixed parameter '{}': expected one of {}", name,
                             fmt::join(kHuang2022ParameterNames, ", ")));
        }
        map.is_free[static_cast<std::size_t>(it - kHuang2022ParameterNames.begin())] = false;
    }
    for (int i = 0; i < kHuang2022ParameterCount; ++i) {
        if (map.is_free[i]) map.free.push_back(i);
    }
    if (map.free.empty()) fail("every parameter is fixed: nothing to fit");
    return map;
}

}  // namespace

HuangFitResult fit_huang2022(const gonio::Scatterogram& data, const Huang2022Params& start,
                             const HuangFitOptions& options) {
    const auto clock_start = std::chrono::steady_clock::now();
    validate_options(options);
    const ParameterMap map = free_parameters(options);
    const Huang2022Bsdf validated(start);  // InputError names a parameter out of range
    const int n_free = static_cast<int>(map.free.size());
    const Problem problem = prepare(data, options);
    const int n_obs = static_cast<int>(problem.data.size());
    if (n_obs <= n_free) {
        fail(
            fmt::format("{} observations with signal for {} free parameters: expected more "
                        "observations than free parameters (max_relative_error = {}, "
                        "pixel_stride = {})",
                        n_obs, n_free, options.max_relative_error, options.pixel_stride));
    }

    std::optional<HuangFitResult> best;
    std::vector<double> chi_squares;
    int evaluations = 0;
    for (const HuangValues& s : huang_starts(problem, map, huang2022_values(start), options)) {
        HuangFitResult run = local_fit(problem, map, s, options);
        chi_squares.push_back(run.chi_square);
        evaluations += run.function_evaluations;
        if (!best || run.chi_square < best->chi_square) best = std::move(run);
    }
    // Basin hopping: scans from the best optimum, and a local run from a better scanned point,
    // while that lowers χ² (at most three rounds).
    for (int round = 0; round < 3 && options.global_starts > 0; ++round) {
        const std::optional<HuangValues> better =
            scan_for_better(problem, map, best->values, best->chi_square, options);
        if (!better) break;
        HuangFitResult run = local_fit(problem, map, *better, options);
        chi_squares.push_back(run.chi_square);
        evaluations += run.function_evaluations;
        if (!(run.chi_square < best->chi_square)) break;
        best = std::move(run);
    }
    HuangFitResult result = std::move(*best);
    result.local_fits = static_cast<int>(chi_squares.size());
    result.start_chi_squares = std::move(chi_squares);
    result.function_evaluations = evaluations;
    result.wall_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - clock_start).count();
    return result;
}

}  // namespace plumage::analysis
