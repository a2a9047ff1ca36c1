#include "sim/tracer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <limits>

#include <fmt/format.h>
#include <omp.h>

#include "common/constants.h"
#include "common/error.h"

namespace plumage::sim {

struct ExplicitScatterer::Spectral {
    enum class Kind { film, dielectric, diffuse, absorber };
    struct Surface {
        Kind kind;
        optics::Complex outside, inside;  // indices of the two sides at λ
        FilmOptics film{};
        std::optional<FilmTable> table_outside, table_inside;
        // The film's responses at λ (its tables where they hold), made once per λ: it points
        // at the tables above, so it is set when `surfaces` is complete and no Surface moves.
        std::optional<TabulatedFilmResponse> film_source;
        double albedo = 0.0;
        const Medium* medium_outside = nullptr;  // null when inactive at λ
        const Medium* medium_inside = nullptr;
    };
    Spectral() = default;
    Spectral(const Spectral&) = delete;  // film_source points into `surfaces`
    Spectral& operator=(const Spectral&) = delete;

    double lambda_nm;
    optics::Complex ambient;
    std::vector<Surface> surfaces;
};

namespace {

std::atomic<std::uint64_t> next_scatterer_id{1};

constexpr std::size_t kMaxCachedWavelengths = 512;

std::uint64_t wavelength_key(double lambda_nm) {
    std::uint64_t bits;
    static_assert(sizeof(bits) == sizeof(lambda_nm));
    std::memcpy(&bits, &lambda_nm, sizeof(bits));
    return bits;
}

int lobe_of(const PathResult& path) {
    using K = EventKind;
    if (path.medium_scatters > 0) return ExplicitScatterer::kVolume;
    if (path.events == 0) return ExplicitScatterer::kT;
    if (path.events == 1 && path.kinds[0] == K::film_reflect) return ExplicitScatterer::kR;
    if (path.events == 3 && path.kinds[0] == K::film_transmit &&
        path.kinds[1] == K::diffuse_reflect && path.kinds[2] == K::film_transmit) {
        return ExplicitScatterer::kTRT;
    }
    return ExplicitScatterer::kMulti;
}

// An escaped path's event for the instruments (sim/scatterer/scatterer.h).
SpectralScatterEvent spectral_event(const PathResult& path) {
    const ScatterEvent& e = *path.event;
    return {e.wo, e.lobe, e.exit_position_um, path.lit_diffuse_density};
}

void record(PathResult& path, EventKind kind) {
    if (path.events < PathResult::kRecordedEvents) path.kinds[path.events] = kind;
    ++path.events;
}

void check_path_request(const Vec3d& wi, const Vec2& position_um) {
    if (!wi.allFinite() || std::abs(wi.norm() - 1.0) > 1e-9 || wi.z() == 0.0) {
        throw InputError(fmt::format(
            "tracer: wi = ({}, {}, {}): expected a unit direction off the patch plane (wi.z != 0)",
            wi.x(), wi.y(), wi.z()));
    }
    if (!position_um.allFinite()) {
        throw InputError(fmt::format("tracer: position = ({}, {}) um: expected finite values",
                                     position_um.x(), position_um.y()));
    }
}

// Where light leaving from origin along direction crosses the top plane (upward) or the
// bottom plane (downward); a horizontal ray keeps its (x, y).
Vec2 exit_point(const Vec3d& origin, const Vec3d& direction, double top_z, double bottom_z) {
    Vec2 exit = origin.head<2>();
    if (direction.z() != 0.0) {
        const double plane = direction.z() > 0.0 ? top_z : bottom_z;
        const double t = (plane - origin.z()) / direction.z();
        if (t > 0.0) exit += t * direction.head<2>();
    }
    return exit;
}

// Russian roulette once the path is long (survivors carry 1) or its weight is low (survivors
// carry w_min): survive with q = weight / carried. Returns the weight the path carries on
// (its own, or `carried`), 0 when roulette ends it.
double roulette(PathResult& path, double weight, const TracerOptions& options, Rng& rng) {
    double carried = 1.0;
    if (path.events < options.roulette_after_events) {
        if (!(weight < options.roulette_below_weight)) return weight;
        carried = options.roulette_below_weight;
    }
    if (!(weight < carried)) return weight;
    if (rng.uniform() * carried >= weight) {
        path.ended_by_roulette = true;
        return 0.0;
    }
    return carried;
}

}  // namespace

void TracerOptions::validate() const {
    if (max_events < 1 || max_events > 1'000'000) {
        throw InputError(
            fmt::format("tracer: max_events = {}: expected 1..1000000 (1: single-event lobes only)",
                        max_events));
    }
    if (roulette_after_events < 1) {
        throw InputError(fmt::format("tracer: roulette_after_events = {}: expected >= 1",
                                     roulette_after_events));
    }
    if (!std::isfinite(roulette_below_weight) || roulette_below_weight < 0.0 ||
        roulette_below_weight >= 1.0) {
        throw InputError(fmt::format(
            "tracer: roulette_below_weight = {}: expected a path weight in [0, 1) (0: off)",
            roulette_below_weight));
    }
    if (!std::isfinite(film_table_tolerance) || !(film_table_tolerance > 0.0) ||
        film_table_tolerance > 0.01) {
        throw InputError(
            fmt::format("tracer: film_table_tolerance = {}: expected an absolute reflectance error "
                        "in (0, 0.01]",
                        film_table_tolerance));
    }
}

ExplicitScatterer::ExplicitScatterer(std::shared_ptr<const Scene> scene,
                                     const TracerOptions& options)
    : scene_(std::move(scene)), options_(options), id_(next_scatterer_id++) {
    if (!scene_) throw InputError("tracer: scene is null: expected a scene");
    options_.validate();
    const Eigen::AlignedBox3d box = scene_->bounds();
    const double extent = box.isEmpty() ? 0.0 : box.diagonal().norm();
    // The entry planes sit just outside the geometry, far enough that float rounding of
    // the start point cannot put it inside a surface.
    const double margin = 1e-3 + 1e-6 * extent;
    top_z_ = (box.isEmpty() ? 0.0 : box.max().z()) + margin;
    bottom_z_ = (box.isEmpty() ? 0.0 : box.min().z()) - margin;
    lobe_names_ = {"R", "TRT", "T", "multi"};
    for (std::size_t i = 0; i < scene_->surface_count(); ++i) {
        const bool may_scatter = [&] {
            for (bool outside : {true, false}) {
                if (dynamic_cast<const HomogeneousAbsorbingMedium*>(&scene_->medium(i, outside)) ==
                    nullptr) {
                    return true;
                }
            }
            return false;
        }();
        if (may_scatter) {
            lobe_names_.push_back("volume");
            break;
        }
    }
}

ExplicitScatterer::ExplicitScatterer(SceneDescription description, const TracerOptions& options)
    : ExplicitScatterer(std::make_shared<const Scene>(std::move(description)), options) {}

const std::vector<std::string>& ExplicitScatterer::lobe_names() const { return lobe_names_; }

std::shared_ptr<const ExplicitScatterer::Spectral> ExplicitScatterer::build_spectral(
    double lambda_nm) const {
    auto s = std::make_shared<Spectral>();
    s->lambda_nm = lambda_nm;
    s->ambient = scene_->description().ambient->index(lambda_nm);
    s->surfaces.reserve(scene_->surface_count());
    for (std::size_t i = 0; i < scene_->surface_count(); ++i) {
        const SurfaceMaterial& m = scene_->surface_material(i);
        Spectral::Surface out;
        out.outside = m.outside->index(lambda_nm);
        out.inside = m.inside->index(lambda_nm);
        const Medium& outside = scene_->medium(i, true);
        const Medium& inside = scene_->medium(i, false);
        out.medium_outside = outside.active(lambda_nm) ? &outside : nullptr;
        out.medium_inside = inside.active(lambda_nm) ? &inside : nullptr;
        if (const auto* film = std::get_if<ThinFilmInterface>(&m.layer)) {
            out.kind = Spectral::Kind::film;
            out.film = {out.outside, film->film->index(lambda_nm), out.inside, film->thickness_um,
                        film->coherence};
            if (options_.tabulate_films) {
                out.table_outside =
                    FilmTable::build(out.film, true, lambda_nm, options_.film_table_tolerance);
                out.table_inside =
                    FilmTable::build(out.film, false, lambda_nm, options_.film_table_tolerance);
            }
        } else if (const auto* diffuse = std::get_if<DiffuseLayer>(&m.layer)) {
            out.kind = Spectral::Kind::diffuse;
            out.albedo = diffuse->albedo(lambda_nm);
            if (!std::isfinite(out.albedo) || out.albedo < 0.0 || out.albedo > 1.0) {
                throw InputError(fmt::format("surface '{}': albedo = {} at {} nm: expected [0, 1]",
                                             scene_->surface_name(i), out.albedo, lambda_nm));
            }
        } else if (std::holds_alternative<DielectricInterface>(m.layer)) {
            out.kind = Spectral::Kind::dielectric;
        } else {
            out.kind = Spectral::Kind::absorber;
        }
        s->surfaces.push_back(std::move(out));
    }
    for (Spectral::Surface& surface : s->surfaces) {
        if (surface.kind != Spectral::Kind::film) continue;
        surface.film_source.emplace(surface.film, lambda_nm,
                                    surface.table_outside ? &*surface.table_outside : nullptr,
                                    surface.table_inside ? &*surface.table_inside : nullptr);
    }
    return s;
}

std::shared_ptr<const ExplicitScatterer::Spectral> ExplicitScatterer::lookup_spectral(
    double lambda_nm) const {
    const std::uint64_t key = wavelength_key(lambda_nm);
    std::shared_ptr<const Spectral> data;
    {
        std::lock_guard lock(cache_mutex_);
        if (auto it = cache_.find(key); it != cache_.end()) data = it->second;
    }
    if (!data) {
        // Built outside the lock (tables take up to milliseconds); the contents depend on
        // λ alone, so a duplicate built by another thread is identical.
        data = build_spectral(lambda_nm);
        std::lock_guard lock(cache_mutex_);
        if (cache_.size() >= kMaxCachedWavelengths) cache_.clear();
        data = cache_.try_emplace(key, data).first->second;
    }
    return data;
}

const ExplicitScatterer::Spectral& ExplicitScatterer::spectral(double lambda_nm) const {
    // Per thread, the last wavelength: instruments trace many paths per wavelength, so
    // this is the common case and takes no lock.
    struct Last {
        std::uint64_t owner = 0;
        double lambda_nm = 0.0;
        std::shared_ptr<const Spectral> data;
    };
    thread_local Last last_of_thread;
    Last& last = last_of_thread;  // one look-up of the thread's copy
    if (last.owner == id_ && last.lambda_nm == lambda_nm) return *last.data;
    last = {id_, lambda_nm, lookup_spectral(lambda_nm)};
    return *last.data;
}

struct ExplicitScatterer::SpectralSet {
    std::vector<double> lambdas_nm;
    std::vector<std::shared_ptr<const Spectral>> at;  // per wavelength
    // Per surface: whether a shared path may pass it without choosing its hero (tracer.h).
    std::vector<char> film_shared, dielectric_shared;
    // Per surface and side (0 outside, 1 inside): a medium that scatters at some λ.
    std::vector<std::array<char, 2>> scatters;
    // Per surface and side: no medium at any λ (a flight there is straight and lossless).
    std::vector<std::array<char, 2>> no_medium;
    // Per surface: a film with one material on both sides and no medium at any λ, which light
    // passes without turning ("Connections to collimated lights", tracer.h).
    std::vector<char> film_straight;
};

const ExplicitScatterer::SpectralSet& ExplicitScatterer::spectral_set(
    std::span<const double> lambdas_nm) const {
    struct Last {
        std::uint64_t owner = 0;
        SpectralSet set;
    };
    thread_local Last last;
    if (last.owner == id_ && std::equal(lambdas_nm.begin(), lambdas_nm.end(),
                                        last.set.lambdas_nm.begin(), last.set.lambdas_nm.end()))
        return last.set;
    SpectralSet set;
    set.lambdas_nm.assign(lambdas_nm.begin(), lambdas_nm.end());
    for (double l : lambdas_nm) set.at.push_back(lookup_spectral(l));
    const std::size_t surfaces = scene_->surface_count();
    set.film_shared.assign(surfaces, 1);
    set.dielectric_shared.assign(surfaces, 1);
    set.scatters.assign(surfaces, {0, 0});
    set.no_medium.assign(surfaces, {1, 1});
    set.film_straight.assign(surfaces, 1);
    auto scatters = [](const Medium* m) {
        return m != nullptr && dynamic_cast<const HomogeneousAbsorbingMedium*>(m) == nullptr;
    };
    for (std::size_t i = 0; i < surfaces; ++i) {
        const Spectral::Surface& first = set.at.front()->surfaces[i];
        for (const auto& at : set.at) {
            const Spectral::Surface& s = at->surfaces[i];
            // Refraction through a film bends by the outside/inside indices (the film's own
            // index does not change the direction); at a bare interface R depends on both.
            if (s.outside.real() != first.outside.real() || s.inside.real() != first.inside.real())
                set.film_shared[i] = 0;
            if (s.outside != first.outside || s.inside != first.inside)
                set.dielectric_shared[i] = 0;
            set.scatters[i][0] = set.scatters[i][0] || scatters(s.medium_outside);
            set.scatters[i][1] = set.scatters[i][1] || scatters(s.medium_inside);
            if (s.medium_outside != nullptr) set.no_medium[i][0] = 0;
            if (s.medium_inside != nullptr) set.no_medium[i][1] = 0;
            if (s.kind != Spectral::Kind::film || s.film.outside != s.film.inside)
                set.film_straight[i] = 0;
        }
        if (!set.no_medium[i][0] || !set.no_medium[i][1]) set.film_straight[i] = 0;
    }
    last = {id_, std::move(set)};
    return last.set;
}

namespace {

// trace()'s event at a surface, at its one wavelength.
InterfaceEvent one_wavelength_event(const ExplicitScatterer::Spectral::Surface& surface,
                                    const Vec3d& direction, const SurfaceNormals& normals,
                                    Rng& rng) {
    using Kind = ExplicitScatterer::Spectral::Kind;
    switch (surface.kind) {
        case Kind::film:
            return thin_film_event(direction, normals, surface.film, *surface.film_source, rng);
        case Kind::dielectric:
            return dielectric_event(direction, normals, surface.outside, surface.inside, rng);
        case Kind::diffuse:
            return diffuse_event(direction, normals, surface.albedo, rng);
        case Kind::absorber:
            break;
    }
    return absorber_event(direction, normals);
}

}  // namespace

bool ExplicitScatterer::scatter_in(const Medium& medium, double lambda_nm, double distance_um,
                                   Vec3d& origin, Vec3d& direction, double& weight,
                                   PathResult& path, Rng& rng) const {
    if (path.events >= options_.max_events) {
        path.reached_max_events = true;
        return false;
    }
    record(path, EventKind::medium_scatter);
    ++path.medium_scatters;
    const MediumScatter scatter = medium.scatter(direction, lambda_nm, rng);
    weight *= scatter.weight;
    origin += distance_um * direction;
    direction = scatter.direction;
    return weight > 0.0;
}

std::optional<ScatterEvent> ExplicitScatterer::sample(const Vec3d& wi, double lambda_nm,
                                                      const Vec2& position_um, Rng& rng) const {
    return trace(wi, lambda_nm, position_um, rng).event;
}

PathResult ExplicitScatterer::trace(const Vec3d& wi, double lambda_nm, const Vec2& position_um,
                                    Rng& rng, std::vector<RaySegment>* rays) const {
    check_path_request(wi, position_um);
    optics::require_wavelength(lambda_nm);
    const Spectral& spectral_data = spectral(lambda_nm);

    PathResult path;
    Vec3d origin = entry_origin(position_um, wi);
    Vec3d direction = -wi;
    double weight = 1.0;
    PrimitiveRef skip;
    optics::Complex expected = spectral_data.ambient;  // index of the side the light is on

    auto escape = [&]() {
        if (expected != spectral_data.ambient) ++path.medium_mismatches;
        const Vec2 exit = exit_point(origin, direction, top_z_, bottom_z_);
        PLUMAGE_CHECK(std::isfinite(weight) && weight >= 0.0,
                      fmt::format("path weight {} after {} events", weight, path.events));
        path.event = ScatterEvent{direction.normalized(), weight, lobe_of(path), exit};
    };

    auto survives_roulette = [&]() {
        const double carried = roulette(path, weight, options_, rng);
        if (!(carried > 0.0)) return false;
        weight = carried;
        return true;
    };

    for (;;) {
        if (rays != nullptr) rays->push_back({origin, direction});
        ++path.rays;
        const std::optional<SurfaceHit> hit =
            scene_->intersect(origin, direction, skip, &path.self_hits_rejected);
        if (!hit) {
            escape();
            return path;
        }
        const Spectral::Surface& surface = spectral_data.surfaces[hit->surface];
        const double facing = direction.dot(hit->normals.geometric);
        if (facing == 0.0) {
            // Exactly parallel to the facet: it has no projected area for this ray.
            skip = hit->primitive;
            continue;
        }
        const bool from_outside = facing < 0.0;
        if ((from_outside ? surface.outside : surface.inside) != expected) ++path.medium_mismatches;

        // The medium between the last event and this surface.
        if (const Medium* medium = from_outside ? surface.medium_outside : surface.medium_inside) {
            const MediumFlight flight = medium->fly(hit->distance_um, lambda_nm, rng);
            weight *= flight.weight;
            if (flight.scattered) {
                if (!scatter_in(*medium, lambda_nm, flight.distance_um, origin, direction, weight,
                                path, rng))
                    return path;
                skip = {};
                if (!survives_roulette()) return path;
                continue;
            }
            // Before the event: a film met from inside melanin is evaluated directly.
            if (!(weight > 0.0) || !survives_roulette()) return path;
        }

        if (path.events >= options_.max_events) {
            path.reached_max_events = true;
            return path;
        }
        const InterfaceEvent event = one_wavelength_event(surface, direction, hit->normals, rng);
        record(path, event.kind);
        weight *= event.throughput;
        if (event.kind == EventKind::absorb || !(weight > 0.0)) return path;

        expected = event.to_outside ? surface.outside : surface.inside;
        origin = scene_->spawn_point(*hit, event.to_outside);
        direction = event.direction;
        skip = hit->primitive;
        if (!survives_roulette()) return path;
    }
}

namespace {

// The responses at every wavelength of a shared path, at the cos θ the event asks for: the
// film's (Airy or its table), or a bare interface's Fresnel R and T. It answers the event with
// the mean choice probability p̄ (tracer.h), so the event picks reflection with p̄ and the caller
// re-weights each λ from R_k, T_k.
class SharedResponse final : public FilmResponseSource {
public:
    using Set = std::vector<std::shared_ptr<const ExplicitScatterer::Spectral>>;
    enum class Interface { film, bare };
    SharedResponse(const Set& at, std::span<const double> lambdas_nm, std::size_t surface,
                   Interface kind)
        : at_(at), lambdas_nm_(lambdas_nm), surface_(surface), kind_(kind) {}
    FilmResponse response(bool from_outside, double cos_theta) const override;

