// Spongy keratin volumes: filling fractions, the channel spectrum's peak, determinism,
// parameter checks, .vdb input/output and the keratin/air mesh.
#include "geometry/spongy_volume.h"
#include "common/constants.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/tools/Interpolation.h>

#include "tests/test_util.h"

namespace plumage::geometry {
namespace {

using plumage::testing::input_error_message;

// Small volumes keep the fixture fast: 60³ voxels (1.2 µm box, 20 nm voxels) hold six
// periods of a = 0.2 µm.
ChannelVolumeParams small_channel(double f, std::uint64_t seed = 7) {
    ChannelVolumeParams p;
    p.length_scale_um = 0.2;
    p.keratin_fraction = f;
    p.box_um = 1.2;
    p.voxel_um = 0.02;
    p.seed = seed;
    return p;
}

SphereVolumeParams small_spheres(double f, std::uint64_t seed = 7) {
    SphereVolumeParams p;
    p.sphere_radius_um = 0.1;
    p.keratin_fraction = f;
    p.box_um = 1.2;
    p.voxel_um = 0.02;
    p.seed = seed;
    return p;
}

// Independent recount of the indicator: voxels of the box whose stored value is < 0.
double recount_keratin(const SpongyVolume& v) {
    auto accessor = v.level_set->getConstAccessor();
    long count = 0;
    for (int i = 0; i < v.voxels_per_side; ++i) {
        for (int j = 0; j < v.voxels_per_side; ++j) {
            for (int k = 0; k < v.voxels_per_side; ++k) {
                count += accessor.getValue(openvdb::Coord(i, j, k)) < 0.0f;
            }
        }
    }
    return static_cast<double>(count) / std::pow(static_cast<double>(v.voxels_per_side), 3);
}

// Every voxel value of the box and its margin, for exact comparisons.
std::vector<float> all_values(const openvdb::FloatGrid& grid, int n) {
    std::vector<float> values;
    auto accessor = grid.getConstAccessor();
    for (int i = -5; i < n + 5; ++i) {
        for (int j = -5; j < n + 5; ++j) {
            for (int k = -5; k < n + 5; ++k)
                values.push_back(accessor.getValue(openvdb::Coord(i, j, k)));
        }
    }
    return values;
}

// Volume enclosed by a closed, outward-wound mesh (divergence theorem).
double enclosed_volume(const TriangleMesh& mesh) {
    double volume = 0.0;
    for (const Triangle& t : mesh.triangles) {
        volume += mesh.positions[t[0]].dot(mesh.positions[t[1]].cross(mesh.positions[t[2]])) / 6.0;
    }
    return volume;
}

// ---------------------------------------------------------------------------------------

// "Within 2 %" is read as an absolute error of 0.02 in the fraction. The construction
// promises more, and that is asserted too: the channel threshold is the quantile, so the
// error is at most half a voxel (0.5/N³); random sequential addition stops at the sphere
// that brings the count closest, so the error is at most half a sphere's voxels.
TEST(SpongyVolume, ChannelVolumeHitsTheFillingFraction) {
    for (double f : {0.4, 0.5, 0.6}) {
        const SpongyVolume v = make_channel_volume(small_channel(f));
        const double voxels = std::pow(v.voxels_per_side, 3);
        std::printf("channel f = %.2f: measured %.7f (error %.2e)\n", f, v.keratin_fraction,
                    v.keratin_fraction - f);
        EXPECT_NEAR(v.keratin_fraction, f, 0.02);
        EXPECT_NEAR(v.keratin_fraction, f, 0.5 / voxels + 1e-15);
        EXPECT_EQ(recount_keratin(v), v.keratin_fraction);
    }
}

// The periodic keratin test (what full wave's slab asks): at every voxel centre it is the
// voxel's indicator, so its mean there is the measured fraction exactly; it repeats with the
// box; and at 20 000 random points its mean is the fraction within 4 binomial standard errors
// (interpolation between centres moves the boundary, not the volume, to first order).
TEST(SpongyVolume, PeriodicKeratinTestIsTheVolumeRepeated) {
    const SpongyVolume v = make_channel_volume(small_channel(0.5));
    const auto inside = periodic_keratin_test(*v.level_set);
    const int n = v.voxels_per_side;
    const double h = v.voxel_um, box = n * h;
    std::size_t at_centres = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k) {
                const Eigen::Vector3d c((i + 0.5) * h, (j + 0.5) * h, (k + 0.5) * h);
                const bool keratin = inside(c);
                at_centres += keratin ? 1 : 0;
                if (i == j && j == k) {
                    EXPECT_EQ(inside(c + Eigen::Vector3d(box, 0.0, 0.0)), keratin);
                    EXPECT_EQ(inside(c - Eigen::Vector3d(0.0, 3.0 * box, 0.0)), keratin);
                }
            }
    EXPECT_EQ(static_cast<double>(at_centres) / std::pow(n, 3), v.keratin_fraction);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0.0, box);
    const int samples = 20000;
    int hits = 0;
    for (int s = 0; s < samples; ++s) hits += inside({u(rng), u(rng), u(rng)}) ? 1 : 0;
    const double mean = static_cast<double>(hits) / samples;
    EXPECT_NEAR(mean, v.keratin_fraction, 4.0 * std::sqrt(0.25 / samples));
}

