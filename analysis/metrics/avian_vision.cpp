#include "analysis/metrics/avian_vision.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <utility>

#include <fmt/format.h>

#include "common/error.h"
#include "common/require.h"

namespace plumage::analysis::embedded {
extern const char* const kPavoVisualSystemsCsv;  // analysis/metrics/data/pavo_visual_systems.csv
}  // namespace plumage::analysis::embedded

// Parameters and sources.
//
// Templates (systems without a table):
//  - A1 template α band: A 69.7, a 0.8795 + 0.0459 exp(−(λmax − 300)²/11940), B 28, b 0.922,
//    C −14.9, c 1.104, D 0.674; β band: A_β 0.26, λ_β 189 + 0.315 λmax, b_β −40.5 + 0.195 λmax
//    (Govardovskii, Fyhrquist, Reuter, Kuzmin & Donner 2000, Vis. Neurosci. 17:509).
//  - Oil-droplet transmittance exp(−exp(−2.89 B_mid (λ − λcut) + 1.08)) with λmid = a λcut + b:
//    C 0.99, 24.38; Y 0.90, 70.03; R 0.99, 28.65; P 0.96, 33.57 (Hart & Vorobyev 2005, J. Comp.
//    Physiol. A 191:381, regressions per droplet type). Templates hold for λmax in 300–700 nm
//    (Govardovskii's fits span 357–620 nm).
//
// pavo's birds (tables: analysis/metrics/data/pavo_visual_systems.csv, sources per column in
// analysis/metrics/data/README.md):
//  - relative cone densities: 1 : 2 : 2 : 4 for bluetit, avg.uv and avg.v (pavo's coldist
//    default, Leiothrix lutea, Vorobyev et al. 1998, J. Comp. Physiol. A 183:621); 1 : 1.9 :
//    2.2 : 2.1 for pfowl (Hart 2002, J. Exp. Biol. 205:3925, Fig. 8, from Hart 2001).
//  - Weber fraction 0.1 for the LWS cone and 0.1 for the double cone (coldist's defaults;
//    Vorobyev et al. 1998, Leiothrix lutea, behavioural).
//  - double cones: blue tit's (bt.dc) for the UV-sensitive birds, chicken's (ch.dc) for the
//    violet-sensitive ones (pavo has no peafowl double cone; both are Galliformes).