    mutable std::array<double, PathTracing::kMaxSharedWavelengths> reflectance{}, transmittance{};
    mutable double mean_reflect_probability = 0.0;

private:
    const Set& at_;
    std::span<const double> lambdas_nm_;
    std::size_t surface_;
    Interface kind_;
};

// dielectric_event's unpolarised Fresnel R and T (sim/interface_events.cpp) for one wavelength.
FilmResponse bare_interface_response(const ExplicitScatterer::Spectral::Surface& s,
                                     bool from_outside, double cos_theta) {
    const optics::Complex n_in = from_outside ? s.outside : s.inside;
    const optics::Complex n_out = from_outside ? s.inside : s.outside;
    const optics::FresnelIntensities f =
        n_out.imag() == 0.0
            ? lossless_fresnel_unpolarised(n_in.real(), n_out.real(), cos_theta)
            : optics::fresnel_intensities_unpolarised(n_in.real(), n_out, cos_theta);
    return {f.reflectance, f.transmittance};
}

FilmResponse SharedResponse::response(bool from_outside, double cos_theta) const {
    double p = 0.0;
    for (std::size_t k = 0; k < lambdas_nm_.size(); ++k) {
        const ExplicitScatterer::Spectral::Surface& s = at_[k]->surfaces[surface_];
        const FilmResponse r = kind_ == Interface::film
                                   ? s.film_source->response(from_outside, cos_theta)
                                   : bare_interface_response(s, from_outside, cos_theta);
        reflectance[k] = std::max(0.0, r.reflectance);
        transmittance[k] = std::max(0.0, r.transmittance);
        const double total = reflectance[k] + transmittance[k];
        if (total > 0.0) p += reflectance[k] / total;
    }
    mean_reflect_probability = p / static_cast<double>(lambdas_nm_.size());
    return {mean_reflect_probability, 1.0 - mean_reflect_probability};
}

// A bare interface's Fresnel R and T at one wavelength (dielectric_event's), kept for the caller
// once the event has asked for them.
class OneBareResponse final : public FilmResponseSource {
public:
    explicit OneBareResponse(const ExplicitScatterer::Spectral::Surface& surface)
        : surface_(surface) {}
    FilmResponse response(bool from_outside, double cos_theta) const override {
        last = bare_interface_response(surface_, from_outside, cos_theta);
        return last;
    }
    mutable FilmResponse last{0.0, 0.0};

private:
    const ExplicitScatterer::Spectral::Surface& surface_;
};

// A film's response with the choice made in advance: the event takes the given side with
// probability 1 and throughput 1 (interface_events.cpp's choose()); `inner`'s R and T stay
// available to weigh the branch.
class ForcedFilmChoice final : public FilmResponseSource {
public:
    ForcedFilmChoice(const FilmResponseSource& inner, bool reflect)
        : inner_(inner), reflect_(reflect) {}
    FilmResponse response(bool from_outside, double cos_theta) const override {
        const FilmResponse r = inner_.response(from_outside, cos_theta);
        taken = std::max(0.0, reflect_ ? r.reflectance : r.transmittance);
        return reflect_ ? FilmResponse{1.0, 0.0} : FilmResponse{0.0, 1.0};
    }
    mutable double taken = 0.0;  // the inner R (reflect) or T of the last response

private:
    const FilmResponseSource& inner_;
    bool reflect_;
};

}  // namespace

std::size_t ExplicitScatterer::sample_spectral_branches(const Vec3d& wi,
                                                        std::span<const double> lambdas_nm,
                                                        const Vec2& position_um, Rng& rng,
                                                        const BranchOptions& options,
                                                        std::span<SpectralScatterEvent> events,
                                                        std::span<double> weights) const {
    const std::size_t n = lambdas_nm.size();
    PLUMAGE_CHECK(events.size() >= kMaxBranches && weights.size() >= kMaxBranches * n,
                  "sample_spectral_branches: room for kMaxBranches branches");
    const bool guide_valid = options.guided_fraction >= 0.0 && options.guided_fraction < 1.0 &&
                             options.detector_half_angle_rad > 0.0 &&
                             options.detector_half_angle_rad < 0.5 * kPi;
    PLUMAGE_CHECK(options.guided_fraction == 0.0 || guide_valid,
                  "sample_spectral_branches: guided_fraction in [0, 1), cones of 0 … 90°");
    PLUMAGE_CHECK(
        options.guided_branches <= BranchOptions::kMaxGuidedBranches &&
            (options.guided_branches == 0 || (guide_valid && !options.detector_axes.empty())),
        "sample_spectral_branches: guided_branches in [0, 3], with cones of 0 … 90°");
    const bool diffuse_branches = options.guided_branches > 0;
    const bool split_reflections = options.split_first_film && options.split_reflections;
    std::size_t count = 0;
    auto keep = [&](const PathResult& path) {
        if (path.event) events[count++] = spectral_event(path);
    };
    auto play = [&](Rng& stream, FirstFilm branch, const FirstHit* first) {
        if (!diffuse_branches && !(split_reflections && branch == FirstFilm::reflect) &&
            !options.split_aimed_reflections) {
            keep(walk_spectral(wi, lambdas_nm, position_um, stream, weights.subspan(count * n, n),
                               branch, &options, first));
            return;
        }
        PendingBranches pending;
        keep(walk_spectral(wi, lambdas_nm, position_um, stream, weights.subspan(count * n, n),
                           branch, &options, first, nullptr, &pending));
        // The branches it left (the guided ones of its first diffuse event, the transmitted one
        // of a reflected branch's second film), each on its own stream.
        for (std::size_t b = 0; b < pending.count; ++b) {
            Rng branch_rng(pending.at[b].stream_seed, pending.at[b].stream_item);
            keep(walk_spectral(wi, lambdas_nm, position_um, branch_rng,
                               weights.subspan(count * n, n), branch, &options, nullptr,
                               &pending.at[b]));
        }
    };
    if (!options.split_first_film) {
        play(rng, FirstFilm::sampled, nullptr);
        return count;
    }
    // The entry ray is the same for both branches (it draws no random number): cast once.
    check_path_request(wi, position_um);
    FirstHit first;
    first.hit = scene_->intersect(entry_origin(position_um, wi), -wi, {}, &first.skipped);
    // The reflected branch on a copy of the stream: both branches draw the same hero.
    Rng reflected_rng = rng;
    play(reflected_rng, FirstFilm::reflect, &first);
    play(rng, FirstFilm::transmit, &first);
    return count;
}

std::optional<SpectralScatterEvent> ExplicitScatterer::sample_spectral(
    const Vec3d& wi, std::span<const double> lambdas_nm, const Vec2& position_um, Rng& rng,
    std::span<double> weights) const {
    const PathResult path = trace_spectral(wi, lambdas_nm, position_um, rng, weights);
    if (!path.event) return std::nullopt;
    return spectral_event(path);
}

PathResult ExplicitScatterer::trace_spectral(const Vec3d& wi, std::span<const double> lambdas_nm,
                                             const Vec2& position_um, Rng& rng,
                                             std::span<double> weights, FirstFilm first_film,
                                             const BranchOptions* guide) const {
    return walk_spectral(wi, lambdas_nm, position_um, rng, weights, first_film, guide, nullptr);
}

// The share of the light paths lit straight at their first diffuse event that the light side
// walks on (tracer.h, "Connections to collimated lights"): on the rock dove's 3660-pair BRDF, with
// the two sides partitioning the paths, 0.25 and 0.1 took 90 s and 89 s to 1 %, walking every one
// 108 s; with the balance heuristic and split reflections 75 s and 77 s (bench/README.md). 0.25
// keeps the weights of the paths only the light side makes (a second diffuse event) within 4×.
constexpr double kGoOnLit = 0.25;

// A connected walk's lights and where its connections go (trace_connected()).
struct ExplicitScatterer::Connections {
    std::span<const Vec3d> lights;
    LightConnectionSink* sink = nullptr;
};

// One shared walk of walk_spectral() (tracer.h: spectral path sharing, splitting, guided diffuse
// branches, detector-side walks, connections to the lights): the state it carries between events
// and one function per step, called in the order the walk takes them.
class ExplicitScatterer::SpectralWalk {
public:
    SpectralWalk(const ExplicitScatterer& tracer, const SpectralSet& set,
                 std::span<const double> lambdas_nm, std::span<double> weights, Rng& rng,
                 FirstFilm first_film, const BranchOptions* guide, PendingBranches* pending,
                 WalkState& st, const Connections* connections = nullptr)
        : t_(tracer),
          set_(set),
          hs_(*set.at[st.hero]),
          lambdas_(lambdas_nm),
          weights_(weights),
          n_(lambdas_nm.size()),
          rng_(rng),
          first_film_(first_film),
          guide_(guide),
          pending_(pending),
          st_(st),
          w_(st.w),
          path_(st.path),
          guided_(guide != nullptr && guide->guided_fraction > 0.0 &&
                  !guide->detector_axes.empty()),
          adjoint_(guide != nullptr && guide->adjoint),
          // The detector cones' cos α, for either way of guiding (one value for the whole walk).
          cos_guide_(guide != nullptr &&
                             (guide->guided_fraction > 0.0 || guide->guided_branches > 0)
                         ? std::cos(guide->detector_half_angle_rad)
                         : 1.0),
          branch_diffuse_(pending != nullptr && guide != nullptr && guide->guided_branches > 0 &&
                          !guide->detector_axes.empty()),
          leave_lit_(guide != nullptr && guide->connected_light_side),
          split_reflections_(guide != nullptr && guide->split_reflections && pending != nullptr &&
                             first_film == FirstFilm::reflect),
          split_aimed_(guide != nullptr && guide->split_aimed_reflections && pending != nullptr &&
                       !guide->detector_axes.empty()),
          cos_aim_(guide != nullptr ? std::cos(guide->detector_half_angle_rad) : 1.0),
          connections_(connections) {}