TEST(SpongyVolume, SphereVolumeHitsTheFillingFraction) {
    for (double f : {0.4, 0.5, 0.6}) {
        const SphereVolumeParams params = small_spheres(f);
        const SpongyVolume v = make_sphere_volume(params);
        const double voxels = std::pow(v.voxels_per_side, 3);
        const double r = params.sphere_radius_um;
        const double sphere_voxels =
            4.0 / 3.0 * std::numbers::pi * std::pow(r / params.voxel_um, 3);
        std::printf("sphere f = %.2f: measured %.7f (error %.2e), %zu spheres\n", f,
                    v.keratin_fraction, v.keratin_fraction - f, v.air_sphere_centres_um.size());
        EXPECT_NEAR(v.keratin_fraction, f, 0.02);
        EXPECT_NEAR(v.keratin_fraction, f, 0.5 * sphere_voxels / voxels);
        EXPECT_EQ(recount_keratin(v), v.keratin_fraction);

        // The voxel fraction against the continuous packing: Monte Carlo points outside
        // every sphere. 20000 points have a standard error √(f(1−f)/20000) <= 0.0036,
        // so 0.02 is 5.5 σ, with room for the voxelisation bias (measured differences are
        // 0.002–0.003, about one σ).
        const double box = v.box_um;
        const double separation = params.min_separation_diameters * 2.0 * r;
        std::mt19937_64 rng(12345);
        std::uniform_real_distribution<double> uniform(0.0, box);
        auto image = [&](double d) { return d - box * std::round(d / box); };
        int keratin = 0;
        const int points = 20000;
        for (int s = 0; s < points; ++s) {
            const Vec3 x(uniform(rng), uniform(rng), uniform(rng));
            bool in_air = false;
            for (const Vec3& c : v.air_sphere_centres_um) {
                const Vec3 d(image(x[0] - c[0]), image(x[1] - c[1]), image(x[2] - c[2]));
                if (d.squaredNorm() < r * r) {
                    in_air = true;
                    break;
                }
            }
            keratin += !in_air;
        }
        const double continuous = static_cast<double>(keratin) / points;
        std::printf("  continuous keratin fraction (Monte Carlo) %.4f\n", continuous);
        EXPECT_NEAR(continuous, v.keratin_fraction, 0.02);

        // The minimum centre separation holds between every pair (nearest image).
        double closest = box;
        const auto& c = v.air_sphere_centres_um;
        for (std::size_t a = 0; a < c.size(); ++a) {
            for (std::size_t b = a + 1; b < c.size(); ++b) {
                const Vec3 d(image(c[a][0] - c[b][0]), image(c[a][1] - c[b][1]),
                             image(c[a][2] - c[b][2]));
                closest = std::min(closest, d.norm());
            }
        }
        EXPECT_GE(closest, separation);
    }
}

