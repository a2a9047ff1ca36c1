// Physical optics through transparent interfaces (sim/wave/surface/physical_optics_hybrid_2d.h)
// against the suite's full wave on the two cross-sections of tests/reference/po_transmission
// (structures.h; README.md there): a keratin arc over a separate melanin layer with a varying
// gap, and a melanin ellipse 1 µm thick that transmits. At θ_i = 30°, 450/550/650 nm, TE and TM,
// each quantity of issue 36's list is compared with the finer grid's value; its floor is the
// grid's own difference (the coarser grid against the finer), which the physics cannot beat.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/constants.h"
#include "sim/optics/material.h"
#include "sim/wave/surface/physical_optics_hybrid_2d.h"
#include "tests/reference/po_transmission/structures.h"

namespace plumage::sim::wave {
namespace {

namespace fs = std::filesystem;
namespace ref = reference::po_transmission;

fs::path reference_dir() {
    return fs::path(PLUMAGE_SOURCE_DIR) / "tests/reference/po_transmission";
}

std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> out;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) out.push_back(cell);
    return out;
}

// (case, polarisation, λ, resolution) → the columns after the key.
using Key = std::tuple<std::string, std::string, double, double>;

std::map<Key, std::vector<double>> read_rows(const fs::path& file, std::size_t key_end) {
    std::ifstream in(file);
    EXPECT_TRUE(in) << file;
    std::string line;
    std::getline(in, line);
    std::map<Key, std::vector<double>> out;
    while (std::getline(in, line)) {
        const std::vector<std::string> c = split(line);
        const Key key{c[0], c[1], std::stod(c[3]), std::stod(c[4])};
        for (std::size_t m = key_end; m < c.size(); ++m) out[key].push_back(std::stod(c[m]));
    }
    return out;
}

// The quantities of issue 36's acceptance from σ on the reference's 0.5° grid and the widths.
struct Quantities {
    double spike = 0.0;   // ∫σ within 2.5° of the specular direction (the 5° window)
    double back = 0.0;    // ∫σ over the back half-space, ω_s·ω_i > 0
    double lobe_deg = 0;  // θ_s of σ's largest value in the back half-space
    double scattering = 0.0, extinction = 0.0, absorption = 0.0;
};

Quantities from_sigma(const std::vector<double>& theta_deg, const std::vector<double>& sigma) {
    Quantities q;
    const double d = 0.5 * kPi / 180.0;
    double best = -1.0;
    for (std::size_t m = 0; m < sigma.size(); ++m) {
        if (std::abs(theta_deg[m] + ref::kThetaIDeg) <= 2.5) q.spike += sigma[m] * d;
        if (std::abs(theta_deg[m] - ref::kThetaIDeg) < 90.0) {
            q.back += sigma[m] * d;
            if (sigma[m] > best) best = sigma[m], q.lobe_deg = theta_deg[m];
        }
    }
    return q;
}

struct Line {
    const char* name;
    double Quantities::*member;
    double tolerance;  // issue 36's
};

const std::vector<Line>& lines() {
    static const std::vector<Line> l{{"specular spike", &Quantities::spike, 0.15},
                                     {"back-scattered power", &Quantities::back, 0.12},
                                     {"sigma_scat", &Quantities::scattering, 0.08},
                                     {"sigma_ext", &Quantities::extinction, 0.06},
                                     {"sigma_abs", &Quantities::absorption, 0.06}};
    return l;
}

// far_field.csv keeps the back half-space and a little more, θ_s = −62°, −61.5°, …, 122°
// (θ_i = 30°): every quantity taken from σ lies in it.
std::vector<double> grid_deg() {
    std::vector<double> out;
    for (int m = 0; m <= 368; ++m) out.push_back(-62.0 + 0.5 * m);
    return out;
}

// far_field.csv holds one row per angle: σ per key, in the file's (grid_deg) order.
std::map<Key, std::vector<double>> read_sigma(const fs::path& file) {
    std::map<Key, std::vector<double>> sigma;
    std::ifstream in(file);
    EXPECT_TRUE(in);
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
        const std::vector<std::string> c = split(line);
        sigma[Key{c[0], c[1], std::stod(c[3]), std::stod(c[4])}].push_back(std::stod(c[6]));
    }
    return sigma;
}