    // The walk from `first`'s entry hit when given, or from the state's origin, to its end.
    PathResult run(const FirstHit* first) {
        for (;;) {
            ++path_.rays;
            // A branch's entry ray was cast once for both (sample_spectral_branches()).
            const bool entry_cast = first != nullptr && path_.rays == 1;
            if (entry_cast) path_.self_hits_rejected += first->skipped;
            const std::optional<SurfaceHit> hit =
                entry_cast ? first->hit
                           : t_.scene_->intersect(st_.origin, st_.direction, st_.skip,
                                                  &path_.self_hits_rejected);
            // Splitting (tracer.h): only a path whose first event is at a film has a reflected
            // branch; any other first event belongs to the transmitted branch alone.
            const bool first_event = path_.events == 0;
            const bool reflected_branch = first_event && first_film_ == FirstFilm::reflect;
            if (!hit) {
                if (!reflected_branch && connections_ == nullptr) escape();
                return path_;
            }
            const Spectral::Surface& surface = hs_.surfaces[hit->surface];
            const double facing = st_.direction.dot(hit->normals.geometric);
            if (facing == 0.0) {
                st_.skip = hit->primitive;
                continue;
            }
            const bool from_outside = facing < 0.0;
            if ((from_outside ? surface.outside : surface.inside) != st_.expected)
                ++path_.medium_mismatches;
            const bool film = surface.kind == Spectral::Kind::film;
            const bool forced = first_event && first_film_ != FirstFilm::sampled && film;
            if (reflected_branch && !forced) return path_;
            const Flight flight = fly(*hit, from_outside, reflected_branch);
            if (flight == Flight::ended) return path_;
            if (flight == Flight::scattered) continue;
            if (path_.events >= t_.options_.max_events) {
                path_.reached_max_events = true;
                return path_;
            }
            // (Only after a flight through no medium: the branch left casts its ray again.)
            if (st_.split_next_film) {
                st_.split_next_film = false;
                if (film && set_.no_medium[hit->surface][from_outside ? 0 : 1] != 0)
                    leave_transmitted_branch();
            }
            if (surface.kind == Spectral::Kind::diffuse && !goes_on_at_diffuse(*hit, from_outside))
                return path_;
            const InterfaceEvent event = surface_event(*hit, forced || st_.forced_film >= 0);
            st_.forced_film = -1;
            if (leave_lit_) {
                st_.lit_straight = st_.lit_straight && event.kind == EventKind::film_transmit &&
                                   set_.film_straight[hit->surface] != 0;
            }
            // A detector-side walk estimates the forward light paths, not their transpose.
            if (adjoint_) scale(adjoint_shading_factor(st_.direction, event, hit->normals));
            if (forked_ > 0) leave_guided_branches(*hit);
            record(path_, event.kind);
            // A reflected branch splits again at its next event if that is a film.
            if (split_reflections_ && path_.events == 1) st_.split_next_film = true;
            if (event.kind == EventKind::absorb || !(largest() > 0.0)) return path_;
            st_.expected = event.to_outside ? surface.outside : surface.inside;
            st_.origin = t_.scene_->spawn_point(*hit, event.to_outside);
            st_.direction = event.direction;
            st_.skip = hit->primitive;
            if (!survives_roulette()) return path_;
        }
    }

private:
    enum class Flight { arrived, scattered, ended };

