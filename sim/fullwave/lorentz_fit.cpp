#include "sim/fullwave/lorentz_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <Eigen/Dense>

#include "common/require.h"

namespace plumage::sim::fullwave {

namespace {

using Complex = std::complex<double>;

// The largest quality factor f_k / γ_k of an absorbing material's poles. The source's pulse
// spans the band and beyond, so it excites poles just above it; an undamped one rings long
// after the pulse (melanin's unconstrained fit put a lossless pole at 266 nm, and a 20 µm
// barbule's run at 45 px/µm did not decay in 15 minutes). At Q ≤ 10 a pole's energy falls by
// e within 1/(2π γ) ≤ 10/(2π f) time units, under two of its periods, and the fit loses little
// (melanin over 380–780 nm: 4.2e-3 in n + ik against 3.8e-3 undamped).
constexpr double kMaxQuality = 10.0;

double frequency_per_um(double lambda_nm) { return 1e3 / lambda_nm; }

Complex pole_term(const LorentzPole& p, double f) {
    const double f2 = p.frequency_per_um * p.frequency_per_um;
    return p.strength * f2 / Complex(f2 - f * f, -f * p.damping_per_um);
}

// The data at the fit's frequencies: ε and the weight 1/|ε| of each (a relative misfit).
struct Samples {
    std::vector<double> f;
    std::vector<Complex> eps;
    bool lossy = false;
};

Samples sample(const optics::Material& m, double lo_nm, double hi_nm, int n) {
    Samples s;
    const double f_lo = frequency_per_um(hi_nm), f_hi = frequency_per_um(lo_nm);
    for (int i = 0; i < n; ++i) {
        const double f = f_lo + (f_hi - f_lo) * i / (n - 1);
        const Complex index = m.index(1e3 / f);
        s.f.push_back(f);
        s.eps.push_back(index * index);
        s.lossy = s.lossy || index.imag() > 0.0;
    }
    return s;
}

// Pole positions and widths from unconstrained parameters: f in (f_min, f_max) and γ in
// (f / kMaxQuality, f / kMaxQuality + γ_max) by logistic maps, so Nelder–Mead needs no bounds.
struct Shape {
    double f_min, f_max, gamma_max;
    bool lossy;
    int per_pole() const { return lossy ? 2 : 1; }
    std::vector<LorentzPole> poles(const Eigen::VectorXd& p) const {
        std::vector<LorentzPole> out;
        const auto logistic = [](double x) { return 1.0 / (1.0 + std::exp(-x)); };
        for (int k = 0; k < p.size() / per_pole(); ++k) {
            LorentzPole pole;
            pole.frequency_per_um = f_min + (f_max - f_min) * logistic(p[per_pole() * k]);
            pole.damping_per_um = lossy ? pole.frequency_per_um / kMaxQuality +
                                              gamma_max * logistic(p[per_pole() * k + 1])
                                        : 0.0;
            out.push_back(pole);
        }
        return out;
    }
};

// ε_∞ ≥ 1 and σ_k ≥ 0 minimising the weighted misfit for these poles: the bounded linear
// least squares solved by trying every set of variables held at their bound (the optimum is
// the best feasible one). Fills the strengths in `poles`; returns the misfit.
double solve_strengths(const Samples& s, std::vector<LorentzPole>& poles, double& eps_infinity) {
    const int n = static_cast<int>(poles.size()) + 1;  // x = (ε_∞ − 1, σ_1 … σ_N)
    const int rows = static_cast<int>(s.f.size()) * (s.lossy ? 2 : 1);
    Eigen::MatrixXd a(rows, n);
    Eigen::VectorXd b(rows);
    for (std::size_t i = 0; i < s.f.size(); ++i) {
        const double w = 1.0 / std::abs(s.eps[i]);
        const int r = static_cast<int>(i) * (s.lossy ? 2 : 1);
        a(r, 0) = w;
        b(r) = w * (s.eps[i].real() - 1.0);
        if (s.lossy) a(r + 1, 0) = 0.0, b(r + 1) = w * s.eps[i].imag();
        for (int k = 1; k < n; ++k) {
            LorentzPole unit = poles[static_cast<std::size_t>(k - 1)];
            unit.strength = 1.0;
            const Complex t = pole_term(unit, s.f[i]);
            a(r, k) = w * t.real();
            if (s.lossy) a(r + 1, k) = w * t.imag();
        }
    }
    double best = std::numeric_limits<double>::infinity();
    Eigen::VectorXd best_x = Eigen::VectorXd::Zero(n);
    for (unsigned mask = 0; mask < (1u << n); ++mask) {  // set bits: free variables
        std::vector<int> free;
        for (int j = 0; j < n; ++j)
            if (mask & (1u << j)) free.push_back(j);
        Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
        if (!free.empty()) {
            Eigen::MatrixXd sub(rows, static_cast<int>(free.size()));
            for (std::size_t j = 0; j < free.size(); ++j)
                sub.col(static_cast<int>(j)) = a.col(free[j]);
            const Eigen::VectorXd y = sub.colPivHouseholderQr().solve(b);
            bool feasible = true;
            for (std::size_t j = 0; j < free.size(); ++j) {
                feasible = feasible && y[static_cast<int>(j)] >= 0.0;
                x[free[j]] = y[static_cast<int>(j)];
            }
            if (!feasible) continue;
        }
        const double misfit = (a * x - b).squaredNorm();
        if (misfit < best) best = misfit, best_x = x;
    }
    eps_infinity = 1.0 + best_x[0];
    for (int k = 1; k < n; ++k) poles[static_cast<std::size_t>(k - 1)].strength = best_x[k];
    return best;
}

double misfit(const Samples& s, const Shape& shape, const Eigen::VectorXd& p) {
    std::vector<LorentzPole> poles = shape.poles(p);
    double eps_infinity = 1.0;
    return solve_strengths(s, poles, eps_infinity);
}

// Nelder–Mead (standard coefficients 1, 2, 1/2, 1/2) from p with initial steps of 1.
Eigen::VectorXd nelder_mead(const Samples& s, const Shape& shape, Eigen::VectorXd p) {
    const int n = static_cast<int>(p.size());
    std::vector<Eigen::VectorXd> x(static_cast<std::size_t>(n + 1), p);
    std::vector<double> v(static_cast<std::size_t>(n + 1));
    for (int i = 0; i < n; ++i) x[static_cast<std::size_t>(i + 1)][i] += 1.0;
    for (std::size_t i = 0; i < x.size(); ++i) v[i] = misfit(s, shape, x[i]);
    for (int iteration = 0; iteration < 600 * n; ++iteration) {
        std::vector<std::size_t> order(x.size());
        for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
        std::sort(order.begin(), order.end(), [&](std::size_t i, std::size_t j) {
            return v[i] < v[j] || (v[i] == v[j] && i < j);
        });
        const std::size_t best = order.front(), worst = order.back(),
                          second = order[order.size() - 2];
        if (v[worst] - v[best] <= 1e-13 * (v[best] + 1e-300)) break;
        Eigen::VectorXd centroid = Eigen::VectorXd::Zero(n);
        for (std::size_t i = 0; i < x.size(); ++i)
            if (i != worst) centroid += x[i] / n;
        const auto at = [&](double t) {
            return Eigen::VectorXd(centroid + t * (x[worst] - centroid));
        };
        const Eigen::VectorXd reflected = at(-1.0);
        const double vr = misfit(s, shape, reflected);
        if (vr < v[best]) {
            const Eigen::VectorXd expanded = at(-2.0);
            const double ve = misfit(s, shape, expanded);
            x[worst] = ve < vr ? expanded : reflected;
            v[worst] = std::min(ve, vr);
        } else if (vr < v[second]) {
            x[worst] = reflected, v[worst] = vr;
        } else {
            const Eigen::VectorXd contracted = vr < v[worst] ? at(-0.5) : at(0.5);
            const double vc = misfit(s, shape, contracted);
            if (vc < std::min(vr, v[worst])) {
                x[worst] = contracted, v[worst] = vc;
            } else {  // shrink towards the best
                for (std::size_t i = 0; i < x.size(); ++i)
                    if (i != best) {
                        x[i] = x[best] + 0.5 * (x[i] - x[best]);
                        v[i] = misfit(s, shape, x[i]);
                    }
            }
        }
    }
    return x[static_cast<std::size_t>(std::min_element(v.begin(), v.end()) - v.begin())];
}

double max_index_error(const optics::Material& m, const LorentzPermittivity& model, double lo_nm,
                       double hi_nm) {
    double worst = 0.0;
    for (int i = 0; i <= 400; ++i) {
        const double lambda = lo_nm + (hi_nm - lo_nm) * i / 400.0;
        worst = std::max(worst, std::abs(std::sqrt(model.epsilon(lambda)) - m.index(lambda)));
    }
    return worst;
}

}  // namespace

Complex LorentzPermittivity::epsilon(double lambda_nm) const {
    const double f = frequency_per_um(lambda_nm);
    Complex eps = eps_infinity;
    for (const LorentzPole& p : poles) eps += pole_term(p, f);
    return eps;
}

LorentzFit fit_lorentz(const optics::Material& material, double lambda_min_nm, double lambda_max_nm,
                       double max_pole_frequency_per_um, int max_poles, double target_index_error) {
    const std::string what = fmt::format("Lorentz fit of '{}'", material.name());
    require(std::isfinite(lambda_min_nm) && std::isfinite(lambda_max_nm) && lambda_min_nm > 200.0 &&
                lambda_min_nm < lambda_max_nm && lambda_max_nm <= 2000.0,
            what,
            fmt::format("band {}–{} nm: expected 200 < min < max <= 2000", lambda_min_nm,
                        lambda_max_nm));
    const double f_band = frequency_per_um(lambda_min_nm);
    require(std::isfinite(max_pole_frequency_per_um) && max_pole_frequency_per_um > f_band, what,
            "max_pole_frequency", max_pole_frequency_per_um,
            fmt::format("a frequency above the band's highest ({:.4g} 1/µm)", f_band));
    require(max_poles >= 1 && max_poles <= 3, what, "max_poles", max_poles, "1, 2 or 3");
    require(std::isfinite(target_index_error) && target_index_error > 0.0, what,
            "target_index_error", target_index_error, "a finite value > 0");

    const Samples s = sample(material, lambda_min_nm, lambda_max_nm, 81);
    // Poles anywhere from a quarter of the band's lowest frequency to the cap (broad poles in
    // the band describe melanin's absorption), widths up to ten times the band's top frequency.
    const Shape shape{0.25 * frequency_per_um(lambda_max_nm), max_pole_frequency_per_um,
                      10.0 * f_band, s.lossy};
    LorentzFit fit;
    fit.material = material.name();
    fit.lambda_min_nm = lambda_min_nm;
    fit.lambda_max_nm = lambda_max_nm;
    fit.max_index_error = std::numeric_limits<double>::infinity();
    Eigen::VectorXd kept(0);
    for (int poles = 1; poles <= max_poles; ++poles) {
        // the new pole from a fixed grid of starts, the earlier ones where they were
        Eigen::VectorXd best_p;
        double best_v = std::numeric_limits<double>::infinity();
        for (const double pf : {-2.0, -0.7, 0.7, 2.0})
            for (const double pg : {-3.0, -1.0, 1.0}) {
                if (!s.lossy && pg != -3.0) continue;
                Eigen::VectorXd start(kept.size() + shape.per_pole());
                start << kept, (s.lossy ? Eigen::VectorXd{{pf, pg}} : Eigen::VectorXd{{pf}});
                const Eigen::VectorXd p = nelder_mead(s, shape, start);
                const double v = misfit(s, shape, p);
                if (v < best_v) best_v = v, best_p = p;
            }
        kept = best_p;
        LorentzPermittivity model;
        model.poles = shape.poles(kept);
        solve_strengths(s, model.poles, model.eps_infinity);
        std::erase_if(model.poles, [](const LorentzPole& p) { return p.strength == 0.0; });
        const double error = max_index_error(material, model, lambda_min_nm, lambda_max_nm);
        if (error < fit.max_index_error) fit.model = model, fit.max_index_error = error;
        if (fit.max_index_error <= target_index_error) break;
    }
    return fit;
}

}  // namespace plumage::sim::fullwave
