// "Did you mean ...?" for names a user typed: the command line's subcommands and flags
// (studies/main.cpp) and study files' keys (studies/study_file.cpp) suggest the same way.
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace plumage {

// Edits between a and b: insertions, deletions, substitutions and swaps of two neighbouring
// characters, one each (the optimal string alignment distance: "lenght" is one edit from
// "length").
inline std::size_t edit_distance(std::string_view a, std::string_view b) {
    std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
    for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
    for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        for (std::size_t j = 1; j <= b.size(); ++j) {
            d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1,
                                d[i - 1][j - 1] + (a[i - 1] != b[j - 1] ? 1 : 0)});
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
                d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
        }
    }
    return d[a.size()][b.size()];
}

// The candidate nearest to `typed` within `max_edits` edits (the first of equals), or "" when
// none is that near or `typed` is itself a candidate.
inline std::string nearest_name(std::string_view typed, const std::vector<std::string>& candidates,
                                std::size_t max_edits = 2) {
    std::string best;
    std::size_t best_distance = max_edits + 1;
    for (const std::string& name : candidates) {
        const std::size_t d = edit_distance(typed, name);
        if (d == 0) return {};
        if (d < best_distance) best = name, best_distance = d;
    }
    return best;
}

}  // namespace plumage