namespace plumage::analysis {

namespace {

constexpr double kTemplateFirstNm = 300.0;  // the suite's spectral range, for templates
constexpr double kTemplateLastNm = 800.0;
constexpr const char* kPavoDataFile = "analysis/metrics/data/pavo_visual_systems.csv";

void require_lambda_max(double lambda_max_nm) {
    require(std::isfinite(lambda_max_nm) && lambda_max_nm >= 300.0 && lambda_max_nm <= 700.0,
            "visual pigment template", "lambda_max_nm", lambda_max_nm, "a value in [300, 700] nm");
}

// Photon flux of the illuminant, relative: E(λ) λ.
double photon_flux(optics::Illuminant illuminant, double lambda_nm) {
    return optics::illuminant_power(illuminant, lambda_nm) * lambda_nm;
}

}  // namespace

double govardovskii_a1(double lambda_max_nm, double lambda_nm, bool beta_band) {
    require_lambda_max(lambda_max_nm);
    require(std::isfinite(lambda_nm) && lambda_nm > 0.0, "visual pigment template", "lambda_nm",
            lambda_nm, "a finite value > 0");
    const double x = lambda_max_nm / lambda_nm;
    const double d = lambda_max_nm - 300.0;
    const double a = 0.8795 + 0.0459 * std::exp(-d * d / 11940.0);
    const double alpha = 1.0 / (std::exp(69.7 * (a - x)) + std::exp(28.0 * (0.922 - x)) +
                                std::exp(-14.9 * (1.104 - x)) + 0.674);
    if (!beta_band) return alpha;
    const double peak = 189.0 + 0.315 * lambda_max_nm;
    const double width = -40.5 + 0.195 * lambda_max_nm;
    const double u = (lambda_nm - peak) / width;
    return alpha + 0.26 * std::exp(-u * u);
}

double oil_droplet_b_mid(OilDroplet type, double lambda_cut_nm) {
    require(std::isfinite(lambda_cut_nm) && lambda_cut_nm >= 300.0 && lambda_cut_nm <= 700.0,
            "oil droplet", "lambda_cut_nm", lambda_cut_nm, "a value in [300, 700] nm");
    std::pair<double, double> regression;
    switch (type) {
        case OilDroplet::transparent:
            throw InputError(
                "oil droplet: a transparent droplet has no B_mid (it does not filter)");
        case OilDroplet::clear_c:
            regression = {0.99, 24.38};
            break;
        case OilDroplet::yellow_y:
            regression = {0.90, 70.03};
            break;
        case OilDroplet::red_r:
            regression = {0.99, 28.65};
            break;
        case OilDroplet::pale_p:
            regression = {0.96, 33.57};
            break;
    }
    const double lambda_mid = regression.first * lambda_cut_nm + regression.second;
    return 0.5 / (lambda_mid - lambda_cut_nm);
}

double oil_droplet_transmittance(OilDroplet type, double lambda_cut_nm, double lambda_nm) {
    if (type == OilDroplet::transparent) return 1.0;
    const double b_mid = oil_droplet_b_mid(type, lambda_cut_nm);
    return std::exp(-std::exp(-2.89 * b_mid * (lambda_nm - lambda_cut_nm) + 1.08));
}

namespace {

// The embedded CSV: '#' comment lines, a header of quoted column names, then one row per nm.
std::map<std::string, std::vector<double>> read_pavo_columns() {
    std::istringstream in(embedded::kPavoVisualSystemsCsv);
    std::string line;
    std::vector<std::string> names;
    std::map<std::string, std::vector<double>> columns;
    while (std::getline(in, line)) {
        if (line.empty() || line.front() == '#') continue;
        std::vector<std::string> cells;
        std::istringstream row(line);
        for (std::string cell; std::getline(row, cell, ',');) {
            cell.erase(std::remove(cell.begin(), cell.end(), '"'), cell.end());
            cells.push_back(cell);
        }
        if (names.empty()) {
            names = cells;
            continue;
        }
        if (cells.size() != names.size()) {
            throw InputError(fmt::format("{}: a row has {} cells, the header {}: \"{}\"",
                                         kPavoDataFile, cells.size(), names.size(), line));
        }
        for (std::size_t j = 0; j < cells.size(); ++j) {
            std::size_t used = 0;
            double v = std::nan("");
            try {
                v = std::stod(cells[j], &used);
            } catch (const std::exception&) {
                used = 0;
            }
            if (used != cells[j].size() || !std::isfinite(v) || v < 0.0) {
                throw InputError(
                    fmt::format("{}: column {} holds \"{}\": expected a finite "
                                "number ≥ 0",
                                kPavoDataFile, names[j], cells[j]));
            }
            columns[names[j]].push_back(v);
        }
    }
    const auto& wl = columns["wl"];
    for (std::size_t k = 0; k < wl.size(); ++k) {
        if (wl[k] != 300.0 + static_cast<double>(k)) {
            throw InputError(fmt::format("{}: wl = {} in row {}: expected 300–700 nm at 1 nm",
                                         kPavoDataFile, wl[k], k + 1));
        }
    }
    if (wl.size() != 401) {
        throw InputError(fmt::format("{}: {} rows: expected 401 (300–700 nm at 1 nm)",
                                     kPavoDataFile, wl.size()));
    }
    return columns;
}

const std::vector<double>& pavo_column(const std::map<std::string, std::vector<double>>& columns,
                                       const std::string& name) {
    const auto it = columns.find(name);
    if (it == columns.end()) {
        throw InputError(fmt::format("{}: no column \"{}\"", kPavoDataFile, name));
    }
    return it->second;
}

struct PavoBird {
    const char* pavo_name;
    const char* name;
    const char* source;
    std::array<const char*, kAvianCones> cone_names;
    ConeVector densities;
    const char* double_cone_column;
    const char* double_cone;
};

// Sources: analysis/metrics/data/README.md and the parameter list above.
constexpr std::array<PavoBird, 4> kPavoBirds{{
    {"bluetit",
     "UVS (blue tit)",
     "blue tit Cyanistes caeruleus, Hart et al. 2000 (pavo 2.9.0 \"bluetit\"); densities "
     "1:2:2:4, Vorobyev et al. 1998",
     {"UVS", "SWS", "MWS", "LWS"},
     {1.0, 2.0, 2.0, 4.0},
     "bt.dc",
     "blue tit double cone"},
    {"pfowl",
     "VS (peafowl)",
     "peafowl Pavo cristatus, Hart 2002 (pavo 2.9.0 \"pfowl\"); densities 1:1.9:2.2:2.1, "
     "Hart 2002",
     {"VS", "SWS", "MWS", "LWS"},
     {1.0, 1.9, 2.2, 2.1},
     "ch.dc",
     "chicken double cone"},
    {"avg.uv",
     "UVS (avian average)",
     "average UV-sensitive bird, Endler & Mielke 2005 (pavo 2.9.0 \"avg.uv\"); densities "
     "1:2:2:4, Vorobyev et al. 1998",
     {"UVS", "SWS", "MWS", "LWS"},
     {1.0, 2.0, 2.0, 4.0},
     "bt.dc",
     "blue tit double cone"},
    {"avg.v",
     "VS (avian average)",
     "average violet-sensitive bird, Endler & Mielke 2005 (pavo 2.9.0 \"avg.v\"); densities "
     "1:2:2:4, Vorobyev et al. 1998",
     {"VS", "SWS", "MWS", "LWS"},
     {1.0, 2.0, 2.0, 4.0},
     "ch.dc",
     "chicken double cone"},
}};

AvianVisualSystem make_pavo_system(const PavoBird& bird,
                                   const std::map<std::string, std::vector<double>>& columns) {
    auto table = std::make_shared<ConeTable>();
    table->first_nm = 300.0;
    AvianVisualSystem system;
    system.name = bird.name;
    system.source = bird.source;
    constexpr std::array<const char*, kAvianCones> kSuffix{".u", ".s", ".m", ".l"};
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        table->cones[i] = pavo_column(columns, std::string(bird.pavo_name) + kSuffix[i]);
        const auto peak = std::max_element(table->cones[i].begin(), table->cones[i].end());
        system.cones[i] =
            ConeClass{bird.cone_names[i],
                      table->first_nm + static_cast<double>(peak - table->cones[i].begin()),
                      OilDroplet::transparent, 0.0, bird.densities[i]};
    }
    table->double_cone = pavo_column(columns, bird.double_cone_column);
    system.table = std::move(table);
    system.double_cone = bird.double_cone;
    system.weber_fraction = 0.1;
    system.weber_reference = 3;
    system.weber_achromatic = 0.1;
    return system;
}

// Linear between whole nanometres, zero outside.
double table_value(const std::vector<double>& column, double first_nm, double lambda_nm) {
    return optics::interpolate_uniform_table(column, first_nm, 1.0, lambda_nm);
}

}  // namespace

