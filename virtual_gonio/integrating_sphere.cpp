// The integrating sphere (conventions and parameter table in the header): its work item (a
// chunk of one wavelength's quanta) and its reduction (Σw and Σw² above and below the patch);
// the passes, the stop rule, threads and ranks are the pass loop's.
#include "virtual_gonio/integrating_sphere.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>

#include "common/constants.h"
#include "common/cpu_time.h"
#include "common/error.h"
#include "common/require.h"
#include "common/seed.h"
#include "sim/scatterer/random.h"
#include "virtual_gonio/direction_sets.h"
#include "virtual_gonio/instrument_registry.h"
#include "virtual_gonio/record/hdf5_file.h"
#include "virtual_gonio/record_provenance.h"

namespace plumage::gonio {
namespace {

constexpr std::uint64_t kChunk = 4096;
constexpr std::string_view kWhat = "integrating sphere";

// Σw, Σw² of the quanta that left upwards (R) and downwards (T).
struct Tally {
    double up = 0.0, up_sq = 0.0, down = 0.0, down_sq = 0.0;
};

// Mean and standard error of the mean of n quanta from Σw and Σw².
std::pair<double, double> mean_and_error(double sum, double sum_sq, double n) {
    const double mean = sum / n;
    const double variance = n > 1.0 ? std::max(0.0, sum_sq / n - mean * mean) / (n - 1.0) : 0.0;
    return {mean, std::sqrt(variance)};
}

class SpherePasses final : public PassMeasurement {
public:
    SpherePasses(const Scatterer& scatterer, IntegratingSphereRecord& r)
        : scatterer_(scatterer),
          r_(r),
          c_(r.config),
          nl_(c_.wavelengths_nm.size()),
          chunks_((c_.quanta_per_pass + kChunk - 1) / kChunk),
          totals_(nl_) {
        orthonormal_frame(c_.light, e1_, e2_);
        for (std::size_t k = 0; k < nl_; ++k)
            seeds_.push_back(derive_seed(c_.seed, "integrating_sphere/quantum", k));
    }

    std::size_t start_pass(int pass) override {
        pass_ = static_cast<std::uint64_t>(pass);
        items_.assign(nl_ * chunks_, Tally{});
        return items_.size();
    }

    // Item it: chunk it % chunks of wavelength it / chunks.
    void run_item(std::size_t it) override {
        const std::size_t k = it / chunks_;
        const std::uint64_t c = it % chunks_;
        const std::uint64_t first = pass_ * c_.quanta_per_pass + c * kChunk;
        const std::uint64_t count = std::min(kChunk, c_.quanta_per_pass - c * kChunk);
        const Vec3d wi = c_.light;
        Tally& t = items_[it];
        for (std::uint64_t q = first; q < first + count; ++q) {
            Rng rng(seeds_[k], q);
            // Uniform over the beam's disc, projected along wi onto the patch plane.
            const double radius = c_.beam_radius_um * std::sqrt(rng.uniform()),
                         angle = 2.0 * kPi * rng.uniform();
            const Vec3d offset = radius * (std::cos(angle) * e1_ + std::sin(angle) * e2_);
            const Vec2 position(offset.x() - offset.z() * wi.x() / wi.z(),
                                offset.y() - offset.z() * wi.y() / wi.z());
            const auto event = scatterer_.sample(wi, c_.wavelengths_nm[k], position, rng);
            if (!event || !(event->weight > 0.0)) continue;
            PLUMAGE_CHECK(std::isfinite(event->weight),
                          "non-finite quantum weight from " + scatterer_.name());
            const double w = event->weight;
            (event->wo.z() > 0.0 ? t.up : t.down) += w;
            (event->wo.z() > 0.0 ? t.up_sq : t.down_sq) += w * w;
        }
    }
    void pack(std::size_t it, Bytes& out) const override { out.put(items_[it]); }
    void unpack(std::size_t it, Bytes& in) override { items_[it] = in.get<Tally>(); }