// Full wave's quantities of one run.
Quantities full_wave_at(const std::map<Key, std::vector<double>>& totals,
                        const std::map<Key, std::vector<double>>& sigma, const Key& key) {
    Quantities q = from_sigma(grid_deg(), sigma.at(key));
    q.scattering = totals.at(key)[1];
    q.absorption = totals.at(key)[2];
    q.extinction = totals.at(key)[3];
    return q;
}

// Full wave's quantities on the two finest grids of (case, polarisation, λ) in the files.
std::pair<Quantities, Quantities> full_wave(const std::map<Key, std::vector<double>>& totals,
                                            const std::map<Key, std::vector<double>>& sigma,
                                            const std::string& name, const std::string& pol,
                                            double lambda) {
    std::vector<double> grids;
    for (const auto& [key, row] : totals)
        if (std::get<0>(key) == name && std::get<1>(key) == pol && std::get<2>(key) == lambda)
            grids.push_back(std::get<3>(key));
    EXPECT_GE(grids.size(), 2u) << name << " " << pol << " " << lambda;
    std::sort(grids.rbegin(), grids.rend());
    return {full_wave_at(totals, sigma, {name, pol, lambda, grids[0]}),
            full_wave_at(totals, sigma, {name, pol, lambda, grids[1]})};
}

// step_um: the hybrid's surface step (0: λ/10).
Quantities hybrid(const CrossSection2d& section, const std::string& pol, double lambda,
                  double step_um = 0.0) {
    std::vector<double> theta;
    for (double d : grid_deg()) theta.push_back(d * kPi / 180.0);
    const Incidence2d incidence{lambda, ref::kThetaIDeg * kPi / 180.0,
                                pol == "TE" ? Polarisation2d::te : Polarisation2d::tm};
    HybridOptions options;
    options.step_um = step_um;
    const HybridFarField2d po = hybrid_far_field(section, incidence, theta, options);
    Quantities q = from_sigma(grid_deg(), po.sigma_um_per_rad);
    q.scattering = po.scattering_width_um;
    q.extinction = po.extinction_width_um;
    q.absorption = po.absorption_width_um;
    return q;
}

// One line of check.csv: a quantity of one case, physical optics against full wave.
struct CheckRow {
    std::string name, pol;
    double lambda;
    std::string quantity;
    double po, fw, grid,
        target;  // grid: |fine − coarse|; target: issue 36's (relative, or ° for the lobe)
    bool within() const {
        return quantity == "lobe_deg" ? std::abs(po - fw) <= target + grid
                                      : std::abs(po - fw) <= target * std::abs(fw) + grid;
    }
};

const std::vector<CheckRow>& check_rows() {
    static const std::vector<CheckRow> rows = [] {
        const auto totals = read_rows(reference_dir() / "totals.csv", 5);
        const auto sigma = read_sigma(reference_dir() / "far_field.csv");
        const std::map<std::string, CrossSection2d> sections{
            {"film_over_melanin", ref::film_over_melanin_hybrid()},
            {"semi_transparent_body", ref::semi_transparent_body_hybrid()}};
        std::vector<CheckRow> out;
        for (const auto& [name, section] : sections)
            for (const std::string pol : {"TE", "TM"})
                for (const double lambda : ref::kLambdasNm) {
                    const auto [fine, coarse] = full_wave(totals, sigma, name, pol, lambda);
                    const Quantities q = hybrid(section, pol, lambda);
                    out.push_back({name, pol, lambda, "lobe_deg", q.lobe_deg, fine.lobe_deg,
                                   std::abs(fine.lobe_deg - coarse.lobe_deg), 2.0});
                    for (const Line& l : lines())
                        out.push_back({name, pol, lambda, l.name, q.*l.member, fine.*l.member,
                                       std::abs(fine.*l.member - coarse.*l.member), l.tolerance});
                }
        return out;
    }();
    return rows;
}