// The thresholded shell field's indicator spectrum peaks at k0 = 2π/a: thresholding adds
// harmonics (odd Hermite orders only at f = 0.5) that are broad next to the shell. The
// shell width Δk = 2π/L is a/L of k0 (10 % and 10.4 % here), so the parabolic vertex,
// not the shell, is what can meet 5 %. The second case has L/a = 9.6, so k0 falls
// between shells.
TEST(SpongyVolume, ChannelSpectrumPeaksAtTheLengthScale) {
    struct Case {
        double a, box, voxel, f;
    };
    for (const Case& c : {Case{0.2, 2.0, 0.02, 0.5}, Case{0.25, 2.4, 0.025, 0.4}}) {
        ChannelVolumeParams p;
        p.length_scale_um = c.a;
        p.box_um = c.box;
        p.voxel_um = c.voxel;
        p.keratin_fraction = c.f;
        p.seed = 3;
        const auto start = std::chrono::steady_clock::now();
        const SpongyVolume v = make_channel_volume(p);
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const double k0 = kTwoPi / c.a;
        std::printf(
            "channel a = %.3f um, N = %d (%.2f s): peak length %.4f um (error %+.2f %%), "
            "peak k %.3f vs k0 %.3f\n",
            c.a, v.voxels_per_side, seconds, v.spectrum.peak_length_um,
            100.0 * (v.spectrum.peak_length_um / c.a - 1.0), v.spectrum.peak_wavenumber_per_um, k0);
        EXPECT_NEAR(v.spectrum.peak_length_um / c.a, 1.0, 0.05);
        EXPECT_NEAR(v.spectrum.peak_wavenumber_per_um / k0, 1.0, 0.05);
        EXPECT_NEAR(v.spectrum.shell_width_per_um, kTwoPi / c.box, 1e-12);
    }
}

TEST(SpongyVolume, SameSeedGivesTheSameGridAndOtherSeedsDoNot) {
    const int n = 60;
    const auto channel = all_values(*make_channel_volume(small_channel(0.5, 11)).level_set, n);
    EXPECT_EQ(all_values(*make_channel_volume(small_channel(0.5, 11)).level_set, n), channel);
    ChannelVolumeParams other_item = small_channel(0.5, 11);
    other_item.item = 1;
    for (const auto& other : {all_values(*make_channel_volume(small_channel(0.5, 12)).level_set, n),
                              all_values(*make_channel_volume(other_item).level_set, n)}) {
        // Two independent indicators at f = 0.5 disagree on half the voxels; with (L/a)³
        // = 216 correlation volumes the spread is about 0.5/√216 ≈ 0.034.
        // (Outside the box both are air, so only the box's N³ voxels can disagree.)
        long differ = 0;
        for (std::size_t i = 0; i < channel.size(); ++i)
            differ += (channel[i] < 0.0f) != (other[i] < 0.0f);
        const double box_voxels = std::pow(n, 3);
        const double disagreement = static_cast<double>(differ) / box_voxels;
        std::printf("channel: sign disagreement with another stream %.3f\n", disagreement);
        EXPECT_NEAR(disagreement, 0.5, 0.15);
    }
    const auto spheres = all_values(*make_sphere_volume(small_spheres(0.5, 11)).level_set, n);
    EXPECT_EQ(all_values(*make_sphere_volume(small_spheres(0.5, 11)).level_set, n), spheres);
    EXPECT_NE(all_values(*make_sphere_volume(small_spheres(0.5, 12)).level_set, n), spheres);
}

// The sphere level set is r − |x − c| of the nearest sphere image, clipped by the box
// (max with minus the distance to the nearest face), checked at voxels drawn at random
// against a brute-force search over all spheres and their images.
TEST(SpongyVolume, SphereLevelSetIsTheDistanceToTheSpheres) {
    const SphereVolumeParams params = small_spheres(0.5);
    const SpongyVolume v = make_sphere_volume(params);
    const double band = params.half_width_voxels * params.voxel_um;
    const double box = v.box_um;
    auto accessor = v.level_set->getConstAccessor();
    std::mt19937_64 rng(99);
    std::uniform_int_distribution<int> index(0, v.voxels_per_side - 1);
    int compared = 0;
    for (int s = 0; s < 2000; ++s) {
        const openvdb::Coord ijk(index(rng), index(rng), index(rng));
        const Vec3 x = (Vec3(ijk.x(), ijk.y(), ijk.z()) + Vec3::Constant(0.5)) * params.voxel_um;
        double phi = -1e9;
        for (const Vec3& c : v.air_sphere_centres_um) {
            Vec3 d = x - c;
            for (int a = 0; a < 3; ++a) d[a] -= box * std::round(d[a] / box);
            phi = std::max(phi, params.sphere_radius_um - d.norm());
        }
        const double to_face = std::min(x.minCoeff(), box - x.maxCoeff());
        phi = std::max(phi, -to_face);
        if (std::abs(phi) >= band) continue;
        ++compared;
        EXPECT_NEAR(accessor.getValue(ijk), phi, 1e-6) << ijk;
    }
    EXPECT_GT(compared, 1000);
}