double ConeTable::last_nm() const { return first_nm + static_cast<double>(cones[0].size()) - 1.0; }

const AvianVisualSystem& pavo_visual_system(std::string_view pavo_name) {
    static const std::vector<AvianVisualSystem> systems = [] {
        const auto columns = read_pavo_columns();
        std::vector<AvianVisualSystem> all;
        for (const PavoBird& bird : kPavoBirds) all.push_back(make_pavo_system(bird, columns));
        return all;
    }();
    for (std::size_t b = 0; b < kPavoBirds.size(); ++b) {
        if (pavo_name == kPavoBirds[b].pavo_name) return systems[b];
    }
    throw InputError(fmt::format(
        "avian vision: no visual system \"{}\": expected one of pavo's bluetit, pfowl, avg.uv, "
        "avg.v",
        pavo_name));
}

const AvianVisualSystem& ultraviolet_sensitive_system() { return pavo_visual_system("bluetit"); }

const AvianVisualSystem& violet_sensitive_system() { return pavo_visual_system("pfowl"); }

double cone_sensitivity(const AvianVisualSystem& system, std::size_t cone, double lambda_nm) {
    PLUMAGE_CHECK(cone < kAvianCones, "cone index out of range");
    if (system.table)
        return table_value(system.table->cones[cone], system.table->first_nm, lambda_nm);
    const ConeClass& c = system.cones[cone];
    return govardovskii_a1(c.lambda_max_nm, lambda_nm, system.beta_band) *
           oil_droplet_transmittance(c.droplet, c.lambda_cut_nm, lambda_nm);
}

double double_cone_sensitivity(const AvianVisualSystem& system, double lambda_nm) {
    if (!system.table || system.table->double_cone.empty()) {
        throw InputError(fmt::format("avian vision: {} has no double cone", system.name));
    }
    return table_value(system.table->double_cone, system.table->first_nm, lambda_nm);
}

std::array<double, 2> sensitivity_range_nm(const AvianVisualSystem& system) {
    if (system.table) return {system.table->first_nm, system.table->last_nm()};
    return {kTemplateFirstNm, kTemplateLastNm};
}