    void add_pass() override {
        for (std::size_t it = 0; it < items_.size(); ++it) {
            Tally& total = totals_[it / chunks_];
            total.up += items_[it].up, total.up_sq += items_[it].up_sq;
            total.down += items_[it].down, total.down_sq += items_[it].down_sq;
        }
    }
    PassEstimate estimate(int passes) override {
        r_.passes = passes;
        r_.quanta = static_cast<std::uint64_t>(passes) * c_.quanta_per_pass;
        const double n = static_cast<double>(r_.quanta);
        double signal = 0.0, error = 0.0;
        for (std::size_t k = 0; k < nl_; ++k) {
            std::tie(r_.reflectance[k], r_.reflectance_error[k]) =
                mean_and_error(totals_[k].up, totals_[k].up_sq, n);
            std::tie(r_.transmittance[k], r_.transmittance_error[k]) =
                mean_and_error(totals_[k].down, totals_[k].down_sq, n);
            signal += r_.reflectance[k];
            error += r_.reflectance_error[k];
        }
        PassEstimate e;
        e.quanta = r_.quanta;
        e.relative_error = signal > 0.0 ? error / signal : 1.0;
        return e;
    }

private:
    const Scatterer& scatterer_;
    IntegratingSphereRecord& r_;
    const IntegratingSphereConfig& c_;
    std::size_t nl_;
    std::uint64_t chunks_, pass_ = 0;
    Vec3d e1_, e2_;
    std::vector<std::uint64_t> seeds_;
    std::vector<Tally> items_, totals_;  // per item of the pass; per wavelength over all passes
};

// The study file's [integrating_sphere] table (virtual_gonio/instrument_registry.h).
constexpr InstrumentParameter kParameters[] = {
    {.name = "incidence_deg",
     .unit = "deg",
     .default_value = 0.0,
     .min = 0.0,
     .max = 85.0,
     .meaning = "polar angle of the light from the patch normal"},
    {.name = "azimuth_deg",
     .unit = "deg",
     .default_value = 90.0,
     .min = -360.0,
     .max = 360.0,
     .meaning = "azimuth of the light from +x"},
    {.name = "beam_radius_um",
     .unit = "µm",
     .default_value = 10.0,
     .min = 0.0,
     .max = 1e6,
     .min_open = true,
     .meaning = "radius of the beam's cross-section"},
    {.name = "quanta_per_pass",
     .unit = "1",
     .default_value = 100000,
     .min = 1,
     .max = 1e9,
     .integer = true,
     .meaning = "quanta per wavelength and pass"},
    {.name = "max_passes",
     .unit = "1",
     .default_value = 10,
     .min = 1,
     .max = 100000,
     .integer = true,
     .meaning = "passes at most"},
    {.name = "target_relative_error",
     .unit = "1",
     .default_value = 0.01,
     .min = 0.0,
     .max = 1.0,
     .max_open = true,
     .meaning = "stop once Σσ(R)/ΣR is at most this (0: run max_passes; the study's "
                "target_relative_error, when set, replaces it)"},
};

IntegratingSphereConfig config_of(const InstrumentValues& v, const MeasurementSetting& s) {
    IntegratingSphereConfig c;
    c.wavelengths_nm = s.wavelengths_nm;
    c.light = direction_from_angles(v["incidence_deg"] * kDeg, v["azimuth_deg"] * kDeg);
    c.beam_radius_um = v["beam_radius_um"];
    c.quanta_per_pass = static_cast<std::uint64_t>(v["quanta_per_pass"]);
    c.max_passes = static_cast<int>(v["max_passes"]);
    c.target_relative_error =
        s.target_relative_error > 0.0 ? s.target_relative_error : v["target_relative_error"];
    c.time_budget_s = s.time_budget_s;
    c.seed = s.seed;
    c.config_text = s.config_text;
    return c;
}

void check_entry(const InstrumentValues& v, const MeasurementSetting& s) {
    config_of(v, s).validate();
}

InstrumentResult measure_entry(const Scatterer& scatterer, const InstrumentValues& v,
                               const MeasurementSetting& s) {
    const IntegratingSphereConfig c = config_of(v, s);
    const IntegratingSphereRecord r = measure_integrating_sphere(scatterer, c, s.progress);
    write_integrating_sphere_record(r, s.folder / "integrating_sphere.h5");
    InstrumentResult out;
    out.cells = fmt::format("{} λ × {} quanta per λ", c.wavelengths_nm.size(), r.quanta);
    out.files = {"integrating_sphere.h5"};
    out.error = r.convergence.empty() ? 0.0 : r.convergence.back().estimated_relative_rms_error;
    out.error_meaning = "Σσ(R)/ΣR over the wavelengths";
    out.wall_time_s = r.wall_time_s;
    out.curves_title =
        fmt::format("Integrating sphere: light at {:g}° incidence", v["incidence_deg"]);
    out.curves_quantity = "directional-hemispherical fraction (1)";
    out.curves = {{"reflectance R", r.reflectance, r.reflectance_error},
                  {"transmittance T", r.transmittance, r.transmittance_error}};
    return out;
}

}  // namespace

InstrumentEntry integrating_sphere_instrument() {
    return {.table = "integrating_sphere",
            .description = "directional-hemispherical reflectance and transmittance",
            .parameters = kParameters,
            .check = check_entry,
            .measure = measure_entry};
}

void IntegratingSphereConfig::validate() const {
    require_wavelengths(wavelengths_nm, kWhat);
    require(light.allFinite() && std::abs(light.norm() - 1.0) < 1e-9 && light.z() > 0.0, kWhat,
            fmt::format("light = ({}, {}, {}): expected a unit vector above the patch (z > 0)",
                        light.x(), light.y(), light.z()));
    require(std::isfinite(beam_radius_um) && beam_radius_um > 0.0, kWhat,
            fmt::format("beam_radius_um = {}: expected finite and > 0", beam_radius_um));
    require(quanta_per_pass >= 1 && quanta_per_pass <= 1'000'000'000, kWhat,
            fmt::format("quanta_per_pass = {}: expected 1 to 10^9", quanta_per_pass));
    require(max_passes >= 1 && max_passes <= 100000, kWhat,
            fmt::format("max_passes = {}: expected 1 to 100000", max_passes));
    require(target_relative_error >= 0.0 && target_relative_error < 1.0, kWhat,
            fmt::format("target_relative_error = {}: expected [0, 1)", target_relative_error));
    require(time_budget_s > 0.0, kWhat,
            fmt::format("time_budget_s = {}: expected > 0", time_budget_s));
}

IntegratingSphereRecord measure_integrating_sphere(const Scatterer& scatterer,
                                                   const IntegratingSphereConfig& config,
                                                   bool progress) {
    config.validate();
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = process_cpu_seconds();
    record_measurement_seed("integrating_sphere", config.seed);  // common/seed.h
    IntegratingSphereRecord r;
    r.config = config;
    r.scatterer = scatterer.name();
    const std::size_t nl = config.wavelengths_nm.size();
    r.reflectance.assign(nl, 0.0);
    r.reflectance_error.assign(nl, 0.0);
    r.transmittance.assign(nl, 0.0);
    r.transmittance_error.assign(nl, 0.0);
    SpherePasses passes(scatterer, r);
    StopRule rule;
    rule.max_passes = config.max_passes;
    rule.target_error = config.target_relative_error;
    rule.time_budget_s = config.time_budget_s;
    PassLoopControl loop;
    loop.interrupt = &interrupt_flag();
    if (progress) loop.progress = fmt::format("integrating sphere, {}", r.scatterer);
    loop.quanta_per = "wavelength";
    auto elapsed = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    PassLoopState state;
    run_passes(passes, rule, loop, elapsed, state);
    if (state.interrupted)
        throw Interrupted(fmt::format("interrupted while measuring R and T of {}", r.scatterer));
    r.convergence = std::move(state.rows);
    r.wall_time_s = elapsed();
    r.cpu_time_s = process_cpu_seconds() - cpu_start;
    return r;
}

void write_integrating_sphere_record(const IntegratingSphereRecord& r,
                                     const std::filesystem::path& path) {
    const auto& c = r.config;
    const std::uint64_t nl = c.wavelengths_nm.size();
    using Dims = std::vector<std::uint64_t>;
    record::Hdf5Writer h5(path);
    h5.set_attribute("/", "format", "plumage record 1 (virtual_gonio/RECORD.md)");
    const std::vector<double> light = {c.light.x(), c.light.y(), c.light.z()};
    h5.write("instrument/light_direction", std::span<const double>(light), Dims{3},
             {{"units", "1"}, {"description", "unit vector towards the light, patch frame"}});
    write_polarisation(h5);
    h5.set_attribute("/instrument", "kind", "integrating_sphere");
    h5.set_attribute("/instrument", "beam_radius_um", c.beam_radius_um);
    h5.set_attribute("/instrument", "quanta_per_pass", static_cast<double>(c.quanta_per_pass));
    h5.set_attribute("/instrument", "max_passes", static_cast<double>(c.max_passes));
    h5.set_attribute("/instrument", "target_relative_error", c.target_relative_error);
    h5.write("wavelength_nm", std::span<const double>(c.wavelengths_nm), Dims{nl},
             {{"units", "nm"}, {"description", "vacuum wavelengths of the measurement"}});
    auto spectrum = [&](const char* name, const std::vector<double>& v, const char* what) {
        h5.write(name, std::span<const double>(v), Dims{nl},
                 {{"units", "1"}, {"description", what}});
    };
    spectrum("reflectance", r.reflectance,
             "directional-hemispherical reflectance: the fraction of the beam leaving above");
    spectrum("reflectance_standard_error", r.reflectance_error,
             "Monte Carlo standard error of reflectance");
    spectrum("transmittance", r.transmittance,
             "directional-hemispherical transmittance: the fraction leaving below the patch");
    spectrum("transmittance_standard_error", r.transmittance_error,
             "Monte Carlo standard error of transmittance");
    write_convergence(h5, r.convergence,
                      convergence_attributes("pass, wall_time_s, quanta_per_wavelength, "
                                             "power_weighted_relative_error_of_reflectance"));
    write_provenance(h5, {.scatterer = r.scatterer,
                          .seed = c.seed,
                          .threads = omp_get_max_threads(),
                          .wall_time_s = r.wall_time_s,
                          .cpu_time_s = r.cpu_time_s,
                          .config = c.config_text});
    h5.commit();
}

}  // namespace plumage::gonio