// Quartiles of |∇φ| (central differences) over the voxels within one voxel of the
// surface, away from the box faces (where the clipping makes creases).
std::array<double, 3> gradient_quartiles(const SpongyVolume& v) {
    auto accessor = v.level_set->getConstAccessor();
    const double h = v.voxel_um;
    auto at = [&](int i, int j, int k) {
        return static_cast<double>(accessor.getValue(openvdb::Coord(i, j, k)));
    };
    std::vector<double> norms;
    for (int i = 2; i < v.voxels_per_side - 2; ++i) {
        for (int j = 2; j < v.voxels_per_side - 2; ++j) {
            for (int k = 2; k < v.voxels_per_side - 2; ++k) {
                if (std::abs(at(i, j, k)) >= h) continue;
                const Vec3 gradient(at(i + 1, j, k) - at(i - 1, j, k),
                                    at(i, j + 1, k) - at(i, j - 1, k),
                                    at(i, j, k + 1) - at(i, j, k - 1));
                norms.push_back(gradient.norm() / (2.0 * h));
            }
        }
    }
    std::sort(norms.begin(), norms.end());
    auto quantile = [&](double q) {
        return norms[static_cast<std::size_t>(q * static_cast<double>(norms.size() - 1))];
    };
    return {quantile(0.25), quantile(0.5), quantile(0.75)};
}

// Both level sets are distances near the surface (|∇φ| = 1), not just any function with
// the right zero set. Central differences of an exact distance read slightly below 1 on
// curved surfaces and well below at the sphere-type creases (where air spheres meet),
// hence the sphere's lower quartile (measured 0.80) is not bounded; the channel volume's
// redistanced band measured 0.96 / 1.01 / 1.05.
TEST(SpongyVolume, LevelSetsAreDistancesNearTheSurface) {
    const auto channel = gradient_quartiles(make_channel_volume(small_channel(0.5)));
    const auto spheres = gradient_quartiles(make_sphere_volume(small_spheres(0.5)));
    std::printf("|grad phi| quartiles: channel %.3f %.3f %.3f, sphere %.3f %.3f %.3f\n", channel[0],
                channel[1], channel[2], spheres[0], spheres[1], spheres[2]);
    EXPECT_NEAR(channel[1], 1.0, 0.05);
    EXPECT_GT(channel[0], 0.9);
    EXPECT_LT(channel[2], 1.1);
    EXPECT_NEAR(spheres[1], 1.0, 0.05);
    EXPECT_LE(spheres[2], 1.0 + 1e-6);  // r − |x − c| has |∇| = 1 exactly; differences shrink it
}

// ---------------------------------------------------------------------------------------

struct BadParameter {
    std::string key;
    std::function<void()> make;
};