std::string check_csv(const std::vector<CheckRow>& rows) {
    std::string out =
        "case,polarisation,lambda_nm,quantity,physical_optics,full_wave,grid,target,within\n";
    for (const CheckRow& r : rows)
        out += fmt::format("{},{},{:g},{},{:.4g},{:.4g},{:.2g},{:g},{}\n", r.name, r.pol, r.lambda,
                           r.quantity, r.po, r.fw, r.grid, r.target, r.within() ? "yes" : "no");
    return out;
}

// Every quantity of issue 36's list, against full wave, as committed in check.csv (README.md
// there explains each miss); PLUMAGE_WRITE_PO_CHECK=1 rewrites the file.
TEST(PoTransmissionReference, PhysicalOpticsThroughInterfacesAgainstFullWave) {
    const std::vector<CheckRow>& rows = check_rows();
    int within = 0;
    for (const CheckRow& r : rows) {
        within += r.within() ? 1 : 0;
        const std::string miss = r.quantity == "lobe_deg"
                                     ? fmt::format("{:+.1f}°", r.po - r.fw)
                                     : fmt::format("{:+.1f} %", 100.0 * (r.po / r.fw - 1.0));
        std::printf("%-21s %s %g nm %-20s PO %8.4f FW %8.4f (%s, grid %.2g) %s\n", r.name.c_str(),
                    r.pol.c_str(), r.lambda, r.quantity.c_str(), r.po, r.fw, miss.c_str(), r.grid,
                    r.within() ? "within" : "MISSES");
    }
    std::printf("%d of %zu within issue 36's targets (plus the grid's difference)\n", within,
                rows.size());
    const fs::path committed = reference_dir() / "check.csv";
    if (std::getenv("PLUMAGE_WRITE_PO_CHECK")) std::ofstream(committed) << check_csv(rows);
    std::ifstream in(committed);
    ASSERT_TRUE(in) << committed;
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_EQ(text.str(), check_csv(rows)) << "physical optics moved against full wave: "
                                              "rerun with PLUMAGE_WRITE_PO_CHECK=1 and explain it";
}

// The level before this one made every body opaque: extinction 2 × the projected width. Light
// through the melanin body brings physical optics nearer full wave at every wavelength.
TEST(PoTransmissionReference, ABodyThatTransmitsBeatsTheOpaqueBody) {
    const geometry::EllipticalArc body(ref::kBodySemiXUm, ref::kBodySemiZUm, -kPi, kPi);
    const double opaque = 2.0 * body.projected_width(ref::kThetaIDeg * kPi / 180.0);
    for (const CheckRow& r : check_rows()) {
        if (r.name != "semi_transparent_body" || r.quantity != "sigma_ext") continue;
        std::printf("%s %g nm: extinction %.3f, opaque %.3f, full wave %.3f µm\n", r.pol.c_str(),
                    r.lambda, r.po, opaque, r.fw);
        EXPECT_LT(std::abs(r.po - r.fw), std::abs(opaque - r.fw));
    }
}

// The widths study (README.md, "Wider"): the arc over its layer, the arc alone and the arc
// flattened into a free film, stretched along x (structures.h), at 550 nm against full wave on
// its 60 px/µm grid (at 1×, 60 against 90 px/µm moves these quantities by at most 2.3 %). What
// the structures' ends do (the thick film's end faces, light guided along the film, the gap's
// shadow edges) is a fixed amount that the wider sections dilute; physical optics leaves it out.
struct Widened {
    std::string name;
    double lateral;
    CrossSection2d section;
    double tilt_deg = 0.0;  // flat_film_over_melanin's film turned (structures.h)
    std::vector<double> lambdas_nm{550.0};
    double step_um = 0.0;   // the hybrid's surface step (0: λ/10)
    double raise_um = 0.0;  // the film, or film_over_melanin's arc, lifted (structures.h)
    // The section's name with _tiltT and _raiseR where they apply.
    std::string label(const std::string& base) const {
        std::string out = tilt_deg == 0.0 ? base : fmt::format("{}_tilt{:g}", base, tilt_deg);
        if (raise_um != 0.0) out += fmt::format("_raise{:g}", raise_um);
        return out;
    }
    std::string key() const {
        return label(lateral == 1.0 ? name : fmt::format("{}_x{:g}", name, lateral));
    }
};

