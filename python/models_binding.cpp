// plumage._core's models: Model (a Scatterer with eval over numpy arrays) and one factory per
// analytic model of analysis/, taking the C++ parameter fields as keywords.
#include <algorithm>
#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <pybind11/stl.h>

#include "analysis/models/filip2024.h"
#include "analysis/models/huang2022.h"
#include "analysis/models/lambertian.h"
#include "analysis/models/padrongriffe2024.h"
#include "common/error.h"
#include "python/binding_util.h"

namespace plumage::python {
namespace {

// ---------------------------------------------------------------------------------------------
// Keyword parameters: one Field per C++ member, named as the member.

template <typename Params>
struct Field {
    std::string name;
    std::function<void(Params&, py::handle)> set;
    std::function<py::object(const Params&)> get;
};

template <typename Params>
Field<Params> scalar(std::string name, double Params::*member) {
    return {std::move(name), [member](Params& p, py::handle v) { p.*member = v.cast<double>(); },
            [member](const Params& p) { return py::cast(p.*member); }};
}

// A member reached through a getter of a nested struct (PadronGriffe2024Params::geometry).
template <typename Params, typename T>
Field<Params> nested(std::string name, std::function<T&(Params&)> at) {
    return {std::move(name), [at](Params& p, py::handle v) { at(p) = v.cast<T>(); },
            [at](const Params& p) { return py::cast(at(const_cast<Params&>(p))); }};
}

template <typename Params>
std::string field_names(const std::vector<Field<Params>>& fields) {
    std::string names;
    for (const auto& f : fields) names += (names.empty() ? "" : ", ") + f.name;
    return names;
}

// Applies the keywords to `p`; TypeError for an unknown key or a value of the wrong type.
template <typename Params>
void apply(const std::string& model, const std::vector<Field<Params>>& fields,
           const py::dict& kwargs, Params& p) {
    for (const auto& [key, value] : kwargs) {
        const std::string name = py::str(key);
        const auto f = std::find_if(fields.begin(), fields.end(),
                                    [&](const Field<Params>& x) { return x.name == name; });
        if (f == fields.end()) {
            throw py::type_error(fmt::format("{}: unknown parameter '{}'; valid parameters: {}",
                                             model, name, field_names(fields)));
        }
        try {
            f->set(p, value);
        } catch (const py::cast_error&) {
            throw py::type_error(fmt::format("{}: parameter '{}' = {}: expected a number", model,
                                             name, std::string(py::repr(value))));
        }
    }
}

template <typename Params>
py::dict to_dict(const std::vector<Field<Params>>& fields, const Params& p) {
    py::dict d;
    for (const auto& f : fields) d[py::str(f.name)] = f.get(p);
    return d;
}

// ---------------------------------------------------------------------------------------------
// The models.

class Model {
public:
    Model(std::shared_ptr<const Scatterer> scatterer, py::dict params)
        : scatterer_(std::move(scatterer)), params_(std::move(params)) {}

    std::string name() const { return scatterer_->name(); }
    const std::vector<std::string>& lobe_names() const { return scatterer_->lobe_names(); }
    py::dict params() const { return py::dict(params_); }