TEST(SpongyVolume, RejectsBadParametersByName) {
    const double nan = std::nan("");
    const double inf = std::numeric_limits<double>::infinity();
    auto channel = [](std::function<void(ChannelVolumeParams&)> edit) {
        return [edit] {
            ChannelVolumeParams p = small_channel(0.5);
            edit(p);
            make_channel_volume(p);
        };
    };
    auto spheres = [](std::function<void(SphereVolumeParams&)> edit) {
        return [edit] {
            SphereVolumeParams p = small_spheres(0.5);
            edit(p);
            make_sphere_volume(p);
        };
    };
    const std::vector<BadParameter> cases = {
        {"length_scale_um", channel([](auto& p) { p.length_scale_um = 0.04; })},  // = 2 voxels
        {"length_scale_um", channel([](auto& p) { p.length_scale_um = 0.02; })},  // = 1 voxel
        {"length_scale_um", channel([](auto& p) { p.length_scale_um = 0.7; })},   // box < 2a
        {"length_scale_um", channel([&](auto& p) { p.length_scale_um = nan; })},
        {"keratin_fraction", channel([](auto& p) { p.keratin_fraction = 0.0; })},
        {"keratin_fraction", channel([](auto& p) { p.keratin_fraction = 1.0; })},
        {"keratin_fraction", channel([](auto& p) { p.keratin_fraction = -0.2; })},
        {"keratin_fraction", channel([&](auto& p) { p.keratin_fraction = nan; })},
        {"shell_relative_width", channel([](auto& p) { p.shell_relative_width = 0.0; })},
        {"shell_relative_width", channel([&](auto& p) { p.shell_relative_width = inf; })},
        {"box_um", channel([](auto& p) { p.box_um = 1.21; })},  // 60.5 voxels
        {"box_um", channel([&](auto& p) { p.box_um = inf; })},
        {"box_um", channel([](auto& p) { p.box_um = 20.0; })},  // 1000 voxels per side
        {"voxel_um", channel([](auto& p) { p.voxel_um = 0.0; })},
        {"voxel_um", channel([](auto& p) { p.voxel_um = -0.02; })},
        {"voxel_um", channel([&](auto& p) { p.voxel_um = nan; })},
        {"half_width_voxels", channel([](auto& p) { p.half_width_voxels = 0.5; })},
        {"sphere_radius_um", spheres([](auto& p) { p.sphere_radius_um = 0.02; })},  // = voxel
        {"sphere_radius_um", spheres([](auto& p) { p.sphere_radius_um = 0.01; })},
        {"sphere_radius_um", spheres([](auto& p) { p.sphere_radius_um = 0.4; })},  // > L/4
        {"sphere_radius_um", spheres([&](auto& p) { p.sphere_radius_um = nan; })},
        {"keratin_fraction", spheres([](auto& p) { p.keratin_fraction = 1.5; })},
        {"keratin_fraction", spheres([&](auto& p) { p.keratin_fraction = inf; })},
        {"min_separation_diameters", spheres([](auto& p) { p.min_separation_diameters = 0.0; })},
        {"min_separation_diameters", spheres([](auto& p) { p.min_separation_diameters = 2.5; })},
        {"min_separation_diameters", spheres([&](auto& p) { p.min_separation_diameters = nan; })},
        {"max_attempts", spheres([](auto& p) { p.max_attempts = 0; })},
        {"box_um", spheres([&](auto& p) { p.box_um = nan; })},
        {"voxel_um", spheres([&](auto& p) { p.voxel_um = inf; })},
    };
    for (const BadParameter& c : cases) {
        const std::string message = input_error_message(c.make);
        EXPECT_NE(message.find(c.key), std::string::npos) << c.key << ": " << message;
        EXPECT_NE(message.find("expected"), std::string::npos) << message;
    }
    // The two limits of the spectral peak say why.
    const std::string too_fine = input_error_message(cases[0].make);
    EXPECT_NE(too_fine.find("Nyquist"), std::string::npos) << too_fine;
    const std::string too_small_box = input_error_message(cases[2].make);
    EXPECT_NE(too_small_box.find("box_um"), std::string::npos) << too_small_box;
    EXPECT_NE(too_small_box.find("two periods"), std::string::npos) << too_small_box;
    std::printf("%s\n%s\n", too_fine.c_str(), too_small_box.c_str());
}

// Disjoint spheres (separation one diameter) jam near an air fraction of 0.38, so 0.8
// is out of reach; the message says what was reached.
TEST(SpongyVolume, UnreachableSphereFractionSaysWhatWasReached) {
    SphereVolumeParams p = small_spheres(0.2);
    p.min_separation_diameters = 1.0;
    p.max_attempts = 50000;
    const std::string message = input_error_message([&] { make_sphere_volume(p); });
    std::printf("%s\n", message.c_str());
    EXPECT_NE(message.find("unreachable"), std::string::npos) << message;
    EXPECT_NE(message.find("reached an air fraction of 0."), std::string::npos) << message;
    EXPECT_NE(message.find("keratin_fraction = 0.2"), std::string::npos) << message;
}

// ---------------------------------------------------------------------------------------

std::filesystem::path temporary_path(const std::string& name) {
    return std::filesystem::path(::testing::TempDir()) / name;
}

