// Measured BRDFs in the RGL tensor layout (".bsdf"): the files of the RGL material database
// (Dupuy & Jakob 2018, "An Adaptive Parameterization for Efficient Material Acquisition and
// Rendering", ACM TOG 37(6)) that Mitsuba 3's `measured` BSDF and pbrt-v4's "measured"
// material load. We write any evaluable BRDF (an analytic Scatterer, or a function) in that
// layout, read such files back, and evaluate them the way Mitsuba 3's `measured` plugin does.
//
// The container (a "tensor file", little-endian):
//   "tensor_file\0" (12 bytes) | version: uint8 major = 1, uint8 minor = 0 | uint32 field count
//   per field: uint16 name length | name bytes | uint16 rank | uint8 dtype | uint64 offset of
//              the data from the start of the file | rank × uint64 extents (slowest first)
//   then the fields' data, C order (last index contiguous). dtype codes (Mitsuba's
//   Struct::Type): 1 uint8, 2 int8, 3 uint16, 4 int16, 5 uint32, 6 int32, 7 uint64, 8 int64,
//   9 float16, 10 float32, 11 float64. We write data at 8-byte aligned offsets.
//
// The fields of a measured BRDF (names, dtypes and shapes as both readers check them):
//   description  uint8   [n]                      free text
//   jacobian     uint8   [1]                      1: spectra is divided by ndf/(4 σ), see below
//   theta_i      float32 [n_θ]                    elevation nodes of the parameter direction, rad
//   phi_i        float32 [n_φ]                    azimuth nodes, rad; n_φ ≤ 2: isotropic
//   wavelengths  float32 [n_λ]                    nm
//   ndf          float32 [H_d, W_d]               D(ω_m), 1/sr, on the unit square u_m
//   sigma        float32 [H_d, W_d]               σ(ω) = ∫ D(m) ⟨ω, m⟩⁺ dm, on u(ω)
//   vndf         float32 [n_φ, n_θ, H_v, W_v]     density of u_m given the parameter direction
//   luminance    float32 [n_φ, n_θ, N, N]         sampling density on the sample square
//   spectra      float32 [n_φ, n_θ, n_λ, N, N]    the BRDF, on the sample square
// A direction (θ, φ) maps to the unit square u = (√(2θ/π), (φ + π)/(2π)); 2D tables put u.x
// (θ) along the last, contiguous axis. All tables are bilinear interpolants over uniform
// nodes k/(W − 1) of the unit square, and linear in θ_i, φ_i and λ between their nodes
// (clamped outside).
//
// Evaluation (Mitsuba 3, `measured::eval`; ω_v the parameter direction, ω_l the other, both
// in the upper hemisphere): ω_m = (ω_v + ω_l)/|ω_v + ω_l|; u_m from ω_m's (θ_m, φ_m), with
// φ_m − φ_v in place of φ_m when isotropic (wrapped into [0, 1)); s = the inverse of the vndf
// warp at u_m for the parameters (φ_v, θ_v) — the sample square coordinate whose forward warp
// lands on u_m; then
//   q(ω_v, ω_l, λ) = spectra(s; φ_v, θ_v, λ) · ndf(u_m) / (4 σ(u(ω_v)))   (jacobian = 1).
// Mitsuba's eval returns q as f · cos θ of its `wo` (the light side; its `si.wi` is the
// parameter direction, towards the viewer when tracing from the camera). In our convention
// (sim/scatterer/scatterer.h: ω_i towards the light, ω_o towards the detector, f without cosine):
//   q(ω_v = ω_o, ω_l = ω_i, λ) = f(ω_i, ω_o, λ) · cos θ_i.
// So the parameter grid runs over the VIEW direction ω_o, which keeps non-reciprocal models
// (Huang's TRT lobe) right in a path tracer that starts at the camera. The vndf warp is the
// continuous piecewise-bilinear marginal/conditional inversion of Mitsuba's Marginal2D
// (BilinearWarp2D below, implemented from its mathematics: the exact inverse CDF of the
// bilinear interpolant, rows first); the file only means what it means through that warp.
//
// What we write (RglBsdfSettings below):
//  - NDF: Dupuy & Jakob's retro-reflection estimate. Under a Smith-like microfacet model the
//    retro-reflection is f(ω, ω) ≈ F D(ω) / (4 cos θ σ(ω)), so D(ω) ∝ f(ω, ω) cos θ σ[D](ω):
//    D is the leading eigenfunction of that linear operator, found by power iteration with
//    σ by quadrature and D normalised to ∫ D cos θ_m dm = 1. Then a fraction ndf_floor of the
//    cosine NDF 1/π is mixed in so that D > 0 everywhere: the warp collapses zero-density
//    regions onto one point, and there the table could not hold the diffuse part of f (Huang's
//    TRT, Lambert). Any positive NDF gives a correct file (spectra = q · 4σ / D compensates);
//    the estimate decides where the sample square's nodes fall, i.e. how well sharp lobes are
//    resolved and how well Mitsuba samples them. A model that knows its microfacet
//    distribution may give it instead (model_ndf, mixed with the estimate by model_ndf_share):
//    tried with Huang's arc of barbule normals, it crowds the nodes into the narrow R band and
//    was measured worse between the nodes (below), so the export keeps the estimate.
//  - sigma: by quadrature of the stored (float32, interpolated) NDF; vndf: D(m) ⟨ω_v, m⟩⁺ /
//    σ(ω_v) times the Jacobian 2π² u_x sin θ_m of the u_m square; spectra: at each node s of
//    the sample square, u_m = warp(s), ω_l = reflect(ω_v, ω_m), spectra = q · 4 σ / D with D, σ
//    the reader's own interpolated float32 values, so the reader reproduces q at the nodes up
//    to float32 rounding; luminance: the CIE Y-weighted mean of spectra over the wavelengths
//    (the plain mean for one wavelength), floored at 1e-3 of its slice maximum so that every
//    direction with f > 0 can be sampled.
//  - Isotropic (phi_i_count = 1): one φ_i node at 0 and relative azimuths (the model is then
//    assumed isotropic: it is tabulated at φ_v = 0). Anisotropic (phi_i_count ≥ 3): φ_i nodes
//    uniform over [−π, π], both ends stored, absolute azimuths — the full circle, which both
//    Mitsuba (reduction 1) and pbrt-v4 (which rejects the folded layouts) read.
//  - Reflection only: the format has no transmission and no back side (Mitsuba returns 0 when
//    either direction is below the surface); Huang's T lobe and any BTDF are not exported.
//
// Accuracy (measured; tests/virtual_gonio/rgl_bsdf_test.cpp unless said otherwise):
//  - at the nodes (view on a θ_i/φ_i node, light on a node of the sample square) a file gives
//    the source's f to float32 rounding (Lambertian 1.9e-6, Huang 2022 5.5e-7 relative), except
//    on the sample square's column s_x = 0 (the half vector's pole, where u = √(2θ_m/π) turns
//    the ~1e-8 rounding of θ_m into ~1e-4 of the NDF grid) and for grazing pairs whose half
//    vector is ill-conditioned (1.2e-5 at view 85°, light 87°);
//  - between nodes it is a bilinear interpolant on the warped grid. Lambertian (24², 8 θ_i):
//    mean 0.9 % (both θ ≤ 60°) and 1.4 % (≤ 80°), max 14 % and 27 %, at the mirror pairs of
//    grazing views, where the first column of the sample square spans θ_m up to ~17°.
//    Huang 2022 (rock-dove parameters) at the export's default grid (32², 10 θ_i, 25 φ_i, 20 nm),
//    3000 random pairs: Σ|Δf| cos θ_i / Σ f cos θ_i = 0.09 (θ ≤ 60°), 0.12 (θ ≤ 75°), 0.11–0.16
//    at wavelengths between the nodes; the R lobe's θ_d = 4.5° is what the grid resolves worst.
//    interpolation_error() below, 3000 pairs θ ≤ 75°, seed 41, relative |f_file/f − 1| (issue
//    41; bench/README.md): default grid, 16 wavelengths, a wavelength per pair anywhere in
//    400–700 nm: median 2.57 %, 95th percentile 68 %, Σ f cos θ-weighted 15.6 %. At 550 nm
//    alone (the angular part): median 3.20 %; a 48² square 2.48 %; 19 θ_i × 49 φ_i nodes 1.47 %
//    (95th percentile 40 %, weighted 9.3 %): the view grid, not the sample square, is what
//    limits it. The model's own NDF at share 0.25: 3.98 % (worse);
//  - Mitsuba's sampling density (vndf × luminance warps) integrates to 0.995–0.998 over the
//    hemisphere for the Lambertian file; f cos θ / pdf stays within [0.57, 0.82].
// Not checked: neither Mitsuba 3 nor pbrt-v4 runs here (no package on this machine), so the
// files are tested against this reader, which follows Mitsuba 3's source. pbrt-v4 reads the
// same fields (it requires version 1.0 and, when anisotropic, φ_i spanning 2π, as written);
// read from its source (not run), its MeasuredBxDF::Sample_f takes wo (the view) as the
// parameter direction and returns q / cos θ_wi = f, as Mitsuba reads the table, but its f()
// takes wi (the light) as the parameter and divides by cos θ_wi, which by that reading is
// f · cos θ_wo / cos θ_wi (and swaps view and light for a non-reciprocal model such as Huang's
// TRT). We write for Mitsuba's reading, the one the format's own sampling code assumes.
//
// Frames. Mitsuba's and pbrt-v4's local shading frame is x = ∂p/∂u (the mesh's texture-u
// tangent), y = n × x, z = n; φ = atan2(y, x). Our patch frame is +x the barb axis, +y the
// barbules' direction, +z the patch normal, φ from +x towards +y: the two coincide when the
// mesh's texture u runs along the barb. An isotropic file does not care.
//
// Parameter table (RglBsdfSettings):
//  | name              | unit | default | valid range                                     |
//  |-------------------|------|---------|-------------------------------------------------|
//  | wavelengths_nm    | nm   | —       | ≥ 1 value, increasing, in (0, 10000)            |
//  | theta_i_count     | 1    | 10      | [2, 256] nodes in [0, theta_max_deg]            |
//  | theta_max_deg     | deg  | 85      | (0, 89]: beyond it the last slice is used       |
//  | phi_i_count       | 1    | 1       | 1 (isotropic) or [3, 361] over [−π, π]          |
//  | sample_resolution | 1    | 32      | [2, 512], N of the N × N spectra/luminance grid |
//  | vndf_resolution   | 1    | 64      | [2, 1024], W_v = H_v of the vndf grid           |
//  | ndf_resolution    | 1    | 64      | [2, 1024], W_d = H_d (H_d = 2 when isotropic)   |
//  | ndf_floor         | 1    | 0.1     | (0, 1], share of the cosine NDF mixed in        |
//  | ndf_iterations    | 1    | 30      | [0, 1000] power iterations at most (0: cosine   |
//  |                   |      |         | NDF only); stops once a step changes D < 1e-6   |
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "sim/scatterer/scatterer.h"

