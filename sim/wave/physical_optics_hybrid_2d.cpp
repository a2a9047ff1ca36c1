// Physical optics through transparent interfaces (physical_optics_hybrid_2d.h has the
// derivation and the list of what is kept).
#include "sim/wave/physical_optics_hybrid_2d.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
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

double sinc(double x) { return std::abs(x) < 1e-4 ? 1.0 - x * x / 6.0 : std::sin(x) / x; }

// One curve's stack at the wavelength, both ways round.
struct CurveOptics {
    std::vector<optics::StackLayer> down, up;  // films as met from the + side, from the − side
    Complex substrate;
    double films_um = 0.0;  // D, the films' total thickness
    bool sheet = false;     // substrate is air: ambient on both sides
};

// A ray: a leg of one path. `inside` is −1 in the ambient, else the curve whose substrate the
// ray travels in (its body); nu and kappa are the body's ν and |Re k|/k (header).
struct Ray {
    Vec o, d;
    Complex u;
    double power, width;
    std::uint64_t code;
    std::size_t skip;
    int events = 0;
    int inside = -1;
    Complex nu = 1.0;
    double kappa = 1.0;
    bool primary = true;
};

// Where a wave meets an ambient face: the term u (a ω_s·n_f + b) before the footprint is known.
struct Hit {
    std::size_t launch;
    std::uint64_t code;
    Vec p, n_f, t_f;
    double cos_in;  // |d·n_f| of the arriving ray, for its width on the face
    double width;   // the ray's planar width
    Complex u, a, b;
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
    double absorbed = 0.0, truncated = 0.0;
};

class Tracer {
public:
    Tracer(const SampledCrossSection2d& sampled, const std::vector<CurveOptics>& optics,
           double lambda_nm, optics::Polarisation pol, const HybridOptions& options)
        : sampled_(sampled),
          chords_(sampled),
          optics_(optics),
          lambda_nm_(lambda_nm),
          k_(2.0 * kPi / (1e-3 * lambda_nm)),
          pol_(pol),
          options_(options) {}

    // Follows every path of one launched ray; appends its hits on ambient faces.
    void trace(const Ray& launch, std::size_t launch_index, std::vector<Hit>& hits,
               Tally& tally) const {
        std::vector<Ray> stack{launch};
        const double floor = options_.min_power * launch.power;
        while (!stack.empty()) {
            Ray ray = stack.back();
            stack.pop_back();
            if (ray.events >= options_.max_events || ray.power < floor) {
                tally.truncated += ray.power;
                continue;
            }
            const std::optional<ChordIndex2d::Hit> hit = chords_.first_hit(ray.o, ray.d, ray.skip);
            if (!hit) {
                if (ray.inside >= 0) tally.truncated += ray.power;  // an open body
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
                from_ambient(ray, next, s, launch_index, from_plus, c, stack, hits, tally);
            } else if (ray.inside >= 0 && !from_plus &&
                       optics_[static_cast<std::size_t>(ray.inside)].substrate == c.substrate) {
                from_inside(ray, next, s, launch_index, c, stack, hits, tally);
            } else {
                tally.truncated += ray.power;  // a nested body or an open one (header)
            }
        }
    }

private:
    void advance(Ray& ray, double length, Tally& tally) const {
        if (ray.inside < 0) {
            ray.u *= std::polar(1.0, k_ * length);
            return;
        }
        ray.u *= std::exp(Complex(0.0, k_) * ray.nu * length);
        const double kept = std::exp(-2.0 * k_ * ray.nu.imag() * length);
        tally.absorbed += ray.power * (1.0 - kept);
        ray.power *= kept;
    }