TEST(SpongyVolume, VdbRoundTripKeepsValuesAndMetadata) {
    const SpongyVolume v = make_sphere_volume(small_spheres(0.5));
    const auto path = temporary_path("spongy_round_trip.vdb");
    save_level_set(*v.level_set, path);
    // Nothing but the file itself is left behind.
    for (const auto& entry : std::filesystem::directory_iterator(path.parent_path())) {
        EXPECT_EQ(entry.path().string().find("spongy_round_trip.vdb.partial"), std::string::npos);
    }
    const openvdb::FloatGrid::Ptr loaded = load_level_set(path);
    EXPECT_EQ(all_values(*loaded, v.voxels_per_side), all_values(*v.level_set, v.voxels_per_side));
    EXPECT_EQ(loaded->activeVoxelCount(), v.level_set->activeVoxelCount());
    EXPECT_EQ(loaded->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_DOUBLE_EQ(loaded->voxelSize()[0], 0.02);
    EXPECT_EQ(loaded->transform(), v.level_set->transform());
    EXPECT_EQ(loaded->metaValue<std::string>("plumage_morphology"), "sphere");
    EXPECT_EQ(measure_keratin_fraction(*loaded), v.keratin_fraction);
    EXPECT_EQ(measure_power_spectrum(*loaded).power_um3, v.spectrum.power_um3);
    std::filesystem::remove(path);
}

TEST(SpongyVolume, VdbLoadErrorsNameTheFileAndGrid) {
    openvdb::initialize();
    const auto missing = temporary_path("spongy_no_such_file.vdb");
    std::string message = input_error_message([&] { load_level_set(missing); });
    EXPECT_NE(message.find(missing.string()), std::string::npos) << message;
    EXPECT_NE(message.find("no such file"), std::string::npos) << message;

    const auto text = temporary_path("spongy_not_a_vdb.vdb");
    std::ofstream(text) << "not a vdb file\n";
    message = input_error_message([&] { load_level_set(text); });
    EXPECT_NE(message.find(text.string()), std::string::npos) << message;
    EXPECT_NE(message.find("not a readable .vdb"), std::string::npos) << message;

    // A file with a fog volume named "density" and an Int32 grid named "keratin".
    auto fog = openvdb::FloatGrid::create(0.0f);
    fog->setName("density");
    fog->setGridClass(openvdb::GRID_FOG_VOLUME);
    fog->tree().setValue(openvdb::Coord(0, 0, 0), 1.0f);
    auto ints = openvdb::Int32Grid::create(0);
    ints->setName("keratin");
    const auto other = temporary_path("spongy_other_grids.vdb");
    openvdb::io::File(other.string()).write(openvdb::GridCPtrVec{fog, ints});

    message = input_error_message([&] { load_level_set(other, "air"); });
    EXPECT_NE(message.find(other.string()), std::string::npos) << message;
    EXPECT_NE(message.find("no grid named 'air'"), std::string::npos) << message;
    EXPECT_NE(message.find("'density'"), std::string::npos) << message;
    message = input_error_message([&] { load_level_set(other, "keratin"); });
    EXPECT_NE(message.find("'keratin'"), std::string::npos) << message;
    EXPECT_NE(message.find("expected a FloatGrid"), std::string::npos) << message;
    message = input_error_message([&] { load_level_set(other, "density"); });
    EXPECT_NE(message.find("'density'"), std::string::npos) << message;
    EXPECT_NE(message.find("expected a level set"), std::string::npos) << message;
    std::printf("%s\n", message.c_str());

    // Measurements need the box a plumage volume records in its metadata.
    fog->setGridClass(openvdb::GRID_LEVEL_SET);
    message = input_error_message([&] { measure_keratin_fraction(*fog); });
    EXPECT_NE(message.find("plumage_voxels_per_side"), std::string::npos) << message;

    // Saving into a folder that does not exist is an I/O error, and leaves nothing.
    EXPECT_THROW(save_level_set(*fog, temporary_path("no_such_folder") / "x.vdb"), IoError);
    std::filesystem::remove(text);
    std::filesystem::remove(other);
}

// ---------------------------------------------------------------------------------------

// What holds for the mesh of keratin ∩ box (adaptivity 0):
//  - closed and consistently wound: every directed edge (a, b) is matched by as many
//    (b, a), so there is no boundary, also where the periodic volume is cut by the box
//    faces (the cut faces are part of the surface), and no component is wound against
//    its neighbours;
//  - outward normals point into air: half a voxel along the normal from a face's
//    centroid the level set (trilinear) is positive. Not on every face: dual contouring
//    puts a crease cell's vertex at the mean of its edge crossings, up to ~0.3 voxel off
//    the surface, so faces along the box edges of the cut and (sphere-type) along the
//    circles where air spheres meet can fail. Measured: 1 face in 176 000 (channel) and
//    86 in 178 000 (sphere); 0–17 and 28–108 over 4 seeds × f = 0.4, 0.6; a reversed mesh
//    fails on nearly all. The bound is 0.1 %.
//  - the enclosed (signed) volume is the keratin volume, which also fixes the global
//    orientation: |V_mesh / L³ − f_voxels| <= 0.015. Both estimate the same body; the
//    mesh is biased low for the thinner phase, as a polyhedron with its vertices on a
//    convex surface is inscribed in it (features here have radii of 2–3 voxels), and low
//    along the box's edges, where crease cells cut the corner. Measured at L = 1.2 µm,
//    4 seeds: channel −0.012 (f = 0.4), −0.006 (0.5), −0.003 (0.6); sphere −0.006 to
//    +0.003; the seed-to-seed spread is below 0.001.
void expect_closed_and_facing_air(const SpongyVolume& v, const char* what) {
    const TriangleMesh mesh = level_set_to_mesh(*v.level_set);
    ASSERT_GT(mesh.triangles.size(), 1000u);
    std::unordered_map<std::uint64_t, int> directed;
    for (const Triangle& t : mesh.triangles) {
        for (int e = 0; e < 3; ++e) {
            const std::uint64_t a = t[e], b = t[(e + 1) % 3];
            ++directed[a << 32 | b];
        }
    }
    long unmatched = 0;
    for (const auto& [edge, count] : directed) {
        const std::uint64_t reverse = (edge & 0xffffffffu) << 32 | edge >> 32;
        const auto it = directed.find(reverse);
        unmatched += it == directed.end() || it->second != count;
    }
    EXPECT_EQ(unmatched, 0) << what;

    // The sampler keeps a reference to the accessor: it must outlive it.
    const openvdb::FloatGrid::ConstAccessor accessor = v.level_set->getConstAccessor();
    const openvdb::tools::GridSampler<openvdb::FloatGrid::ConstAccessor, openvdb::tools::BoxSampler>
        sampler(accessor, v.level_set->transform());
    auto sample = [&](const Vec3& x) { return sampler.wsSample(openvdb::Vec3d(x[0], x[1], x[2])); };
    const double step = 0.5 * v.voxel_um;
    long into_keratin = 0, faces = 0;
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        if (mesh.face_area(i) < 1e-12) continue;  // no normal
        const Triangle& t = mesh.triangles[i];
        const Vec3 centroid =
            (mesh.positions[t[0]] + mesh.positions[t[1]] + mesh.positions[t[2]]) / 3.0;
        into_keratin += !(sample(centroid + step * mesh.face_normal(i)) > 0.0f);
        ++faces;
    }
    const double mesh_fraction = enclosed_volume(mesh) / std::pow(v.box_um, 3);
    std::printf(
        "%s mesh: %zu triangles, %ld unmatched directed edges, %ld of %ld normals "
        "point into keratin, enclosed fraction %.5f vs voxels %.5f\n",
        what, mesh.triangles.size(), unmatched, into_keratin, faces, mesh_fraction,
        v.keratin_fraction);
    EXPECT_LE(into_keratin, faces / 1000) << what;
    EXPECT_NEAR(mesh_fraction, v.keratin_fraction, 0.015) << what;
    const auto bounds = mesh.bounds();
    for (int a = 0; a < 3; ++a) {
        EXPECT_GE(bounds[0][a], -1e-5) << what;
        EXPECT_LE(bounds[1][a], v.box_um + 1e-5) << what;
    }
}