    // The hero alone goes on (tracer.h): every other λ's weight to 0, the hero's × N.
    void collapse() {
        if (st_.single) return;
        const double carried = w_[st_.hero] * static_cast<double>(n_);
        std::fill(w_.begin(), w_.begin() + static_cast<std::ptrdiff_t>(n_), 0.0);
        w_[st_.hero] = carried;
        st_.single = true;
    }
    double largest() const {
        if (st_.single) return w_[st_.hero];
        return *std::max_element(w_.begin(), w_.begin() + static_cast<std::ptrdiff_t>(n_));
    }
    void scale(double factor) {
        if (st_.single) {
            w_[st_.hero] *= factor;
        } else {
            for (std::size_t k = 0; k < n_; ++k) w_[k] *= factor;
        }
    }
    void escape() {
        if (st_.expected != hs_.ambient) ++path_.medium_mismatches;
        const Vec2 exit = exit_point(st_.origin, st_.direction, t_.top_z_, t_.bottom_z_);
        for (std::size_t k = 0; k < n_; ++k) {
            PLUMAGE_CHECK(std::isfinite(w_[k]) && w_[k] >= 0.0,
                          fmt::format("path weight {} at {} nm after {} events", w_[k], lambdas_[k],
                                      path_.events));
            weights_[k] = w_[k];
        }
        path_.event = ScatterEvent{st_.direction.normalized(), largest(), lobe_of(path_), exit};
        path_.lit_diffuse_density = st_.lit_diffuse_density;
    }
    // As in trace(), on the largest weight; every λ is scaled alike.
    bool survives_roulette() {
        const double weight = largest();
        const double carried = roulette(path_, weight, t_.options_, rng_);
        if (!(carried > 0.0)) return false;
        if (carried != weight) scale(carried / weight);
        return true;
    }

