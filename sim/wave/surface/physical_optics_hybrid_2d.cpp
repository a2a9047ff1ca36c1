// Physical optics through transparent interfaces (physical_optics_hybrid_2d.h has the
// derivation and the list of what is kept).
#include "sim/wave/surface/physical_optics_hybrid_2d.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>
#include <parallel/algorithm>

#include "common/constants.h"
#include "common/error.h"
#include "common/fast_trig.h"
#include "geometry/elliptical_arc.h"
#include "sim/optics/material.h"

namespace plumage::sim::wave {
namespace {

using Vec = Eigen::Vector2d;
using Complex = std::complex<double>;

[[noreturn]] void refuse(const std::string& message) {
    throw InputError(fmt::format("physical optics through interfaces: {}", message));
}

Complex decaying_sqrt(Complex z) {
    Complex q = std::sqrt(z);
    if (q.imag() < 0.0 || (q.imag() == 0.0 && q.real() < 0.0)) q = -q;
    return q;
}

// One curve's stack at the wavelength, both ways round.
struct CurveOptics {
    std::vector<optics::StackLayer> down, up;  // films as met from the + side, from the − side
    Complex substrate;
    double films_um = 0.0;  // D, the films' total thickness
    bool sheet = false;     // substrate is air: ambient on both sides
};

// Both polarisations ride on one ray (the paths' geometry does not depend on them): index 0
// and 1 of these arrays are the polarisations asked, in order; unused entries stay zero.
constexpr std::size_t kPols = 2;
using Amplitudes = std::array<Complex, kPols>;
using Powers = std::array<double, kPols>;

// A ray: a leg of one path. `inside` is −1 in the ambient, else the curve whose substrate the
// ray travels in (its body); nu and kappa are the body's ν and |Re k|/k (header).
struct Ray {
    Vec o, d;
    Amplitudes u{};
    Powers power{};
    double width = 0.0;
    std::uint64_t code = 0;
    std::size_t skip = 0;
    int events = 0;
    int inside = -1;
    Complex nu = 1.0;
    double kappa = 1.0;
    bool primary = true;
};

// Where a wave meets an ambient face: the term a ω_s·n_f + b (the wave's amplitude u included)
// before the footprint is known.
struct Hit {
    std::uint64_t code;
    Vec p, n_f, t_f;
    double cos_in;  // |d·n_f| of the arriving ray, for its width on the face
    double width;   // the ray's planar width
    Amplitudes a, b;
    double g;  // the wave's tangential wavenumber along t_f, over k
};

std::uint64_t extend_code(std::uint64_t code, std::size_t curve, int side, int branch) {
    std::uint64_t x = code ^ (static_cast<std::uint64_t>(curve) * 0x9E3779B97F4A7C15ULL +
                              static_cast<std::uint64_t>(side * 2 + branch + 7));
    x ^= x >> 31;
    x *= 0xBF58476D1CE4E5B9ULL;
    x ^= x >> 29;
    return x;
}

struct Tally {
    Powers absorbed{}, truncated{};
};

// A planar stack's media at one Snell invariant β, what both polarisations' responses share:
// the indices, q = √(n² − β²) on the decaying branch, and each film's phase factors e^{∓iδ}.
// Held inline (a tracer asks for one at every interface a ray meets); a stack of more than
// kInlineMedia media goes to the heap.
class StackMedia {
public:
    StackMedia(Complex n_in, std::span<const optics::StackLayer> layers, Complex n_out, double beta,
               double lambda_nm)
        : size_(layers.size() + 2) {
        if (size_ > kInlineMedia) heap_.resize(4 * size_);
        Complex* buffer = size_ > kInlineMedia ? heap_.data() : inline_.data();
        n_ = buffer;
        q_ = buffer + size_;
        down_ = buffer + 2 * size_;
        up_ = buffer + 3 * size_;
        n_[0] = n_in;
        for (std::size_t j = 0; j < layers.size(); ++j) n_[j + 1] = layers[j].n;
        n_[size_ - 1] = n_out;
        for (std::size_t j = 0; j < size_; ++j) q_[j] = decaying_sqrt(n_[j] * n_[j] - beta * beta);
        q_in_ = q_[0];
        q_out_ = q_[size_ - 1];
        // Exactly grazing in a lossless medium (a face sampled where its normal is square to
        // the light, at a symmetric ellipse's side): the matrices become 0/0. The limit is
        // multilayer.cpp's: nothing enters the first medium of positive thickness that differs
        // from the incidence one (r = −1, t = 0); with none, the stack is absent.
        if (q_in_ == 0.0) {
            grazing_ = Grazing::absent;
            for (std::size_t j = 1; j < size_; ++j) {
                const bool present = j + 1 == size_ || layers[j - 1].thickness_um > 0.0;
                if (present && n_[j] != n_[0]) {
                    grazing_ = Grazing::reflected;
                    break;
                }
            }
            return;
        }
        // A lossless film at exactly its own critical angle (q = 0 inside the stack) has a
        // finite limit that the matrices reach continuously; a q of 1e-9 stands in for it (its
        // error is of that order) rather than dividing by the zero t of the film's lower
        // interface.
        for (std::size_t j = 1; j < size_; ++j)
            if (q_[j] == 0.0) q_[j] = 1e-9;
        const double k0 = 2.0 * kPi / (1e-3 * lambda_nm);
        for (std::size_t j = 1; j + 1 < size_; ++j) {
            const Complex delta = k0 * q_[j] * layers[j - 1].thickness_um;
            down_[j] = std::exp(Complex(0.0, -1.0) * delta);
            up_[j] = std::exp(Complex(0.0, 1.0) * delta);
        }
    }
    StackMedia(const StackMedia&) = delete;
    StackMedia& operator=(const StackMedia&) = delete;