TEST(SpongyVolume, MeshIsClosedAndItsNormalsPointIntoAir) {
    expect_closed_and_facing_air(make_channel_volume(small_channel(0.5)), "channel");
    expect_closed_and_facing_air(make_sphere_volume(small_spheres(0.5)), "sphere");
    // Adaptive meshing keeps the orientation; fewer polygons.
    const SpongyVolume v = make_channel_volume(small_channel(0.6));
    const TriangleMesh fine = level_set_to_mesh(*v.level_set, 0.0);
    const TriangleMesh coarse = level_set_to_mesh(*v.level_set, 0.5);
    const double coarse_fraction = enclosed_volume(coarse) / std::pow(v.box_um, 3);
    std::printf("adaptivity 0.5: %zu triangles (0: %zu), enclosed fraction %.5f vs voxels %.5f\n",
                coarse.triangles.size(), fine.triangles.size(), coarse_fraction,
                v.keratin_fraction);
    EXPECT_LT(coarse.triangles.size(), fine.triangles.size());
    EXPECT_NEAR(coarse_fraction, v.keratin_fraction, 0.02);
    EXPECT_NE(input_error_message([&] { level_set_to_mesh(*v.level_set, 1.5); }).find("adaptivity"),
              std::string::npos);
}

}  // namespace
}  // namespace plumage::geometry
