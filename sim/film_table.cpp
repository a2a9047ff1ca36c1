#include "sim/film_table.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/error.h"

namespace plumage::sim {

std::optional<FilmTable> FilmTable::build(const FilmOptics& film, bool from_outside,
                                          double lambda_nm, double tolerance) {
    if (!std::isfinite(tolerance) || !(tolerance > 0.0)) {
        throw InputError(fmt::format(
            "film table tolerance = {}: expected a finite absolute reflectance error > 0",
            tolerance));
    }
    const double incident = (from_outside ? film.outside : film.inside).real();
    const double exit = (from_outside ? film.inside : film.outside).real();
    // Total reflection possible inside the film or at its far side: a kink in c.
    if (incident > film.film.real() || incident > exit) return std::nullopt;

    FilmTable table;
    for (int nodes = kMinNodes; nodes <= kMaxNodes; nodes = 2 * nodes - 1) {
        const double h = (1.0 - kMinCos) / (nodes - 1);
        table.nodes_.resize(nodes);
        for (int i = 0; i < nodes; ++i) {
            table.nodes_[i] = film_response(film, from_outside, lambda_nm, kMinCos + i * h);
        }
        table.scale_ = 1.0 / h;
        double worst = 0.0;
        for (int i = 0; i + 1 < nodes; ++i) {
            const FilmResponse exact =
                film_response(film, from_outside, lambda_nm, kMinCos + (i + 0.5) * h);
            worst = std::max(
                {worst,
                 std::abs(0.5 * (table.nodes_[i].reflectance + table.nodes_[i + 1].reflectance) -
                          exact.reflectance),
                 std::abs(0.5 *
                              (table.nodes_[i].transmittance + table.nodes_[i + 1].transmittance) -
                          exact.transmittance)});
        }
        table.midpoint_error_ = worst;
        if (worst <= 0.25 * tolerance) return table;
    }
    return std::nullopt;
}

}  // namespace plumage::sim