    // r and t for one polarisation (header: stack_response).
    StackResponse2d respond(optics::Polarisation pol) const {
        StackResponse2d out;
        out.q_in = q_in_;
        out.q_out = q_out_;
        if (grazing_ == Grazing::reflected) {
            out.r = -1.0;
            out.reflectance = 1.0;
            return out;
        }
        if (grazing_ == Grazing::absent) {
            out.t = 1.0;
            out.transmittance = 1.0;
            return out;
        }
        // Byrnes' transfer matrix (multilayer.h): M = Π (1/t_j)[[1, r_j], [r_j, 1]]
        // diag(e^{−iδ}, e^{iδ}).
        Complex m00 = 1.0, m01 = 0.0, m10 = 0.0, m11 = 1.0;
        for (std::size_t j = 0; j + 1 < size_; ++j) {
            if (j > 0) {
                m00 *= down_[j];
                m10 *= down_[j];
                m01 *= up_[j];
                m11 *= up_[j];
            }
            Complex r, t;
            if (pol == optics::Polarisation::s) {
                r = (q_[j] - q_[j + 1]) / (q_[j] + q_[j + 1]);
                t = 2.0 * q_[j] / (q_[j] + q_[j + 1]);
            } else {
                const Complex den = n_[j + 1] * n_[j + 1] * q_[j] + n_[j] * n_[j] * q_[j + 1];
                r = (n_[j + 1] * n_[j + 1] * q_[j] - n_[j] * n_[j] * q_[j + 1]) / den;
                t = 2.0 * n_[j] * n_[j + 1] * q_[j] / den;
            }
            const Complex inv_t = 1.0 / t;  // one complex division instead of four
            const Complex a00 = (m00 + m01 * r) * inv_t, a01 = (m00 * r + m01) * inv_t;
            const Complex a10 = (m10 + m11 * r) * inv_t, a11 = (m10 * r + m11) * inv_t;
            m00 = a00, m01 = a01, m10 = a10, m11 = a11;
        }
        out.r = m10 / m00;
        out.t = 1.0 / m00;
        out.reflectance = std::norm(out.r);
        const auto flux = [pol](Complex index, Complex qq) {
            return pol == optics::Polarisation::s ? qq.real()
                                                  : (index * std::conj(qq / index)).real();
        };
        const double in = flux(n_[0], q_[0]);
        out.transmittance =
            in > 0.0 ? std::norm(out.t) * flux(n_[size_ - 1], q_[size_ - 1]) / in : 0.0;
        return out;
    }

private:
    static constexpr std::size_t kInlineMedia = 8;
    enum class Grazing { no, reflected, absent };
    std::size_t size_;
    std::array<Complex, 4 * kInlineMedia> inline_;
    std::vector<Complex> heap_;
    Complex *n_, *q_, *down_, *up_;
    Complex q_in_, q_out_;
    Grazing grazing_ = Grazing::no;
};

class Tracer {
public:
    Tracer(const SampledCrossSection2d& sampled, const std::vector<CurveOptics>& optics,
           double lambda_nm, std::span<const optics::Polarisation> pols,
           const HybridOptions& options)
        : sampled_(sampled),
          chords_(sampled),
          optics_(optics),
          lambda_nm_(lambda_nm),
          k_(2.0 * kPi / (1e-3 * lambda_nm)),
          pols_(pols.begin(), pols.end()),
          options_(options) {}

    // Buffers one thread reuses from ray to ray (a ray's paths are a few dozen legs and hits;
    // growing fresh vectors for each was a tenth of the tracing's time).
    struct Scratch {
        std::vector<Ray> stack;
        std::vector<Hit> hits;
    };

    // Follows every path of one launched ray; its hits on ambient faces, in the order met, go
    // into `hits` (sized to fit). A path ends when the power of every polarisation traced is
    // below the floor.
    void trace(const Ray& launch, std::vector<Hit>& hits, Tally& tally, Scratch& scratch) const {
        scratch.hits.clear();
        follow(launch, scratch.stack, scratch.hits, tally);
        hits.assign(scratch.hits.begin(), scratch.hits.end());
    }

private:
    void follow(const Ray& launch, std::vector<Ray>& stack, std::vector<Hit>& hits,
                Tally& tally) const {
        stack.assign(1, launch);
        const double floor = options_.min_power * launch.power[0];
        while (!stack.empty()) {
            Ray ray = stack.back();
            stack.pop_back();
            if (ray.events >= options_.max_events || strongest(ray.power) < floor) {
                add(tally.truncated, ray.power);
                continue;
            }
            const std::optional<ChordIndex2d::Hit> hit = chords_.first_hit(ray.o, ray.d, ray.skip);
            if (!hit) {
                if (ray.inside >= 0) add(tally.truncated, ray.power);  // an open body
                continue;
            }
            advance(ray, hit->t, tally);
            const std::size_t j = hit->chord;
            const SurfaceSample2d& s = sampled_.samples[j];
            const Vec p = ray.o + hit->t * ray.d;
            const bool from_plus = ray.d.dot(s.normal) < 0.0;
            const CurveOptics& c = optics_[static_cast<std::size_t>(s.curve)];
            Ray next = ray;
            next.o = p;
            next.skip = j;
            next.events = ray.events + 1;
            next.primary = false;
            if (ray.inside < 0 && (from_plus || c.sheet)) {
                from_ambient(ray, next, s, from_plus, c, stack, hits, tally);
            } else if (ray.inside >= 0 && !from_plus &&
                       optics_[static_cast<std::size_t>(ray.inside)].substrate == c.substrate) {
                from_inside(ray, next, s, c, stack, hits, tally);
            } else {
                add(tally.truncated, ray.power);  // a nested body or an open one (header)
            }
        }
    }

    static double strongest(const Powers& p) { return std::max(p[0], p[1]); }
    static void add(Powers& to, const Powers& p) {
        for (std::size_t i = 0; i < kPols; ++i) to[i] += p[i];
    }

    // The stack's response for each polarisation traced (q does not depend on it).
    std::array<StackResponse2d, kPols> responses(Complex n_in,
                                                 std::span<const optics::StackLayer> layers,
                                                 Complex n_out, double beta) const {
        const StackMedia media(n_in, layers, n_out, beta, lambda_nm_);
        std::array<StackResponse2d, kPols> m{};
        for (std::size_t i = 0; i < pols_.size(); ++i) m[i] = media.respond(pols_[i]);
        return m;
    }