namespace plumage::gonio {

// ---- the tensor file container -------------------------------------------------------------

enum class TensorDtype : std::uint8_t { uint8 = 1, float32 = 10 };

struct TensorField {
    std::uint8_t dtype = 0;            // Mitsuba's Struct::Type code (see above)
    std::vector<std::uint64_t> shape;  // extents, slowest first
    std::vector<std::uint8_t> bytes;   // little-endian data, C order
};
using TensorFields = std::map<std::string, TensorField>;

// Atomic: written to a temporary beside `path`, renamed into place. IoError on failure.
void write_tensor_file(const std::filesystem::path& path, const TensorFields& fields);
// InputError naming the file (and the field) when the file is not a complete version-1.0
// tensor file: too short, wrong magic, unknown version or dtype, a field outside the file.
TensorFields read_tensor_file(const std::filesystem::path& path);

// ---- Mitsuba's continuous Marginal2D warp -------------------------------------------------

// A density on [0, 1]² given as a W × H grid of nodes per slice (bilinear in between), with
// up to three parameters over which slices are blended linearly (Mitsuba's Marginal2D<Float,
// D, true>). normalize = true: each slice is normalised to integrate to 1 and sample()/
// invert() are the exact inverse-CDF warp of the blended bilinear density (rows first, then
// the column within the row); normalize = false: only eval(), the plain interpolant.
class BilinearWarp2D final {
public:
    BilinearWarp2D() = default;
    // data: [param_0]…[param_{D−1}][H][W]; params[d]: increasing node values of parameter d.
    BilinearWarp2D(std::span<const float> data, int width, int height,
                   std::vector<std::vector<double>> params, bool normalize);
    // Interpolated value at pos (density w.r.t. the unit square when normalised).
    double eval(const Vec2& pos, std::span<const double> param = {}) const;
    struct Result {
        Vec2 point;
        double pdf;  // density of point w.r.t. the unit square
    };
    // avoid_extrema: clamp u to [2⁻²⁴, 1 − 2⁻²⁴] first, as Mitsuba does when it samples;
    // the writer maps the exact corners of its nodes (false).
    Result sample(const Vec2& u, std::span<const double> param = {},
                  bool avoid_extrema = true) const;
    Result invert(const Vec2& point, std::span<const double> param = {}) const;

private:
    struct Weights {
        std::size_t slice = 0;                // first slice of the blend
        std::array<double, 6> weight{};       // per parameter: (1 − t, t)
        std::array<std::size_t, 3> stride{};  // in slices; 0 for a single node
    };
    Weights weights(std::span<const double> param) const;
    double lookup(const std::vector<double>& table, std::size_t per_slice, const Weights& w,
                  std::size_t index) const;

