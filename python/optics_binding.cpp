// plumage._core's optics: material indices, Airy films and transfer-matrix stacks of
// sim/optics over flat arrays of equal length (python/plumage/optics.py broadcasts).
#include <complex>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <pybind11/complex.h>
#include <pybind11/stl.h>

#include "python/binding_util.h"
#include "sim/optics/material.h"
#include "sim/optics/multilayer.h"
#include "sim/optics/thin_film.h"

namespace plumage::python {
namespace {

// ---------------------------------------------------------------------------------------------
// Optics.

// A material argument: a name (keratin, melanin, air) or a constant complex index.
std::shared_ptr<const optics::Material> material_of(const py::handle& m) {
    if (py::isinstance<py::str>(m)) {
        const std::string name = py::str(m);
        if (name == "keratin") return optics::keratin();
        if (name == "melanin") return optics::melanin();
        if (name == "air") return optics::air();
        throw py::value_error(fmt::format(
            "unknown material '{}': expected keratin, melanin, air or a complex index", name));
    }
    try {
        return std::make_shared<optics::ConstantMaterial>("constant",
                                                          m.cast<std::complex<double>>());
    } catch (const py::cast_error&) {
        throw py::type_error(fmt::format("material {}: expected a name or a complex index",
                                         std::string(py::repr(m))));
    }
}

enum class Pol { s, p, unpolarised };
Pol polarisation_of(const std::string& name) {
    if (name == "s") return Pol::s;
    if (name == "p") return Pol::p;
    if (name == "unpolarised") return Pol::unpolarised;
    throw py::value_error(
        fmt::format("polarisation '{}': expected 's', 'p' or 'unpolarised'", name));
}

py::array_t<std::complex<double>> index_of(const py::handle& material, const Array& lambda_nm) {
    const auto m = material_of(material);
    py::array_t<std::complex<double>> out(
        std::vector<py::ssize_t>(lambda_nm.shape(), lambda_nm.shape() + lambda_nm.ndim()));
    const double* l = lambda_nm.data();
    std::complex<double>* o = out.mutable_data();
    parallel_for(lambda_nm.size(), 1, [&](py::ssize_t i) { o[i] = m->index(l[i]); });
    return out;
}

// R, T, A over flat inputs of equal length (the Python layer broadcasts).
template <typename Eval>
py::tuple intensities(py::ssize_t n, std::optional<int> threads, const Eval& eval) {
    Array r(n), t(n), a(n);
    double *pr = r.mutable_data(), *pt = t.mutable_data(), *pa = a.mutable_data();
    parallel_for(n, threads, [&](py::ssize_t i) {
        const auto x = eval(i);
        pr[i] = x.reflectance;
        pt[i] = x.transmittance;
        pa[i] = x.absorptance;
    });
    return py::make_tuple(r, t, a);
}

void require_length(const Array& a, py::ssize_t n, const char* what) {
    if (a.size() != n) throw py::value_error(fmt::format("{}: expected {} values", what, n));
}

py::tuple thin_film(const Array& thickness_um, const Array& lambda_nm, const Array& cos_theta,
                    double above, const py::handle& film, const py::handle& below,
                    const std::string& polarisation, std::optional<int> threads) {
    const py::ssize_t n = lambda_nm.size();
    require_length(thickness_um, n, "thickness_um");
    require_length(cos_theta, n, "cos_theta");
    const auto f = material_of(film), b = material_of(below);
    const Pol pol = polarisation_of(polarisation);
    const double *d = thickness_um.data(), *l = lambda_nm.data(), *c = cos_theta.data();
    return intensities(n, threads, [&](py::ssize_t i) {
        const optics::FilmMedia media{above, f->index(l[i]), b->index(l[i])};
        if (pol == Pol::unpolarised)
            return optics::airy_film_intensities_unpolarised(media, d[i], l[i], c[i]);
        return optics::airy_film_intensities(
            media, d[i], l[i], c[i],
            pol == Pol::s ? optics::Polarisation::s : optics::Polarisation::p);
    });
}

struct LayerSpec {
    std::shared_ptr<const optics::Material> material;
    double thickness_um;
    optics::Coherence coherence;
};

py::tuple transfer_matrix(const py::list& layers, const Array& lambda_nm, const Array& cos_theta,
                          double ambient, const py::handle& substrate,
                          const std::string& polarisation, std::optional<int> threads) {
    const py::ssize_t n = lambda_nm.size();
    require_length(cos_theta, n, "cos_theta");
    std::vector<LayerSpec> specs;
    for (const py::handle layer : layers) {
        const auto t = layer.cast<py::tuple>();
        if (t.size() != 2 && t.size() != 3) {
            throw py::value_error(
                "each layer: (material, thickness_um) or (material, thickness_um, 'incoherent')");
        }
        optics::Coherence coherence = optics::Coherence::coherent;
        if (t.size() == 3) {
            const std::string c = py::str(t[2]);
            if (c == "incoherent")
                coherence = optics::Coherence::incoherent;
            else if (c != "coherent")
                throw py::value_error(
                    fmt::format("layer coherence '{}': expected 'coherent' or "
                                "'incoherent'",
                                c));
        }
        specs.push_back({material_of(t[0]), t[1].cast<double>(), coherence});
    }
    const auto sub = material_of(substrate);
    const Pol pol = polarisation_of(polarisation);
    const double *l = lambda_nm.data(), *c = cos_theta.data();
    return intensities(n, threads, [&](py::ssize_t i) {
        std::vector<optics::StackLayer> stack;
        stack.reserve(specs.size());
        for (const auto& s : specs)
            stack.push_back({s.material->index(l[i]), s.thickness_um, s.coherence});
        const optics::StackIndices indices{ambient, stack, sub->index(l[i])};
        if (pol == Pol::unpolarised)
            return optics::transfer_matrix_intensities_unpolarised(indices, l[i], c[i]);
        return optics::transfer_matrix_intensities(
            indices, l[i], c[i], pol == Pol::s ? optics::Polarisation::s : optics::Polarisation::p);
    });
}

}  // namespace

void bind_optics(py::module_& m) {
    m.def("index", &index_of, py::arg("material"), py::arg("wavelength_nm"));
    m.def("thin_film", &thin_film, py::arg("thickness_um"), py::arg("wavelength_nm"),
          py::arg("cos_theta"), py::arg("above"), py::arg("film"), py::arg("below"),
          py::arg("polarisation"), py::arg("threads") = py::none());
    m.def("transfer_matrix", &transfer_matrix, py::arg("layers"), py::arg("wavelength_nm"),
          py::arg("cos_theta"), py::arg("ambient"), py::arg("substrate"), py::arg("polarisation"),
          py::arg("threads") = py::none());
}

}  // namespace plumage::python