    void advance(Ray& ray, double length, Tally& tally) const {
        if (ray.inside < 0) {
            const Complex phase = std::polar(1.0, k_ * length);
            for (Complex& u : ray.u) u *= phase;
            return;
        }
        const Complex phase = std::exp(Complex(0.0, k_) * ray.nu * length);
        const double kept = std::exp(-2.0 * k_ * ray.nu.imag() * length);
        for (std::size_t i = 0; i < kPols; ++i) {
            ray.u[i] *= phase;
            tally.absorbed[i] += ray.power[i] * (1.0 - kept);
            ray.power[i] *= kept;
        }
    }

    // A ray in the ambient meets a face: a sheet from either side or a body from outside.
    void from_ambient(const Ray& ray, const Ray& next, const SurfaceSample2d& s, bool from_plus,
                      const CurveOptics& c, std::vector<Ray>& stack, std::vector<Hit>& hits,
                      Tally& tally) const {
        const Vec n_f = from_plus ? s.normal : Vec(-s.normal);
        const double cos_i = std::min(1.0, -ray.d.dot(n_f));
        const double beta = ray.d.dot(s.tangent);
        const Complex n_beyond = c.sheet ? Complex(1.0) : c.substrate;
        const std::array<StackResponse2d, kPols> m =
            responses(1.0, from_plus ? c.down : c.up, n_beyond, beta);
        const Complex ik(0.0, k_);
        // The films are not drawn: move r and t to the curve (header, "Interfaces").
        const Complex r_shift =
            from_plus ? Complex(1.0) : std::exp(-2.0 * ik * m[0].q_in * c.films_um);
        const Complex shift = std::exp(-ik * (from_plus ? m[0].q_out : m[0].q_in) * c.films_um);
        const double gain = from_plus ? std::norm(shift) : 1.0;
        const int side = from_plus ? 0 : 1;
        const auto curve = static_cast<std::size_t>(s.curve);
        Hit hit{extend_code(ray.code, curve, side, 2),
                next.o,
                n_f,
                s.tangent,
                cos_i,
                ray.width,
                {},
                {},
                beta};
        Ray reflected = next;
        reflected.d = ray.d + 2.0 * cos_i * n_f;
        reflected.code = extend_code(ray.code, curve, side, 0);
        Ray through = next;
        through.code = extend_code(ray.code, curve, side, 1);
        for (std::size_t i = 0; i < pols_.size(); ++i) {
            const Complex r = m[i].r * r_shift, t = m[i].t * shift;
            tally.absorbed[i] +=
                ray.power[i] * std::max(0.0, 1.0 - m[i].reflectance - m[i].transmittance);
            const Complex across = c.sheet ? t : Complex(0.0);
            hit.a[i] = ray.u[i] * (1.0 + r - across);
            hit.b[i] = -ray.u[i] * (1.0 - r - across) * cos_i;
            reflected.u[i] = ray.u[i] * r;
            reflected.power[i] = ray.power[i] * m[i].reflectance;
            through.u[i] = ray.u[i] * t;
            through.power[i] = ray.power[i] * m[i].transmittance * gain;
            // Into a body, the shift's gain undoes the virtual leg's loss in the films.
            if (!c.sheet)
                tally.absorbed[i] -= ray.power[i] * m[i].transmittance * (std::norm(shift) - 1.0);
        }
        if (!ray.primary || !from_plus) hits.push_back(hit);
        stack.push_back(reflected);
        if (!c.sheet) {
            // Into the body: direction from Re q, width × cos θ_t / cos θ_i, ν for its legs.
            const double re_q = m[0].q_out.real();
            through.kappa = std::hypot(beta, re_q);
            through.d = (beta * s.tangent - re_q * s.normal) / through.kappa;
            through.nu = (m[0].q_out * re_q + beta * beta) / through.kappa;
            through.width = ray.width * (re_q / through.kappa) / cos_i;
            through.inside = s.curve;
        }
        if (strongest(through.power) > 0.0) stack.push_back(through);
    }

    // A ray inside a body meets the body's boundary: internal reflection and the exit wave.
    void from_inside(const Ray& ray, const Ray& next, const SurfaceSample2d& s,
                     const CurveOptics& c, std::vector<Ray>& stack, std::vector<Hit>& hits,
                     Tally& tally) const {
        const double cos_in = std::min(1.0, ray.d.dot(s.normal));
        const double beta = ray.kappa * ray.d.dot(s.tangent);
        const std::array<StackResponse2d, kPols> m = responses(c.substrate, c.up, 1.0, beta);
        const Complex ik(0.0, k_);
        const Complex r_shift = std::exp(-2.0 * ik * m[0].q_in * c.films_um);
        const Complex shift = std::exp(-ik * m[0].q_in * c.films_um);
        // The ray reached the curve through a virtual leg of the films' thickness D inside the
        // body (header, "Interfaces"): its power at the real interface is `gain` times more,
        // and the reflected ray will lose that again on its way back; the book undoes both.
        const double gain = std::norm(shift);
        const double re_q = m[0].q_in.real();
        const double kappa = std::hypot(beta, re_q);
        const bool escapes = std::abs(beta) < 1.0;  // else total internal reflection
        const double cos_out = escapes ? std::sqrt(1.0 - beta * beta) : 0.0;
        const auto curve = static_cast<std::size_t>(s.curve);
        Ray reflected = next;
        reflected.d = ray.d - 2.0 * cos_in * s.normal;
        reflected.code = extend_code(ray.code, curve, 1, 0);
        reflected.kappa = kappa;
        reflected.nu = (m[0].q_in * re_q + beta * beta) / kappa;
        Ray out = next;
        out.d = beta * s.tangent + cos_out * s.normal;
        out.width = ray.width * cos_out / (re_q / kappa);
        out.inside = -1;
        out.nu = 1.0;
        out.kappa = 1.0;
        out.code = extend_code(ray.code, curve, 1, 1);
        Hit hit{extend_code(ray.code, curve, 1, 2),
                next.o,
                s.normal,
                s.tangent,
                cos_in,
                ray.width,
                {},
                {},
                beta};
        for (std::size_t i = 0; i < pols_.size(); ++i) {
            const Complex r = m[i].r * r_shift, t = m[i].t * shift;
            const double real = ray.power[i] * gain;
            tally.absorbed[i] += real * std::max(0.0, 1.0 - m[i].reflectance - m[i].transmittance) -
                                 ray.power[i] * (gain - 1.0) -
                                 real * m[i].reflectance * (gain - 1.0);
            reflected.u[i] = ray.u[i] * r;
            reflected.power[i] = real * m[i].reflectance * gain;
            hit.a[i] = ray.u[i] * t;
            hit.b[i] = ray.u[i] * t * cos_out;
            out.u[i] = ray.u[i] * t;
            out.power[i] = escapes ? real * m[i].transmittance : 0.0;
        }
        stack.push_back(reflected);
        if (!escapes) return;
        hits.push_back(hit);
        if (strongest(out.power) > 0.0) stack.push_back(out);
    }