// The lifts of the arc over its layer (µm), 3× and 1× wide: a fringe of its specular window at
// 550 nm (README.md).
constexpr double kArcLiftsUm[] = {0.04, 0.08, 0.16, 0.20, 0.24, 0.28};
constexpr double kNarrowArcLiftsUm[] = {0.04, 0.08, 0.16, 0.24};
// The 3× arc at 650 nm, a quarter and a half fringe (0.375 µm) up.
constexpr double kArcLiftsAt650Um[] = {0.1, 0.19};

std::vector<Widened> widened() {
    std::vector<Widened> out;
    for (const double s : {1.0, 2.0, 4.0})
        out.push_back({"free_flat_film", s, ref::free_flat_film_hybrid(s)});
    for (const double s : {1.0, 3.0}) out.push_back({"free_arc", s, ref::free_arc_hybrid(s)});
    for (const double s : {1.0, 2.0, 3.0})
        out.push_back(
            {"film_over_melanin", s, ref::film_over_melanin_hybrid(s), 0.0,
             s == 2.0 ? std::vector<double>{550.0} : std::vector<double>{450.0, 550.0, 650.0}});
    for (const double s : {1.0, 3.0})
        out.push_back({"flat_film_over_melanin", s, ref::flat_film_over_melanin_hybrid(s)});
    for (const double tilt : {-12.0, -6.0, 6.0, 12.0})
        out.push_back(
            {"flat_film_over_melanin", 1.0, ref::flat_film_over_melanin_hybrid(1.0, tilt), tilt});
    for (const double lateral : {1.0, 3.0})
        for (const double tilt : {-3.0, 3.0})
            out.push_back({"flat_film_over_melanin", lateral,
                           ref::flat_film_over_melanin_hybrid(lateral, tilt), tilt});
    // Lifted by 1 µm, so that the 3× film can be turned by ±6° (the arc's steepest slope at 3×).
    for (const double lateral : {1.0, 3.0})
        for (const double tilt : {-6.0, 0.0, 6.0}) {
            if (lateral == 1.0 && tilt == 0.0) continue;
            out.push_back({"flat_film_over_melanin",
                           lateral,
                           ref::flat_film_over_melanin_hybrid(lateral, tilt, 1.0),
                           tilt,
                           {550.0},
                           0.0,
                           1.0});
        }
    // The 3× arc lifted through one fringe of its specular window (the gap at its top 0.75 µm +
    // the lift; the window's fringe repeats every λ / (2 cos θ_i) = 0.32 µm of lift at 550 nm),
    // two points of it at 650 nm, and the 1× arc lifted.
    const auto lifted_arc = [&out](double lateral, double lift, std::vector<double> lambdas) {
        out.push_back({"film_over_melanin", lateral, ref::film_over_melanin_hybrid(lateral, lift),
                       0.0, std::move(lambdas), 0.0, lift});
    };
    for (const double lift : kArcLiftsUm) lifted_arc(3.0, lift, {550.0});
    for (const double lift : kArcLiftsAt650Um) lifted_arc(3.0, lift, {650.0});
    for (const double lift : kNarrowArcLiftsUm) lifted_arc(1.0, lift, {450.0, 550.0, 650.0});
    // The stretched ellipse's tips (radius 0.25/(2.5 s) µm) are sharper than λ/10, which the
    // level refuses: all three at a 0.03 µm step.
    for (const double s : {1.0, 2.0, 3.0})
        out.push_back({"semi_transparent_body",
                       s,
                       ref::semi_transparent_body_hybrid(s),
                       0.0,
                       {450.0, 550.0, 650.0},
                       0.03});
    return out;
}

double relative_error(const std::pair<Quantities, Quantities>& po_fw, double Quantities::*q) {
    return po_fw.first.*q / (po_fw.second.*q) - 1.0;
}