    // The medium between the last event and this surface: a scattering one takes the hero alone
    // (a scattering there continues the walk from inside the medium); absorbing ones weigh each λ.
    Flight fly(const SurfaceHit& hit, bool from_outside, bool reflected_branch) {
        const std::size_t index = hit.surface;
        if (set_.scatters[index][from_outside ? 0 : 1]) collapse();
        if (!st_.single) {
            bool met_medium = false;
            for (std::size_t k = 0; k < n_; ++k) {
                const Spectral::Surface& sk = set_.at[k]->surfaces[index];
                if (const Medium* medium = from_outside ? sk.medium_outside : sk.medium_inside) {
                    w_[k] *= medium->fly(hit.distance_um, lambdas_[k], rng_).weight;
                    met_medium = true;
                }
            }
            if (met_medium && (!(largest() > 0.0) || !survives_roulette())) return Flight::ended;
            return Flight::arrived;
        }
        const Spectral::Surface& surface = hs_.surfaces[index];
        const Medium* medium = from_outside ? surface.medium_outside : surface.medium_inside;
        if (medium == nullptr) return Flight::arrived;
        const double lambda = lambdas_[st_.hero];
        const MediumFlight flight = medium->fly(hit.distance_um, lambda, rng_);
        w_[st_.hero] *= flight.weight;
        if (!flight.scattered)
            return !(w_[st_.hero] > 0.0) || !survives_roulette() ? Flight::ended : Flight::arrived;
        if (reflected_branch) return Flight::ended;
        if (path_.events >= t_.options_.max_events) {
            path_.reached_max_events = true;
            return Flight::ended;
        }
        record(path_, EventKind::medium_scatter);
        ++path_.medium_scatters;
        st_.lit_straight = false;
        const MediumScatter scatter = medium->scatter(st_.direction, lambda, rng_);
        w_[st_.hero] *= scatter.weight;
        st_.origin += flight.distance_um * st_.direction;
        st_.direction = scatter.direction;
        st_.skip = {};
        if (!(w_[st_.hero] > 0.0) || !survives_roulette()) return Flight::ended;
        return Flight::scattered;
    }

    // Before a diffuse event: a connected walk connects at its first diffuse event and ends there.
    // A light path lit straight from the source at its first one goes on with probability
    // kGoOnLit, its weights divided by it, and carries its density factor for the instrument's
    // weights as long as this stays its only diffuse event (tracer.h, "Connections to collimated
    // lights"). False: the walk ends here.
    bool goes_on_at_diffuse(const SurfaceHit& hit, bool from_outside) {
        const bool side_clear = set_.no_medium[hit.surface][from_outside ? 0 : 1] != 0;
        if (connections_ != nullptr) {
            if (side_clear) connect_lights(hit, from_outside);
            return false;
        }
        st_.lit_diffuse_density = 0.0;
        if (leave_lit_ && !st_.diffuse_met && st_.lit_straight && side_clear) {
            if (!(rng_.uniform() < kGoOnLit)) return false;
            scale(1.0 / kGoOnLit);
            st_.lit_diffuse_density = kGoOnLit * std::abs(st_.direction.dot(hit.normals.geometric));
        }
        return true;
    }

    // The event for the path's direction at the surface hit; each λ's weight takes its factor.
    InterfaceEvent surface_event(const SurfaceHit& hit, bool forced) {
        const Spectral::Surface& surface = hs_.surfaces[hit.surface];
        switch (surface.kind) {
            case Spectral::Kind::film:
                return film_event(hit, forced);
            case Spectral::Kind::dielectric:
                return dielectric_surface_event(hit);
            case Spectral::Kind::diffuse:
                return diffuse_surface_event(hit);
            case Spectral::Kind::absorber:
                break;
        }
        return absorber_event(st_.direction, hit.normals);
    }

    // Whether every λ's event at this hit has the hero's regime (sim/interface_events.h): then
    // they reflect alike, and only a transmission needs the hero (tracer.h, "Reflection stays
    // shared").
    bool regimes_agree(const SurfaceHit& hit, bool film) const {
        std::array<double, kMaxSharedWavelengths> outside, inside;
        for (std::size_t k = 0; k < n_; ++k) {
            const Spectral::Surface& s = set_.at[k]->surfaces[hit.surface];
            outside[k] = (film ? s.film.outside : s.outside).real();
            inside[k] = (film ? s.film.inside : s.inside).real();
        }
        return specular_regimes_agree(st_.direction, hit.normals, std::span(outside.data(), n_),
                                      std::span(inside.data(), n_));
    }

