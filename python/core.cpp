// plumage._core: the analytic models (models_binding.cpp), the Huang fit (fit_binding.cpp) and the
// film optics (optics_binding.cpp) for Python. The `plumage` package wraps this module;
// python/plumage/models.py and optics.py document the API users see.
//
// Every vectorised call reads its numpy inputs, releases the GIL and loops in C++ with OpenMP
// over the elements (schedule(static)). Each output element is computed on its own from its
// inputs, by the same const eval() the instruments call, so the results are the same bits for any
// thread count. Errors: InputError → ValueError (the C++ message), IoError → OSError,
// InvariantError → RuntimeError; an unknown keyword → TypeError naming it and the valid ones.
//
// Units and frames are the C++ ones (sim/scatterer/scatterer.h): directions are unit vectors in the
// patch frame (+z the patch normal, +x the barb axis) pointing away from the patch, wavelengths in
// nm, f in 1/sr, lengths in µm, angles in radians.
#include <exception>
#include <limits>
#include <mutex>

#include <fmt/format.h>
#include <omp.h>

#include "common/error.h"
#include "common/interrupt.h"
#include "python/binding_util.h"

namespace plumage::python {

std::string shape_text(const Array& a) {
    std::string s = "(";
    for (py::ssize_t k = 0; k < a.ndim(); ++k) s += fmt::format("{}{}", k ? ", " : "", a.shape(k));
    return s + (a.ndim() == 1 ? ",)" : ")");
}

// The common length of arguments whose counts are each 1 (broadcast) or N.
py::ssize_t broadcast_count(std::initializer_list<std::pair<py::ssize_t, const char*>> counts) {
    py::ssize_t n = 1;
    for (const auto& [c, what] : counts) {
        if (c != 1 && n != 1 && c != n) {
            std::string shapes;
            for (const auto& [c2, w2] : counts) shapes += fmt::format(" {}: {}", w2, c2);
            throw py::value_error("cannot broadcast the arguments' lengths together:" + shapes);
        }
        if (c != 1) n = c;
    }
    return n;
}

void parallel_for(py::ssize_t n, std::optional<int> threads,
                  const std::function<void(py::ssize_t)>& body) {
    if (threads && *threads < 1) throw py::value_error("threads: expected a count >= 1");
    std::mutex mutex;
    py::ssize_t failed_at = std::numeric_limits<py::ssize_t>::max();
    std::exception_ptr failure;
    {
        py::gil_scoped_release release;
        const int t = threads ? *threads : omp_get_max_threads();
#pragma omp parallel for schedule(static) num_threads(t)
        for (py::ssize_t i = 0; i < n; ++i) {
            try {
                body(i);
            } catch (...) {
                const std::lock_guard lock(mutex);
                if (i < failed_at) {
                    failed_at = i;
                    failure = std::current_exception();
                }
            }
        }
    }
    if (!failure) return;
    try {
        std::rethrow_exception(failure);
    } catch (const InputError& e) {
        throw py::value_error(fmt::format("element {}: {}", failed_at, e.what()));
    }
}

}  // namespace plumage::python

PYBIND11_MODULE(_core, m) {
    using namespace plumage;
    using namespace plumage::python;
    m.doc() = "Plumage's C++ models and optics (use the `plumage` package, not this module)";
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const InputError& e) {
            PyErr_SetString(PyExc_ValueError, e.what());
        } catch (const IoError& e) {
            PyErr_SetString(PyExc_OSError, e.what());
        } catch (const InvariantError& e) {
            PyErr_SetString(PyExc_RuntimeError, e.what());
        } catch (const Interrupted& e) {
            PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
        }
    });

    bind_models(m);
    bind_optics(m);
    bind_fit(m);
    bind_studies(m);
}
