// sin and cos without branches or calls, so that a loop over them vectorises: the far-field sums
// of physical optics (O(elements × angles) sin/cos pairs) spend most of their time here, and
// libm's sincos is a scalar call that the compiler cannot put in SIMD lanes.
//
// Method: Cody–Waite reduction by π/2 in three parts (x − n·π/2 exact for |n| < 2^20, because
// each part of π/2 has 33 significant bits), then fdlibm's minimax polynomials on [−π/4, π/4]
// (__kernel_sin, __kernel_cos), the quadrant chosen by selects on n mod 4 held as a double.
// Accuracy: absolute error ≤ 2.3e-16 for |x| ≤ 1.6e6 (tests/common/fast_trig_test.cpp against
// libm, including every quadrant boundary); beyond, the reduction loses digits (about 1e-9 at
// 1e7): callers bound |x| (physical_optics_hybrid_2d.cpp refuses scenes where k·|r| could exceed
// kSinCosLimit).
#pragma once

#include <cmath>

namespace plumage {

inline constexpr double kSinCosLimit = 1.6e6;

inline void sin_cos(double x, double& sin_x, double& cos_x) {
    constexpr double kTwoOverPi = 6.36619772367581382433e-01;
    constexpr double kPio2Part1 = 1.57079632673412561417e+00;
    constexpr double kPio2Part2 = 6.07710050630396597660e-11;
    constexpr double kPio2Part3 = 2.02226624879595063154e-21;
    constexpr double kRound = 0x1.8p52;  // adding and subtracting it rounds to an integer
    const double n = (x * kTwoOverPi + kRound) - kRound;
    const double q = n - 4.0 * ((n * 0.25 + kRound) - kRound);  // n mod 4, in {−2, …, 2}
    const double r = ((x - n * kPio2Part1) - n * kPio2Part2) - n * kPio2Part3;
    const double z = r * r;
    const double s =
        r +
        r * z *
            (-1.66666666666666324348e-01 +
             z * (8.33333333332248946124e-03 +
                  z * (-1.98412698298579493134e-04 +
                       z * (2.75573137070700676789e-06 +
                            z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))));
    const double c =
        1.0 - 0.5 * z +
        z * z *
            (4.16666666666666019037e-02 +
             z * (-1.38888888888741095749e-03 +
                  z * (2.48015872894767294178e-05 +
                       z * (-2.75573143513906633035e-07 +
                            z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
    // Quadrant q: (sin, cos) = (s, c), (c, −s), (−s, −c), (−c, s) for q = 0, 1, ±2, −1.
    const bool swap = std::abs(q) == 1.0;
    const double sin_r = swap ? c : s;
    const double cos_r = swap ? s : c;
    sin_x = (q < -0.5 || q > 1.5) ? -sin_r : sin_r;
    cos_x = (q > 0.5 || q < -1.5) ? -cos_r : cos_r;
}

}  // namespace plumage