    // A shared choice's weights: each λ R_k/p̄ on reflection, T_k/(1 − p̄) on transmission, times
    // the event's throughput (tracer.h); a transmission through λ-dependent indices then goes on
    // with the hero alone.
    void weigh_shared_choice(const InterfaceEvent& e, const SharedResponse& source, bool reflected,
                             bool transmitted, bool bends) {
        const double p = source.mean_reflect_probability;
        if (reflected) {
            for (std::size_t k = 0; k < n_; ++k) w_[k] *= e.throughput * source.reflectance[k] / p;
        } else if (transmitted) {
            for (std::size_t k = 0; k < n_; ++k)
                w_[k] *= e.throughput * source.transmittance[k] / (1.0 - p);
            if (bends) collapse();
        }
    }

    // A bare interface: one Fresnel factor where its indices are the same at every λ; where they
    // differ, the shared choice with mean p̄ when every λ's regime agrees, else the hero's walk.
    InterfaceEvent dielectric_surface_event(const SurfaceHit& hit) {
        const Spectral::Surface& surface = hs_.surfaces[hit.surface];
        if (split_aimed_ && room_for_aimed_branch() && aimed(hit)) {
            if (std::optional<InterfaceEvent> e = split_aimed_reflection(hit)) return *e;
        }
        if (!set_.dielectric_shared[hit.surface]) {
            if (!st_.single && regimes_agree(hit, false)) {
                const SharedResponse source(set_.at, lambdas_, hit.surface,
                                            SharedResponse::Interface::bare);
                const InterfaceEvent e =
                    dielectric_event(st_.direction, hit.normals, surface.outside.real(),
                                     surface.inside.real(), source, rng_);
                weigh_shared_choice(e, source, e.kind == EventKind::specular_reflect,
                                    e.kind == EventKind::refract, true);
                return e;
            }
            collapse();
        }
        const InterfaceEvent e =
            dielectric_event(st_.direction, hit.normals, surface.outside, surface.inside, rng_);
        scale(e.throughput);
        return e;
    }

    // Whether an aimed reflection's branch fits in pending_ beside the branches the walk may still
    // leave: its first diffuse event's guided ones and a reflected branch's split at its next film.
    bool room_for_aimed_branch() const {
        const std::size_t reserve = guide_->guided_branches + (split_reflections_ ? 1 : 0);
        return pending_->count + reserve < pending_->at.size();
    }

    // Whether the walk's mirror direction about the shading normal lies within a detector cone
    // (inside a dielectric too: tracer.h says why).
    bool aimed(const SurfaceHit& hit) const {
        const Vec3d mirror = reflect(st_.direction, hit.normals.shading);
        for (const Vec3d& axis : guide_->detector_axes)
            if (mirror.dot(axis) >= cos_aim_) return true;
        return false;
    }

    // Reflections aimed at the detectors (tracer.h), at an aimed interface: the reflected side
    // goes on as a branch in pending_ (each λ × R_k) and the walk takes the transmitted side
    // (× T_k; through λ-dependent indices with the hero alone). No value at total internal
    // reflection, which is no choice: the event is then the usual one.
    std::optional<InterfaceEvent> split_aimed_reflection(const SurfaceHit& hit) {
        const Spectral::Surface& surface = hs_.surfaces[hit.surface];
        const bool bends = !set_.dielectric_shared[hit.surface];
        if (bends && !st_.single && !regimes_agree(hit, false)) collapse();
        const double n_out = surface.outside.real(), n_in = surface.inside.real();
        const SharedResponse shared(set_.at, lambdas_, hit.surface,
                                    SharedResponse::Interface::bare);
        const OneBareResponse hero(surface);
        const FilmResponseSource& inner =
            st_.single ? static_cast<const FilmResponseSource&>(hero) : shared;
        const InterfaceEvent reflected = dielectric_event(st_.direction, hit.normals, n_out, n_in,
                                                          ForcedFilmChoice(inner, true), rng_);
        if (reflected.kind != EventKind::specular_reflect) return std::nullopt;
        // The reflected branch, from this event on its own stream.
        WalkState& branch = leave_branch(fork_seed(), 0);
        const double shading =
            adjoint_ ? adjoint_shading_factor(st_.direction, reflected, hit.normals) : 1.0;
        for (std::size_t k = 0; k < n_; ++k) {
            const double r =
                st_.single ? (k == st_.hero ? hero.last.reflectance : 0.0) : shared.reflectance[k];
            branch.w[k] *= std::max(0.0, r) * shading;
        }
        go_on(branch, hit, reflected);
        branch.lit_straight = false;
        branch.forced_film = -1;
        // The walk goes on through the interface.
        const InterfaceEvent transmitted = dielectric_event(st_.direction, hit.normals, n_out, n_in,
                                                            ForcedFilmChoice(inner, false), rng_);
        if (st_.single) {
            w_[st_.hero] *= std::max(0.0, hero.last.transmittance);
        } else {
            for (std::size_t k = 0; k < n_; ++k) w_[k] *= std::max(0.0, shared.transmittance[k]);
            if (bends) collapse();
        }
        return transmitted;
    }

    // A film: the hero's own walk, or the shared choice with mean p̄ (tracer.h); a forced first
    // film (splitting) takes the branch's side with its R_k or T_k. Between λ-dependent indices
    // the path stays shared through a reflection when every λ's regime agrees.
    InterfaceEvent film_event(const SurfaceHit& hit, bool forced) {
        const Spectral::Surface& surface = hs_.surfaces[hit.surface];
        const bool bends = !set_.film_shared[hit.surface];
        if (bends && !st_.single && !regimes_agree(hit, true)) collapse();
        // The forced side: a split second film's, else the first film's branch.
        const bool reflect =
            st_.forced_film >= 0 ? st_.forced_film == 1 : first_film_ == FirstFilm::reflect;
        if (st_.single) {
            const TabulatedFilmResponse& source = *surface.film_source;
            if (forced) {
                const ForcedFilmChoice choice(source, reflect);
                const InterfaceEvent e =
                    thin_film_event(st_.direction, hit.normals, surface.film, choice, rng_);
                w_[st_.hero] *= choice.taken;
                return e;
            }
            const InterfaceEvent e =
                thin_film_event(st_.direction, hit.normals, surface.film, source, rng_);
            w_[st_.hero] *= e.throughput;
            return e;
        }
        const SharedResponse source(set_.at, lambdas_, hit.surface,
                                    SharedResponse::Interface::film);
        if (forced) {
            const ForcedFilmChoice choice(source, reflect);
            const InterfaceEvent e =
                thin_film_event(st_.direction, hit.normals, surface.film, choice, rng_);
            for (std::size_t k = 0; k < n_; ++k)
                w_[k] *= reflect ? source.reflectance[k] : source.transmittance[k];
            if (bends && !reflect) collapse();
            return e;
        }
        const InterfaceEvent e =
            thin_film_event(st_.direction, hit.normals, surface.film, source, rng_);
        weigh_shared_choice(e, source, e.kind == EventKind::film_reflect,
                            e.kind == EventKind::film_transmit, bends);
        return e;
    }

    // A diffuse event's weights: each λ its albedo (diffuse_event's clamp) times throughput.
    void diffuse_weights(std::array<double, kMaxSharedWavelengths>& weights_k,
                         std::size_t surface_index, double throughput) const {
        if (st_.single) {
            weights_k[st_.hero] *=
                std::clamp(hs_.surfaces[surface_index].albedo, 0.0, 1.0) * throughput;
        } else {
            for (std::size_t k = 0; k < n_; ++k)
                weights_k[k] *=
                    std::clamp(set_.at[k]->surfaces[surface_index].albedo, 0.0, 1.0) * throughput;
        }
    }