ConeVector receptor_noise(const AvianVisualSystem& system) {
    double total = 0.0;
    for (const ConeClass& c : system.cones) {
        require(std::isfinite(c.relative_density) && c.relative_density > 0.0, system.name,
                "relative_density", c.relative_density, "a finite value > 0");
        total += c.relative_density;
    }
    require(system.weber_reference < kAvianCones, system.name, "weber_reference",
            static_cast<double>(system.weber_reference), "a cone index 0..3");
    require(std::isfinite(system.weber_fraction) && system.weber_fraction > 0.0, system.name,
            "weber_fraction", system.weber_fraction, "a finite value > 0");
    const double nu = system.weber_fraction *
                      std::sqrt(system.cones[system.weber_reference].relative_density / total);
    ConeVector omega{};
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        omega[i] = nu / std::sqrt(system.cones[i].relative_density / total);
    }
    return omega;
}

namespace {

// Weights w_k with Σ_k w_k R_k = Σ_λ R(λ) I(λ) S(λ) / Σ_λ I(λ) S(λ) over the whole nanometres λ
// of [from, to], R(λ) linear between the grid's points: the von Kries-adapted 1 nm catch.
// Returns the weights and the white-light catch Σ_λ I(λ) S(λ) (0: the span catches nothing).
template <typename Sensitivity>
std::pair<std::vector<double>, double> one_nm_weights(const optics::WavelengthGrid& grid,
                                                      double from, double to,
                                                      optics::Illuminant illuminant,
                                                      Sensitivity sensitivity) {
    std::vector<double> w(grid.size(), 0.0);
    double white = 0.0;
    std::size_t k = 0;  // grid[k] ≤ λ ≤ grid[k + 1]
    for (double l = std::ceil(from - 1e-9); l <= to + 1e-9; l += 1.0) {
        const double weight = photon_flux(illuminant, l) * sensitivity(l);
        white += weight;
        if (grid.size() == 1) {
            w[0] += weight;
            continue;
        }
        while (k + 2 < grid.size() && grid[k + 1] < l) ++k;
        const double t = std::clamp((l - grid[k]) / (grid[k + 1] - grid[k]), 0.0, 1.0);
        w[k] += (1.0 - t) * weight;
        w[k + 1] += t * weight;
    }
    if (white > 0.0) {
        for (double& v : w) v /= white;
    }
    return {std::move(w), white};
}

}  // namespace

ConeCatches::ConeCatches(const AvianVisualSystem& system, const optics::WavelengthGrid& grid,
                         optics::Illuminant illuminant)
    : system_(system) {
    if (illuminant == optics::Illuminant::d65 && (grid.first() < 300.0 || grid.last() > 830.0)) {
        throw InputError(fmt::format(
            "avian quantum catches: the grid spans {}–{} nm; D65 is tabulated on 300–830 nm",
            grid.first(), grid.last()));
    }
    const auto [data_first, data_last] = sensitivity_range_nm(system);
    const double from = std::max(grid.first(), data_first), to = std::min(grid.last(), data_last);
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        auto cone = [&](double l) { return cone_sensitivity(system, i, l); };
        auto [w, white] = one_nm_weights(grid, from, to, illuminant, cone);
        if (!(white > 0.0)) {
            throw InputError(
                fmt::format("avian quantum catches: the {} cone of {} catches no light "
                            "on the grid {}–{} nm",
                            system.cones[i].name, system.name, grid.first(), grid.last()));
        }
        weights_[i] = std::move(w);
        // The cone's white-light catch over all its data, against the grid's span.
        const double all = one_nm_weights(grid, data_first, data_last, illuminant, cone).second;
        captured_share_[i] = all > 0.0 ? white / all : 0.0;
    }
    if (system.table && !system.table->double_cone.empty()) {
        auto [w, white] = one_nm_weights(grid, from, to, illuminant, [&](double l) {
            return double_cone_sensitivity(system, l);
        });
        if (white > 0.0) double_cone_weights_ = std::move(w);
    }
}

double ConeCatches::double_cone(std::span<const double> reflectance) const {
    if (double_cone_weights_.empty()) {
        throw InputError(fmt::format("avian quantum catches: {} has no double cone{}", system_.name,
                                     system_.table ? " catching light on this grid" : ""));
    }
    PLUMAGE_CHECK(reflectance.size() == double_cone_weights_.size(),
                  fmt::format("spectrum has {} samples, grid {}", reflectance.size(),
                              double_cone_weights_.size()));
    double q = 0.0;
    for (std::size_t k = 0; k < reflectance.size(); ++k) {
        q += double_cone_weights_[k] * reflectance[k];
    }
    return q;
}