    int width_ = 0, height_ = 0;
    std::vector<std::vector<double>> params_;
    std::vector<double> data_, conditional_cdf_, marginal_cdf_;
};

// ---- measured BRDF tables ------------------------------------------------------------------

struct RglBsdfSettings {
    std::vector<double> wavelengths_nm;
    int theta_i_count = 10;
    double theta_max_deg = 85.0;
    int phi_i_count = 1;
    int sample_resolution = 32;
    int vndf_resolution = 64;
    int ndf_resolution = 64;
    double ndf_floor = 0.1;
    int ndf_iterations = 30;
    // When given, the NDF is this density of the half vector m (patch frame, upper hemisphere;
    // any scale: it is normalised) instead of the retro-reflection estimate: a model that
    // knows its microfacet distribution (Huang's arc of barbule normals) puts the sample
    // square's nodes where its lobes are. Each NDF node holds D's mean over its cell (solid
    // angle weighted, 8 × 8 points; over every azimuth when isotropic), so that a lobe
    // narrower than a cell still moves the nodes; ndf_floor is mixed in as for the estimate.
    std::function<double(const Vec3d& m)> model_ndf;
    // With model_ndf: the model's NDF takes this share of the estimate (both normalised), the
    // retro-reflection estimate the rest; 1: the model's alone. The estimate holds the smooth
    // lobes (Huang's TRT) that the model's NDF does not describe.
    double model_ndf_share = 1.0;
    // Called at the start of each step of the tabulation (and every quarter of the spectra)
    // with what it is about to do; empty: silent.
    std::function<void(const std::string& step)> progress;
    std::string description;
    void validate() const;  // InputError naming the setting
};

// The fields of a measured-BRDF tensor file, as stored (float32 values, C order).
struct RglBsdfTables {
    std::string description;
    bool jacobian = true;
    std::vector<float> theta_i, phi_i, wavelengths;
    int ndf_width = 0, ndf_height = 0;  // W_d (θ), H_d (φ)
    std::vector<float> ndf, sigma;      // [H_d][W_d]
    int vndf_width = 0, vndf_height = 0;
    std::vector<float> vndf;  // [n_φ][n_θ][H_v][W_v]
    int sample_resolution = 0;
    std::vector<float> luminance;  // [n_φ][n_θ][N][N]
    std::vector<float> spectra;    // [n_φ][n_θ][n_λ][N][N]
    TensorFields to_fields() const;
    // Validates names, dtypes, shapes and values; InputError "<source>: field '<name>': …".
    static RglBsdfTables from_fields(const TensorFields& fields, const std::string& source);
};

// f(ω_i, ω_o, λ) in 1/sr, our convention (sim/scatterer/scatterer.h); only ω_i.z, ω_o.z > 0 is
// asked.
using BrdfFunction = std::function<double(const Vec3d& wi, const Vec3d& wo, double lambda_nm)>;

// Tabulates f (see "What we write"). Deterministic; parallel over slices (OpenMP); throws
// Interrupted on Ctrl-C. Non-finite or negative values of f are an InvariantError.
RglBsdfTables tabulate_rgl_bsdf(const BrdfFunction& f, const RglBsdfSettings& settings);
// The same for an analytic model: InputError unless scatterer.can_evaluate().
RglBsdfTables tabulate_rgl_bsdf(const Scatterer& scatterer, const RglBsdfSettings& settings);
void write_rgl_bsdf(const std::filesystem::path& path, const RglBsdfTables& tables);

// A measured BRDF read from tables or a .bsdf file, evaluated as Mitsuba 3's `measured` does
// (including its folded layouts: φ_i spanning π or π/2, "reduction" 2 or 4).
class RglBsdf final {
public:
    explicit RglBsdf(RglBsdfTables tables);
    static RglBsdf read(const std::filesystem::path& path);  // InputError naming file, field

