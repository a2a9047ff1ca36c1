#include "analysis/metrics/compare.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"
#include "common/relative_l1.h"
#include "sim/optics/colour.h"
#include "sim/scatterer/random.h"

namespace plumage::analysis {
namespace {

double standard_error_at(const std::vector<double>& se, std::size_t i) {
    return se.size() > i ? se[i] : 0.0;
}

// A record's noise: its Monte Carlo standard errors, or none for a cubature (the eval
// estimator), whose error estimate is the rule's own, not noise (header).
const std::vector<double>& noise(const gonio::BrdfRecord& r, const std::vector<double>& se) {
    static const std::vector<double> none;
    return r.estimator_used == gonio::Estimator::eval ? none : se;
}

ErrorMeasures measures(const std::vector<double>& a, const std::vector<double>& b,
                       const std::vector<double>& a_error, const std::vector<double>& b_error,
                       const gonio::BrdfRecord& r) {
    const std::size_t np = r.config.pairs.size(), nl = r.config.wavelengths_nm.size();
    double sq = 0.0, wsq = 0.0, wsum = 0.0, var = 0.0, sigma = 0.0;
    RelativeL1 l1;
    for (std::size_t p = 0; p < np; ++p) {
        const double w = r.config.pairs[p].wi.z() * r.config.pairs[p].wo.z();
        for (std::size_t k = 0; k < nl; ++k) {
            const std::size_t i = p * nl + k;
            const double d = a[i] - b[i];
            sq += d * d;
            l1.add(a[i], b[i]);
            wsq += w * d * d;
            wsum += w;
            const double v = std::pow(standard_error_at(a_error, i), 2) +
                             std::pow(standard_error_at(b_error, i), 2);
            var += v;
            sigma += std::sqrt(v);
        }
    }
    const double n = static_cast<double>(np * nl);
    ErrorMeasures m;
    m.rmse = std::sqrt(sq / n);
    m.relative_l1 = l1.value();
    m.cosine_weighted_rmse = std::sqrt(wsq / wsum);
    m.rmse_noise_floor = std::sqrt(var / n);
    m.relative_l1_noise_floor =
        RelativeL1::of(std::sqrt(2.0 / std::numbers::pi) * sigma, l1.reference());
    return m;
}

// A lobe's block [lobe][pair][wavelength] of a record's per-lobe arrays (empty if absent).
std::vector<double> lobe_block(const std::vector<double>& values, std::size_t lobe,
                               std::size_t cells) {
    if (values.size() < (lobe + 1) * cells) return {};
    return {values.begin() + static_cast<long>(lobe * cells),
            values.begin() + static_cast<long>((lobe + 1) * cells)};
}

}  // namespace

RecordComparison compare_records(const gonio::BrdfRecord& a, const gonio::BrdfRecord& b,
                                 std::size_t worst_count) {
    const auto& ca = a.config;
    const auto& cb = b.config;
    if (ca.pairs.size() != cb.pairs.size() || ca.wavelengths_nm != cb.wavelengths_nm) {
        throw InputError(
            fmt::format("compare: the records differ in direction pairs ({} vs {}) or wavelengths; "
                        "measure both on the same instrument",
                        ca.pairs.size(), cb.pairs.size()));
    }
    for (std::size_t p = 0; p < ca.pairs.size(); ++p) {
        if ((ca.pairs[p].wi - cb.pairs[p].wi).norm() > 1e-12 ||
            (ca.pairs[p].wo - cb.pairs[p].wo).norm() > 1e-12) {
            throw InputError(
                fmt::format("compare: direction pair {} differs between the records", p));
        }
    }
    const std::size_t np = ca.pairs.size(), nl = ca.wavelengths_nm.size();
    RecordComparison c;
    c.total = measures(a.value, b.value, noise(a, a.standard_error), noise(b, b.standard_error), a);
    for (std::size_t la = 0; la < a.lobes.size(); ++la) {
        const auto it = std::find(b.lobes.begin(), b.lobes.end(), a.lobes[la]);
        if (it == b.lobes.end()) continue;
        const std::size_t lb = static_cast<std::size_t>(it - b.lobes.begin());
        c.lobes.emplace_back(
            a.lobes[la],
            measures(lobe_block(a.lobe_values, la, np * nl), lobe_block(b.lobe_values, lb, np * nl),
                     noise(a, lobe_block(a.lobe_standard_error, la, np * nl)),
                     noise(b, lobe_block(b.lobe_standard_error, lb, np * nl)), a));
    }
    c.colour_available = optics::carries_colour(ca.wavelengths_nm);
    if (c.colour_available) {
        const optics::ReflectanceToXyz to_xyz(optics::WavelengthGrid(ca.wavelengths_nm),
                                              optics::Illuminant::d65);
        std::vector<double> fa(nl), fb(nl), noisy(nl);
        double total = 0.0, floor = 0.0;
        constexpr int kNoiseDraws = 16;
        constexpr std::uint64_t kNoiseSeed = 0x636f6d70617265;  // "compare": a fixed stream
        for (std::size_t p = 0; p < np; ++p) {
            for (std::size_t k = 0; k < nl; ++k) {
                fa[k] = std::numbers::pi * a.value[p * nl + k];
                fb[k] = std::numbers::pi * b.value[p * nl + k];
            }
            const optics::Lab lab_b = optics::lab_from_xyz(to_xyz(fb), to_xyz.white());
            const double de =
                optics::ciede2000(lab_b, optics::lab_from_xyz(to_xyz(fa), to_xyz.white()));
            total += de;
            c.max_delta_e00 = std::max(c.max_delta_e00, de);
            for (int draw = 0; draw < kNoiseDraws; ++draw) {
                Rng rng(kNoiseSeed, p * kNoiseDraws + static_cast<std::uint64_t>(draw));
                for (std::size_t k = 0; k < nl; ++k) {
                    const double s =
                        std::hypot(standard_error_at(noise(a, a.standard_error), p * nl + k),
                                   standard_error_at(noise(b, b.standard_error), p * nl + k));
                    // Box–Muller: one normal deviate per wavelength.
                    const double u1 = 1.0 - rng.uniform(), u2 = rng.uniform();
                    noisy[k] = fb[k] + std::numbers::pi * s * std::sqrt(-2.0 * std::log(u1)) *
                                           std::cos(2.0 * std::numbers::pi * u2);
                }
                floor +=
                    optics::ciede2000(lab_b, optics::lab_from_xyz(to_xyz(noisy), to_xyz.white()));
            }
        }
        c.mean_delta_e00 = total / static_cast<double>(np);
        c.delta_e00_noise_floor = floor / static_cast<double>(np * kNoiseDraws);
    }
    std::vector<CellDifference> cells;
    for (std::size_t p = 0; p < np; ++p)
        for (std::size_t k = 0; k < nl; ++k)
            cells.push_back({p, k, a.value[p * nl + k], b.value[p * nl + k],
                             a.standard_error.empty() ? 0.0 : a.standard_error[p * nl + k]});
    const std::size_t keep = std::min(worst_count, cells.size());
    std::partial_sort(cells.begin(), cells.begin() + static_cast<long>(keep), cells.end(),
                      [](const auto& x, const auto& y) {
                          return std::abs(x.test - x.reference) > std::abs(y.test - y.reference);
                      });
    c.worst.assign(cells.begin(), cells.begin() + static_cast<long>(keep));
    return c;
}

std::string comparison_markdown(const RecordComparison& c, const gonio::BrdfRecord& r,
                                const std::string& test_name, const std::string& reference_name) {
    std::string md = fmt::format(
        "| {} against {} | RMSE (1/sr) | its noise floor | relative L1 | its noise floor | "
        "cos-weighted RMSE (1/sr) |\n|---|---|---|---|---|---|\n",
        test_name, reference_name);
    auto row = [](const std::string& name, const ErrorMeasures& m) {
        return fmt::format("| {} | {:.4g} | {:.2g} | {:.4g} | {:.2g} | {:.4g} |\n", name, m.rmse,
                           m.rmse_noise_floor, m.relative_l1, m.relative_l1_noise_floor,
                           m.cosine_weighted_rmse);
    };
    md += row("all lobes", c.total);
    for (const auto& [name, m] : c.lobes) md += row(name, m);
    md +=
        "\nNoise floor: what the number would be if the two were the same BRDF measured with "
        "these standard errors.\n";
    if (c.colour_available) {
        md += fmt::format(
            "\nColour (π·f under D65): mean ΔE00 {:.2f} (noise floor {:.2f}), max ΔE00 {:.2f}.\n",
            c.mean_delta_e00, c.delta_e00_noise_floor, c.max_delta_e00);
    }
    md +=
        "\nWorst cells:\n\n| pair | θ_i, φ_i (deg) | θ_o, φ_o (deg) | λ (nm) | test | reference | "
        "test σ |\n|---|---|---|---|---|---|---|\n";
    for (const auto& w : c.worst) {
        const auto& p = r.config.pairs[w.pair];
        auto deg = [](double v) { return v * 180.0 / std::numbers::pi; };
        md += fmt::format(
            "| {} | {:.1f}, {:.1f} | {:.1f}, {:.1f} | {} | {:.4g} | {:.4g} | {:.2g} |\n", w.pair,
            deg(std::acos(p.wi.z())), deg(std::atan2(p.wi.y(), p.wi.x())), deg(std::acos(p.wo.z())),
            deg(std::atan2(p.wo.y(), p.wo.x())), r.config.wavelengths_nm[w.wavelength], w.test,
            w.reference, w.standard_error);
    }
    return md;
}

double mean_transmitted(const gonio::Scatterogram& s, int lobe) {
    if (lobe < 0 || static_cast<std::size_t>(lobe) >= s.lobes.size()) return 0.0;
    const std::size_t nl = s.config.wavelengths_nm.size();
    double mean = 0.0;
    for (std::size_t k = 0; k < nl; ++k) {
        mean +=
            s.transmitted_lobes[static_cast<std::size_t>(lobe) * nl + k] / static_cast<double>(nl);
    }
    return mean;
}

double reflected_share(const gonio::Scatterogram& s, int lobe) {
    if (lobe < 0 || static_cast<std::size_t>(lobe) >= s.lobes.size()) return 0.0;
    const std::size_t nl = s.config.wavelengths_nm.size();
    double share = 0.0, reflected = 0.0;
    for (std::size_t i = 0; i < s.pixels() * nl; ++i) {
        reflected += s.intensity[i] * s.solid_angle_sr[i / nl];
        share += s.lobe_intensity[static_cast<std::size_t>(lobe) * s.pixels() * nl + i] *
                 s.solid_angle_sr[i / nl];
    }
    return reflected > 0.0 ? share / reflected : 0.0;
}

// Σ|a − b| Ω / Σ b Ω over pixels and wavelengths, for one lobe (or all when lobe < 0).
double image_relative_l1(const gonio::Scatterogram& a, const gonio::Scatterogram& b, int lobe_a,
                         int lobe_b) {
    const std::size_t n = a.pixels() * a.config.wavelengths_nm.size();
    const auto& va = lobe_a < 0 ? a.intensity : a.lobe_intensity;
    const auto& vb = lobe_b < 0 ? b.intensity : b.lobe_intensity;
    const std::size_t oa = lobe_a < 0 ? 0 : static_cast<std::size_t>(lobe_a) * n;
    const std::size_t ob = lobe_b < 0 ? 0 : static_cast<std::size_t>(lobe_b) * n;
    RelativeL1 l1;
    const std::size_t nl = a.config.wavelengths_nm.size();
    for (std::size_t i = 0; i < n; ++i) l1.add(va[oa + i], vb[ob + i], a.solid_angle_sr[i / nl]);
    return l1.value();
}

double image_relative_l1_noise_floor(const gonio::Scatterogram& a, const gonio::Scatterogram& b) {
    const std::size_t nl = a.config.wavelengths_nm.size();
    double noise = 0.0, ref = 0.0;
    for (std::size_t i = 0; i < a.pixels() * nl; ++i) {
        const double omega = a.solid_angle_sr[i / nl];
        noise += std::hypot(a.standard_error[i], b.standard_error[i]) * omega;
        ref += b.intensity[i] * omega;
    }
    return ref > 0.0 ? std::sqrt(2.0 / kPi) * noise / ref : 0.0;
}

int lobe_index(const std::vector<std::string>& lobes, const std::string& name) {
    for (std::size_t i = 0; i < lobes.size(); ++i)
        if (lobes[i] == name) return static_cast<int>(i);
    return -1;
}

}  // namespace plumage::analysis
