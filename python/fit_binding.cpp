// plumage._core's Huang fit: analysis/huang2022_fit.h on a scatterogram given as numpy arrays
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

#include "analysis/huang2022_fit.h"
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

py::dict fit(const std::string& illumination, const Array& beam_direction, double cone_aperture_rad,
             const Array& wavelengths_nm, const Array& intensity, const Array& standard_error,
             const Array& solid_angle_sr, const py::dict& start,
             const analysis::HuangFitOptions& options) {
    const gonio::Scatterogram data =
        scatterogram_of(illumination, beam_direction, cone_aperture_rad, wavelengths_nm, intensity,
                        standard_error, solid_angle_sr);
    const analysis::Huang2022Params first = params_of(start);
    analysis::HuangFitResult r;
    {
        py::gil_scoped_release release;
        r = analysis::fit_huang2022(data, first, options);
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
    d["covariance"] = r.covariance_available ? py::cast(r.covariance) : py::none();
    d["residual_rms_per_sr"] = r.residual_rms;
    d["reduced_chi_square"] = r.reduced_chi_square;
    d["observations"] = r.observations;
    d["pixels"] = r.pixels;
    d["wavelengths_nm"] = r.wavelengths_nm;
    d["degrees_of_freedom"] = r.degrees_of_freedom;
    d["iterations"] = r.iterations;
    d["function_evaluations"] = r.function_evaluations;
    d["converged"] = r.converged;
    d["termination"] = r.termination;
    d["wall_time_s"] = r.wall_time_s;
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
        .def_readwrite("threads", &O::threads);
    m.def("fit_huang2022", &fit);
    m.def("huang2022_scatterogram", &predict);
}

}  // namespace plumage::python