    // A ray in the ambient meets a face: a sheet from either side or a body from outside.
    void from_ambient(const Ray& ray, const Ray& next, const SurfaceSample2d& s, std::size_t launch,
                      bool from_plus, const CurveOptics& c, std::vector<Ray>& stack,
                      std::vector<Hit>& hits, Tally& tally) const {
        const Vec n_f = from_plus ? s.normal : Vec(-s.normal);
        const double cos_i = std::min(1.0, -ray.d.dot(n_f));
        const double beta = ray.d.dot(s.tangent);
        const Complex n_beyond = c.sheet ? Complex(1.0) : c.substrate;
        const StackResponse2d m =
            stack_response(1.0, from_plus ? c.down : c.up, n_beyond, beta, lambda_nm_, pol_);
        const Complex ik(0.0, k_);
        // The films are not drawn: move r and t to the curve (header, "Interfaces").
        const Complex r = from_plus ? m.r : m.r * std::exp(-2.0 * ik * m.q_in * c.films_um);
        const Complex shift = std::exp(-ik * (from_plus ? m.q_out : m.q_in) * c.films_um);
        const Complex t = m.t * shift;
        const int side = from_plus ? 0 : 1;
        const double transmitted = m.transmittance * std::norm(from_plus ? shift : Complex(1.0));
        tally.absorbed += ray.power * std::max(0.0, 1.0 - m.reflectance - m.transmittance);
        if (!ray.primary || !from_plus) {
            const Complex through = c.sheet ? t : Complex(0.0);
            hits.push_back({launch,
                            extend_code(ray.code, static_cast<std::size_t>(s.curve), side, 2),
                            next.o, n_f, s.tangent, cos_i, ray.width, ray.u, 1.0 + r - through,
                            -(1.0 - r - through) * cos_i, beta});
        }
        Ray reflected = next;
        reflected.d = ray.d + 2.0 * cos_i * n_f;
        reflected.u = ray.u * r;
        reflected.power = ray.power * m.reflectance;
        reflected.code = extend_code(ray.code, static_cast<std::size_t>(s.curve), side, 0);
        stack.push_back(reflected);
        Ray through = next;
        through.u = ray.u * t;
        through.power = ray.power * transmitted;
        through.code = extend_code(ray.code, static_cast<std::size_t>(s.curve), side, 1);
        if (!c.sheet) {
            // Into the body: direction from Re q, width × cos θ_t / cos θ_i, ν for its legs.
            const double re_q = m.q_out.real();
            through.kappa = std::hypot(beta, re_q);
            through.d = (beta * s.tangent - re_q * s.normal) / through.kappa;
            through.nu = (m.q_out * re_q + beta * beta) / through.kappa;
            through.width = ray.width * (re_q / through.kappa) / cos_i;
            through.inside = s.curve;
            // The shift's gain undoes the virtual leg's loss inside the films' thickness.
            tally.absorbed -= ray.power * m.transmittance * (std::norm(shift) - 1.0);
        }
        if (through.power > 0.0) stack.push_back(through);
    }

    // A ray inside a body meets the body's boundary: internal reflection and the exit wave.
    void from_inside(const Ray& ray, const Ray& next, const SurfaceSample2d& s, std::size_t launch,
                     const CurveOptics& c, std::vector<Ray>& stack, std::vector<Hit>& hits,
                     Tally& tally) const {
        const double cos_in = std::min(1.0, ray.d.dot(s.normal));
        const double beta = ray.kappa * ray.d.dot(s.tangent);
        const StackResponse2d m = stack_response(c.substrate, c.up, 1.0, beta, lambda_nm_, pol_);
        const Complex ik(0.0, k_);
        const Complex r = m.r * std::exp(-2.0 * ik * m.q_in * c.films_um);
        const Complex shift = std::exp(-ik * m.q_in * c.films_um);
        const Complex t = m.t * shift;
        // The ray reached the curve through a virtual leg of the films' thickness D inside the
        // body (header, "Interfaces"): its power at the real interface is `gain` times more,
        // and the reflected ray will lose that again on its way back; the book undoes both.
        const double gain = std::norm(shift);
        const double real = ray.power * gain;
        tally.absorbed += real * std::max(0.0, 1.0 - m.reflectance - m.transmittance) -
                          ray.power * (gain - 1.0) - real * m.reflectance * (gain - 1.0);
        const double re_q = m.q_in.real();
        const double kappa = std::hypot(beta, re_q);
        Ray reflected = next;
        reflected.d = ray.d - 2.0 * cos_in * s.normal;
        reflected.u = ray.u * r;
        reflected.power = real * m.reflectance * gain;
        reflected.code = extend_code(ray.code, static_cast<std::size_t>(s.curve), 1, 0);
        reflected.kappa = kappa;
        reflected.nu = (m.q_in * re_q + beta * beta) / kappa;
        stack.push_back(reflected);
        if (!(std::abs(beta) < 1.0)) return;  // total internal reflection
        const double cos_out = std::sqrt(1.0 - beta * beta);
        hits.push_back({launch, extend_code(ray.code, static_cast<std::size_t>(s.curve), 1, 2),
                        next.o, s.normal, s.tangent, cos_in, ray.width, ray.u, t, t * cos_out,
                        beta});
        Ray out = next;
        out.d = beta * s.tangent + cos_out * s.normal;
        out.u = ray.u * t;
        out.power = real * m.transmittance;
        out.width = ray.width * cos_out / (re_q / kappa);
        out.inside = -1;
        out.nu = 1.0;
        out.kappa = 1.0;
        out.code = extend_code(ray.code, static_cast<std::size_t>(s.curve), 1, 1);
        if (out.power > 0.0) stack.push_back(out);
    }

