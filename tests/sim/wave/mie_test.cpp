// Mie series against published values (Bohren & Huffman 1983 Appendix A; Wiscombe's MIEV0
// test cases, NCAR TN-140 1979 / Appl. Opt. 1980), the Rayleigh limit, the optical
// theorem and energy conservation.
//
// Sign conventions: Wiscombe writes m = n − ik (e^{+iωt}) where we write n + ik; cross-
// sections and |S| do not depend on the convention, Im S flips sign, so only those are
// compared.
#include "sim/wave/volume/mie.h"
#include "common/constants.h"

#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "common/error.h"

namespace plumage::sim::wave {
namespace {

using Complex = std::complex<double>;

// (1/x²) ∫_{−1}^{1} (|S1|² + |S2|²) dμ and its first moment, by composite Simpson on θ
// (smooth integrand; 4000 intervals resolve x up to ~20 to 1e-9).
struct AngularIntegrals {
    double q_sca, g;
};
AngularIntegrals integrate_amplitudes(const MieCoefficients& c, double x) {
    const int intervals = 4000;
    double total = 0.0, moment = 0.0;
    for (int i = 0; i <= intervals; ++i) {
        const double theta = kPi * i / intervals;
        const double w = (i == 0 || i == intervals) ? 1.0 : (i % 2 ? 4.0 : 2.0);
        const MieAmplitudes s = mie_amplitudes(c, std::cos(theta));
        const double value = (std::norm(s.s1) + std::norm(s.s2)) * std::sin(theta);
        total += w * value;
        moment += w * value * std::cos(theta);
    }
    const double h = kPi / intervals / 3.0;
    return {total * h / (x * x), moment / total};
}

TEST(Mie, BohrenHuffmanAppendixA) {
    // m = 1.55, λ = 0.6328 µm, a = 0.525 µm: x = 5.213 (BH's BHMIE example).
    const double x = 2.0 * kPi * 0.525 / 0.6328;
    const MieEfficiencies q = mie_efficiencies(Complex(1.55, 0.0), x);
    // Published to 5 decimals: tolerance half a unit of the last digit.
    EXPECT_NEAR(q.q_ext, 3.10543, 5e-6);
    EXPECT_NEAR(q.q_sca, 3.10543, 5e-6);
    EXPECT_NEAR(q.q_back, 2.92534, 5e-6);
    EXPECT_NEAR(q.g, 0.63314, 5e-6);
}

struct WiscombeCase {
    int number;
    Complex m;  // our convention, n + ik
    double x;
    double q_sca;
    double g;
};

TEST(Mie, WiscombeMiev0TestCases) {
    // MIEV0 test cases (Wiscombe 1979, 6 decimals): tolerance one unit of the last digit.
    const std::vector<WiscombeCase> cases = {
        {7, Complex(0.75, 0.0), 10.0, 2.232265, 0.896473},
        {9, Complex(1.33, 1e-5), 1.0, 0.093923, 0.184517},
        {10, Complex(1.33, 1e-5), 100.0, 2.096594, 0.868959},
        {14, Complex(1.5, 1.0), 1.0, 0.6634538, 0.192136},
        {17, Complex(10.0, 10.0), 1.0, 2.049405, -0.110664},
        {18, Complex(10.0, 10.0), 100.0, 1.836785, 0.556215},
        // Large spheres: the term count (x + 4.05 x^{1/3} + 2) and the D_n start for |mx| up
        // to 1.4·10⁵.
        {8, Complex(0.75, 0.0), 1000.0, 1.997908, 0.844944},
        {11, Complex(1.33, 1e-5), 10000.0, 1.723857, 0.907840},
        {16, Complex(1.5, 1.0), 10000.0, 1.236575, 0.846309},
        {19, Complex(10.0, 10.0), 10000.0, 1.795393, 0.548194},
    };
    for (const auto& c : cases) {
        const MieEfficiencies q = mie_efficiencies(c.m, c.x);
        EXPECT_NEAR(q.q_sca, c.q_sca, 1e-6) << "case " << c.number;
        EXPECT_NEAR(q.g, c.g, 1e-6) << "case " << c.number;
    }
    // Case 10 also lists Q_ext = 2.101321 (absorption 0.0047 of a weakly absorbing drop);
    // this case needs the deep start of the D_n recurrence (mie.cpp).
    EXPECT_NEAR(mie_efficiencies(Complex(1.33, 1e-5), 100.0).q_ext, 2.101321, 1e-6);
    // Case 7's backscattering amplitude: S1(180°) = −1.07857 ∓ 0.0360881 i.
    const MieCoefficients c7 = mie_coefficients(Complex(0.75, 0.0), 10.0);
    const MieAmplitudes back = mie_amplitudes(c7, -1.0);
    EXPECT_NEAR(back.s1.real(), -1.07857, 1e-5);
    EXPECT_NEAR(std::abs(back.s1.imag()), 3.60881e-2, 1e-6);
}

TEST(Mie, AmplitudesOfAnAbsorbingSphere) {
    // m = 1.5 − 1i (Wiscombe's convention) at x = 1, MIEV0 test case 14: S1, S2 at θ = 0°,
    // 60°, 120°, 180°, unnormalised amplitudes to 6 decimals (as reproduced in the test
    // suite of Prahl's miepython, which checks against MIEV0's output).
    const MieCoefficients c = mie_coefficients(Complex(1.5, 1.0), 1.0);
    struct Row {
        double theta_deg, s1_re, s1_im, s2_re, s2_im;
    };
    for (const Row& r : {Row{0, 0.584080, 0.190515, 0.584080, 0.190515},
                         Row{60, 0.517525, 0.178443, 0.287964, 0.041054},
                         Row{120, 0.400212, 0.156643, -0.174875, -0.122959},
                         Row{180, 0.348844, 0.146829, -0.348844, -0.146829}}) {
        const MieAmplitudes s = mie_amplitudes(c, std::cos(r.theta_deg * kPi / 180.0));
        EXPECT_NEAR(s.s1.real(), r.s1_re, 1e-6) << r.theta_deg;
        EXPECT_NEAR(std::abs(s.s1.imag()), std::abs(r.s1_im), 1e-6) << r.theta_deg;
        EXPECT_NEAR(s.s2.real(), r.s2_re, 1e-6) << r.theta_deg;
        EXPECT_NEAR(std::abs(s.s2.imag()), std::abs(r.s2_im), 1e-6) << r.theta_deg;
    }
}

TEST(Mie, RayleighLimit) {
    // Q_sca = 8/3 x⁴ |(m² − 1)/(m² + 2)|² (1 + O(x²)): the relative error over x² stays
    // bounded as x → 0, and falls by ~4 per halving of x.
    for (Complex m : {Complex(1.5, 0.0), Complex(1.33, 0.1), Complex(0.75, 0.0)}) {
        const Complex m2 = m * m;
        const double polarisability = std::norm((m2 - 1.0) / (m2 + 2.0));
        double previous = 0.0;
        for (double x : {0.04, 0.02, 0.01, 0.005}) {
            const MieEfficiencies q = mie_efficiencies(m, x);
            const double rayleigh = 8.0 / 3.0 * std::pow(x, 4) * polarisability;
            const double error = std::abs(q.q_sca / rayleigh - 1.0);
            EXPECT_LT(error, 2.0 * x * x) << "m = " << m << " x = " << x;
            if (previous > 0.0) {
                EXPECT_NEAR(previous / error, 4.0, 0.2) << "x = " << x;
            }
            previous = error;
        }
    }
}

TEST(Mie, OpticalTheoremAndEnergy) {
    for (Complex m : {Complex(1.55, 0.0), Complex(1.33, 1e-3), Complex(1.5, 1.0)}) {
        for (double x : {0.3, 2.0, 12.0}) {
            const MieCoefficients c = mie_coefficients(m, x);
            const MieEfficiencies q = mie_efficiencies(c, x);
            // Optical theorem: Q_ext = 4 Re S(0) / x², S1(0) = S2(0).
            const MieAmplitudes forward = mie_amplitudes(c, 1.0);
            EXPECT_LT(std::abs(forward.s1 - forward.s2), 1e-12 * std::abs(forward.s1));
            EXPECT_NEAR(4.0 * forward.s1.real() / (x * x), q.q_ext, 1e-12 * q.q_ext);
            // Q_sca and g from the angular integral of the amplitudes (Simpson error ~1e-10).
            const AngularIntegrals integral = integrate_amplitudes(c, x);
            EXPECT_NEAR(integral.q_sca, q.q_sca, 1e-8 * q.q_sca) << m << " x = " << x;
            EXPECT_NEAR(integral.g, q.g, 1e-8) << m << " x = " << x;
            // Energy: lossless spheres do not absorb; absorbing ones absorb >= 0.
            if (m.imag() == 0.0) {
                EXPECT_NEAR(q.q_abs, 0.0, 1e-12 * q.q_ext);
            } else {
                EXPECT_GT(q.q_abs, 0.0);
            }
            // Q_back from S1(π).
            const MieAmplitudes back = mie_amplitudes(c, -1.0);
            EXPECT_NEAR(4.0 * std::norm(back.s1) / (x * x), q.q_back, 1e-12 * q.q_back + 1e-300);
        }
    }
}

TEST(Mie, RefusesBadInput) {
    EXPECT_THROW(mie_efficiencies(Complex(1.5, 0.0), 0.0), InputError);
    EXPECT_THROW(mie_efficiencies(Complex(1.5, 0.0), -1.0), InputError);
    EXPECT_THROW(mie_efficiencies(Complex(1.5, -0.1), 1.0), InputError);
    EXPECT_THROW(mie_efficiencies(Complex(-1.5, 0.0), 1.0), InputError);
    const MieCoefficients c = mie_coefficients(Complex(1.5, 0.0), 1.0);
    EXPECT_THROW(mie_amplitudes(c, 1.5), InputError);
}

}  // namespace
}  // namespace plumage::sim::wave
