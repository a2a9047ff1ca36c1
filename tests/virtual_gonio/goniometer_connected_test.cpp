// The goniometer's connected lights (virtual_gonio/goniometer.h, connect_lights; sim/tracer.h,
// "Connections to collimated lights"): a white plate, whose every path both sides make, reads
// albedo/π mounted or not (a white furnace at albedo 1), and with the balance heuristic's weight
// on either side (many walks per quantum, or many quanta per walk); on the rock-dove barbule row,
// on a plate that a keratin sphere partly shadows and on a scattering slab, the two halves
// together agree with the plain forward walk cell by cell (on the row lobe by lobe too) (χ² per
// wavelength, largest |z| within the Šidák bound), with the same bits on 1 and 2 threads and after
// a resumed interruption; bad combinations are refused by name.
#include <omp.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/metrics/statistics.h"
#include "analysis/models/lambertian.h"
#include "common/constants.h"
#include "common/error.h"
#include "sim/optics/material.h"
#include "sim/scatterer/mounted_scatterer.h"
#include "sim/tracer.h"
#include "tests/sim/scattering_slab_example.h"
#include "tests/sim/sim_test_util.h"
#include "tests/sim/small_barbule_row.h"
#include "tests/virtual_gonio/record_agreement.h"
#include "virtual_gonio/goniometer.h"