    const SampledCrossSection2d& sampled_;
    ChordIndex2d chords_;
    const std::vector<CurveOptics>& optics_;
    double lambda_nm_, k_;
    std::vector<optics::Polarisation> pols_;
    HybridOptions options_;
};

void validate(const HybridOptions& o, double step) {
    if (!std::isfinite(o.launch_step_um) || o.launch_step_um < 0.0 ||
        o.launch_step_um > step * (1.0 + 1e-12))
        refuse(fmt::format("launch_step_um = {:.4g} must be 0 or in (0, {:.4g}] (the surface step)",
                           o.launch_step_um, step));
    if (o.max_events < 1 || o.max_events > 64)
        refuse(fmt::format("max_events = {} must be in [1, 64]", o.max_events));
    if (!(o.min_power >= 0.0 && o.min_power < 1.0))
        refuse(fmt::format("min_power = {:.4g} must be in [0, 1)", o.min_power));
    if (o.circle_angles != 0 && o.circle_angles < 360)
        refuse(fmt::format("circle_angles = {} must be 0 or >= 360", o.circle_angles));
}

// Two curves closer than a step where one faces the other cannot be told apart by the surface
// sampling (an inner interface, a film drawn as two curves): refused (header).
void refuse_close_curves(const SampledCrossSection2d& sampled, double step) {
    // Samples binned in cells of one step: a pair closer than a step lies in neighbouring cells.
    std::unordered_map<std::uint64_t, std::vector<std::size_t>> cells;
    const auto cell_of = [step](const Vec& p) {
        return std::pair{static_cast<std::int64_t>(std::floor(p.x() / step)),
                         static_cast<std::int64_t>(std::floor(p.y() / step))};
    };
    const auto key = [](std::int64_t ix, std::int64_t iz) {
        return (static_cast<std::uint64_t>(ix) << 32) ^ static_cast<std::uint64_t>(iz & 0xffffffff);
    };
    for (std::size_t m = 0; m < sampled.samples.size(); ++m) {
        const auto [ix, iz] = cell_of(sampled.samples[m].point);
        cells[key(ix, iz)].push_back(m);
    }
    for (const SurfaceSample2d& sa : sampled.samples) {
        const auto [ix, iz] = cell_of(sa.point);
        for (std::int64_t dx = -1; dx <= 1; ++dx)
            for (std::int64_t dz = -1; dz <= 1; ++dz) {
                const auto it = cells.find(key(ix + dx, iz + dz));
                if (it == cells.end()) continue;
                for (const std::size_t b : it->second) {
                    const SurfaceSample2d& sb = sampled.samples[b];
                    if (sb.curve == sa.curve) continue;
                    const Vec gap = sb.point - sa.point;
                    const double distance = gap.norm();
                    if (distance < step && gap.dot(sa.normal) > 0.7 * distance)
                        refuse(fmt::format(
                            "curve {} faces curve {} {:.4g} µm away at ({:.4g}, {:.4g}) µm, "
                            "closer than the sampling step {:.4g} µm: inner interfaces must be "
                            "at least a step apart",
                            sa.curve, sb.curve, distance, sa.point.x(), sa.point.y(), step));
                }
            }
    }
}

std::vector<CurveOptics> curve_optics(const CrossSection2d& section, double lambda_nm) {
    std::vector<CurveOptics> out;
    for (const Curve2d& curve : section.curves) {
        CurveOptics c;
        for (const FilmLayer2d& film : curve.stack.films) {
            c.down.push_back({film.material->index(lambda_nm), film.thickness_um});
            c.films_um += film.thickness_um;
        }
        c.up.assign(c.down.rbegin(), c.down.rend());
        c.substrate = curve.stack.substrate->index(lambda_nm);
        c.sheet = c.substrate == Complex(1.0, 0.0);
        out.push_back(std::move(c));
    }
    return out;
}

// The hits of every launched ray, each ray's in its own vector as its thread wrote them (not
// copied into one: at tens of MB a wavelength, the copy was a third of the tracing's time and
// serial). Hit j of ray l is the (offset[l] + j)-th in launch order.
struct BeamHits {
    std::vector<std::vector<Hit>> of_ray;
    std::vector<std::size_t> offset;  // hits of the rays before each; back(): all of them

    std::size_t size() const { return offset.back(); }
    // Calls f(global index, hit) for every hit of ray l.
    template <class F>
    void for_ray(std::size_t l, F&& f) const {
        for (std::size_t j = 0; j < of_ray[l].size(); ++j) f(offset[l] + j, of_ray[l][j]);
    }
};

// An element's footprint on its face: half the distance between the hits of its neighbours on
// the same path, one-sided at a path's edge, the planar width where it has none (header).
std::vector<double> footprints(const BeamHits& hits) {
    struct Key {
        std::uint64_t code;
        // The ray (trace_beam refuses 2^32 rays or more) and the hit among its own.
        std::uint32_t launch, index;
    };
    std::vector<Key> keys(hits.size());
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t ls = 0; ls < static_cast<std::ptrdiff_t>(hits.of_ray.size()); ++ls) {
        const auto l = static_cast<std::size_t>(ls);
        for (std::size_t j = 0; j < hits.of_ray[l].size(); ++j)
            keys[hits.offset[l] + j] = {hits.of_ray[l][j].code, static_cast<std::uint32_t>(l),
                                        static_cast<std::uint32_t>(j)};
    }
    // No two keys are equal (the hits of one ray end different paths, whose codes differ), so
    // the order is total and the parallel sort's result does not depend on the thread count.
    __gnu_parallel::sort(keys.begin(), keys.end(), [](const Key& x, const Key& y) {
        return x.code != y.code ? x.code < y.code : x.launch < y.launch;
    });
    const auto hit = [&hits](const Key& key) -> const Hit& {
        return hits.of_ray[key.launch][key.index];
    };
    std::vector<double> out(hits.size());
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t ms = 0; ms < static_cast<std::ptrdiff_t>(keys.size()); ++ms) {
        const auto m = static_cast<std::size_t>(ms);
        const Key& key = keys[m];
        const Hit& h = hit(key);
        const Hit* prev = nullptr;
        const Hit* next = nullptr;
        if (m > 0 && keys[m - 1].code == key.code && keys[m - 1].launch + 1 == key.launch)
            prev = &hit(keys[m - 1]);
        if (m + 1 < keys.size() && keys[m + 1].code == key.code &&
            keys[m + 1].launch == key.launch + 1)
            next = &hit(keys[m + 1]);
        double& fp = out[hits.offset[key.launch] + key.index];
        if (prev && next) {
            fp = 0.5 * (next->p - prev->p).norm();
        } else if (prev || next) {
            fp = ((prev ? prev : next)->p - h.p).norm();
        } else {
            fp = h.width / std::max(h.cos_in, 1e-6);
        }
    }
    return out;
}