    const SampledCrossSection2d& sampled_;
    ChordIndex2d chords_;
    const std::vector<CurveOptics>& optics_;
    double lambda_nm_, k_;
    optics::Polarisation pol_;
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

// An element's footprint on its face: half the distance between the hits of its neighbours on
// the same path, one-sided at a path's edge, the planar width where it has none (header).
std::vector<double> footprints(const std::vector<Hit>& hits) {
    std::vector<std::size_t> order(hits.size());
    for (std::size_t m = 0; m < order.size(); ++m) order[m] = m;
    std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
        return hits[x].code != hits[y].code ? hits[x].code < hits[y].code
                                            : hits[x].launch < hits[y].launch;
    });
    std::vector<double> out(hits.size());
    for (std::size_t m = 0; m < order.size(); ++m) {
        const Hit& h = hits[order[m]];
        const Hit* prev = nullptr;
        const Hit* next = nullptr;
        if (m > 0 && hits[order[m - 1]].code == h.code && hits[order[m - 1]].launch + 1 == h.launch)
            prev = &hits[order[m - 1]];
        if (m + 1 < order.size() && hits[order[m + 1]].code == h.code &&
            hits[order[m + 1]].launch == h.launch + 1)
            next = &hits[order[m + 1]];
        if (prev && next) {
            out[order[m]] = 0.5 * (next->p - prev->p).norm();
        } else if (prev || next) {
            out[order[m]] = ((prev ? prev : next)->p - h.p).norm();
        } else {
            out[order[m]] = h.width / std::max(h.cos_in, 1e-6);
        }
    }
    return out;
}

// The radiating elements of the traced hits, as structure of arrays.
struct Elements {
    std::vector<double> px, pz, nx, nz, tx, tz, fp, g;
    std::vector<Complex> a, b;
};

Elements elements_of(const std::vector<Hit>& hits) {
    const std::vector<double> fp = footprints(hits);
    Elements e;
    for (std::size_t m = 0; m < hits.size(); ++m) {
        const Hit& h = hits[m];
        const double actual = fp[m] * h.cos_in;
        if (!(actual > 0.0)) continue;
        // GO's intensity law: the amplitude scales as √(planar width / actual width).
        const Complex strength = h.u * std::sqrt(h.width / actual) * fp[m];
        e.px.push_back(h.p.x());
        e.pz.push_back(h.p.y());
        e.nx.push_back(h.n_f.x());
        e.nz.push_back(h.n_f.y());
        e.tx.push_back(h.t_f.x());
        e.tz.push_back(h.t_f.y());
        e.fp.push_back(fp[m]);
        e.g.push_back(h.g);
        e.a.push_back(strength * h.a);
        e.b.push_back(strength * h.b);
    }
    return e;
}

