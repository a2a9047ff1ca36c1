// First-Born scattering tables: Born (RGD) against Mie as the contrast vanishes, phase
// function normalisation, the channel volume's medium, and the validity limits.
#include "sim/wave/volume/born_medium.h"
#include "common/constants.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/error.h"
#include "geometry/spongy_volume.h"
#include "sim/wave/volume/effective_index.h"
#include "sim/wave/volume/index_field.h"
#include "sim/wave/volume/mie.h"
#include "sim/wave/volume/structure_factor.h"
#include "tests/test_util.h"

namespace plumage::sim::wave {
namespace {

using Complex = std::complex<double>;

double sphere_form_factor(double u) {
    if (u < 1e-4) return 1.0 - u * u / 10.0;
    return 3.0 * (std::sin(u) - u * std::cos(u)) / (u * u * u);
}

TEST(WaveBorn, SingleSphereApproachesMieLinearlyInContrast) {
    // One sphere in vacuum, x = k a = 1.5: RGD through born_scattering with the spectrum
    // of one sphere per unit volume, S(q) = V² F(qa)², against Mie's Q_sca π a². The
    // first neglected Born term is O(m − 1) relative, so the difference halves with m − 1.
    const double lambda_nm = 500.0;
    const double k = 2.0 * kPi / (lambda_nm * 1e-3);
    const double a = 1.5 / k;
    const double volume = 4.0 / 3.0 * kPi * a * a * a;
    auto spectrum = [&](double q) {
        const double f = sphere_form_factor(q * a);
        return volume * volume * f * f;
    };
    double previous = 0.0;
    for (double dm : {0.08, 0.04, 0.02, 0.01}) {
        const Complex m(1.0 + dm, 0.0);
        const ScatteringTable born =
            born_scattering(spectrum, m * m - 1.0, Complex(1.0, 0.0), lambda_nm);
        const MieEfficiencies mie = mie_efficiencies(m, k * a);
        const double sigma_mie = mie.q_sca * kPi * a * a;
        const double difference = std::abs(born.mu_s_per_um / sigma_mie - 1.0);
        std::printf(
            "RGD vs Mie, x = 1.5, m - 1 = %.3f: sigma_RGD / sigma_Mie - 1 = %+.4e, g "
            "%.5f vs %.5f\n",
            dm, born.mu_s_per_um / sigma_mie - 1.0, born.g, mie.g);
        EXPECT_LT(difference, 2.0 * dm) << "m - 1 = " << dm;
        EXPECT_NEAR(born.g, mie.g, 2.0 * dm) << "m - 1 = " << dm;
        if (previous > 0.0) {
            EXPECT_NEAR(previous / difference, 2.0, 0.25) << "m - 1 = " << dm;
        }
        previous = difference;
    }
}

TEST(WaveBorn, SphereRouteIsDiluteMieWithoutCorrelations) {
    // S(q) = 1 (uncorrelated centres): μ_s = ρ Q_sca π a² and g = g_Mie, with Mie evaluated
    // in the effective medium (m = n_s / n_eff, x = k0 n_eff a). 512-point Gauss–Legendre
    // on a smooth integrand (x ≈ 1.6): agreement to ~1e-12.
    const optics::ConstantMaterial air("air", Complex(1.0, 0.0));
    const optics::ConstantMaterial keratin("keratin", Complex(1.56, 0.0));
    const double radius = 0.1, density = 0.05;  // φ = 2.1e-4
    const double lambda_nm = 550.0;
    const ScatteringTable t = sphere_medium(
        radius, density, air, keratin, [](double) { return 1.0; }, lambda_nm);
    const double phi = density * 4.0 / 3.0 * kPi * std::pow(radius, 3);
    const Complex n_eff = bruggeman_index(Complex(1.0, 0.0), Complex(1.56, 0.0), phi);
    EXPECT_EQ(t.n_eff, n_eff);
    const double x = 2.0 * kPi / (lambda_nm * 1e-3) * n_eff.real() * radius;
    const MieEfficiencies mie = mie_efficiencies(Complex(1.0 / n_eff.real(), 0.0), x);
    EXPECT_NEAR(t.mu_s_per_um, density * mie.q_sca * kPi * radius * radius, 1e-12 * t.mu_s_per_um);
    EXPECT_NEAR(t.g, mie.g, 1e-12);
    // Hard-sphere correlations (PY at the sphere fraction of a dense packing) suppress
    // forward scattering, so they lower μ_s and g.
    const double dense = 0.3 / (4.0 / 3.0 * kPi * std::pow(radius, 3));
    const ScatteringTable correlated = sphere_medium(
        radius, dense, air, keratin,
        [&](double q) { return percus_yevick_structure_factor(q, 2.0 * radius, 0.3); }, lambda_nm);
    const ScatteringTable uncorrelated = sphere_medium(
        radius, dense, air, keratin, [](double) { return 1.0; }, lambda_nm);
    EXPECT_LT(correlated.mu_s_per_um, uncorrelated.mu_s_per_um);
    EXPECT_LT(correlated.g, uncorrelated.g);
}

// The two routes on one hard-sphere packing (air spheres of radius a in a host of index
// n_h = 1 + Δn, volume fraction φ, Percus–Yevick centres): the Born route on the packing's
// exact indicator spectrum ρ V_s² F(qa)² S(q) with the full contrast ε_s − ε_h, and the
// sphere route (Mie in n_eff × S(q)). Returns μ_s(Born) / μ_s(sphere).
double born_over_sphere_route(double delta_n, double phi) {
    const double radius = 0.1, lambda_nm = 500.0;
    const double sphere_volume = 4.0 / 3.0 * kPi * std::pow(radius, 3);
    const double density = phi / sphere_volume;
    const optics::ConstantMaterial sphere("air", Complex(1.0, 0.0));
    const optics::ConstantMaterial host("host", Complex(1.0 + delta_n, 0.0));
    auto structure = [&](double q) { return percus_yevick_structure_factor(q, 2.0 * radius, phi); };
    auto spectrum = [&](double q) {
        const double f = sphere_form_factor(q * radius);
        return density * sphere_volume * sphere_volume * f * f * structure(q);
    };
    const Complex n_s = sphere.index(lambda_nm), n_h = host.index(lambda_nm);
    const ScatteringTable born =
        born_scattering(spectrum, n_s * n_s - n_h * n_h, bruggeman_index(n_s, n_h, phi), lambda_nm);
    const ScatteringTable spheres =
        sphere_medium(radius, density, sphere, host, structure, lambda_nm);
    EXPECT_EQ(born.n_eff, spheres.n_eff);  // the same background: only the contrast differs
    return born.mu_s_per_um / spheres.mu_s_per_um;
}

TEST(WaveBorn, RoutesDifferByTheSquaredDepletedContrastAtWeakContrast) {
    // born_medium.h: Born / sphere route = |ε_s − ε_h|² / |ε_s − ε_eff|² × (1 + O(Δn))
    // → 1 / (1 − φ)². The O(Δn) part has two first-order terms: Bruggeman's second-order
    // term (relative +(4φ/3) Δn here: δ = ε_s − ε_h ≈ −2Δn, ε_h ≈ 1) and Mie's departure
    // from RGD, O(m − 1) with a coefficient below 2 at x ≈ 1.3
    // (SingleSphereApproachesMieLinearlyInContrast). Bound: (4φ/3 + 2) Δn. (At this x they
    // nearly cancel: measured −0.012 Δn, so the Δn² term still shows above Δn ≈ 0.01; the
    // halving is checked below that, 2 ± 0.25 per halving.)
    const double phi = 0.3;
    double previous = 0.0;
    for (const double dn : {0.005, 0.0025, 0.00125, 0.000625, 0.0003125}) {
        const double ratio = born_over_sphere_route(dn, phi);
        const double error = ratio * (1.0 - phi) * (1.0 - phi) - 1.0;
        std::printf("phi %.2f, dn %.5f: Born/sphere %.6f, x (1 - phi)^2 - 1 = %+.3e\n", phi, dn,
                    ratio, error);
        EXPECT_LT(std::abs(error), (4.0 * phi / 3.0 + 2.0) * dn) << "dn = " << dn;
        if (previous != 0.0) {
            EXPECT_NEAR(previous / error, 2.0, 0.25) << "dn = " << dn;
        }
        previous = error;
    }
    // At Δn = 0.08 the limit still holds to a per mille (2.0419 against 1/(1 − φ)² = 2.0408):
    // the routes' contrast conventions, not Mie against Born, make the factor.
    EXPECT_NEAR(born_over_sphere_route(0.08, phi) * (1.0 - phi) * (1.0 - phi), 1.0,
                (4.0 * phi / 3.0 + 2.0) * 0.08);
    // φ → 0 at Δn = 10⁻³ (O(Δn) residue ~10⁻³): ratio − 1 = 2φ + 3φ² + …, so below 2.5 φ
    // for φ <= 0.1 and halving with φ (first order: 2 ± 0.25).
    previous = 0.0;
    for (const double p : {0.1, 0.05, 0.025, 0.0125}) {
        const double excess = born_over_sphere_route(1e-3, p) - 1.0;
        std::printf("dn 0.001, phi %.4f: Born/sphere - 1 = %+.4e (2 phi = %.4e)\n", p, excess,
                    2.0 * p);
        EXPECT_LT(std::abs(excess), 2.5 * p) << "phi = " << p;
        if (previous != 0.0) {
            EXPECT_NEAR(previous / excess, 2.0, 0.25) << "phi = " << p;
        }
        previous = excess;
    }
}

// Born / sphere route on a generated packing, through what the spongy study runs: disjoint air
// spheres (a = 0.1 µm = 5 voxels of 0.02 µm, φ = 0.3) in a box of side box_um, in a host of
// n = 1 + Δn (Δn = 0.04, 0.02, 0.01); first Born on the voxel indicator's measured spectrum, the
// sphere route on the measured S(q) of the centres. Returns ratio · (1 − φ)² − 1 at Δn = 0.01.
double generated_packing_offset(double box_um) {
    geometry::SphereVolumeParams p;
    p.sphere_radius_um = 0.1;
    p.min_separation_diameters = 1.0;
    p.keratin_fraction = 0.7;
    p.box_um = box_um;
    p.voxel_um = 0.02;
    const geometry::SpongyVolume v = geometry::make_sphere_volume(p);
    const IndicatorField field = sample_indicator(*v.level_set);
    const PowerSpectrum spectrum =
        PowerSpectrum::measure_3d(field.as_doubles(), field.voxels_per_side, field.voxel_um);
    const double box = v.box_um, a = p.sphere_radius_um;
    const double density = static_cast<double>(v.air_sphere_centres_um.size()) / std::pow(box, 3);
    const double phi = density * 4.0 / 3.0 * kPi * a * a * a;
    // The voxel spheres hold the true volume to 1e-3 here (φ_vox = φ), so no volume correction.
    EXPECT_NEAR(1.0 - field.filling_fraction(), phi, 2e-3);
    const MeasuredStructureFactor sq = measure_structure_factor(v.air_sphere_centres_um, box, 40.0);
    auto structure = [&sq](double q) { return sq.at(q); };
    const optics::ConstantMaterial air("air", Complex(1.0, 0.0));
    double offset = 0.0;
    for (const double dn : {0.04, 0.02, 0.01}) {
        const optics::ConstantMaterial host("host", Complex(1.0 + dn, 0.0));
        const ScatteringTable born = born_medium(spectrum, host, air, 600.0);
        const ScatteringTable spheres = sphere_medium(a, density, air, host, structure, 600.0);
        const double ratio = born.mu_s_per_um / spheres.mu_s_per_um;
        offset = ratio * (1.0 - phi) * (1.0 - phi) - 1.0;
        std::printf(
            "box %.1f um, phi %.4f, dn %.2f: Born/sphere %.4f, 1/(1 - phi)^2 %.4f (%+.2f %%)\n",
            box_um, phi, dn, ratio, 1.0 / ((1.0 - phi) * (1.0 - phi)), 100.0 * offset);
    }
    return offset;
}

TEST(WaveBorn, GeneratedPackingFollowsTheWeakContrastRatio) {
    // What remains at weak contrast follows the box's shell width Δq = 2π/L, as expected from
    // the tables' interpolation between shells: Born interpolates the shell means of
    // F(qa)² S(q) linearly in q, the sphere route those of S(q) alone and multiplies by the
    // exact F², so they differ by the interpolation error of F², O(Δq²) (measured −3.9 % at
    // L = 1.6 µm, −1.2 % at 3.2 µm). Bound: 2 % at 3.2 µm, and at least halving as L doubles
    // (second order would quarter it; the two packings differ too).
    const double coarse = generated_packing_offset(1.6);
    const double fine = generated_packing_offset(3.2);
    EXPECT_LT(std::abs(fine), 0.02);
    EXPECT_LT(std::abs(fine), 0.5 * std::abs(coarse));
}

TEST(WaveBorn, PhaseFunctionIsNormalised) {
    // A Lorentzian spectrum (an Ornstein–Zernike structure): the table integrates to 1 over
    // the sphere.
    auto spectrum = [](double q) { return 1.0 / (1.0 + 0.01 * q * q); };
    const ScatteringTable t =
        born_scattering(spectrum, Complex(1.4, 0.0), Complex(1.25, 0.0), 500.0, 2001);
    // Trapezoid over θ of p sinθ · 2π on the 2001-point table: O(Δθ²) ≈ 2e-6.
    double integral = 0.0;
    const double dtheta = kPi / static_cast<double>(t.cos_theta.size() - 1);
    for (std::size_t i = 0; i < t.cos_theta.size(); ++i) {
        const double w = (i == 0 || i + 1 == t.cos_theta.size()) ? 0.5 : 1.0;
        integral += w * t.phase_per_sr[i] * std::sin(dtheta * static_cast<double>(i)) * dtheta;
    }
    EXPECT_NEAR(2.0 * kPi * integral, 1.0, 1e-5);
    EXPECT_GT(t.mu_s_per_um, 0.0);
    EXPECT_EQ(t.mu_a_per_um, 0.0);  // lossless background
}

TEST(WaveBorn, ChannelVolumeMedium) {
    geometry::ChannelVolumeParams p;
    p.length_scale_um = 0.2;
    p.keratin_fraction = 0.5;
    p.box_um = 1.28;
    p.voxel_um = 0.02;
    const geometry::SpongyVolume v = geometry::make_channel_volume(p);
    const IndicatorField field = sample_indicator(*v.level_set);
    const PowerSpectrum s = PowerSpectrum::measure_3d(field.as_doubles(), 64, 0.02);
    const auto keratin = optics::keratin();
    const auto air = optics::air();
    // λ/(4 n_max) at 400 nm is 0.0645 µm: 20 nm voxels resolve the visible.
    double previous_mu = 0.0;
    for (double lambda : {400.0, 550.0, 700.0}) {
        const ScatteringTable t = born_medium(s, *keratin, *air, lambda);
        const Complex eps_k = keratin->index(lambda) * keratin->index(lambda);
        const Complex n_eff =
            bruggeman_index(keratin->index(lambda), Complex(1.0, 0.0), field.filling_fraction());
        EXPECT_EQ(t.n_eff, n_eff);
        EXPECT_GT(t.mu_s_per_um, 0.0);
        EXPECT_EQ(t.mu_a_per_um, 0.0);  // lossless keratin
        EXPECT_GE(t.g, -1.0);
        EXPECT_LE(t.g, 1.0);
        // Backscattering peaks where 2 k n_eff = q_peak; at 400–700 nm and a = 0.2 µm the
        // peak q ≈ 31 1/um lies between forward and backward q, so the phase function is
        // neither isotropic nor monotone: just check it is finite and positive.
        for (double value : t.phase_per_sr) EXPECT_GT(value, 0.0);
        std::printf(
            "channel medium, lambda %.0f nm: n_eff %.4f, mu_s %.4f 1/um, g %+.4f "
            "(eps_k %.4f)\n",
            lambda, t.n_eff.real(), t.mu_s_per_um, t.g, eps_k.real());
        if (previous_mu > 0.0) {
            EXPECT_NE(t.mu_s_per_um, previous_mu);
        }
        previous_mu = t.mu_s_per_um;
    }
}

TEST(WaveBorn, SphereVolumeReadBackFromVdbGivesTheSameTables) {
    // The route from an imported grid: a sphere-type volume written to .vdb and read back
    // (geometry/spongy_volume.h) gives bit-identical indicator and tables; a grid without the
    // box metadata (one from elsewhere) is refused, naming what it needs.
    geometry::SphereVolumeParams p;
    p.sphere_radius_um = 0.08;
    p.keratin_fraction = 0.5;
    p.box_um = 1.28;
    p.voxel_um = 0.02;
    const geometry::SpongyVolume v = geometry::make_sphere_volume(p);
    const std::filesystem::path file =
        std::filesystem::temp_directory_path() /
        ("plumage_wave_readback_" + std::to_string(::getpid()) + ".vdb");
    geometry::save_level_set(*v.level_set, file);
    const openvdb::FloatGrid::Ptr read = geometry::load_level_set(file);
    std::filesystem::remove(file);
    const IndicatorField a = sample_indicator(*v.level_set), b = sample_indicator(*read);
    ASSERT_EQ(a.keratin, b.keratin);
    EXPECT_EQ(a.voxel_um, b.voxel_um);
    const auto spectrum = [](const IndicatorField& f) {
        return PowerSpectrum::measure_3d(f.as_doubles(), f.voxels_per_side, f.voxel_um);
    };
    const ScatteringTable ta = born_medium(spectrum(a), *optics::keratin(), *optics::air(), 450.0);
    const ScatteringTable tb = born_medium(spectrum(b), *optics::keratin(), *optics::air(), 450.0);
    EXPECT_EQ(ta.mu_s_per_um, tb.mu_s_per_um);
    EXPECT_EQ(ta.phase_per_sr, tb.phase_per_sr);
    EXPECT_GT(ta.mu_s_per_um, 0.0);

    openvdb::FloatGrid::Ptr foreign = read->deepCopy();
    foreign->removeMeta("plumage_voxels_per_side");
    const std::string message = testing::input_error_message([&] { sample_indicator(*foreign); });
    EXPECT_NE(message.find("plumage_voxels_per_side"), std::string::npos) << message;
    EXPECT_NE(message.find("[0, N)^3"), std::string::npos) << message;
}

TEST(WaveBorn, AbsorbingKeratinGivesAbsorption) {
    const optics::ConstantMaterial lossy("lossy keratin", Complex(1.56, 0.01));
    const optics::ConstantMaterial air("air", Complex(1.0, 0.0));
    const int n = 32;
    std::vector<double> v(static_cast<std::size_t>(n) * n * n);
    for (std::size_t p = 0; p < v.size(); ++p) v[p] = (p / 7) % 2 == 0 ? 1.0 : 0.0;
    const PowerSpectrum s = PowerSpectrum::measure_3d(v, n, 0.02);
    const ScatteringTable t = born_medium(s, lossy, air, 550.0);
    const Complex n_eff =
        bruggeman_index(Complex(1.56, 0.01), Complex(1.0, 0.0), s.filling_fraction());
    EXPECT_NEAR(t.mu_a_per_um, 4.0 * kPi * n_eff.imag() / 0.55, 1e-12);
    EXPECT_GT(t.mu_a_per_um, 0.0);
}

TEST(WaveBorn, RefusesOutsideItsValidity) {
    using plumage::testing::input_error_message;
    const auto keratin = optics::keratin();
    const auto air = optics::air();
    const int n = 16;
    // No contrast: a volume that is all keratin.
    const PowerSpectrum full =
        PowerSpectrum::measure_3d(std::vector<double>(n * n * n, 1.0), n, 0.02);
    EXPECT_NE(input_error_message([&] { born_medium(full, *keratin, *air, 550.0); }).find("f = 1"),
              std::string::npos);
    // Equal indices.
    std::vector<double> half(n * n * n);
    for (std::size_t p = 0; p < half.size(); ++p) half[p] = p % 2 == 0 ? 1.0 : 0.0;
    const PowerSpectrum mixed = PowerSpectrum::measure_3d(half, n, 0.02);
    const optics::ConstantMaterial a("a", Complex(1.5, 0.0)), b("b", Complex(1.5, 0.0));
    EXPECT_NE(input_error_message([&] { born_medium(mixed, a, b, 550.0); }).find("same index"),
              std::string::npos);
    // Voxels too coarse: λ/(4 n_max) at 400 nm for keratin (n ≈ 1.569) is 0.0637 µm.
    const PowerSpectrum coarse = PowerSpectrum::measure_3d(half, n, 0.08);
    const std::string message =
        input_error_message([&] { born_medium(coarse, *keratin, *air, 400.0); });
    EXPECT_NE(message.find("voxel_um = 0.08"), std::string::npos) << message;
    EXPECT_NE(message.find("lambda / (4 n_max)"), std::string::npos) << message;
}

TEST(WaveIndexField, ContrastAndLimits) {
    geometry::SphereVolumeParams p;
    p.sphere_radius_um = 0.05;
    p.keratin_fraction = 0.6;
    p.box_um = 0.8;
    p.voxel_um = 0.02;
    const geometry::SpongyVolume v = geometry::make_sphere_volume(p);
    const IndicatorField field = sample_indicator(*v.level_set);
    EXPECT_DOUBLE_EQ(field.filling_fraction(), v.keratin_fraction);
    const auto keratin = optics::keratin();
    const auto air = optics::air();
    const ContrastField c = index_contrast(field, *keratin, *air, 550.0);
    // Δε has zero mean to first order (Bruggeman ≈ linear average for small contrast); its
    // mean is f ε_k + (1 − f) ε_a − ε_eff, the (positive) gap between the parallel
    // average and Bruggeman.
    Complex mean(0.0, 0.0);
    for (const Complex& d : c.delta_eps) mean += d;
    mean /= static_cast<double>(c.delta_eps.size());
    const double f = c.filling_fraction;
    EXPECT_NEAR(mean.real(), (f * c.eps_keratin + (1.0 - f) * c.eps_air - c.eps_eff).real(), 1e-12);
    EXPECT_GT(mean.real(), 0.0);
    // Voxel limit at short wavelengths: 20 nm voxels fail below λ = 4 · 1.6 · 20 nm ≈ 126 nm;
    // keratin's Cauchy law is accepted there, so the voxel limit is what refuses.
    EXPECT_THROW(index_contrast(field, *keratin, *air, 100.0), InputError);
    openvdb::FloatGrid bare;
    EXPECT_THROW(sample_indicator(bare), InputError);
}

}  // namespace
}  // namespace plumage::sim::wave