    // The cones a guided diffuse event aims at (tracer.h, "Guided diffuse reflection"): the
    // detectors' in air; inside a dielectric (a medulla under its cortex) the directions that
    // leave into them through an interface parallel to the event's facet.
    std::span<const Vec3d> aim(const SurfaceHit& hit) const {
        const std::span<const Vec3d> axes = guide_->detector_axes;
        const double n = st_.expected.real();
        if (!(n > 1.0)) return axes;
        const Vec3d& g = hit.normals.geometric;
        const Vec3d out = st_.direction.dot(g) < 0.0 ? g : Vec3d(-g);
        thread_local std::vector<Vec3d> refracted;
        refracted.resize(axes.size());
        for (std::size_t j = 0; j < axes.size(); ++j)
            refracted[j] = refracted_cone_axis(axes[j], out, n);
        return refracted;
    }

    // A diffuse surface: guiding acts at the path's first diffuse event only (tracer.h), by
    // branches (their directions left in fork_) or by the one-sample mixture.
    InterfaceEvent diffuse_surface_event(const SurfaceHit& hit) {
        const Spectral::Surface& surface = hs_.surfaces[hit.surface];
        const bool first_diffuse = !st_.diffuse_met;
        st_.diffuse_met = true;
        if (branch_diffuse_ && first_diffuse) {
            forked_ = guided_diffuse_branches(st_.direction, hit.normals, aim(hit), cos_guide_,
                                              guide_->guided_branches, rng_, fork_);
            before_fork_ = w_;
            diffuse_weights(w_, hit.surface, fork_[0].throughput);
            return fork_[0];
        }
        if (guided_ && first_diffuse) {
            const InterfaceEvent e = guided_diffuse_event(
                st_.direction, hit.normals, aim(hit), cos_guide_, guide_->guided_fraction, rng_);
            diffuse_weights(w_, hit.surface, e.throughput);
            return e;
        }
        if (st_.single) {
            const InterfaceEvent e =
                diffuse_event(st_.direction, hit.normals, surface.albedo, rng_);
            w_[st_.hero] *= e.throughput;
            return e;
        }
        // The direction for all; each λ its albedo (diffuse_event's clamp).
        const InterfaceEvent e = diffuse_event(st_.direction, hit.normals, 1.0, rng_);
        for (std::size_t k = 0; k < n_; ++k)
            w_[k] *= std::clamp(set_.at[k]->surfaces[hit.surface].albedo, 0.0, 1.0);
        return e;
    }

    // Connections to the lights from the first diffuse event the walk reached from the detector
    // (tracer.h, "Connections to collimated lights"); the walk ends there.
    void connect_lights(const SurfaceHit& hit, bool from_outside) {
        const Vec3d& g = hit.normals.geometric;
        const Vec3d side = from_outside ? g : Vec3d(-g);
        const Vec3d start = t_.scene_->spawn_point(hit, from_outside);
        // The walk's weights times each λ's albedo / π (0 for the λs a hero walk has left).
        std::array<double, kMaxSharedWavelengths> base{}, w{};
        for (std::size_t k = 0; k < n_; ++k) {
            if (st_.single && k != st_.hero) continue;
            base[k] = w_[k] * std::clamp(set_.at[k]->surfaces[hit.surface].albedo, 0.0, 1.0) / kPi;
        }
        const std::span<const Vec3d> lights = connections_->lights;
        for (std::size_t j = 0; j < lights.size(); ++j) {
            const Vec3d& l = lights[j];
            const double cos_l = l.dot(side);
            if (!(cos_l > 0.0)) continue;
            // The ray keeps its direction: where it enters is known before it is cast.
            const Vec2 entry = exit_point(start, l, t_.top_z_, t_.bottom_z_);
            if (!connections_->sink->accepts(j, entry)) continue;
            for (std::size_t k = 0; k < n_; ++k) w[k] = base[k] * cos_l;
            int films = 0;
            bool open = false;
            Vec3d origin = start;
            PrimitiveRef skip = hit.primitive;
            for (;;) {
                const std::optional<SurfaceHit> h = t_.scene_->intersect(origin, l, skip);
                if (!h) {
                    open = true;
                    break;
                }
                if (set_.film_straight[h->surface] == 0) break;
                const double facing = l.dot(h->normals.geometric);
                if (facing != 0.0) {
                    // The film as light from the source meets it, travelling along −l.
                    const FilmIncidence in = film_incidence(-l, h->normals, 1.0);
                    for (std::size_t k = 0; k < n_; ++k) {
                        if (!(w[k] > 0.0)) continue;
                        const FilmResponse r =
                            set_.at[k]->surfaces[h->surface].film_source->response(in.from_outside,
                                                                                   in.cos_i);
                        w[k] *= film_transmitted_factor(r);
                    }
                    ++films;
                    origin = t_.scene_->spawn_point(*h, facing > 0.0);
                }
                skip = h->primitive;
                if (path_.events + 1 + films > t_.options_.max_events) break;
            }
            if (!open || path_.events + 1 + films > t_.options_.max_events) continue;
            int lobe = ExplicitScatterer::kMulti;
            if (path_.medium_scatters > 0) {
                lobe = ExplicitScatterer::kVolume;
            } else if (films == 1 && path_.events == 1 &&
                       path_.kinds[0] == EventKind::film_transmit) {
                lobe = ExplicitScatterer::kTRT;
            }
            connections_->sink->connect(
                {j, entry, lobe, std::span<const double>(w.data(), n_), kGoOnLit * cos_l});
        }
    }

    // The expected factor of a film event's transmitted side: a shared path's T_k (its choice
    // weighs T_k/(1 − p̄) with probability 1 − p̄), the hero's T_k · min(1, R_k + T_k)/(R_k + T_k)
    // (interface_events.cpp, choose: it keeps at most all the light).
    double film_transmitted_factor(const FilmResponse& r) const {
        const double t = std::max(0.0, r.transmittance);
        if (!st_.single) return t;
        const double total = std::max(0.0, r.reflectance) + t;
        return total > 0.0 ? t * std::min(total, 1.0) / total : 0.0;
    }

    // BranchOptions::split_reflections at a film: this walk takes the reflected side; the
    // transmitted one waits in pending_ with the state before this event (its ray is cast again)
    // and its own stream.
    void leave_transmitted_branch() {
        leave_branch(fork_seed(), 0).forced_film = 0;
        st_.forced_film = 1;
    }

    // A branch's stream seed: two draws of the walk's stream, in this order (the operands of one
    // expression would be unsequenced).
    std::uint64_t fork_seed() {
        const std::uint64_t high = rng_.next_u32();
        return (high << 32) | rng_.next_u32();
    }
    // A new branch in pending_: the walk's state as it is, on the stream Rng(seed, item).
    WalkState& leave_branch(std::uint64_t seed, std::uint64_t item) {
        WalkState& branch = pending_->at[pending_->count++];
        branch = st_;
        branch.stream_seed = seed;
        branch.stream_item = item;
        return branch;
    }
    // A branch goes on from `hit` after `event` (its record, side, origin and direction).
    void go_on(WalkState& branch, const SurfaceHit& hit, const InterfaceEvent& event) const {
        record(branch.path, event.kind);
        const Spectral::Surface& surface = hs_.surfaces[hit.surface];
        branch.expected = event.to_outside ? surface.outside : surface.inside;
        branch.origin = t_.scene_->spawn_point(hit, event.to_outside);
        branch.direction = event.direction;
        branch.skip = hit.primitive;
    }