Complex radiate(const Elements& e, double k, double theta_s) {
    const double wx = std::sin(theta_s), wz = std::cos(theta_s);
    Complex sum = 0.0;
    for (std::size_t m = 0; m < e.px.size(); ++m) {
        const double sn = e.nx[m] * wx + e.nz[m] * wz;
        const double st = e.tx[m] * wx + e.tz[m] * wz;
        const double w = sinc(0.5 * k * (e.g[m] - st) * e.fp[m]);  // fp is in a and b
        sum += (e.a[m] * sn + e.b[m]) * w * std::polar(1.0, -k * (wx * e.px[m] + wz * e.pz[m]));
    }
    return sum;
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
    std::vector<Hit> hits;
    Tally tally;
    std::size_t rays = 0;
    double width_um = 0.0;
};

Beam trace_beam(const SampledCrossSection2d& sampled, const std::vector<CurveOptics>& optics,
                const Vec& wi, double k, double lambda_nm, optics::Polarisation pol,
                const HybridOptions& options, double step) {
    const Vec across(wi.y(), -wi.x());
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, top = -lo;
    for (std::size_t j = 0; j < sampled.samples.size(); ++j)
        for (const Vec& p : {sampled.chord_a[j], sampled.chord_b[j]}) {
            lo = std::min(lo, p.dot(across));
            hi = std::max(hi, p.dot(across));
            top = std::max(top, p.dot(wi));
        }
    const double launch_step = options.launch_step_um > 0.0 ? options.launch_step_um : 0.5 * step;
    Beam beam;
    beam.rays = static_cast<std::size_t>(std::ceil((hi - lo) / launch_step)) + 2;
    const double h = (hi - lo) / static_cast<double>(beam.rays - 2);
    beam.width_um = h * static_cast<double>(beam.rays);
    const Tracer tracer(sampled, optics, lambda_nm, pol, options);
    std::vector<std::vector<Hit>> hits(beam.rays);
    std::vector<Tally> tallies(beam.rays);
#pragma omp parallel for schedule(dynamic, 16)
    for (std::ptrdiff_t ms = 0; ms < static_cast<std::ptrdiff_t>(beam.rays); ++ms) {
        const auto m = static_cast<std::size_t>(ms);
        Ray ray;
        ray.o = (lo + (static_cast<double>(m) - 0.5) * h) * across + (top + 1.0) * wi;
        ray.d = -wi;
        ray.u = std::polar(1.0, -k * wi.dot(ray.o));
        ray.power = h;
        ray.width = h;
        ray.code = 0x2545F4914F6CDD1DULL;
        ray.skip = std::numeric_limits<std::size_t>::max();
        tracer.trace(ray, m, hits[m], tallies[m]);
    }
    for (std::size_t m = 0; m < beam.rays; ++m) {
        beam.hits.insert(beam.hits.end(), hits[m].begin(), hits[m].end());
        beam.tally.absorbed += tallies[m].absorbed;
        beam.tally.truncated += tallies[m].truncated;
    }
    return beam;
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
    std::vector<Complex> n{n_in};
    for (const optics::StackLayer& layer : layers) n.push_back(layer.n);
    n.push_back(n_out);
    std::vector<Complex> q(n.size());
    for (std::size_t j = 0; j < n.size(); ++j) q[j] = decaying_sqrt(n[j] * n[j] - beta * beta);
    const double k0 = 2.0 * kPi / (1e-3 * lambda_nm);
    // Byrnes' transfer matrix (multilayer.h): M = Π (1/t_j)[[1, r_j], [r_j, 1]] diag(e^{−iδ},
    // e^{iδ}).
    Complex m00 = 1.0, m01 = 0.0, m10 = 0.0, m11 = 1.0;
    for (std::size_t j = 0; j + 1 < n.size(); ++j) {
        if (j > 0) {
            const Complex delta = k0 * q[j] * layers[j - 1].thickness_um;
            const Complex em = std::exp(Complex(0.0, -1.0) * delta);
            const Complex ep = std::exp(Complex(0.0, 1.0) * delta);
            m00 *= em;
            m10 *= em;
            m01 *= ep;
            m11 *= ep;
        }
        Complex r, t;
        if (pol == optics::Polarisation::s) {
            r = (q[j] - q[j + 1]) / (q[j] + q[j + 1]);
            t = 2.0 * q[j] / (q[j] + q[j + 1]);
        } else {
            const Complex den = n[j + 1] * n[j + 1] * q[j] + n[j] * n[j] * q[j + 1];
            r = (n[j + 1] * n[j + 1] * q[j] - n[j] * n[j] * q[j + 1]) / den;
            t = 2.0 * n[j] * n[j + 1] * q[j] / den;
        }
        const Complex a00 = (m00 + m01 * r) / t, a01 = (m00 * r + m01) / t;
        const Complex a10 = (m10 + m11 * r) / t, a11 = (m10 * r + m11) / t;
        m00 = a00, m01 = a01, m10 = a10, m11 = a11;
    }
    StackResponse2d out;
    out.r = m10 / m00;
    out.t = 1.0 / m00;
    out.q_in = q.front();
    out.q_out = q.back();
    out.reflectance = std::norm(out.r);
    const auto flux = [&](Complex index, Complex qq) {
        return pol == optics::Polarisation::s ? qq.real() : (index * std::conj(qq / index)).real();
    };
    const double in = flux(n.front(), q.front());
    out.transmittance = in > 0.0 ? std::norm(out.t) * flux(n.back(), q.back()) / in : 0.0;
    return out;
}