    // f(wi, wo, λ) for N elements: wi, wo of shape (N, 3) or (3,), λ of shape (N,) or scalar;
    // 0 where wi.z <= 0, and where wo.z <= 0 unless `transmission` (python/plumage/models.py
    // broadcasts (..., 3) arrays to these shapes and documents the call).
    py::object eval(const Array& wi, const Array& wo, const Array& lambda_nm, bool lobes,
                    std::optional<int> threads, bool transmission) const;

private:
    std::shared_ptr<const Scatterer> scatterer_;
    py::dict params_;
};

// Number of 3-vectors in a direction argument: (3,) → 1 (broadcast), (N, 3) → N.
py::ssize_t direction_count(const Array& a, const char* what) {
    if (a.ndim() == 1 && a.shape(0) == 3) return 1;
    if (a.ndim() == 2 && a.shape(1) == 3) return a.shape(0);
    throw py::value_error(fmt::format("{}: expected shape (N, 3) or (3,) (unit vectors), got {}",
                                      what, shape_text(a)));
}

py::ssize_t scalar_count(const Array& a, const char* what) {
    if (a.ndim() == 0) return 1;
    if (a.ndim() == 1) return a.shape(0);
    throw py::value_error(
        fmt::format("{}: expected a scalar or shape (N,), got {}", what, shape_text(a)));
}

py::object Model::eval(const Array& wi, const Array& wo, const Array& lambda_nm, bool lobes,
                       std::optional<int> threads, bool transmission) const {
    const py::ssize_t ni = direction_count(wi, "wi"), no = direction_count(wo, "wo"),
                      nl = scalar_count(lambda_nm, "wavelength_nm");
    const py::ssize_t n = broadcast_count({{ni, "wi"}, {no, "wo"}, {nl, "wavelength_nm"}});
    const double* pi = wi.data();
    const double* po = wo.data();
    const double* pl = lambda_nm.data();
    const std::size_t si = ni == 1 ? 0 : 3, so = no == 1 ? 0 : 3, sl = nl == 1 ? 0 : 1;

    Array total(n);
    double* out = total.mutable_data();
    const std::size_t nlobes = lobes ? scatterer_->lobe_names().size() : 0;
    std::vector<Array> per_lobe;
    std::vector<double*> lobe_out;
    for (std::size_t k = 0; k < nlobes; ++k) {
        per_lobe.emplace_back(n);
        lobe_out.push_back(per_lobe.back().mutable_data());
    }
    const Scatterer& s = *scatterer_;
    parallel_for(n, threads, [&](py::ssize_t i) {
        const std::size_t u = static_cast<std::size_t>(i);
        const Vec3d a(pi[u * si], pi[u * si + 1], pi[u * si + 2]);
        const Vec3d b(po[u * so], po[u * so + 1], po[u * so + 2]);
        std::array<double, 16> buffer{};
        PLUMAGE_CHECK(nlobes <= buffer.size(), "more lobes than the binding's buffer");
        // Below the horizon is 0, not an error: a grid over the sphere, or light from below,
        // is a user's ordinary input (the models are lit from above; Huang's raises there).
        const bool below = a.z() <= 0.0 || (!transmission && b.z() <= 0.0);
        out[i] = below ? 0.0 : s.eval(a, b, pl[u * sl], std::span<double>(buffer.data(), nlobes));
        for (std::size_t k = 0; k < nlobes; ++k) lobe_out[k][i] = buffer[k];
    });
    if (!lobes) return total;
    py::dict result;
    result["total"] = total;
    for (std::size_t k = 0; k < nlobes; ++k) result[py::str(s.lobe_names()[k])] = per_lobe[k];
    return result;
}

const std::vector<Field<analysis::Huang2022Params>>& huang_fields() {
    using P = analysis::Huang2022Params;
    // The names are the model's table's (analysis/models/huang2022.h), in its order.
    static const std::array<double P::*, 7> members = {&P::b,    &P::phi0,    &P::phi1, &P::H,
                                                       &P::d_um, &P::theta_d, &P::mu};
    static const std::vector<Field<P>> fields = [] {
        std::vector<Field<P>> f;
        for (std::size_t i = 0; i < members.size(); ++i)
            f.push_back(
                scalar(std::string(analysis::kHuang2022ParameterTable[i].name), members[i]));
        return f;
    }();
    return fields;
}

const std::vector<Field<analysis::Filip2024Parameters>>& filip_fields() {
    using P = analysis::Filip2024Parameters;
    auto rgb = [](std::string name, analysis::Rgb P::*member) {
        return Field<P>{std::move(name),
                        [member](P& p, py::handle v) { p.*member = v.cast<analysis::Rgb>(); },
                        [member](const P& p) { return py::cast(p.*member); }};
    };
    static const std::vector<Field<P>> fields = {
        scalar("phi_a_rad", &P::phi_a_rad),
        rgb("c_b", &P::c_b),
        rgb("c_a", &P::c_a),
        rgb("c_s", &P::c_s),
        rgb("c_r", &P::c_r),
        scalar("alpha", &P::alpha),
        scalar("beta", &P::beta),
        scalar("gamma", &P::gamma),
        scalar("w", &P::w),
        scalar("d_w", &P::d_w),
        scalar("theta_max_rad", &P::theta_max_rad),
        scalar("brdf_scale_per_sr", &P::brdf_scale_per_sr)};
    return fields;
}

// Padrón-Griffe's own members, then its geometry's (geometry.barb.* and geometry.*) by their
// member names, which do not collide.
const std::vector<Field<analysis::PadronGriffe2024Params>>& padron_fields() {
    using P = analysis::PadronGriffe2024Params;
    using G = geometry::BarbulePatchParams;
    using B = geometry::BarbParams;
    auto geo = [](std::string name, double G::*member) {
        return nested<P, double>(std::move(name),
                                 [member](P& p) -> double& { return p.geometry.*member; });
    };
    auto barb = [](std::string name, double B::*member) {
        return nested<P, double>(std::move(name),
                                 [member](P& p) -> double& { return p.geometry.barb.*member; });
    };
    static const std::vector<Field<P>> fields = {
        scalar("barb_absorption_per_um", &P::barb_absorption_per_um),
        scalar("barbule_absorption_per_um", &P::barbule_absorption_per_um),
        scalar("medulla_albedo", &P::medulla_albedo),
        scalar("barb_alpha_r_rad", &P::barb_alpha_r_rad),
        scalar("barb_beta_r_rad", &P::barb_beta_r_rad),
        scalar("barbule_alpha_r_rad", &P::barbule_alpha_r_rad),
        scalar("barbule_beta_r_rad", &P::barbule_beta_r_rad),
        scalar("azimuthal_roughness_rad", &P::azimuthal_roughness_rad),
        nested<P, int>("fibre_offsets", [](P& p) -> int& { return p.fibre_offsets; }),
        barb("barb_width_um", &B::barb_width_um),
        barb("barb_axis_ratio", &B::barb_axis_ratio),
        barb("barb_rotation_rad", &B::barb_rotation_rad),
        barb("medulla_scale", &B::medulla_scale),
        barb("medulla_offset_y_um", &B::medulla_offset_y_um),
        barb("medulla_offset_z_um", &B::medulla_offset_z_um),
        geo("barbule_width_um", &G::barbule_width_um),
        geo("barbule_axis_ratio", &G::barbule_axis_ratio),
        geo("barbule_rotation_rad", &G::barbule_rotation_rad),
        geo("barbule_inclination_rad", &G::barbule_inclination_rad),
        geo("barbule_length", &G::barbule_length),
        geo("barbule_separation", &G::barbule_separation),
        geo("barb_spacing", &G::barb_spacing)};
    return fields;
}

const std::vector<Field<double>>& lambertian_fields() {
    static const std::vector<Field<double>> fields = {
        {"albedo", [](double& a, py::handle v) { a = v.cast<double>(); },
         [](const double& a) { return py::cast(a); }}};
    return fields;
}

Model make_huang(const py::dict& kwargs) {
    analysis::Huang2022Params p;
    apply("Huang2022", huang_fields(), kwargs, p);
    return Model(std::make_shared<analysis::Huang2022Bsdf>(p), to_dict(huang_fields(), p));
}

Model make_filip(std::optional<std::string> preset, const py::dict& kwargs) {
    analysis::Filip2024Parameters p =
        preset ? analysis::filip2024_preset(*preset) : analysis::Filip2024Parameters{};
    apply("Filip2024", filip_fields(), kwargs, p);
    return Model(std::make_shared<analysis::Filip2024Brdf>(p), to_dict(filip_fields(), p));
}

Model make_padron(const py::dict& kwargs) {
    analysis::PadronGriffe2024Params p;
    apply("PadronGriffe2024", padron_fields(), kwargs, p);
    return Model(std::make_shared<analysis::PadronGriffe2024Bsdf>(p), to_dict(padron_fields(), p));
}

Model make_lambertian(const py::dict& kwargs) {
    double albedo = 0.8;
    apply("Lambertian", lambertian_fields(), kwargs, albedo);
    return Model(std::make_shared<analysis::LambertianScatterer>(albedo),
                 to_dict(lambertian_fields(), albedo));
}

}  // namespace

// A model's parameter table (common/parameter_spec.h) as a list of dicts, in the table's order:
// the names the model's keyword arguments and the fits take, with unit, default and range.
py::list parameter_table(const std::string& model) {
    std::span<const ParameterSpec> table;
    if (model == "huang2022") {
        table = analysis::kHuang2022ParameterTable;
    } else if (model == "filip2024") {
        table = analysis::kFilip2024ParameterTable;
    } else {
        throw py::value_error(fmt::format(
            "parameter_table: unknown model '{}': expected 'huang2022' or 'filip2024'", model));
    }
    py::list out;
    for (const ParameterSpec& p : table) {
        py::dict d;
        d["name"] = std::string(p.name);
        d["unit"] = std::string(p.unit);
        d["default"] = p.default_value;
        d["min"] = p.min;
        d["max"] = p.max;
        d["min_open"] = p.min_open;
        d["max_open"] = p.max_open;
        d["range"] = p.range_text();
        d["meaning"] = std::string(p.meaning);
        out.append(d);
    }
    return out;
}

void bind_models(py::module_& m) {
    py::class_<Model>(m, "Model")
        .def_property_readonly("name", &Model::name)
        .def_property_readonly("lobe_names", &Model::lobe_names)
        .def_property_readonly("params", &Model::params)
        .def("eval", &Model::eval, py::arg("wi"), py::arg("wo"), py::arg("wavelength_nm"),
             py::arg("lobes") = false, py::arg("threads") = py::none(),
             py::arg("transmission") = false);
    m.def("make_huang2022", &make_huang);
    m.def("make_filip2024", &make_filip, py::arg("preset"), py::arg("kwargs"));
    m.def("make_padrongriffe2024", &make_padron);
    m.def("make_lambertian", &make_lambertian);
    m.def("parameter_table", &parameter_table, py::arg("model"));
    m.def("filip2024_presets", [] {
        std::vector<std::string> names;
        for (const auto n : analysis::filip2024_preset_names()) names.emplace_back(n);
        return names;
    });
}

}  // namespace plumage::python
