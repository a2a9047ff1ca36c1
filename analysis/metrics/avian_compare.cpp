#include "analysis/metrics/avian_compare.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "analysis/metrics/colour_quadrature.h"
#include "common/error.h"

namespace plumage::analysis {

namespace {

double quantile_of(std::vector<double> v, double q) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    const double at = q * static_cast<double>(v.size() - 1);
    const std::size_t i = static_cast<std::size_t>(at);
    const double f = at - static_cast<double>(i);
    return i + 1 < v.size() ? (1.0 - f) * v[i] + f * v[i + 1] : v[i];
}

double error_at(const std::vector<double>& se, std::size_t i) {
    return se.size() > i ? se[i] : 0.0;
}

double rms_of(const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x * x;
    return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

// Chromatic and achromatic contrasts of the pairs carrying signal, each beside its noise floor.
struct PairContrasts {
    std::vector<double> delta_s, delta_s_floor, delta_l, delta_l_floor;
};

// Adds one pair (test a, reference b, combined standard errors σ); false if a catch of either
// is not positive (then nothing is added).
bool add_pair(const ConeCatches& catches, const AvianVisualSystem& system,
              const std::vector<double>& a, const std::vector<double>& b,
              const std::vector<double>& sigma, PairContrasts& out) {
    const ConeVector qa = catches(a), qb = catches(b);
    auto positive = [](const ConeVector& q) {
        return std::all_of(q.begin(), q.end(), [](double v) { return v > 0.0; });
    };
    if (!positive(qa) || !positive(qb)) return false;
    const bool achromatic = catches.has_double_cone();
    const double la = achromatic ? catches.double_cone(a) : 0.0;
    const double lb = achromatic ? catches.double_cone(b) : 0.0;
    if (achromatic && !(la > 0.0 && lb > 0.0)) return false;
    out.delta_s.push_back(rnl_delta_s(qa, qb, system));
    out.delta_s_floor.push_back(rnl_noise_floor(catches.log_catch_covariance(b, sigma), system));
    if (achromatic) {
        out.delta_l.push_back(achromatic_contrast(la, lb, system));
        out.delta_l_floor.push_back(std::sqrt(catches.log_double_cone_variance(b, sigma)) /
                                    system.weber_achromatic);
    }
    return true;
}

}  // namespace

AvianRecordComparison compare_records_avian(const gonio::BrdfRecord& test,
                                            const gonio::BrdfRecord& reference,
                                            const AvianVisualSystem& system,
                                            double signal_fraction) {
    const auto& wl = reference.config.wavelengths_nm;
    const std::size_t nl = wl.size(), np = reference.config.pairs.size();
    if (test.config.wavelengths_nm != wl || test.config.pairs.size() != np) {
        throw InputError("avian comparison: the records' wavelengths or direction pairs differ");
    }
    const ConeCatches catches(system, optics::WavelengthGrid(wl));
    AvianRecordComparison c;
    c.system = system.name;
    c.source = system.source;
    for (std::size_t i = 0; i < kAvianCones; ++i) c.cone_names[i] = system.cones[i].name;
    c.pairs = np;
    c.signal_fraction = signal_fraction;
    c.captured_share = catches.captured_share();
    double brightest = 0.0;
    std::vector<double> mean(np, 0.0);
    for (std::size_t p = 0; p < np; ++p) {
        for (std::size_t k = 0; k < nl; ++k)
            mean[p] += reference.at(p, k) / static_cast<double>(nl);
        brightest = std::max(brightest, mean[p]);
    }
    std::vector<double> a(nl), b(nl), sigma(nl);
    PairContrasts pc;
    for (std::size_t p = 0; p < np; ++p) {
        if (!(mean[p] > 0.0) || mean[p] < signal_fraction * brightest) continue;
        for (std::size_t k = 0; k < nl; ++k) {
            const std::size_t i = p * nl + k;
            a[k] = std::numbers::pi * test.value[i];
            b[k] = std::numbers::pi * reference.value[i];
            sigma[k] = std::numbers::pi * std::hypot(error_at(test.standard_error, i),
                                                     error_at(reference.standard_error, i));
        }
        if (!add_pair(catches, system, a, b, sigma, pc)) continue;
        if (pc.delta_s.back() > c.max) c.max = pc.delta_s.back(), c.max_pair = p;
    }
    const std::vector<double>& distances = pc.delta_s;
    c.pairs_with_signal = distances.size();
    c.median = quantile_of(distances, 0.5);
    c.p95 = quantile_of(distances, 0.95);
    c.median_noise_floor = quantile_of(pc.delta_s_floor, 0.5);
    c.rms = rms_of(distances);
    c.rms_noise_floor = rms_of(pc.delta_s_floor);
    c.has_double_cone = catches.has_double_cone();
    c.rms_delta_l = rms_of(pc.delta_l);
    c.rms_delta_l_noise_floor = rms_of(pc.delta_l_floor);
    c.max_delta_l =
        pc.delta_l.empty() ? 0.0 : *std::max_element(pc.delta_l.begin(), pc.delta_l.end());
    if (!distances.empty()) {
        c.share_above_one_jnd =
            static_cast<double>(std::count_if(distances.begin(), distances.end(),
                                              [](double d) { return d > 1.0; })) /
            static_cast<double>(distances.size());
    }
    return c;
}

std::string avian_comparison_markdown(const std::vector<AvianRecordComparison>& rows,
                                      const gonio::BrdfRecord& reference,
                                      const std::string& test_name,
                                      const std::string& reference_name) {
    const auto& wl = reference.config.wavelengths_nm;
    std::string md = fmt::format(
        "| bird ({} against {}) | pairs with signal | ΔS RMS (JND) | its noise floor (RMS) | "
        "median | median floor | 95th pct | max | pairs > 1 JND | ΔL RMS (JND) | its noise "
        "floor (RMS) | ΔL max |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        test_name, reference_name);
    for (const auto& r : rows) {
        md += fmt::format(
            "| {} | {} of {} | {:.2f} | {:.2f} | {:.2f} | {:.2f} | {:.2f} | {:.2f} | {:.0f} % | "
            "{} |\n",
            r.system, r.pairs_with_signal, r.pairs, r.rms, r.rms_noise_floor, r.median,
            r.median_noise_floor, r.p95, r.max, 100.0 * r.share_above_one_jnd,
            r.has_double_cone ? fmt::format("{:.2f} | {:.2f} | {:.2f}", r.rms_delta_l,
                                            r.rms_delta_l_noise_floor, r.max_delta_l)
                              : std::string("– | – | –"));
    }
    md += fmt::format(
        "\nNoise floor: per pair, the RMS ΔS that the two records' standard errors alone put "
        "between equal spectra (first order in σ/R); a ΔS at its floor is noise, one well above "
        "it the model's. ΔL: the achromatic (double-cone) contrast |ln(q_a / q_b)| / 0.1, the "
        "brightness difference a bird sees, beside its floor alike. Catches are summed on 1 nm "
        "over the grid's span, the spectra interpolated linearly between its points (pavo's "
        "way: docs/avian_vision.md). Pairs with signal: the reference's mean π·f at least "
        "{:g} % of its brightest pair's.\n",
        rows.empty() ? 0.0 : 100.0 * rows.front().signal_fraction);
    // The verdict, like against like (RMS against RMS); 20 % margin for the floor being first
    // order and the RMS over a few hundred pairs (≈ 3 % relative spread) being noisy itself.
    for (const auto& r : rows) {
        if (r.pairs_with_signal == 0) continue;
        md += fmt::format(
            "{}: the chromatic difference is {} (RMS ΔS {:.2f} against {:.2f} from noise).\n",
            r.system,
            r.rms <= 1.2 * r.rms_noise_floor
                ? "within the Monte Carlo noise: to this bird the model's colours match the "
                  "simulation's at this precision"
                : "above the Monte Carlo noise: the model's",
            r.rms, r.rms_noise_floor);
    }
    md += fmt::format(
        "\nWhat the grid ({}–{} nm) holds of each cone's catch of a white under D65 over "
        "the range of the cones' data (300–700 nm for pavo 2.9.0's birds):",
        wl.front(), wl.back());
    for (const auto& r : rows) {
        md += fmt::format(" {}:", r.system);
        for (std::size_t i = 0; i < kAvianCones; ++i) {
            md += fmt::format(" {} {:.0f} %{}", r.cone_names[i], 100.0 * r.captured_share[i],
                              i + 1 < kAvianCones ? "," : ";");
        }
    }
    if (md.back() == ';') md.back() = '.';
    md += "\n\nThe birds:";
    for (const auto& r : rows) md += fmt::format(" {}: {}.", r.system, r.source);
    md += "\n";
    return md;
}

AvianQuadratureError avian_quadrature_error(
    std::size_t spectra, const optics::WavelengthGrid& grid, const AvianVisualSystem& system,
    const std::function<double(std::size_t, double)>& reflectance) {
    const auto range = sensitivity_range_nm(system);
    const double first = std::ceil(std::max(grid.first(), range[0]) - 1e-9);
    const double last = std::floor(std::min(grid.last(), range[1]) + 1e-9);
    if (!(last > first)) {
        throw InputError(
            "avian quadrature error: the grid spans no whole nanometres of the "
            "cones' data");
    }
    const optics::WavelengthGrid fine = optics::WavelengthGrid::uniform(first, last, 1.0);
    const ConeCatches coarse_catches(system, grid), fine_catches(system, fine);
    const bool achromatic = coarse_catches.has_double_cone() && fine_catches.has_double_cone();
    std::vector<double> delta_s(spectra, -1.0), delta_l(spectra, 0.0);
    for_each_spectrum_on_two_grids(
        spectra, grid, fine, reflectance,
        [&](std::size_t i, std::span<const double> coarse, std::span<const double> dense) {
            const ConeVector qc = coarse_catches(coarse), qf = fine_catches(dense);
            bool positive = true;
            for (std::size_t c = 0; c < kAvianCones; ++c) positive &= qc[c] > 0.0 && qf[c] > 0.0;
            const double lc = achromatic ? coarse_catches.double_cone(coarse) : 1.0;
            const double lf = achromatic ? fine_catches.double_cone(dense) : 1.0;
            if (!positive || !(lc > 0.0 && lf > 0.0)) return;
            delta_s[i] = rnl_delta_s(qc, qf, system);
            delta_l[i] = achromatic ? achromatic_contrast(lc, lf, system) : 0.0;
        });
    AvianQuadratureError e;
    std::vector<double> s, l;
    for (std::size_t i = 0; i < spectra; ++i) {
        if (delta_s[i] < 0.0) continue;
        s.push_back(delta_s[i]);
        l.push_back(delta_l[i]);
        e.max_delta_s = std::max(e.max_delta_s, delta_s[i]);
        e.max_delta_l = std::max(e.max_delta_l, delta_l[i]);
    }
    e.spectra = s.size();
    e.rms_delta_s = rms_of(s);
    e.rms_delta_l = rms_of(l);
    return e;
}

std::vector<std::size_t> pavo_export_pairs(const gonio::BrdfRecord& reference,
                                           const std::vector<AvianRecordComparison>& rows) {
    const std::size_t np = reference.config.pairs.size(),
                      nl = reference.config.wavelengths_nm.size();
    std::vector<std::pair<double, std::size_t>> brightness(np);
    for (std::size_t p = 0; p < np; ++p) {
        double mean = 0.0;
        for (std::size_t k = 0; k < nl; ++k) mean += reference.at(p, k);
        brightness[p] = {mean, p};
    }
    std::sort(brightness.begin(), brightness.end());
    std::vector<std::size_t> pairs;
    auto add = [&](std::size_t p) {
        if (std::find(pairs.begin(), pairs.end(), p) == pairs.end()) pairs.push_back(p);
    };
    if (np == 0) return pairs;
    add(brightness.back().second);
    for (const auto& r : rows) {
        if (r.pairs_with_signal > 0) add(r.max_pair);
    }
    add(brightness[np / 2].second);
    return pairs;
}

namespace {

// A symmetric matrix between the spectra as a markdown table: the title in the corner, a header
// of names, 0 on the diagonal, cell(i, j) (" value |") elsewhere.
std::string pairwise_matrix_markdown(
    const std::string& title, const std::vector<std::string>& names,
    const std::function<std::string(std::size_t, std::size_t)>& cell) {
    std::string md = fmt::format("| {} |", title);
    for (const auto& n : names) md += fmt::format(" {} |", n);
    md += "\n|---|";
    for (std::size_t j = 0; j < names.size(); ++j) md += "---|";
    md += "\n";
    for (std::size_t i = 0; i < names.size(); ++i) {
        md += fmt::format("| {} |", names[i]);
        for (std::size_t j = 0; j < names.size(); ++j)
            md += i == j ? std::string(" 0 |") : cell(i, j);
        md += "\n";
    }
    return md;
}

// The achromatic contrast ΔL between every two spectra beside √(floor_i² + floor_j²), then each
// spectrum's adapted catches; "–" where a double-cone catch is not positive.
std::string achromatic_and_catches_markdown(const std::vector<std::string>& names,
                                            const std::vector<std::vector<double>>& spectra,
                                            const std::vector<std::vector<double>>& errors,
                                            const ConeCatches& catches) {
    const AvianVisualSystem& system = catches.system();
    std::vector<double> q_l, floor;
    for (std::size_t i = 0; i < spectra.size(); ++i) {
        q_l.push_back(catches.double_cone(spectra[i]));
        floor.push_back(q_l.back() > 0.0
                            ? std::sqrt(catches.log_double_cone_variance(spectra[i], errors[i])) /
                                  system.weber_achromatic
                            : 0.0);
    }
    std::string md =
        "\n" + pairwise_matrix_markdown(
                   fmt::format("ΔL, {} ({})", system.name, system.double_cone), names,
                   [&](std::size_t i, std::size_t j) {
                       return q_l[i] > 0.0 && q_l[j] > 0.0
                                  ? fmt::format(" {:.1f} ({:.1f}) |",
                                                achromatic_contrast(q_l[i], q_l[j], system),
                                                std::hypot(floor[i], floor[j]))
                                  : std::string(" – |");
                   });
    md += fmt::format("\n| quantum catch, {} (von Kries) |", system.name);
    for (const ConeClass& c : system.cones) md += fmt::format(" {} |", c.name);
    md += " double cone |\n|---|---|---|---|---|---|\n";
    for (std::size_t i = 0; i < names.size(); ++i) {
        md += fmt::format("| {} |", names[i]);
        for (double q : catches(spectra[i])) md += fmt::format(" {:.4g} |", q);
        md += fmt::format(" {:.4g} |\n", q_l[i]);
    }
    return md;
}

}  // namespace

std::string rnl_matrix_markdown(const std::vector<std::string>& names,
                                const std::vector<std::vector<double>>& spectra,
                                const std::vector<std::vector<double>>& errors,
                                const std::vector<double>& wavelengths_nm,
                                const AvianVisualSystem& system) {
    PLUMAGE_CHECK(names.size() == spectra.size(), "one name per spectrum");
    const ConeCatches catches(system, optics::WavelengthGrid(wavelengths_nm));
    PLUMAGE_CHECK(errors.size() == spectra.size(), "one error list per spectrum");
    std::vector<ConeVector> q;
    std::vector<bool> usable;
    std::vector<double> floor;
    for (std::size_t i = 0; i < spectra.size(); ++i) {
        const auto& s = spectra[i];
        q.push_back(catches(s));
        usable.push_back(
            std::all_of(q.back().begin(), q.back().end(), [](double v) { return v > 0.0; }));
        floor.push_back(usable.back()
                            ? rnl_noise_floor(catches.log_catch_covariance(s, errors[i]), system)
                            : 0.0);
    }
    std::string md =
        pairwise_matrix_markdown(system.name, names, [&](std::size_t i, std::size_t j) {
            return usable[i] && usable[j]
                       ? fmt::format(" {:.1f} ({:.1f}) |", rnl_delta_s(q[i], q[j], system),
                                     std::hypot(floor[i], floor[j]))
                       : std::string(" – |");
        });
    if (catches.has_double_cone())
        md += achromatic_and_catches_markdown(names, spectra, errors, catches);
    return md;
}

std::string pavo_csv_text(const std::vector<double>& wavelengths_nm,
                          const std::vector<std::string>& names,
                          const std::vector<std::vector<double>>& columns) {
    PLUMAGE_CHECK(names.size() == columns.size(), "one name per column");
    std::string text = "wl";
    for (const std::string& n : names) text += "," + n;
    text += "\n";
    for (std::size_t k = 0; k < wavelengths_nm.size(); ++k) {
        text += fmt::format("{:g}", wavelengths_nm[k]);
        for (const auto& column : columns) {
            PLUMAGE_CHECK(column.size() == wavelengths_nm.size(), "one value per wavelength");
            text += fmt::format(",{:.6g}", column[k]);
        }
        text += "\n";
    }
    return text;
}

std::string avian_catches_csv(const std::vector<double>& wavelengths_nm,
                              const std::vector<std::string>& names,
                              const std::vector<std::vector<double>>& columns) {
    PLUMAGE_CHECK(names.size() == columns.size(), "one name per column");
    std::string text = "bird,sample,q_short,q_sws,q_mws,q_lws,q_double_cone\n";
    const optics::WavelengthGrid grid(wavelengths_nm);
    for (const char* bird : {"bluetit", "pfowl", "avg.uv", "avg.v"}) {
        std::optional<ConeCatches> catches;
        try {
            catches.emplace(pavo_visual_system(bird), grid);
        } catch (const InputError&) {
            // A cone without light on this grid: its catches are not defined (NA below).
        }
        for (std::size_t j = 0; j < names.size(); ++j) {
            text += fmt::format("{},{}", bird, names[j]);
            if (!catches || !catches->has_double_cone()) {
                text += ",NA,NA,NA,NA,NA\n";
                continue;
            }
            std::vector<double> r(columns[j].size());
            for (std::size_t k = 0; k < r.size(); ++k) r[k] = columns[j][k] / 100.0;
            for (double q : (*catches)(r)) text += fmt::format(",{:.6g}", q);
            text += fmt::format(",{:.6g}\n", catches->double_cone(r));
        }
    }
    return text;
}

std::string pavo_pair_name(const std::string& prefix, const gonio::DirectionPair& pair) {
    auto polar = [](const Vec3d& v) {
        return static_cast<int>(
            std::lround(std::acos(std::clamp(v.z(), -1.0, 1.0)) * 180.0 / std::numbers::pi));
    };
    auto azimuth = [](const Vec3d& v) {
        const double deg = std::atan2(v.y(), v.x()) * 180.0 / std::numbers::pi;
        return static_cast<int>(std::lround(deg < 0.0 ? deg + 360.0 : deg)) % 360;
    };
    return fmt::format("{}_i{}a{}_o{}a{}", prefix, polar(pair.wi), azimuth(pair.wi), polar(pair.wo),
                       azimuth(pair.wo));
}

}  // namespace plumage::analysis