// The radiating elements, as structure of arrays: the direct term's lit samples and the traced
// hits, each u (a ω_s·n + b) e^{−ik ω_s·p} times the sinc of its footprint, with a and b per
// polarisation (footprint and amplitude included). Elements with k·footprint <= kShortSinc come
// first (`short_count`): their sinc is a polynomial; a longer footprint (a ray that meets its face
// obliquely) takes a sin/cos more.
constexpr double kShortSinc = 3.0;
struct Elements {
    // The arrays in one allocation, not zeroed: radiating_elements writes every element once,
    // in parallel, so the pages (tens of MB a wavelength) are first touched by both threads
    // rather than cleared by one.
    static constexpr std::size_t kArrays = 8 + 4 * kPols;
    std::unique_ptr<double[]> store;
    double *px, *pz, *nx, *nz, *tx, *tz, *fp, *g;
    std::array<double*, kPols> ar, ai, br, bi;
    std::size_t count = 0, short_count = 0;

    explicit Elements(std::size_t n)
        : store(std::make_unique_for_overwrite<double[]>(kArrays * n)), count(n) {
        double* next = store.get();
        const auto take = [&next, n] { return std::exchange(next, next + n); };
        for (double** array : {&px, &pz, &nx, &nz, &tx, &tz, &fp, &g}) *array = take();
        for (std::size_t i = 0; i < kPols; ++i) {
            ar[i] = take();
            ai[i] = take();
            br[i] = take();
            bi[i] = take();
        }
    }
    void set(std::size_t m, const Vec& p, const Vec& n, const Vec& t, double footprint,
             double g_over_k, const Amplitudes& a, const Amplitudes& b) {
        px[m] = p.x();
        pz[m] = p.y();
        nx[m] = n.x();
        nz[m] = n.y();
        tx[m] = t.x();
        tz[m] = t.y();
        fp[m] = footprint;
        g[m] = g_over_k;
        for (std::size_t i = 0; i < kPols; ++i) {
            ar[i][m] = a[i].real();
            ai[i][m] = a[i].imag();
            br[i][m] = b[i].real();
            bi[i][m] = b[i].imag();
        }
    }
    std::size_t size() const { return count; }
};

// The elements of the direct term and of the hits, short ones first. The direct term
// (physical_optics_2d.cpp's kernel, one per polarisation, on the same lit samples; ds <= λ/10 is
// short) has the phase e^{−ik (ω_i + ω_s)·p}: the incident wave's e^{−ik ω_i·p} goes into a and
// b, and its sinc of (ω_i + ω_s)·t is the element's with g = −ω_i·t. A hit's element is its
// footprint on the face, the amplitude scaled by GO's intensity law √(planar width / actual
// width). Filled in parallel, each element at a place fixed beforehand.
Elements radiating_elements(const std::vector<FarFieldKernel2d>& kernels, const BeamHits& hits,
                            double k) {
    const FarFieldKernel2d& first = kernels.front();
    const std::size_t direct = first.px.size();
    const std::vector<double> fp = footprints(hits);
    // Each hit's place: short ones after the direct term, long ones after those; none for a
    // footprint the rays left empty.
    constexpr std::size_t kNone = static_cast<std::size_t>(-1);
    std::vector<std::size_t> place(hits.size(), kNone);
    std::size_t shorts = 0, longs = 0;
    for (std::size_t l = 0; l < hits.of_ray.size(); ++l)
        hits.for_ray(l, [&](std::size_t m, const Hit& h) {
            if (fp[m] * h.cos_in > 0.0) (k * fp[m] <= kShortSinc ? shorts : longs) += 1;
        });
    std::size_t next_short = direct, next_long = direct + shorts;
    for (std::size_t l = 0; l < hits.of_ray.size(); ++l)
        hits.for_ray(l, [&](std::size_t m, const Hit& h) {
            if (fp[m] * h.cos_in > 0.0)
                place[m] = k * fp[m] <= kShortSinc ? next_short++ : next_long++;
        });
    Elements e(direct + shorts + longs);
    e.short_count = direct + shorts;
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t ms = 0; ms < static_cast<std::ptrdiff_t>(direct); ++ms) {
        const auto m = static_cast<std::size_t>(ms);
        const Vec p(first.px[m], first.pz[m]), t(first.tx[m], first.tz[m]);
        const Complex incident = std::polar(1.0, -first.k * first.wi.dot(p));
        Amplitudes a{}, b{};
        for (std::size_t i = 0; i < kernels.size(); ++i) {
            a[i] = kernels[i].a[m] * incident;
            b[i] = kernels[i].b[m] * incident;
        }
        e.set(m, p, Vec(first.nx[m], first.nz[m]), t, first.ds[m], -first.wi.dot(t), a, b);
    }
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t ls = 0; ls < static_cast<std::ptrdiff_t>(hits.of_ray.size()); ++ls)
        hits.for_ray(static_cast<std::size_t>(ls), [&](std::size_t m, const Hit& h) {
            if (place[m] == kNone) return;
            const double scale = std::sqrt(h.width / (fp[m] * h.cos_in)) * fp[m];
            Amplitudes a{}, b{};
            for (std::size_t i = 0; i < kPols; ++i) {
                a[i] = h.a[i] * scale;
                b[i] = h.b[i] * scale;
            }
            e.set(place[m], h.p, h.n_f, h.t_f, fp[m], h.g, a, b);
        });
    return e;
}