namespace plumage::gonio {
namespace {

const std::vector<double> kSeven = {400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0};

// One pair per light and per view of the Filip set (light i with view i, 60 pairs): each cell its
// own quanta on both sides, so that cells are independent. (A view's walks serve all of its
// lights at once, and a light's quanta all of its views, so cells that share either are
// correlated, which a χ² over cells does not allow.)
std::vector<DirectionPair> independent_pairs() {
    const std::vector<DirectionPair> all = filip2024_btf_pairs();  // light-major, 61 × 60
    std::vector<DirectionPair> pairs;
    for (std::size_t i = 0; i < 60; ++i) pairs.push_back(all[i * 60 + i]);
    return pairs;
}

GoniometerConfig connected_config(const std::vector<double>& wavelengths) {
    GoniometerConfig c;
    c.pairs = independent_pairs();
    c.wavelengths_nm = wavelengths;
    c.detector_half_angle_rad = 8.0 * kDeg;
    c.beam_radius_um = 20.0;
    c.estimator = Estimator::photon;
    c.share_wavelength_paths = true;
    c.split_paths = true;
    c.connect_lights = true;
    c.seed = 5;
    c.quanta_per_pass = 6000;
    c.max_passes = 1;
    return c;
}

// Every cell's z against the truth: per wavelength (one walk serves them all) χ² at 0.1 %/nλ, and
// the largest |z| within Šidák's 1 % bound; and per wavelength the cells' mean (independent cells)
// within its error at 1 %/nλ, which sees a bias of a few per cent that the χ² over single cells
// would not.
void expect_cells_read(const BrdfRecord& r, const std::vector<double>& truth,
                       const std::string& what) {
    const std::size_t nl = r.config.wavelengths_nm.size();
    std::vector<double> chi2(nl, 0.0), sum(nl, 0.0), variance(nl, 0.0);
    double max_z = 0.0;
    for (std::size_t i = 0; i < r.value.size(); ++i) {
        ASSERT_GT(r.standard_error[i], 0.0) << what << " cell " << i;
        ASSERT_TRUE(std::isfinite(r.standard_error[i])) << what << " cell " << i;
        const double z = (r.value[i] - truth[i % nl]) / r.standard_error[i];
        chi2[i % nl] += z * z;
        sum[i % nl] += r.value[i] - truth[i % nl];
        variance[i % nl] += r.standard_error[i] * r.standard_error[i];
        max_z = std::max(max_z, std::abs(z));
    }
    const auto dof = static_cast<int>(r.value.size() / nl);
    const double pooled_bound = analysis::two_sided_normal_quantile(0.01 / static_cast<double>(nl));
    for (std::size_t k = 0; k < nl; ++k) {
        EXPECT_GT(analysis::chi_square_p_value(chi2[k], dof), 1e-3 / static_cast<double>(nl))
            << what << ' ' << r.config.wavelengths_nm[k] << " nm: chi2/dof " << chi2[k] / dof;
        ::testing::Test::RecordProperty(what + "_chi2_per_dof_" + std::to_string(k),
                                        std::to_string(chi2[k] / dof));
        EXPECT_LT(std::abs(sum[k]) / std::sqrt(variance[k]), pooled_bound)
            << what << ' ' << r.config.wavelengths_nm[k] << " nm: mean of the cells off by "
            << sum[k] / dof;
    }
    const auto cells = static_cast<int>(r.value.size());
    EXPECT_LT(max_z, analysis::two_sided_normal_quantile(analysis::sidak_significance(0.01, cells)))
        << what;
}

// The plain shared walk (no splitting, no connections) with more quanta, the reference: a cell
// with few hits reads low and precise at once, which a Wald z misreads, so it gets more hits.
GoniometerConfig plain_walk(const std::vector<double>& wavelengths, std::uint64_t seed,
                            std::uint64_t quanta) {
    GoniometerConfig c = connected_config(wavelengths);
    c.split_paths = false;
    c.connect_lights = false;
    c.seed = seed;
    c.quanta_per_pass = quanta;
    return c;
}

// A connected record against the plain walk's, cell by cell: per wavelength χ² at 0.1 %/nλ
// (at least min_dof cells each), and the largest |z| within Šidák's 1 % bound.
void expect_agreement(const BrdfRecord& r, const BrdfRecord& plain, int min_dof) {
    const std::vector<double>& lambdas = r.config.wavelengths_nm;
    const testing::RecordAgreement agreement = testing::compare_per_wavelength(r, plain);
    for (std::size_t k = 0; k < lambdas.size(); ++k) {
        const int dof = agreement.dof[k];
        ASSERT_GT(dof, min_dof);
        ::testing::Test::RecordProperty("chi2_per_dof_" + std::to_string(k),
                                        std::to_string(agreement.chi2[k] / dof));
        EXPECT_GT(analysis::chi_square_p_value(agreement.chi2[k], dof),
                  1e-3 / static_cast<double>(lambdas.size()))
            << lambdas[k] << " nm: chi2/dof " << agreement.chi2[k] / dof;
    }
    ::testing::Test::RecordProperty("max_z", std::to_string(agreement.max_z));
    EXPECT_LT(agreement.max_z, analysis::two_sided_normal_quantile(
                                   analysis::sidak_significance(0.01, agreement.cells)));
}

TEST(ConnectedGoniometer, WhitePlateReadsAlbedoOverPiWhicheverSideCarriesIt) {
    // At 650 nm a white furnace: albedo 1, every cell 1/π, so ∫ f cos θ dω = 1 (nothing lost).
    const std::vector<double> albedo = {0.3, 0.6, 1.0};
    const std::vector<double> lambdas = {450.0, 550.0, 650.0};
    const auto plate = std::make_shared<sim::ExplicitScatterer>(sim::single_mesh_scene(
        testing::square_mesh(300.0), sim::diffuse_layer([](double lambda_nm) {
            return lambda_nm < 500.0 ? 0.3 : lambda_nm < 600.0 ? 0.6 : 1.0;
        }),
        "plate"));
    GoniometerConfig c = connected_config(lambdas);
    c.quanta_per_pass = 2000;
    c.connected_quanta_per_pass = 4000;
    std::vector<double> truth;
    for (double a : albedo) truth.push_back(a / kPi);
    const BrdfRecord r = measure_brdf(*plate, c);
    EXPECT_TRUE(r.lights_connected);
    expect_cells_read(r, truth, "plate");
    // No lobe but "multi" (a lone diffuse event) carries anything, and with two walks per quantum
    // the connections carry nearly all of it (w_D ≈ 0.97 here): errors of a few per cent.
    const std::size_t cells = r.value.size();
    for (std::size_t i = 0; i < cells; ++i) {
        EXPECT_EQ(r.lobe_values[sim::ExplicitScatterer::kMulti * cells + i], r.value[i]);
        EXPECT_LT(r.standard_error[i], 0.05 * r.value[i]) << i;
    }
    // Mounted at 40°: the same plate, both sides' points turned back into the instrument's frame.
    const MountedScatterer mounted(plate, 40.0 * kDeg);
    expect_cells_read(measure_brdf(mounted, c), truth, "mounted_plate");
    // 400 quanta per walk: the light side's weight n_L ρ / (n_L ρ + n_D) is about 0.9 where the
    // footprints overlap, so the light side carries most of the value; weights that did not add
    // to 1 would move the cells with this ratio. Ten passes, so that the detector side has ten
    // blocks to take its variance from.
    GoniometerConfig light_heavy = c;
    light_heavy.quanta_per_pass = 2000;
    light_heavy.connected_quanta_per_pass = 5;
    light_heavy.max_passes = 10;
    expect_cells_read(measure_brdf(*plate, light_heavy), truth, "plate_light_side_heavy");
    expect_cells_read(measure_brdf(mounted, light_heavy), truth, "mounted_plate_light_side_heavy");
}

TEST(ConnectedGoniometer, AgreesWithTheForwardWalkOnTheBarbuleRow) {
    const sim::ExplicitScatterer patch = testing::small_barbule_row();
    const int before = omp_get_max_threads();
    omp_set_num_threads(2);
    const BrdfRecord plain = measure_brdf(patch, plain_walk(kSeven, 4, 30000));
    const GoniometerConfig c = connected_config(kSeven);
    const BrdfRecord r = measure_brdf(patch, c);
    ASSERT_TRUE(r.lights_connected);
    expect_agreement(r, plain, 40);
    const std::size_t nl = kSeven.size();
    // The TRT lobe, which the connections carry whole here, the same way, per wavelength.
    const std::size_t cells = r.value.size();
    std::vector<double> trt_chi2(nl, 0.0);
    std::vector<int> trt_dof(nl, 0);
    for (std::size_t i = 0; i < cells; ++i) {
        const std::size_t at = sim::ExplicitScatterer::kTRT * cells + i;
        const double var =
            std::pow(r.lobe_standard_error[at], 2) + std::pow(plain.lobe_standard_error[at], 2);
        if (!(var > 0.0)) continue;
        trt_chi2[i % nl] += std::pow(r.lobe_values[at] - plain.lobe_values[at], 2) / var;
        ++trt_dof[i % nl];
    }
    for (std::size_t k = 0; k < nl; ++k) {
        ASSERT_GT(trt_dof[k], 40);
        RecordProperty("trt_chi2_per_dof_" + std::to_string(k),
                       std::to_string(trt_chi2[k] / trt_dof[k]));
        EXPECT_GT(analysis::chi_square_p_value(trt_chi2[k], trt_dof[k]),
                  1e-3 / static_cast<double>(nl))
            << kSeven[k] << " nm: TRT chi2/dof " << trt_chi2[k] / trt_dof[k];
    }
    // The same bits on one thread.
    omp_set_num_threads(1);
    const BrdfRecord one = measure_brdf(patch, c);
    omp_set_num_threads(before);
    EXPECT_EQ(one.value, r.value);
    EXPECT_EQ(one.standard_error, r.standard_error);
    EXPECT_EQ(one.lobe_values, r.lobe_values);
}

// A plate under a film in air with a keratin sphere between them, under the beam: light reaches
// the plate straight through the film (the connections' part), or refracted by the sphere (the
// quanta's), and the sphere blocks connections. The halves must still add to the plain walk.
TEST(ConnectedGoniometer, AgreesWithTheForwardWalkWhereADielectricShadowsThePlate) {
    sim::SceneDescription scene;
    sim::UnitMesh unit{"film, sphere and plate", {}};
    unit.surfaces.push_back({"film", testing::square_mesh(300.0, 40.0),
                             sim::thin_film_interface(optics::keratin(), 0.6)});
    unit.surfaces.push_back({"sphere", testing::sphere_mesh(15.0, 4, {0.0, 0.0, 15.0}),
                             sim::dielectric_interface(optics::keratin())});
    unit.surfaces.push_back({"plate", testing::square_mesh(1000.0, 0.0),
                             sim::diffuse_layer(sim::constant_albedo(0.7))});
    scene.units.push_back(std::move(unit));
    scene.instances.push_back({0, Eigen::Affine3d::Identity()});
    const sim::ExplicitScatterer patch(std::move(scene));
    const std::vector<double> lambdas = {450.0, 550.0, 650.0};
    expect_agreement(measure_brdf(patch, connected_config(lambdas)),
                     measure_brdf(patch, plain_walk(lambdas, 8, 20000)), 50);
}

// A scattering slab (a medium behind a bare interface, no diffuse surface): no connection can
// be made, so the light side carries every path with weight 1 and must equal the plain walk.
TEST(ConnectedGoniometer, AgreesWithTheForwardWalkOnAScatteringSlab) {
    const sim::ExplicitScatterer slab = testing::henyey_greenstein_slab();
    const std::vector<double> lambdas = {450.0, 550.0, 650.0};
    // More quanta than on the row: the slab's cells are sums of few heavy paths (its bare
    // interface and the medium's hero walks), and a cell of few hits reads low and precise at
    // once, which a Wald z misreads.
    GoniometerConfig c = connected_config(lambdas);
    c.quanta_per_pass = 20000;
    const BrdfRecord r = measure_brdf(slab, c);
    EXPECT_TRUE(r.lights_connected);
    expect_agreement(r, measure_brdf(slab, plain_walk(lambdas, 9, 40000)), 50);
}

TEST(ConnectedGoniometer, AnInterruptedRunResumesToTheSameBits) {
    const auto dir = std::filesystem::temp_directory_path() /
                     ("plumage_connected_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const sim::ExplicitScatterer patch = testing::small_barbule_row();
    GoniometerConfig c = connected_config({450.0, 650.0});
    c.quanta_per_pass = 500;
    c.connected_quanta_per_pass = 300;
    c.max_passes = 3;
    const BrdfRecord uninterrupted = measure_brdf(patch, c);
    RunControl control;
    control.checkpoint = dir / "brdf.h5.checkpoint";
    std::atomic<bool> stop{false};
    control.interrupt = &stop;
    control.on_pass = [&](const ConvergenceRow& row) {
        if (row.pass == 1) stop = true;
    };
    const BrdfRecord first = measure_brdf(patch, c, control);
    EXPECT_TRUE(first.interrupted);
    EXPECT_EQ(first.passes, 1);
    stop = false;
    control.on_pass = nullptr;
    const BrdfRecord resumed = measure_brdf(patch, c, control);
    EXPECT_EQ(resumed.passes, 3);
    EXPECT_EQ(resumed.value, uninterrupted.value);
    EXPECT_EQ(resumed.lobe_standard_error, uninterrupted.lobe_standard_error);
    std::filesystem::remove_all(dir);
}

TEST(ConnectedGoniometer, RefusesWhatItCannotConnect) {
    const sim::ExplicitScatterer patch = testing::small_barbule_row();
    auto refused = [&](const Scatterer& scatterer, const GoniometerConfig& c) {
        try {
            measure_brdf(scatterer, c);
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    GoniometerConfig cones = connected_config({550.0});
    cones.aperture = Aperture::both_cones;
    EXPECT_NE(refused(patch, cones).find("connect_lights with aperture both_cones"),
              std::string::npos);
    GoniometerConfig point = connected_config({550.0});
    point.beam_radius_um = 0.0;
    EXPECT_NE(refused(patch, point).find("beam radius 0 um"), std::string::npos);
    GoniometerConfig separate = connected_config({450.0, 550.0});
    separate.share_wavelength_paths = false;
    EXPECT_NE(refused(patch, separate).find("does not share its wavelengths' paths"),
              std::string::npos);
    const analysis::LambertianScatterer model(0.5);
    EXPECT_NE(refused(model, connected_config({550.0})).find("cannot connect to lights"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::gonio
