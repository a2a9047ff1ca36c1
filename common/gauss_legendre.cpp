#include "common/gauss_legendre.h"

#include <cmath>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/error.h"

namespace plumage {

GaussLegendreRule gauss_legendre(int n) {
    if (n < 1 || n > 4096) {
        throw InputError(
            fmt::format("Gauss-Legendre rule of {} nodes: expected 1 to 4096 nodes", n));
    }
    GaussLegendreRule rule;
    rule.nodes.resize(static_cast<std::size_t>(n));
    rule.weights.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        // Tricomi's first guess; Newton on the three-term recurrence converges in a few steps.
        double x = std::cos(kPi * (i + 0.75) / (n + 0.5));
        double derivative = 1.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = x;
            for (int k = 2; k <= n; ++k) {
                const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            derivative = n * (x * p1 - p0) / (x * x - 1.0);
            const double dx = p1 / derivative;
            x -= dx;
            if (std::abs(dx) < 1e-15) break;
        }
        rule.nodes[static_cast<std::size_t>(i)] = x;
        rule.weights[static_cast<std::size_t>(i)] = 2.0 / ((1.0 - x * x) * derivative * derivative);
    }
    return rule;
}

}  // namespace plumage