// The arc over its layer: σ_scat's and σ_abs's misses at 1× are the ends'. They shrink as the
// section widens, and at 3× the three widths are within issue 36's targets in both
// polarisations; the free film's reflection and widths are within a few per cent once it is
// 12.8 µm wide. The specular spike of the arc over its layer does not come in (README.md). The
// same film flat over the same layer is within every target at 3×, the spike included, and its
// spike within 10 % at 1×; turned by ±3° … ±12° against the layer the spike misses in TM by
// 20–37 % at 1×, and 3× long, turned by ±3° (or lifted by 1 µm and turned by ±6°, the 3× arc's
// steepest slope), it is within target again: the tilted film's miss is its ends (at 450 nm the
// 3× arc is within every target). The 3× arc's spike miss at 550 nm is where the drawn arc sits
// on the fringe of its specular window (lifted through the fringe, it misses only in its dark
// half); the 1× arc's misses at every lift.
// The 1 µm melanin ellipse stretched 2× and 3× is within every power target at 450–650 nm: its
// misses at 1× are its tips. Physical optics against full wave per (section, polarisation,
// lateral scale): the section's name, with _tiltT for a turned film, _raiseR for a lifted one and
// @λ for a wavelength other than 550 nm.
using Compared =
    std::map<std::tuple<std::string, std::string, double>, std::pair<Quantities, Quantities>>;

// Every widened section against its full-wave run (60 px/µm), each printed as a line (once).
const Compared& compare_widened() {
    static const Compared compared = [] {
        auto totals = read_rows(reference_dir() / "widths_totals.csv", 5);
        auto sigma = read_sigma(reference_dir() / "widths_far_field.csv");
        totals.merge(read_rows(reference_dir() / "totals.csv", 5));
        sigma.merge(read_sigma(reference_dir() / "far_field.csv"));
        constexpr double kLambda = 550.0, kGrid = 60.0;
        Compared got;
        for (const Widened& w : widened())
            for (const double lambda : w.lambdas_nm)
                for (const std::string pol : {"TE", "TM"}) {
                    const Quantities fw =
                        full_wave_at(totals, sigma, {w.key(), pol, lambda, kGrid});
                    const Quantities po = hybrid(w.section, pol, lambda, w.step_um);
                    std::string name = w.label(w.name);
                    if (lambda != kLambda) name += fmt::format("@{:g}", lambda);
                    got[{name, pol, w.lateral}] = {po, fw};
                    std::string line =
                        fmt::format("{:<18} x{:g} {:+3g}° +{:g} µm {:g} nm {}", w.name, w.lateral,
                                    w.tilt_deg, w.raise_um, lambda, pol);
                    for (const Line& l : lines())
                        line += fmt::format("  {} {:+.1f} %", l.name,
                                            100.0 * relative_error({po, fw}, l.member));
                    std::printf("%s  lobe %+.1f°\n", line.c_str(), po.lobe_deg - fw.lobe_deg);
                }
        return got;
    }();
    return compared;
}

// Every quantity of issue 36's list within its target; the lobe within 2° when `lobe`.
void expect_within_every_target(const std::pair<Quantities, Quantities>& po_fw,
                                const std::string& what, bool lobe = true) {
    for (const Line& l : lines())
        EXPECT_LT(std::abs(relative_error(po_fw, l.member)), l.tolerance) << what << " " << l.name;
    if (lobe) {
        EXPECT_LE(std::abs(po_fw.first.lobe_deg - po_fw.second.lobe_deg), 2.0) << what;
    }
}

// The arc over its layer: σ_scat's miss shrinks with width, and at 3× the three widths are
// within target at 550 nm (the spike and back-scattered power are not: the drawn arc's window is
// in its fringe's dark half); at 450 nm the 3× section is within every target.
void expect_arc_misses_are_its_ends(const Compared& got, const std::string& pol) {
    const auto& arc1 = got.at({"film_over_melanin", pol, 1.0});
    const auto& arc2 = got.at({"film_over_melanin", pol, 2.0});
    const auto& arc3 = got.at({"film_over_melanin", pol, 3.0});
    const double scat[] = {relative_error(arc1, &Quantities::scattering),
                           relative_error(arc2, &Quantities::scattering),
                           relative_error(arc3, &Quantities::scattering)};
    EXPECT_GT(scat[0], 0.08) << pol << ": the 1× section misses σ_scat";
    EXPECT_LT(std::abs(scat[1]), std::abs(scat[0])) << pol;
    EXPECT_LT(std::abs(scat[2]), std::abs(scat[1])) << pol;
    for (const Line& l : lines()) {
        if (l.member == &Quantities::spike || l.member == &Quantities::back) continue;
        EXPECT_LT(std::abs(relative_error(arc3, l.member)), l.tolerance) << pol << " " << l.name;
    }
    expect_within_every_target(got.at({"film_over_melanin@450", pol, 3.0}), pol + " 450 nm 3×");
}