// sin(x)/x by its Taylor series to x²⁶ for |x| <= kShortSinc: the first term left out is below
// 3e-18 there.
inline double sinc_polynomial(double x) {
    // 1/(2n+1)! with alternating signs, n = 13 … 1, for Horner's scheme in z = x².
    constexpr double kTerms[] = {1.0 / 1.0888869450418352e28,
                                 -1.0 / 1.5511210043330986e25,
                                 1.0 / 2.585201673888498e22,
                                 -1.0 / 5.109094217170944e19,
                                 1.0 / 1.21645100408832e17,
                                 -1.0 / 355687428096000.0,
                                 1.0 / 1307674368000.0,
                                 -1.0 / 6227020800.0,
                                 1.0 / 39916800.0,
                                 -1.0 / 362880.0,
                                 1.0 / 5040.0,
                                 -1.0 / 120.0,
                                 1.0 / 6.0};
    const double z = x * x;
    double sum = 0.0;
    for (const double term : kTerms) sum = sum * z + term;
    // The loop gives S = 1/3! − z/5! + z²/7! − …; sin(x)/x = 1 − z S.
    return 1.0 - z * sum;
}

// Always inlined: it must be compiled inside each of radiate()'s clones (below).
template <bool kShort>
[[gnu::always_inline]] inline void sum_range(const Elements& e, std::size_t from, std::size_t to,
                                             double k, double wx, double wz,
                                             double (&acc)[2 * kPols]) {
    const double *px = e.px, *pz = e.pz, *nx = e.nx, *nz = e.nz;
    const double *tx = e.tx, *tz = e.tz, *fp = e.fp, *g = e.g;
    const double *ar0 = e.ar[0], *ai0 = e.ai[0], *br0 = e.br[0], *bi0 = e.bi[0];
    const double *ar1 = e.ar[1], *ai1 = e.ai[1], *br1 = e.br[1], *bi1 = e.bi[1];
    double re0 = 0.0, im0 = 0.0, re1 = 0.0, im1 = 0.0;
#pragma omp simd reduction(+ : re0, im0, re1, im1)
    for (std::size_t m = from; m < to; ++m) {
        const double sn = nx[m] * wx + nz[m] * wz;
        const double x = 0.5 * k * (g[m] - (tx[m] * wx + tz[m] * wz)) * fp[m];
        double w;
        if constexpr (kShort) {
            w = sinc_polynomial(x);
        } else {
            double sin_x, cos_x;
            sin_cos(x, sin_x, cos_x);
            // Both computed, then chosen: a branch would keep the loop out of SIMD lanes.
            const bool tiny = std::abs(x) < 1e-4;
            const double quotient = sin_x / (tiny ? 1.0 : x);
            w = tiny ? 1.0 - x * x / 6.0 : quotient;
        }
        double s, c;
        sin_cos(-k * (wx * px[m] + wz * pz[m]), s, c);
        const double u0r = (ar0[m] * sn + br0[m]) * w, u0i = (ai0[m] * sn + bi0[m]) * w;
        const double u1r = (ar1[m] * sn + br1[m]) * w, u1i = (ai1[m] * sn + bi1[m]) * w;
        re0 += u0r * c - u0i * s;
        im0 += u0r * s + u0i * c;
        re1 += u1r * c - u1i * s;
        im1 += u1r * s + u1i * c;
    }
    acc[0] += re0;
    acc[1] += im0;
    acc[2] += re1;
    acc[3] += im1;
}

// U(θ_s) of every element for both polarisation slots at `count` <= kAngleBlock directions. The
// elements are swept in chunks that stay in the core's cache while every direction of the block
// is summed over them (one sweep per direction would read all elements from memory each time).
// Each direction's sum runs over the chunks in order in one thread: the same for any thread
// count. On x86-64 with GCC the loop is compiled twice, for AVX2 + FMA and for the baseline,
// and the CPU's is chosen at load time: the two round differently in the last bits, so results
// are bit-identical across threads and ranks on one kind of machine, not across kinds.
constexpr std::size_t kAngleBlock = 16;
constexpr std::size_t kChunk = 1024;
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
__attribute__((target_clones("arch=x86-64-v3", "default")))
#endif
void radiate(const Elements& e, double k, const double* theta_s, std::size_t count,
             std::array<Complex, kPols>* u) {
    double wx[kAngleBlock], wz[kAngleBlock], acc[kAngleBlock][2 * kPols] = {};
    for (std::size_t a = 0; a < count; ++a) {
        wx[a] = std::sin(theta_s[a]);
        wz[a] = std::cos(theta_s[a]);
    }
    for (std::size_t from = 0; from < e.size(); from += kChunk) {
        const std::size_t to = std::min(e.size(), from + kChunk);
        const std::size_t split = std::clamp(e.short_count, from, to);
        for (std::size_t a = 0; a < count; ++a) {
            sum_range<true>(e, from, split, k, wx[a], wz[a], acc[a]);
            sum_range<false>(e, split, to, k, wx[a], wz[a], acc[a]);
        }
    }
    for (std::size_t a = 0; a < count; ++a)
        u[a] = {Complex(acc[a][0], acc[a][1]), Complex(acc[a][2], acc[a][3])};
}

// The direct term's kernel: physical_optics_2d.cpp's, with a sheet's transmitted wave leaving
// through its other face.
FarFieldKernel2d direct_kernel(const CrossSection2d& section, const SampledCrossSection2d& sampled,
                               const Incidence2d& incidence,
                               const std::vector<CurveOptics>& optics) {
    FarFieldKernel2d kernel = prepare_far_field(section, sampled, incidence, FarFieldPart::total);
    const optics::Polarisation pol = incidence.polarisation == Polarisation2d::te
                                         ? optics::Polarisation::s
                                         : optics::Polarisation::p;
    const double k = kernel.k;
    for (std::size_t m = 0; m < kernel.px.size(); ++m) {
        const CurveOptics& c = optics[static_cast<std::size_t>(kernel.curve[m])];
        if (!c.sheet) continue;
        const double ci =
            std::min(1.0, kernel.nx[m] * kernel.wi.x() + kernel.nz[m] * kernel.wi.y());
        const double beta = std::sqrt(std::max(0.0, 1.0 - ci * ci));
        const StackResponse2d s = stack_response(1.0, c.down, 1.0, beta, incidence.lambda_nm, pol);
        const Complex t = s.t * std::exp(Complex(0.0, -k) * s.q_out * c.films_um);
        kernel.a[m] = (1.0 + s.r - t) * kernel.ds[m];
        kernel.b[m] = -(1.0 - s.r - t) * ci * kernel.ds[m];
    }
    return kernel;
}

