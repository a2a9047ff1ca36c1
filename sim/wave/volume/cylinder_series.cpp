#include "sim/wave/volume/cylinder_series.h"

#include <cmath>
#include <numbers>

#include "common/require.h"

namespace plumage::sim::wave {

namespace {

using Complex = std::complex<double>;

// D_n(z) = J_n'(z)/J_n(z) for n = 0 … n_stop, by downward recurrence from well above n_stop.
std::vector<Complex> log_derivatives(Complex z, int n_stop) {
    const int start = n_stop + 15 + static_cast<int>(std::abs(z));
    std::vector<Complex> d(static_cast<std::size_t>(start) + 1, Complex{0.0, 0.0});
    for (int n = start; n > 0; --n) {
        const Complex nz = static_cast<double>(n) / z;
        d[static_cast<std::size_t>(n) - 1] =
            static_cast<double>(n - 1) / z - 1.0 / (d[static_cast<std::size_t>(n)] + nz);
    }
    d.resize(static_cast<std::size_t>(n_stop) + 1);
    return d;
}

}  // namespace

CylinderSeries cylinder_series(Complex m, double x, Polarisation2d pol) {
    require(std::isfinite(m.real()) && std::isfinite(m.imag()) && m.real() > 0.0 && m.imag() >= 0.0,
            "cylinder_series", "the relative index must be finite with Re m > 0 and Im m >= 0");
    require(std::isfinite(x) && x > 0.0 && x <= 1000.0, "cylinder_series", "x", x,
            "a finite size parameter in (0, 1000]");
    const int n_stop = std::max(3, static_cast<int>(x + 4.05 * std::cbrt(x) + 2.0));
    const std::vector<Complex> d = log_derivatives(m * x, n_stop);
    CylinderSeries s{pol, x, {}};
    s.coefficient.reserve(static_cast<std::size_t>(n_stop) + 1);
    for (int n = 0; n <= n_stop; ++n) {
        const double j = std::cyl_bessel_j(n, x), y = std::cyl_neumann(n, x);
        // J_n' = J_{n−1} − (n/x) J_n, with J_{−1} = −J_1 (likewise Y)
        const double j_prev = n == 0 ? -std::cyl_bessel_j(1, x) : std::cyl_bessel_j(n - 1, x);
        const double y_prev = n == 0 ? -std::cyl_neumann(1, x) : std::cyl_neumann(n - 1, x);
        const double jd = j_prev - n / x * j, yd = y_prev - n / x * y;
        const Complex h{j, y}, hd{jd, yd};
        const Complex dn = d[static_cast<std::size_t>(n)];
        // Case I (E ∥ axis): b_n = (J_n' − m D_n J_n) / (H_n' − m D_n H_n);
        // case II (H ∥ axis): a_n = (m J_n' − D_n J_n) / (m H_n' − D_n H_n)  (both divided by
        // J_n(mx))
        s.coefficient.push_back(pol == Polarisation2d::te ? (jd - m * dn * j) / (hd - m * dn * h)
                                                          : (m * jd - dn * j) / (m * hd - dn * h));
    }
    return s;
}

Complex cylinder_amplitude(const CylinderSeries& s, double psi_rad) {
    Complex t = s.coefficient.front();
    for (std::size_t n = 1; n < s.coefficient.size(); ++n)
        t += 2.0 * s.coefficient[n] * std::cos(static_cast<double>(n) * psi_rad);
    return t;
}

double cylinder_sigma(const CylinderSeries& s, double k_per_um, double psi_rad) {
    return 2.0 / (std::numbers::pi * k_per_um) * std::norm(cylinder_amplitude(s, psi_rad));
}

CylinderWidths cylinder_widths(const CylinderSeries& s, double k_per_um) {
    double ext = s.coefficient.front().real(), sca = std::norm(s.coefficient.front());
    for (std::size_t n = 1; n < s.coefficient.size(); ++n) {
        ext += 2.0 * s.coefficient[n].real();
        sca += 2.0 * std::norm(s.coefficient[n]);
    }
    CylinderWidths w;
    w.extinction_um = 4.0 / k_per_um * ext;
    w.scattering_um = 4.0 / k_per_um * sca;
    w.absorption_um = w.extinction_um - w.scattering_um;
    return w;
}

}  // namespace plumage::sim::wave