// The film flat over the layer: within every target at 3×, its spike within 10 % at 1×; turned
// by ±3°, ±6° or ±12° its TM spike misses by more than 20 % at 1×, and 3× long, turned by ±3°,
// its spike and back-scattered power are within target, lifted by 1 µm and turned by 0 or ±6°
// every quantity: the ends' miss, not the tilt's.
void expect_the_tilted_film_misses_the_spike_by_its_ends(const Compared& got,
                                                         const std::string& pol) {
    expect_within_every_target(got.at({"flat_film_over_melanin", pol, 3.0}),
                               pol + " flat film over the layer 3×");
    const auto& flat1 = got.at({"flat_film_over_melanin", pol, 1.0});
    EXPECT_LT(std::abs(relative_error(flat1, &Quantities::spike)), 0.10) << pol;
    double tilted_spike_miss = 0.0;
    for (const double tilt : {-12.0, -6.0, -3.0, 3.0, 6.0, 12.0})
        tilted_spike_miss =
            std::max(tilted_spike_miss,
                     std::abs(relative_error(
                         got.at({fmt::format("flat_film_over_melanin_tilt{:g}", tilt), pol, 1.0}),
                         &Quantities::spike)));
    if (pol == "TM") {
        EXPECT_GT(tilted_spike_miss, 0.2) << "the tilted film's spike";
    }
    for (const double tilt : {-3.0, 3.0}) {
        const auto& long_film =
            got.at({fmt::format("flat_film_over_melanin_tilt{:g}", tilt), pol, 3.0});
        EXPECT_LT(std::abs(relative_error(long_film, &Quantities::spike)), 0.15) << pol << tilt;
        EXPECT_LT(std::abs(relative_error(long_film, &Quantities::back)), 0.12) << pol << tilt;
    }
    // Lifted by 1 µm and turned through the 3× arc's slopes, the 3× film is within every target.
    for (const double tilt : {-6.0, 0.0, 6.0}) {
        const std::string name = tilt == 0.0
                                     ? "flat_film_over_melanin_raise1"
                                     : fmt::format("flat_film_over_melanin_tilt{:g}_raise1", tilt);
        expect_within_every_target(got.at({name, pol, 3.0}), pol + " " + name + " 3×");
    }
}

// The 3× arc over its layer lifted through one fringe of its specular window (kArcLiftsUm): the
// drawn arc sits in the fringe's dark half, where its spike and back-scattered power miss. Where
// the window is at least 0.8 × as bright as at the brightest lift, both are within target; at
// every lift the spike is within 15 % and the back-scattered power within 12 % of their
// brightest values (an error of a fixed size, large against a dim window), and σ_scat, σ_ext and
// σ_abs within their targets.
void expect_the_arcs_spike_misses_in_its_fringes_dark_half(const Compared& got,
                                                           const std::string& pol) {
    std::vector<double> lifts{0.0};
    std::vector<std::pair<Quantities, Quantities>> fringe{got.at({"film_over_melanin", pol, 3.0})};
    for (const double lift : kArcLiftsUm) {
        lifts.push_back(lift);
        fringe.push_back(got.at({fmt::format("film_over_melanin_raise{:g}", lift), pol, 3.0}));
    }
    double spike_max = 0.0, back_max = 0.0;
    for (const auto& [po, fw] : fringe) {
        spike_max = std::max(spike_max, fw.spike);
        back_max = std::max(back_max, fw.back);
    }
    EXPECT_LT(fringe[0].second.spike, 0.5 * spike_max) << pol << ": the drawn arc's window";
    for (std::size_t m = 0; m < fringe.size(); ++m) {
        const auto& [po, fw] = fringe[m];
        const std::string what = fmt::format("{} 3x lifted by {:g} µm", pol, lifts[m]);
        EXPECT_LT(std::abs(po.spike - fw.spike), 0.15 * spike_max) << what;
        EXPECT_LT(std::abs(po.back - fw.back), 0.12 * back_max) << what;
        if (fw.spike >= 0.8 * spike_max)
            expect_within_every_target(fringe[m], what + " (a bright window)");
        for (const Line& l : lines()) {
            if (l.member == &Quantities::spike || l.member == &Quantities::back) continue;
            EXPECT_LT(std::abs(relative_error(fringe[m], l.member)), l.tolerance)
                << what << " " << l.name;
        }
    }
}