// The incident beam cut into rays across the scene's shadow, a launch step apart, each traced
// from beyond the scene; the hits of all rays in launch order (the same for any thread count).
struct Beam {
    BeamHits hits;
    Tally tally;
    std::size_t rays = 0;
    double width_um = 0.0;
};

Beam trace_beam(const SampledCrossSection2d& sampled, const std::vector<CurveOptics>& optics,
                const Vec& wi, double k, double lambda_nm,
                std::span<const optics::Polarisation> pols, const HybridOptions& options,
                double step) {
    const Vec across(wi.y(), -wi.x());
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, top = -lo;
    for (std::size_t j = 0; j < sampled.samples.size(); ++j)
        for (const Vec& p : {sampled.chord_a[j], sampled.chord_b[j]}) {
            lo = std::min(lo, p.dot(across));
            hi = std::max(hi, p.dot(across));
            top = std::max(top, p.dot(wi));
        }
    const double launch_step = options.launch_step_um > 0.0 ? options.launch_step_um : step;
    Beam beam;
    const double rays = std::ceil((hi - lo) / launch_step) + 2.0;
    if (rays > static_cast<double>(std::numeric_limits<std::uint32_t>::max()))
        refuse(
            fmt::format("launch_step_um = {:.4g} cuts the {:.4g} µm beam into {:.4g} rays, more "
                        "than 2^32: raise it",
                        launch_step, hi - lo, rays));
    beam.rays = static_cast<std::size_t>(rays);
    const double h = (hi - lo) / static_cast<double>(beam.rays - 2);
    beam.width_um = h * static_cast<double>(beam.rays);
    const Tracer tracer(sampled, optics, lambda_nm, pols, options);
    std::vector<std::vector<Hit>>& hits = beam.hits.of_ray;
    hits.resize(beam.rays);
    std::vector<Tally> tallies(beam.rays);
#pragma omp parallel
    {
        Tracer::Scratch scratch;
#pragma omp for schedule(dynamic, 16)
        for (std::ptrdiff_t ms = 0; ms < static_cast<std::ptrdiff_t>(beam.rays); ++ms) {
            const auto m = static_cast<std::size_t>(ms);
            Ray ray;
            ray.o = (lo + (static_cast<double>(m) - 0.5) * h) * across + (top + 1.0) * wi;
            ray.d = -wi;
            for (std::size_t i = 0; i < pols.size(); ++i) {
                ray.u[i] = std::polar(1.0, -k * wi.dot(ray.o));
                ray.power[i] = h;
            }
            ray.width = h;
            ray.code = 0x2545F4914F6CDD1DULL;
            ray.skip = std::numeric_limits<std::size_t>::max();
            tracer.trace(ray, hits[m], tallies[m], scratch);
        }
    }
    beam.hits.offset.assign(beam.rays + 1, 0);
    for (std::size_t m = 0; m < beam.rays; ++m) {
        beam.hits.offset[m + 1] = beam.hits.offset[m] + hits[m].size();
        for (std::size_t i = 0; i < kPols; ++i) {
            beam.tally.absorbed[i] += tallies[m].absorbed[i];
            beam.tally.truncated[i] += tallies[m].truncated[i];
        }
    }
    return beam;
}

optics::Polarisation stack_polarisation(Polarisation2d pol) {
    return pol == Polarisation2d::te ? optics::Polarisation::s : optics::Polarisation::p;
}

// hybrid_far_field for the polarisations asked (one or both), sharing the rays and the sums.
std::vector<HybridFarField2d> far_fields(const CrossSection2d& section, double lambda_nm,
                                         double theta_i_rad,
                                         std::span<const Polarisation2d> polarisations,
                                         std::span<const double> theta_s_rad,
                                         const HybridOptions& options) {
    const double step = physical_optics_step(lambda_nm, options.step_um);
    validate(options, step);
    for (double th : theta_s_rad)
        if (!std::isfinite(th)) refuse(fmt::format("theta_s = {:.4g} rad must be finite", th));
    const SampledCrossSection2d sampled = sample_cross_section(section, step);
    refuse_close_curves(sampled, step);
    double reach = 0.0;  // the largest |p| of any sample: bounds every phase k ω_s·p of the sum
    for (const SurfaceSample2d& s : sampled.samples) reach = std::max(reach, s.point.norm());
    const double k = 2.0 * kPi / (1e-3 * lambda_nm);
    if (k * reach > kSinCosLimit)
        refuse(
            fmt::format("the scene reaches {:.4g} µm ({:.4g} wavelengths) from the origin: the "
                        "far-field sum's sin/cos holds to {:.4g} wavelengths",
                        reach, k * reach / (2.0 * kPi), kSinCosLimit / (2.0 * kPi)));
    const std::vector<CurveOptics> optics = curve_optics(section, lambda_nm);
    std::vector<FarFieldKernel2d> kernels;
    std::vector<optics::Polarisation> pols;
    for (const Polarisation2d pol : polarisations) {
        kernels.push_back(direct_kernel(section, sampled, {lambda_nm, theta_i_rad, pol}, optics));
        pols.push_back(stack_polarisation(pol));
    }
    const Vec wi = kernels.front().wi;
    const Beam beam = trace_beam(sampled, optics, wi, k, lambda_nm, pols, options, step);
    const Elements elements = radiating_elements(kernels, beam.hits, k);

    const std::size_t n = theta_s_rad.size();
    const int circle = options.circle_angles;
    const std::size_t extra = circle > 0 ? static_cast<std::size_t>(circle) : 0;
    // The angles asked, the circle's (for the scattering width) and the forward direction.
    std::vector<double> theta(theta_s_rad.begin(), theta_s_rad.end());
    for (std::size_t i = 0; i < extra; ++i)
        theta.push_back(-kPi + (static_cast<double>(i) + 0.5) * 2.0 * kPi / circle);
    theta.push_back(theta_i_rad + kPi);
    std::vector<std::array<Complex, kPols>> u(theta.size());
    const std::size_t blocks = (theta.size() + kAngleBlock - 1) / kAngleBlock;
#pragma omp parallel for schedule(dynamic)
    for (std::ptrdiff_t bs = 0; bs < static_cast<std::ptrdiff_t>(blocks); ++bs) {
        const std::size_t from = static_cast<std::size_t>(bs) * kAngleBlock;
        radiate(elements, k, theta.data() + from, std::min(kAngleBlock, theta.size() - from),
                u.data() + from);
    }
    std::vector<HybridFarField2d> out(polarisations.size());
    for (std::size_t p = 0; p < out.size(); ++p) {
        HybridFarField2d& f = out[p];
        f.k = k;
        f.rays = beam.rays;
        f.beam_width_um = beam.width_um;
        f.absorption_width_um = beam.tally.absorbed[p];
        f.truncated_width_um = beam.tally.truncated[p];
        f.elements = elements.size() - kernels.front().px.size();
        for (std::size_t i = 0; i < n; ++i) {
            f.u.push_back(u[i][p]);
            f.sigma_um_per_rad.push_back(k / (8.0 * kPi) * std::norm(u[i][p]));
        }
        f.scattering_width_um = std::numeric_limits<double>::quiet_NaN();
        if (circle > 0) {
            double scattering = 0.0;  // summed in order: the same for any thread count
            for (std::size_t i = n; i < n + extra; ++i) scattering += std::norm(u[i][p]);
            f.scattering_width_um = k / (8.0 * kPi) * scattering * 2.0 * kPi / circle;
        }
        f.extinction_width_um = -u.back()[p].real();
    }
    return out;
}

}  // namespace

