// plumage._core's Huang fit: analysis/fits/huang2022_fit.h on a scatterogram given as numpy arrays
// (python/plumage/models.py takes them from a record). The fit runs without the GIL, with its own
// OpenMP loop over pixels (`threads`; its result does not depend on the count).
#include <algorithm>
#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "analysis/fits/filip2024_fit.h"
#include "analysis/fits/fit_summary.h"
#include "analysis/fits/huang2022_fit.h"
#include "analysis/fits/user_data.h"
#include "analysis/models/filip2024.h"
#include "common/error.h"
#include "python/binding_util.h"

namespace plumage::python {
namespace {

// The record's scatterogram as the fit reads it: beam or cone or hemisphere illumination, the
// image [rows, columns, λ] with its standard errors, and each pixel's solid angle.
gonio::Scatterogram scatterogram_of(const std::string& illumination, const Array& beam_direction,
                                    double cone_aperture_rad, const Array& wavelengths_nm,
                                    const Array& intensity, const Array& standard_error,
                                    const Array& solid_angle_sr) {
    gonio::Scatterogram s;
    gonio::ScatterometerConfig& c = s.config;
    if (illumination == "beam") {
        c.illumination = gonio::Illumination::beam;
    } else if (illumination == "cone") {
        c.illumination = gonio::Illumination::cone;
    } else if (illumination == "hemisphere") {
        c.illumination = gonio::Illumination::hemisphere;
    } else {
        throw py::value_error(fmt::format(
            "illumination '{}': expected 'beam', 'cone' or 'hemisphere'", illumination));
    }
    if (beam_direction.size() != 3) throw py::value_error("beam_direction: expected 3 values");
    c.beam_direction = Vec3d(beam_direction.at(0), beam_direction.at(1), beam_direction.at(2));
    c.cone_aperture_rad = cone_aperture_rad;
    if (intensity.ndim() != 3 || standard_error.ndim() != 3 || solid_angle_sr.ndim() != 2) {
        throw py::value_error(
            "expected intensity and standard_error [rows, columns, λ], solid_angle_sr [rows, "
            "columns]");
    }
    const py::ssize_t rows = intensity.shape(0), nl = intensity.shape(2);
    if (intensity.shape(1) != rows || wavelengths_nm.size() != nl ||
        standard_error.size() != intensity.size() || solid_angle_sr.shape(0) != rows ||
        solid_angle_sr.shape(1) != rows) {
        throw py::value_error(fmt::format(
            "a square image [{0}, {0}, {1}] with {1} wavelengths, its standard errors and "
            "[{0}, {0}] solid angles: the shapes do not match",
            rows, wavelengths_nm.size()));
    }
    c.image_size = static_cast<int>(rows);
    c.wavelengths_nm.assign(wavelengths_nm.data(), wavelengths_nm.data() + nl);
    s.scatterer = "record";
    s.intensity.assign(intensity.data(), intensity.data() + intensity.size());
    s.standard_error.assign(standard_error.data(), standard_error.data() + standard_error.size());
    s.solid_angle_sr.assign(solid_angle_sr.data(), solid_angle_sr.data() + solid_angle_sr.size());
    return s;
}

analysis::Huang2022Params params_of(const py::dict& start) {
    analysis::Huang2022Params p;
    auto values = analysis::huang2022_values(p);
    for (const auto& [key, value] : start) {
        const std::string name = py::str(key);
        const auto& names = analysis::kHuang2022ParameterNames;
        const auto it = std::find(names.begin(), names.end(), name);
        if (it == names.end()) {
            throw py::type_error(
                fmt::format("fit_huang2022: unknown parameter '{}' in start", name));
        }
        values[static_cast<std::size_t>(it - names.begin())] = value.cast<double>();
    }
    return analysis::huang2022_params(values);
}

py::dict dict_of(const analysis::Huang2022Params& p) {
    py::dict d;
    const auto values = analysis::huang2022_values(p);
    for (int i = 0; i < analysis::kHuang2022ParameterCount; ++i)
        d[py::str(std::string(analysis::kHuang2022ParameterNames[i]))] = values[i];
    return d;
}

// What both fits' results hold alike: covariance and quality, under the same keys.
template <class Fit>
void put_fit_quality(py::dict& d, const Fit& r) {
    d["covariance"] = r.covariance_available ? py::cast(r.covariance) : py::none();
    d["residual_rms_per_sr"] = r.residual_rms;
    d["reduced_chi_square"] = r.reduced_chi_square;
    d["chi_square"] = r.reduced_chi_square * r.degrees_of_freedom;
    d["observations"] = r.observations;
    d["degrees_of_freedom"] = r.degrees_of_freedom;
    d["converged"] = r.converged;
    d["termination"] = r.termination;
}

py::dict fit(const std::string& illumination, const Array& beam_direction, double cone_aperture_rad,
             const Array& wavelengths_nm, const Array& intensity, const Array& standard_error,
             const Array& solid_angle_sr, const py::dict& start,
             const analysis::HuangFitOptions& options, const std::string& data_file) {
    const gonio::Scatterogram data =
        scatterogram_of(illumination, beam_direction, cone_aperture_rad, wavelengths_nm, intensity,
                        standard_error, solid_angle_sr);
    const analysis::Huang2022Params first = params_of(start);
    analysis::HuangFitResult r;
    try {
        py::gil_scoped_release release;
        r = analysis::fit_huang2022(data, first, options);
    } catch (const InputError& e) {
        throw analysis::naming_data_file(e, data_file);
    }
    py::dict d, errors, at_bound;
    for (int i = 0; i < analysis::kHuang2022ParameterCount; ++i) {
        const std::string name(analysis::kHuang2022ParameterNames[i]);
        errors[py::str(name)] = r.standard_errors[i];
        at_bound[py::str(name)] = r.at_bound[i];
    }
    std::vector<std::string> free;
    for (int i : r.free_parameters) free.emplace_back(analysis::kHuang2022ParameterNames[i]);
    d["params"] = dict_of(r.parameters);
    d["standard_errors"] = errors;
    d["at_bound"] = at_bound;
    d["free_parameters"] = free;
    put_fit_quality(d, r);
    d["pixels"] = r.pixels;
    d["wavelengths_nm"] = r.wavelengths_nm;
    d["iterations"] = r.iterations;
    d["function_evaluations"] = r.function_evaluations;
    d["wall_time_s"] = r.wall_time_s;
    // The documented JSON of `plumage fit` (analysis/fits/fit_summary.h, docs/user_data.md).
    d["json"] = analysis::summarise_fit(r, options,
                                        {data_file.empty() ? "numpy arrays" : data_file,
                                         data_file.empty() ? "arrays" : "scatterogram_record",
                                         true,
                                         0,
                                         {}})
                    .to_json();
    return d;
}

// The fit's forward model: the model's image [rows, columns, λ] under the record's illumination.
Array predict(const std::string& illumination, const Array& beam_direction,
              double cone_aperture_rad, const Array& wavelengths_nm, const Array& intensity,
              const Array& standard_error, const Array& solid_angle_sr, const py::dict& params,
              const analysis::HuangFitOptions& options) {
    const gonio::Scatterogram data =
        scatterogram_of(illumination, beam_direction, cone_aperture_rad, wavelengths_nm, intensity,
                        standard_error, solid_angle_sr);
    const analysis::Huang2022Params p = params_of(params);
    gonio::Scatterogram model;
    {
        py::gil_scoped_release release;
        model = analysis::huang2022_scatterogram(p, data.config, options);
    }
    Array out({intensity.shape(0), intensity.shape(1), intensity.shape(2)});
    std::copy(model.intensity.begin(), model.intensity.end(), out.mutable_data());
    return out;
}

// ---- Filip 2024 on BRDF observations ----------------------------------------------------------

int filip_index(const std::string& name) {
    for (int i = 0; i < analysis::kFilip2024ParameterCount; ++i)
        if (analysis::kFilip2024ParameterTable[i].name == name) return i;
    throw py::value_error(fmt::format("fit_filip2024: unknown parameter '{}'", name));
}

// The fit of `data` from `preset` (or parrot) overridden by `start`, with `fixed`/`free` flipping
// the default holds (theta_max, brdf_scale); the result as fit_huang2022's dict, plus each
// observation's model value and residual.
py::dict fit_filip_observations(const analysis::BrdfData& data, const py::dict& start,
                                const std::vector<std::string>& fixed,
                                const std::vector<std::string>& free, const std::string& preset,
                                int global_starts, const std::string& data_file) {
    auto values =
        analysis::to_vector(analysis::filip2024_preset(preset.empty() ? "parrot" : preset));
    for (const auto& [key, value] : start) values[filip_index(py::str(key))] = value.cast<double>();
    analysis::Filip2024FitOptions options;
    for (const auto& name : fixed) options.fixed[filip_index(name)] = true;
    for (const auto& name : free) options.fixed[filip_index(name)] = false;
    options.global_starts = global_starts;
    analysis::Filip2024FitResult r;
    std::vector<double> model;
    try {
        py::gil_scoped_release release;
        r = analysis::fit_filip2024(data.observations, analysis::from_vector(values), options);
        std::array<double, analysis::kFilip2024ParameterCount> gradient{};
        for (const auto& o : data.observations) {
            model.push_back(analysis::filip2024_value_and_gradient(
                r.parameters, analysis::filip2024_geometry(o.wi, o.wo),
                o.channel ? *o.channel : analysis::filip2024_channel(*o.lambda_nm), gradient));
        }
    } catch (const InputError& e) {
        throw analysis::naming_data_file(e, data_file);
    }
    py::dict d, params, errors, at_bound;
    for (int i = 0; i < analysis::kFilip2024ParameterCount; ++i) {
        const py::str name(std::string(analysis::kFilip2024ParameterTable[i].name));
        params[name] = r.values[i];
        errors[name] = r.standard_errors[i];
        at_bound[name] = r.at_bound[i];
    }
    std::vector<std::string> free_names;
    for (int i : r.free_parameters)
        free_names.emplace_back(analysis::kFilip2024ParameterTable[i].name);
    Array model_out(static_cast<py::ssize_t>(model.size()));
    Array residual(static_cast<py::ssize_t>(model.size()));
    for (std::size_t k = 0; k < model.size(); ++k) {
        model_out.mutable_at(static_cast<py::ssize_t>(k)) = model[k];
        residual.mutable_at(static_cast<py::ssize_t>(k)) =
            (model[k] - data.observations[k].value) /
            data.observations[k].standard_error.value_or(1.0);
    }
    std::vector<double> wavelengths;
    for (const auto& o : data.observations)
        if (o.lambda_nm &&
            std::find(wavelengths.begin(), wavelengths.end(), *o.lambda_nm) == wavelengths.end())
            wavelengths.push_back(*o.lambda_nm);
    std::sort(wavelengths.begin(), wavelengths.end());
    d["params"] = params;
    d["standard_errors"] = errors;
    d["at_bound"] = at_bound;
    d["free_parameters"] = free_names;
    put_fit_quality(d, r);
    d["model_per_sr"] = model_out;
    d["residuals"] = residual;
    d["json"] =
        analysis::summarise_fit(r, options,
                                {data_file.empty() ? "numpy arrays" : data_file, data.format,
                                 data.has_standard_errors, data.left_out, wavelengths})
            .to_json();
    return d;
}

// Observations from arrays: angles_deg [n, 4] (θ_i, φ_i, θ_o, φ_o), wavelength_nm [n],
// value [n] (1/sr), sigma [n] or None.
analysis::BrdfData observations_of(const Array& angles_deg, const Array& wavelength_nm,
                                   const Array& value, const std::optional<Array>& sigma) {
    const py::ssize_t n = value.size();
    if (angles_deg.ndim() != 2 || angles_deg.shape(0) != n || angles_deg.shape(1) != 4 ||
        wavelength_nm.size() != n || (sigma && sigma->size() != n)) {
        throw py::value_error(fmt::format(
            "fit_filip2024: expected angles_deg (N, 4), wavelength_nm, value and sigma (N,) with "
            "N = {}; got angles {}, wavelengths {}, sigma {}",
            n, shape_text(angles_deg), wavelength_nm.size(), sigma ? sigma->size() : 0));
    }
    analysis::BrdfData data;
    data.format = "arrays";
    data.has_standard_errors = sigma.has_value();
    for (py::ssize_t k = 0; k < n; ++k) {
        const double* a = angles_deg.data() + 4 * k;
        for (const double theta : {a[0], a[2]}) {
            if (!(theta >= 0.0 && theta < 90.0)) {
                throw py::value_error(fmt::format(
                    "fit_filip2024: row {}: polar angle {} deg: expected [0, 90)", k, theta));
            }
        }
        data.observations.push_back({analysis::direction_from_degrees(a[0], a[1]),
                                     analysis::direction_from_degrees(a[2], a[3]), std::nullopt,
                                     wavelength_nm.at(k), value.at(k),
                                     sigma ? std::optional<double>(sigma->at(k)) : std::nullopt});
    }
    return data;
}

}  // namespace

void bind_fit(py::module_& m) {
    using O = analysis::HuangFitOptions;
    py::class_<O>(m, "HuangFitOptions")
        .def(py::init<>())
        .def_readwrite("fixed", &O::fixed)
        .def_readwrite("wavelengths_nm", &O::wavelengths_nm)
        .def_readwrite("edge_lines", &O::edge_lines)
        .def_readwrite("edge_bisections", &O::edge_bisections)
        .def_readwrite("pixel_stride", &O::pixel_stride)
        .def_readwrite("max_relative_error", &O::max_relative_error)
        .def_readwrite("relative_error_floor", &O::relative_error_floor)
        .def_readwrite("illumination_nodes_radial", &O::illumination_nodes_radial)
        .def_readwrite("illumination_nodes_azimuthal", &O::illumination_nodes_azimuthal)
        .def_readwrite("finite_difference_step", &O::finite_difference_step)
        .def_readwrite("max_function_evaluations", &O::max_function_evaluations)
        .def_readwrite("relative_tolerance", &O::relative_tolerance)
        .def_readwrite("global_starts", &O::global_starts)
        .def_readwrite("threads", &O::threads);
    m.def("fit_huang2022", &fit, py::arg("illumination"), py::arg("beam_direction"),
          py::arg("cone_aperture_rad"), py::arg("wavelengths_nm"), py::arg("intensity"),
          py::arg("standard_error"), py::arg("solid_angle_sr"), py::arg("start"),
          py::arg("options"), py::arg("data_file") = "");
    m.def(
        "fit_filip2024_arrays",
        [](const Array& angles_deg, const Array& wavelength_nm, const Array& value,
           const std::optional<Array>& sigma, const py::dict& start,
           const std::vector<std::string>& fixed, const std::vector<std::string>& free,
           const std::string& preset, int global_starts) {
            return fit_filip_observations(observations_of(angles_deg, wavelength_nm, value, sigma),
                                          start, fixed, free, preset, global_starts, "");
        },
        py::arg("angles_deg"), py::arg("wavelength_nm"), py::arg("value"), py::arg("sigma"),
        py::arg("start"), py::arg("fixed"), py::arg("free"), py::arg("preset"),
        py::arg("global_starts") = analysis::Filip2024FitOptions{}.global_starts);
    m.def(
        "fit_filip2024_file",
        [](const std::string& path, const py::dict& start, const std::vector<std::string>& fixed,
           const std::vector<std::string>& free, const std::string& preset, int global_starts) {
            return fit_filip_observations(analysis::read_brdf_data(path), start, fixed, free,
                                          preset, global_starts, path);
        },
        py::arg("path"), py::arg("start"), py::arg("fixed"), py::arg("free"), py::arg("preset"),
        py::arg("global_starts") = analysis::Filip2024FitOptions{}.global_starts);
    m.def("huang2022_scatterogram", &predict);
}

}  // namespace plumage::python