HybridFarField2d hybrid_far_field(const CrossSection2d& section, const Incidence2d& incidence,
                                  std::span<const double> theta_s_rad,
                                  const HybridOptions& options) {
    if (incidence.cos_elevation != 1.0)
        refuse(fmt::format("cos_elevation = {:.4g}: only in-plane incidence (1) is supported",
                           incidence.cos_elevation));
    const double step = physical_optics_step(incidence.lambda_nm, options.step_um);
    validate(options, step);
    for (double th : theta_s_rad)
        if (!std::isfinite(th)) refuse(fmt::format("theta_s = {:.4g} rad must be finite", th));
    const SampledCrossSection2d sampled = sample_cross_section(section, step);
    refuse_close_curves(sampled, step);
    const std::vector<CurveOptics> optics = curve_optics(section, incidence.lambda_nm);
    const FarFieldKernel2d kernel = direct_kernel(section, sampled, incidence, optics);
    const double k = kernel.k;
    const Vec wi = kernel.wi;
    const optics::Polarisation pol = incidence.polarisation == Polarisation2d::te
                                         ? optics::Polarisation::s
                                         : optics::Polarisation::p;

    const Beam beam = trace_beam(sampled, optics, wi, k, incidence.lambda_nm, pol, options, step);
    HybridFarField2d out;
    out.k = k;
    out.rays = beam.rays;
    out.beam_width_um = beam.width_um;
    out.absorption_width_um = beam.tally.absorbed;
    out.truncated_width_um = beam.tally.truncated;
    const Elements elements = elements_of(beam.hits);
    out.elements = elements.px.size();
    const auto field = [&](double theta) {
        return far_field_at(kernel, theta) + radiate(elements, k, theta);
    };
    out.u.resize(theta_s_rad.size());
    out.sigma_um_per_rad.resize(theta_s_rad.size());
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t is = 0; is < static_cast<std::ptrdiff_t>(theta_s_rad.size()); ++is) {
        const auto i = static_cast<std::size_t>(is);
        out.u[i] = field(theta_s_rad[i]);
        out.sigma_um_per_rad[i] = k / (8.0 * kPi) * std::norm(out.u[i]);
    }
    out.scattering_width_um = std::numeric_limits<double>::quiet_NaN();
    if (const int n = options.circle_angles; n > 0) {
        const double dtheta = 2.0 * kPi / n;
        std::vector<double> power(static_cast<std::size_t>(n));
#pragma omp parallel for schedule(static)
        for (int m = 0; m < n; ++m)
            power[static_cast<std::size_t>(m)] = std::norm(field(-kPi + (m + 0.5) * dtheta));
        double scattering = 0.0;  // summed in order: the same for any thread count
        for (double x : power) scattering += x;
        out.scattering_width_um = k / (8.0 * kPi) * scattering * dtheta;
    }
    out.extinction_width_um = -field(incidence.theta_i_rad + kPi).real();
    return out;
}

}  // namespace plumage::sim::wave