    // The guided branches of the first diffuse event wait in pending_, each from this event with
    // its own direction and stream.
    void leave_guided_branches(const SurfaceHit& hit) {
        const std::uint64_t seed = fork_seed();
        for (std::size_t b = 1; b < forked_; ++b) {
            if (fork_[b].kind != EventKind::diffuse_reflect) continue;
            WalkState& branch = leave_branch(seed, b);
            branch.w = before_fork_;
            diffuse_weights(branch.w, hit.surface, fork_[b].throughput);
            go_on(branch, hit, fork_[b]);
        }
        forked_ = 0;
    }

    const ExplicitScatterer& t_;
    const SpectralSet& set_;
    const Spectral& hs_;  // the hero's optics
    std::span<const double> lambdas_;
    std::span<double> weights_;
    std::size_t n_;
    Rng& rng_;
    FirstFilm first_film_;
    const BranchOptions* guide_;
    PendingBranches* pending_;
    WalkState& st_;
    std::array<double, kMaxSharedWavelengths>& w_;
    PathResult& path_;
    bool guided_, adjoint_;
    double cos_guide_;
    bool branch_diffuse_;
    bool leave_lit_;                  // BranchOptions::connected_light_side
    bool split_reflections_;          // BranchOptions::split_reflections, on a reflected branch
    bool split_aimed_;                // BranchOptions::split_aimed_reflections, with room to leave
    double cos_aim_;                  // cos of the detector cones' half-angle
    const Connections* connections_;  // a connected walk's lights, or none
    // The first diffuse event's guided directions (branch_diffuse_): fork_[1 … forked_ − 1].
    std::array<InterfaceEvent, 1 + BranchOptions::kMaxGuidedBranches> fork_;
    std::size_t forked_ = 0;
    std::array<double, kMaxSharedWavelengths> before_fork_;  // w at that event, before it
};

PathResult ExplicitScatterer::walk_spectral(const Vec3d& wi, std::span<const double> lambdas_nm,
                                            const Vec2& position_um, Rng& rng,
                                            std::span<double> weights, FirstFilm first_film,
                                            const BranchOptions* guide, const FirstHit* first,
                                            const WalkState* resume,
                                            PendingBranches* pending) const {
    const std::size_t n = lambdas_nm.size();
    if (n < 1 || n > kMaxSharedWavelengths || weights.size() != n) {
        throw InputError(fmt::format(
            "tracer: {} wavelengths and {} weights for one shared path: expected 1..{} of each", n,
            weights.size(), kMaxSharedWavelengths));
    }
    check_path_request(wi, position_um);
    for (double l : lambdas_nm) optics::require_wavelength(l);
    const SpectralSet& set = spectral_set(lambdas_nm);
    std::fill(weights.begin(), weights.end(), 0.0);

    WalkState st = resume != nullptr ? *resume : start_state(set, wi, position_um, n, rng);
    SpectralWalk walk(*this, set, lambdas_nm, weights, rng, first_film, guide, pending, st);
    return walk.run(first);
}

ExplicitScatterer::WalkState ExplicitScatterer::start_state(const SpectralSet& set, const Vec3d& wi,
                                                            const Vec2& position_um, std::size_t n,
                                                            Rng& rng) const {
    WalkState st;
    // The hero: the one wavelength that goes on once the path's geometry depends on λ.
    st.hero = std::min(n - 1, static_cast<std::size_t>(rng.uniform() * static_cast<double>(n)));
    st.origin = entry_origin(position_um, wi);
    st.direction = -wi;
    st.expected = set.at[st.hero]->ambient;
    std::fill(st.w.begin(), st.w.begin() + static_cast<std::ptrdiff_t>(n), 1.0);
    st.single = n == 1;
    return st;
}

void ExplicitScatterer::trace_connected(const Vec3d& wo, std::span<const double> lambdas_nm,
                                        const Vec2& position_um, Rng& rng,
                                        std::span<const Vec3d> lights,
                                        LightConnectionSink& sink) const {
    const std::size_t n = lambdas_nm.size();
    if (n < 1 || n > kMaxSharedWavelengths) {
        throw InputError(
            fmt::format("tracer: {} wavelengths for one connected walk: expected 1..{}", n,
                        kMaxSharedWavelengths));
    }
    check_path_request(wo, position_um);
    for (double l : lambdas_nm) optics::require_wavelength(l);
    for (const Vec3d& l : lights) {
        PLUMAGE_CHECK(l.allFinite() && std::abs(l.norm() - 1.0) < 1e-9,
                      "trace_connected: light directions must be unit vectors");
    }
    const SpectralSet& set = spectral_set(lambdas_nm);
    WalkState st = start_state(set, wo, position_um, n, rng);
    // A connected walk's escape counts nothing (a collimated light is never hit).
    std::array<double, kMaxSharedWavelengths> escaped{};
    BranchOptions adjoint;
    adjoint.adjoint = true;
    const Connections connections{lights, &sink};
    SpectralWalk walk(*this, set, lambdas_nm, std::span<double>(escaped.data(), n), rng,
                      FirstFilm::sampled, &adjoint, nullptr, st, &connections);
    walk.run(nullptr);
}

std::vector<std::optional<ScatterEvent>> trace_many(const Scatterer& scatterer, const Vec3d& wi,
                                                    double lambda_nm,
                                                    const BeamFootprint& footprint,
                                                    std::uint64_t seed, std::uint64_t first_index,
                                                    std::size_t count, int threads) {
    if (threads < 1) {
        throw InputError(fmt::format("trace_many: threads = {}: expected >= 1", threads));
    }
    if (!footprint.min_um.allFinite() || !footprint.max_um.allFinite() ||
        (footprint.max_um.array() < footprint.min_um.array()).any()) {
        throw InputError("trace_many: footprint: expected finite corners with min <= max");
    }
    std::vector<std::optional<ScatterEvent>> out(count);
    std::exception_ptr error;
    std::mutex error_mutex;
    const auto n = static_cast<std::int64_t>(count);
    const Vec2 size = footprint.max_um - footprint.min_um;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256)
    for (std::int64_t i = 0; i < n; ++i) {
        try {
            Rng rng(seed, first_index + static_cast<std::uint64_t>(i));
            const double u = rng.uniform(), v = rng.uniform();
            const Vec2 position = footprint.min_um + Vec2(u * size.x(), v * size.y());
            out[static_cast<std::size_t>(i)] = scatterer.sample(wi, lambda_nm, position, rng);
        } catch (...) {
            std::lock_guard lock(error_mutex);
            if (!error) error = std::current_exception();
        }
    }
    if (error) std::rethrow_exception(error);
    return out;
}

double LobeTally::mean(int lobe) const {
    return weight.at(static_cast<std::size_t>(lobe)) / static_cast<double>(samples);
}

double LobeTally::standard_error(int lobe) const {
    const auto n = static_cast<double>(samples);
    const double m = mean(lobe);
    const double second = weight_sq.at(static_cast<std::size_t>(lobe)) / n;
    return std::sqrt(std::max(0.0, second - m * m) / std::max(1.0, n - 1.0));
}

LobeTally tally(const std::vector<std::optional<ScatterEvent>>& samples, std::size_t lobes) {
    LobeTally t;
    t.samples = samples.size();
    t.weight.assign(lobes, 0.0);
    t.weight_sq.assign(lobes, 0.0);
    t.count.assign(lobes, 0);
    for (const auto& s : samples) {
        if (!s) continue;
        const auto lobe = static_cast<std::size_t>(s->lobe);
        PLUMAGE_CHECK(lobe < lobes, fmt::format("lobe index {} of {}", lobe, lobes));
        t.weight[lobe] += s->weight;
        t.weight_sq[lobe] += s->weight * s->weight;
        ++t.count[lobe];
        (s->wo.z() > 0.0 ? t.up : t.down) += s->weight;
    }
    return t;
}

}  // namespace plumage::sim