double ConeCatches::log_double_cone_variance(std::span<const double> reflectance,
                                             std::span<const double> standard_error) const {
    PLUMAGE_CHECK(standard_error.size() == reflectance.size(), "σ and spectrum sizes differ");
    const double q = double_cone(reflectance);
    double s = 0.0;
    for (std::size_t k = 0; k < reflectance.size(); ++k) {
        const double w = double_cone_weights_[k] * standard_error[k];
        s += w * w;
    }
    return s / (q * q);
}

double achromatic_contrast(double q_a, double q_b, const AvianVisualSystem& system) {
    PLUMAGE_CHECK(q_a > 0.0 && q_b > 0.0, "double-cone catches must be positive");
    require(std::isfinite(system.weber_achromatic) && system.weber_achromatic > 0.0, system.name,
            "weber_achromatic", system.weber_achromatic, "a finite value > 0");
    return std::abs(std::log(q_a / q_b)) / system.weber_achromatic;
}

ConeVector ConeCatches::operator()(std::span<const double> reflectance) const {
    PLUMAGE_CHECK(
        reflectance.size() == weights_[0].size(),
        fmt::format("spectrum has {} samples, grid {}", reflectance.size(), weights_[0].size()));
    ConeVector q{};
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        for (std::size_t k = 0; k < reflectance.size(); ++k)
            q[i] += weights_[i][k] * reflectance[k];
    }
    return q;
}

std::array<ConeVector, kAvianCones> ConeCatches::log_catch_covariance(
    std::span<const double> reflectance, std::span<const double> standard_error) const {
    PLUMAGE_CHECK(standard_error.size() == reflectance.size(), "σ and spectrum sizes differ");
    const ConeVector q = (*this)(reflectance);
    std::array<ConeVector, kAvianCones> c{};
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        for (std::size_t j = 0; j < kAvianCones; ++j) {
            double s = 0.0;
            for (std::size_t k = 0; k < reflectance.size(); ++k) {
                s += weights_[i][k] * weights_[j][k] * standard_error[k] * standard_error[k];
            }
            c[i][j] = s / (q[i] * q[j]);
        }
    }
    return c;
}

double rnl_delta_s(const ConeVector& q_a, const ConeVector& q_b, const AvianVisualSystem& system) {
    const ConeVector w = receptor_noise(system);
    ConeVector df{};
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        PLUMAGE_CHECK(q_a[i] > 0.0 && q_b[i] > 0.0, "quantum catches must be positive");
        df[i] = std::log(q_a[i] / q_b[i]);
    }
    // Numerator: each pair (i, j) of receptor differences, weighted by the noise of the other
    // two; denominator: the products of the noises of every three receptors.
    double numerator = 0.0;
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        for (std::size_t j = i + 1; j < kAvianCones; ++j) {
            double others = 1.0;
            for (std::size_t k = 0; k < kAvianCones; ++k) {
                if (k != i && k != j) others *= w[k];
            }
            numerator += others * others * (df[i] - df[j]) * (df[i] - df[j]);
        }
    }
    double denominator = 0.0;
    for (std::size_t left_out = 0; left_out < kAvianCones; ++left_out) {
        double product = 1.0;
        for (std::size_t k = 0; k < kAvianCones; ++k) {
            if (k != left_out) product *= w[k];
        }
        denominator += product * product;
    }
    return std::sqrt(numerator / denominator);
}

std::array<ConeVector, kAvianCones> rnl_metric(const AvianVisualSystem& system) {
    // W = Σ⁻¹ − Σ⁻¹ 1 1ᵀ Σ⁻¹ / (1ᵀ Σ⁻¹ 1), Σ = diag(ω²): the noise-weighted distance with the
    // achromatic direction (all f_i shifted alike) projected out.
    const ConeVector w = receptor_noise(system);
    ConeVector a{};
    double total = 0.0;
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        a[i] = 1.0 / (w[i] * w[i]);
        total += a[i];
    }
    std::array<ConeVector, kAvianCones> m{};
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        for (std::size_t j = 0; j < kAvianCones; ++j) {
            m[i][j] = (i == j ? a[i] : 0.0) - a[i] * a[j] / total;
        }
    }
    return m;
}

double rnl_noise_floor(const std::array<ConeVector, kAvianCones>& covariance,
                       const AvianVisualSystem& system) {
    const auto m = rnl_metric(system);
    double trace = 0.0;
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        for (std::size_t j = 0; j < kAvianCones; ++j) trace += m[i][j] * covariance[j][i];
    }
    return std::sqrt(std::max(0.0, trace));
}

}  // namespace plumage::analysis
