// Shared by the bindings of python/: the array type they take, the element loop that releases
// the GIL, and the checks of array shapes. See core.cpp for the conventions.
#pragma once

#include <cstddef>
#include <functional>
#include <initializer_list>
#include <optional>
#include <string>
#include <utility>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

namespace plumage::python {

namespace py = pybind11;

// float64, C-ordered: numpy converts (copies) other inputs.
using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// Runs body(i) for i in [0, n) on `threads` OpenMP threads (default: OpenMP's count) without the
// GIL, schedule(static). An exception in any element is rethrown after the loop: the one of the
// lowest index (so the message does not depend on the thread count), an InputError as ValueError
// naming that index.
void parallel_for(py::ssize_t n, std::optional<int> threads,
                  const std::function<void(py::ssize_t)>& body);

// "(N, 3)" for messages.
std::string shape_text(const Array& a);
// The common length of arguments whose counts are each 1 (broadcast) or N; ValueError otherwise.
py::ssize_t broadcast_count(std::initializer_list<std::pair<py::ssize_t, const char*>> counts);

void bind_models(py::module_& m);
void bind_optics(py::module_& m);
void bind_fit(py::module_& m);
void bind_studies(py::module_& m);

}  // namespace plumage::python