// The arc over its layer 1× wide: its 550 nm spike misses by more than the target at every lift,
// not only in its fringe's dark half (the section's ends, as σ_scat's miss).
void expect_the_narrow_arcs_spike_misses_at_every_lift(const Compared& got,
                                                       const std::string& pol) {
    EXPECT_LT(relative_error(got.at({"film_over_melanin", pol, 1.0}), &Quantities::spike), -0.15)
        << pol;
    for (const double lift : kNarrowArcLiftsUm) {
        const auto& arc = got.at({fmt::format("film_over_melanin_raise{:g}", lift), pol, 1.0});
        EXPECT_LT(relative_error(arc, &Quantities::spike), -0.15) << pol << " lift " << lift;
    }
}

// The melanin ellipse 2× and 3× longer, still 1 µm thick: every power within target at 450, 550
// and 650 nm, the lobe within 2° at 550 and 650 nm (at 450 nm TM 3× it lies 2.5° off); at 1×
// σ_scat and σ_ext miss at 650 nm: its tips, 0.1 µm in radius.
void expect_ellipse_misses_are_its_tips(const Compared& got, const std::string& pol) {
    for (const double s : {2.0, 3.0})
        for (const std::string name :
             {"semi_transparent_body@450", "semi_transparent_body", "semi_transparent_body@650"})
            expect_within_every_target(got.at({name, pol, s}),
                                       fmt::format("{} {} x{:g}", pol, name, s),
                                       name != "semi_transparent_body@450");
}

// The free film from 12.8 µm on: σ_scat and σ_ext within 1.5 %, the spike within 15 %.
void expect_free_film_holds_once_wide(const Compared& got, const std::string& pol) {
    for (const double s : {2.0, 4.0}) {
        const auto& film = got.at({"free_flat_film", pol, s});
        EXPECT_LT(std::abs(relative_error(film, &Quantities::scattering)), 0.015) << pol << s;
        EXPECT_LT(std::abs(relative_error(film, &Quantities::extinction)), 0.015) << pol << s;
        EXPECT_LT(std::abs(relative_error(film, &Quantities::spike)), 0.15) << pol << s;
    }
}

TEST(PoTransmissionReference, WiderSectionsBringScatteringExtinctionAndAbsorptionWithinTarget) {
    const Compared& got = compare_widened();
    for (const std::string pol : {"TE", "TM"}) {
        expect_arc_misses_are_its_ends(got, pol);
        expect_the_tilted_film_misses_the_spike_by_its_ends(got, pol);
        expect_the_arcs_spike_misses_in_its_fringes_dark_half(got, pol);
        expect_the_narrow_arcs_spike_misses_at_every_lift(got, pol);
        expect_ellipse_misses_are_its_tips(got, pol);
        expect_free_film_holds_once_wide(got, pol);
    }
}

// Issue 36's acceptance 1 on sections wide enough for the level (README.md, "Issue 36's targets
// on the wide sections"): the arc over its layer 3× wide (19.2 µm over a layer 21 µm wide) and the
// melanin ellipse 2× long (10 × 1 µm), at 450, 550 and 650 nm in both polarisations. A quantity is
// within its target, or, on the arc only, in a "dim window": full wave's spike is below half the
// brightest of the arc lifted through the fringe of its specular window at that wavelength, and
// physical optics' spike and back-scattered power are then within 15 % and 12 % of that fringe's
// brightest values (its error has a fixed size, which a dim window makes large).
struct WideRow {
    std::string name, pol;
    double lambda;
    std::string quantity;
    double po, fw, target, window;  // window: full wave's spike / the fringe's brightest (or 1)
    std::string verdict;            // "yes", "dim window" or "no"
};

