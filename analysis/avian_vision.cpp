#include "analysis/avian_vision.h"

#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "common/error.h"
#include "common/require.h"

// Parameter table (sources; values in nm unless stated):
//
//  | quantity                      | value                                | source |
//  |-------------------------------|--------------------------------------|---------------------------------|
//  | A1 template α band            | A 69.7, a 0.8795 + 0.0459 exp(−(λmax | Govardovskii,
//  Fyhrquist, Reuter,| |                               | − 300)²/11940), B 28, b 0.922,       |
//  Kuzmin & Donner 2000, Vis.      | |                               | C −14.9, c 1.104, D 0.674 |
//  Neurosci. 17:509 (A1 template)  | | A1 template β band            | A_β 0.26, λ_β 189 + 0.315
//  λmax,      | same                            | |                               | b_β −40.5 +
//  0.195 λmax               |                                 | | oil droplet transmittance     |
//  exp(−exp(−2.89 B_mid (λ−λcut)+1.08)) | Hart & Vorobyev 2005, J. Comp.  | | λmid = a λcut + b | C
//  0.99, 24.38; Y 0.90, 70.03;        | Physiol. A 191:381 (regressions | | | R 0.99, 28.65; P
//  0.96, 33.57         | per droplet type)               | | UVS system: blue tit          | λmax
//  371 (UVS), 448 (SWS), 502 (MWS),| Hart, Partridge, Cuthill &      | | (Cyanistes caeruleus) |
//  563 (LWS); droplets T, C 413, Y 507, | Bennett 2000, J. Comp. Physiol. | | | R 572 (λcut) | A
//  186:375                       | | UVS relative cone densities   | 1 : 2 : 2 : 4 | Vorobyev et
//  al. 1998, J. Comp.  | |                               |                                      |
//  Physiol. A 183:621 (Leiothrix   | |                               | | lutea; the usual default)
//  | | VS system: peafowl            | peak sensitivities 432 (VS), 477     | Hart 2002, J. Exp.
//  Biol.        | | (Pavo cristatus)              | (SWS), 537 (MWS), 605 (LWS)          | 205:3925
//  (abstract: predicted   | |                               | | peaks with droplets and media)  |
//  | VS relative cone densities    | 1 : 1.9 : 2.2 : 2.1                  | Hart 2002, Fig. 8 (from
//  Hart    | |                               |                                      | 2001, Prog.
//  Retin. Eye Res.)    | | Weber fraction                | 0.1 for the LWS cone                 |
//  Vorobyev et al. 1998 (Leiothrix | |                               | | lutea, behavioural) |
//
// Ranges and limits: templates for λmax in 300–700 nm (Govardovskii's fits span 357–620 nm).
// The VS system is an approximation: its four cones are A1 templates placed at Hart 2002's
// predicted peak sensitivities (which include oil-droplet and ocular-media filtering), without
// the droplets' narrowing of the bands (their λcut were not available to us), so its bands are
// broader than the real cones' on the short-wavelength side. Ocular media are modelled for
// neither system: birds' ocular media cut off in the near UV (50 % transmission at roughly
// 310–340 nm in UVS species, longer in VS species; Hart 2001), so the short-wavelength cone's
// catch below that is overstated here (at 300–330 nm it is mostly the β band and the α band's
// flank); the VS bands sit at peaks that include the media's effect but keep the bare
// template's UV flank, which the media would remove.

namespace plumage::analysis {

namespace {

constexpr double kShareFirstNm = 300.0;  // the suite's spectral range, for captured_share()
constexpr double kShareLastNm = 800.0;

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

const AvianVisualSystem& ultraviolet_sensitive_system() {
    static const AvianVisualSystem system{
        .name = "UVS (blue tit)",
        .source =
            "blue tit Cyanistes caeruleus, Hart et al. 2000; densities 1:2:2:4, Vorobyev "
            "et al. 1998",
        .cones = {{{"UVS", 371.0, OilDroplet::transparent, 0.0, 1.0},
                   {"SWS", 448.0, OilDroplet::clear_c, 413.0, 2.0},
                   {"MWS", 502.0, OilDroplet::yellow_y, 507.0, 2.0},
                   {"LWS", 563.0, OilDroplet::red_r, 572.0, 4.0}}},
        .weber_fraction = 0.1,
        .weber_reference = 3,
        .beta_band = true};
    return system;
}

const AvianVisualSystem& violet_sensitive_system() {
    static const AvianVisualSystem system{
        .name = "VS (peafowl)",
        .source =
            "peafowl Pavo cristatus, Hart 2002 (predicted peak sensitivities, densities "
            "1:1.9:2.2:2.1)",
        .cones = {{{"VS", 432.0, OilDroplet::transparent, 0.0, 1.0},
                   {"SWS", 477.0, OilDroplet::transparent, 0.0, 1.9},
                   {"MWS", 537.0, OilDroplet::transparent, 0.0, 2.2},
                   {"LWS", 605.0, OilDroplet::transparent, 0.0, 2.1}}},
        .weber_fraction = 0.1,
        .weber_reference = 3,
        .beta_band = true};
    return system;
}

double cone_sensitivity(const AvianVisualSystem& system, std::size_t cone, double lambda_nm) {
    PLUMAGE_CHECK(cone < kAvianCones, "cone index out of range");
    const ConeClass& c = system.cones[cone];
    return govardovskii_a1(c.lambda_max_nm, lambda_nm, system.beta_band) *
           oil_droplet_transmittance(c.droplet, c.lambda_cut_nm, lambda_nm);
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

ConeCatches::ConeCatches(const AvianVisualSystem& system, const optics::WavelengthGrid& grid,
                         optics::Illuminant illuminant)
    : system_(system) {
    if (illuminant == optics::Illuminant::d65 && (grid.first() < 300.0 || grid.last() > 830.0)) {
        throw InputError(fmt::format(
            "avian quantum catches: the grid spans {}–{} nm; D65 is tabulated on 300–830 nm",
            grid.first(), grid.last()));
    }
    const std::size_t n = grid.size();
    for (std::size_t i = 0; i < kAvianCones; ++i) {
        std::vector<double>& w = weights_[i];
        w.assign(n, 0.0);
        double sum = 0.0;
        for (std::size_t k = 0; k < n; ++k) {
            const double left = k > 0 ? grid[k] - grid[k - 1] : 0.0;
            const double right = k + 1 < n ? grid[k + 1] - grid[k] : 0.0;
            const double width = n > 1 ? 0.5 * (left + right) : 1.0;
            w[k] = width * photon_flux(illuminant, grid[k]) * cone_sensitivity(system, i, grid[k]);
            sum += w[k];
        }
        if (!(sum > 0.0)) {
            throw InputError(
                fmt::format("avian quantum catches: the {} cone of {} catches no light "
                            "on the grid {}–{} nm",
                            system.cones[i].name, system.name, grid.first(), grid.last()));
        }
        for (double& v : w) v /= sum;
        // The same white-light catch at 1 nm over the suite's range, against the grid's span.
        double inside = 0.0, all = 0.0;
        for (double l = kShareFirstNm; l <= kShareLastNm + 1e-9; l += 1.0) {
            const double q = photon_flux(illuminant, l) * cone_sensitivity(system, i, l);
            all += q;
            if (l >= grid.first() - 1e-9 && l <= grid.last() + 1e-9) inside += q;
        }
        captured_share_[i] = all > 0.0 ? inside / all : 0.0;
    }
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