CrossSection2d barbule_with_gap(double semi_major_um, double b, double film_um, double gap_um) {
    for (const auto& [name, value] : {std::pair{"semi-major axis", semi_major_um},
                                      std::pair{"b", b}, std::pair{"film", film_um}})
        if (!std::isfinite(value) || value <= 0.0)
            refuse(fmt::format("barbule {} = {:.4g} must be finite and > 0", name, value));
    if (!std::isfinite(gap_um) || gap_um < 0.0)
        refuse(fmt::format("barbule gap = {:.4g} µm must be finite and >= 0", gap_um));
    const double shell = film_um + gap_um;
    if (b * semi_major_um <= shell)
        refuse(
            fmt::format("barbule b·A = {:.4g} µm leaves no melanin core under film + gap = "
                        "{:.4g} µm",
                        b * semi_major_um, shell));
    const geometry::EllipticalArc core(semi_major_um - shell, b * semi_major_um - shell, -kPi, kPi);
    Curve2d sheet, body;
    sheet.point = [core, shell](double phi) {
        return Vec(core.point(phi) + shell * core.normal(phi));
    };
    body.point = [core](double phi) { return core.point(phi); };
    sheet.normal = body.normal = [core](double phi) { return core.normal(phi); };
    sheet.t0 = body.t0 = -kPi;
    sheet.t1 = body.t1 = kPi;
    sheet.stack = {{{optics::keratin(), film_um}}, optics::air()};
    body.stack = {{}, optics::melanin()};
    return {{sheet, body}};
}

CrossSection2d row_cross_section(const Row2d& row) {
    if (row.jitter_position_um != 0.0 || row.jitter_rotation_rad != 0.0)
        refuse("row_cross_section takes a row without jitter");
    if (row.count < 1) refuse(fmt::format("row count {} must be >= 1", row.count));
    const Vec u = row.direction.normalized();
    const double c = std::cos(row.tilt_rad), s = std::sin(row.tilt_rad);
    // R(α) of physical_optics_2d.h: (x, z) ↦ (x cos α + z sin α, −x sin α + z cos α).
    const auto turn = [c, s](const Vec& v) {
        return Vec(v.x() * c + v.y() * s, -v.x() * s + v.y() * c);
    };
    CrossSection2d out;
    for (int m = 0; m < row.count; ++m) {
        const Vec centre = (m - 0.5 * (row.count - 1)) * row.spacing_um * u;
        for (const Curve2d& cell : row.cell.curves) {
            Curve2d curve = cell;
            curve.point = [p = cell.point, turn, centre](double t) {
                return Vec(turn(p(t)) + centre);
            };
            curve.normal = [n = cell.normal, turn](double t) { return Vec(turn(n(t))); };
            out.curves.push_back(std::move(curve));
        }
    }
    return out;
}

StackResponse2d stack_response(std::complex<double> n_in,
                               std::span<const optics::StackLayer> layers,
                               std::complex<double> n_out, double beta, double lambda_nm,
                               optics::Polarisation pol) {
    return StackMedia(n_in, layers, n_out, beta, lambda_nm).respond(pol);
}

HybridFarField2d hybrid_far_field(const CrossSection2d& section, const Incidence2d& incidence,
                                  std::span<const double> theta_s_rad,
                                  const HybridOptions& options) {
    if (incidence.cos_elevation != 1.0)
        refuse(fmt::format("cos_elevation = {:.4g}: only in-plane incidence (1) is supported",
                           incidence.cos_elevation));
    const std::array pol{incidence.polarisation};
    return far_fields(section, incidence.lambda_nm, incidence.theta_i_rad, pol, theta_s_rad,
                      options)
        .front();
}

HybridFarFieldPair hybrid_far_field_pair(const CrossSection2d& section, double lambda_nm,
                                         double theta_i_rad, std::span<const double> theta_s_rad,
                                         const HybridOptions& options) {
    const std::array pols{Polarisation2d::te, Polarisation2d::tm};
    std::vector<HybridFarField2d> both =
        far_fields(section, lambda_nm, theta_i_rad, pols, theta_s_rad, options);
    return {std::move(both[0]), std::move(both[1])};
}

}  // namespace plumage::sim::wave