std::vector<WideRow> wide_rows() {
    const Compared& got = compare_widened();
    struct Wide {
        std::string name;
        double lateral;
    };
    const std::map<double, std::vector<double>> lifts{
        {550.0, {std::begin(kArcLiftsUm), std::end(kArcLiftsUm)}},
        {650.0, {std::begin(kArcLiftsAt650Um), std::end(kArcLiftsAt650Um)}}};
    std::vector<WideRow> out;
    for (const Wide& c : {Wide{"film_over_melanin", 3.0}, Wide{"semi_transparent_body", 2.0}})
        for (const std::string pol : {"TE", "TM"})
            for (const double lambda : ref::kLambdasNm) {
                const std::string at = lambda == 550.0 ? "" : fmt::format("@{:g}", lambda);
                const auto& po_fw = got.at({c.name + at, pol, c.lateral});
                const auto& [po, fw] = po_fw;
                double spike_max = fw.spike, back_max = fw.back;
                if (c.name == "film_over_melanin" && lifts.contains(lambda))
                    for (const double lift : lifts.at(lambda)) {
                        const auto& lifted = got.at(
                            {fmt::format("{}_raise{:g}{}", c.name, lift, at), pol, c.lateral});
                        spike_max = std::max(spike_max, lifted.second.spike);
                        back_max = std::max(back_max, lifted.second.back);
                    }
                const double window = fw.spike / spike_max;
                const bool dim = window < 0.5;
                if (dim) {
                    EXPECT_LT(std::abs(po.spike - fw.spike), 0.15 * spike_max) << pol << lambda;
                    EXPECT_LT(std::abs(po.back - fw.back), 0.12 * back_max) << pol << lambda;
                }
                const auto verdict = [dim](bool within) {
                    return within ? "yes" : dim ? "dim window" : "no";
                };
                const std::string name = fmt::format("{}_x{:g}", c.name, c.lateral);
                out.push_back({name, pol, lambda, "lobe_deg", po.lobe_deg, fw.lobe_deg, 2.0, window,
                               verdict(std::abs(po.lobe_deg - fw.lobe_deg) <= 2.0)});
                for (const Line& l : lines()) {
                    const bool within = std::abs(relative_error(po_fw, l.member)) <= l.tolerance;
                    out.push_back({name, pol, lambda, l.name, po.*l.member, fw.*l.member,
                                   l.tolerance, window, verdict(within)});
                }
            }
    return out;
}

TEST(PoTransmissionReference, TheWideSectionsMeetTheTargetsOutsideDimWindows) {
    const std::vector<WideRow> rows = wide_rows();
    std::string csv =
        "case,polarisation,lambda_nm,quantity,physical_optics,full_wave,target,window,"
        "verdict\n";
    int within = 0, dim = 0;
    for (const WideRow& r : rows) {
        csv += fmt::format("{},{},{:g},{},{:.4g},{:.4g},{:g},{:.2f},{}\n", r.name, r.pol, r.lambda,
                           r.quantity, r.po, r.fw, r.target, r.window, r.verdict);
        within += r.verdict == "yes" ? 1 : 0;
        dim += r.verdict == "dim window" ? 1 : 0;
        EXPECT_NE(r.verdict, "no") << r.name << " " << r.pol << " " << r.lambda << " " << r.quantity
                                   << ": physical optics " << r.po << ", full wave " << r.fw;
    }
    std::printf("%d of %zu within issue 36's targets; %d in a dim window\n", within, rows.size(),
                dim);
    const fs::path committed = reference_dir() / "check_wide.csv";
    if (std::getenv("PLUMAGE_WRITE_PO_CHECK")) std::ofstream(committed) << csv;
    std::ifstream in(committed);
    ASSERT_TRUE(in) << committed;
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_EQ(text.str(), csv) << "physical optics moved against full wave: rerun with "
                                  "PLUMAGE_WRITE_PO_CHECK=1 and explain it";
}

}  // namespace
}  // namespace plumage::sim::wave