    // Mitsuba's eval: wi the parameter direction (towards the viewer), wo the other (towards
    // the light), both in the local frame; returns f · cos θ_wo; 0 unless both z > 0.
    double eval_mitsuba(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const;
    // Our convention: f(ω_i, ω_o, λ) in 1/sr (ω_i towards the light), without the cosine:
    // eval_mitsuba(ω_o, ω_i, λ) / cos θ_i.
    double eval(const Vec3d& wi, const Vec3d& wo, double lambda_nm) const;
    // Mitsuba's pdf: the density (1/sr) with which its sample() draws wo given wi — the vndf
    // warp's density times the luminance warp's, over |dω_o/du_m| = 4 ⟨wi, m⟩ 2π² u_x sin θ_m.
    double pdf_mitsuba(const Vec3d& wi, const Vec3d& wo) const;
    // The forward vndf warp at the parameter direction ω_v: sample square → u_m (exact corners).
    Vec2 warp_sample(const Vec3d& wv, const Vec2& s) const;

    bool isotropic() const { return isotropic_; }
    const RglBsdfTables& tables() const { return tables_; }

private:
    // What eval and pdf share: the folded pair, its half vector m and m's warp coordinates u_m
    // (φ_m relative to φ_i when isotropic), wrapped into [0, 1).
    struct HalfVectorFrame {
        Vec3d wi, m;
        double theta_i, phi_i;
        Vec2 u_m;
    };
    HalfVectorFrame half_vector_frame(const Vec3d& wi, const Vec3d& wo) const;
    void fold(Vec3d& wi, Vec3d& wo) const;  // Mitsuba's reductions 2 and 4

    RglBsdfTables tables_;
    bool isotropic_ = true;
    int reduction_ = 1;
    BilinearWarp2D ndf_, sigma_, vndf_, luminance_, spectra_;
};

// ---- between-node accuracy -----------------------------------------------------------------

// How far a file read back is from its source between the nodes: `pairs` direction pairs
// (ω_i, ω_o) uniform in solid angle over θ ≤ theta_max_deg each, at one wavelength per pair
// uniform over the file's wavelength range, drawn from `seed` (the same pairs for every file
// of the same range). Deterministic; parallel over pairs (OpenMP).
struct InterpolationError {
    int pairs = 0;          // drawn
    int positive = 0;       // of which the source's f > 0: the relative errors' population
    double median = 0.0;    // of |f_file / f − 1|
    double p95 = 0.0;       // its 95th percentile
    double weighted = 0.0;  // Σ |f_file − f| cos θ_i / Σ f cos θ_i over all pairs
    double worst = 0.0;     // largest max(f_file / f, f / f_file), ∞ when one of them is 0
};
InterpolationError interpolation_error(const BrdfFunction& f, const RglBsdf& file, int pairs,
                                       double theta_max_deg, std::uint64_t seed);

}  // namespace plumage::gonio
