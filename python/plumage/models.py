"""The analytic feather models of analysis/, vectorised over directions and wavelengths.

    m = plumage.models.Huang2022(d_um=0.55, mu=-0.3)    # keywords: the C++ parameter fields
    f = m.eval(wi, wo, wavelength_nm)                   # wi, wo: (..., 3); λ: (...) or scalar
    parts = m.eval(wi, wo, 550.0, lobes=True)           # {"total": f, "R": ..., "TRT": ..., "T": ...}
    help(plumage.models.Huang2022.eval)                 # units, frames, shapes

eval() returns f(ωi, ωo, λ) in 1/sr as float64, broadcast over the arguments by numpy's rules
(the last axis of wi and wo holds the three components), 0 where ωi or ωo is below the patch
(z <= 0). It releases the GIL and loops in C++ with OpenMP (`threads=` sets the count, default
OpenMP's); every element is computed on its own by the same eval() the instruments call, so the
result is the same for any thread count.

Parameters are the C++ struct fields, with the C++ defaults (the published values):
  Huang2022          analysis/models/huang2022.h  Huang2022Params: b, phi0, phi1, H, d_um, theta_d, mu
  Filip2024          analysis/models/filip2024.h  Filip2024Parameters: phi_a_rad, c_b, c_a, c_s, c_r
                     (R, G, B triples), alpha, beta, gamma, w, d_w, theta_max_rad,
                     brdf_scale_per_sr; preset="parrot" | "rooster" | "flamingo" | "stork"
                     (Table 1) sets them all first (default: the parrot's)
  PadronGriffe2024   analysis/models/padrongriffe2024.h  PadronGriffe2024Params' own fields and its
                     geometry's (geometry/barb.h BarbulePatchParams and BarbParams) by their names
  Lambertian         analysis/models/lambertian.h  albedo (f = albedo/π)
An unknown keyword raises TypeError naming it and the valid ones; a value outside its range
raises ValueError with the C++ message (InputError), as does a direction that is not a unit
vector in eval(). `model.params` is every parameter's value; `model.lobe_names` the lobes' names.

fit_huang2022(record, start, **options) fits Huang2022 to a scatterogram record with the C++
fit (analysis/fits/huang2022_fit.h); huang2022_scatterogram(params, record) is its forward model.
fit_filip2024(data, start, ...) fits Filip2024 to BRDF data (a CSV, a goniometer record or numpy
arrays; analysis/fits/filip2024_fit.h). Both return the parameters with their σ and, under "json", the
fitted-parameters JSON of `plumage fit` (docs/user_data.md).
"""

from __future__ import annotations

import numpy as np

from . import _core

__all__ = ["Huang2022", "Filip2024", "PadronGriffe2024", "Lambertian", "Model", "filip2024_presets",
           "parameter_table", "fit_huang2022", "huang2022_scatterogram", "fit_filip2024"]

# The part of every model's eval() docstring that does not depend on the model: {lobes} and
# {below} are the model's own.
_EVAL_DOC = """f(ωi, ωo, λ): the model's BRDF in 1/sr, evaluated in C++ over numpy arrays.

Frame and units (sim/scatterer/scatterer.h): directions are unit vectors in the patch's
LOCAL frame, +z the patch (barb-plane) normal, +x the barb axis, +y along the barbules (azimuth
from +x towards +y), and both point AWAY from the surface: wi towards the light, wo towards the
viewer (pbrt's and Mitsuba's convention). wavelength_nm is the vacuum wavelength in nm. f is
radiance out per irradiance on the patch plane, in 1/sr: the cosine <wo, z> is not included.

Shapes: wi and wo are arrays of shape (..., 3) (the last axis holds x, y, z), wavelength_nm a
scalar or an array of shape (...); the leading axes broadcast together by numpy's rules, so one
direction (3,) against a (1000, 1000, 3) grid gives a (1000, 1000) result, and wi of shape
(n, 1, 3) against wo of shape (1, m, 3) an (n, m) table. The result has the broadcast shape, a
numpy float64 scalar when every argument is a single value. Lists and ints are converted.

Below the horizon: where wi.z <= 0 (light from below the patch) or wo.z <= 0 (a view below it)
the result is 0, not an error; transmission=True returns the model's value below the patch
instead where it has one ({below}). Directions are not normalised here: give unit vectors
(Huang2022 raises ValueError for a wi off by more than 1e-6). A value the model refuses raises
ValueError naming the element (its index in the flattened broadcast arrays).

lobes=True returns a dict {{"total": f, {lobes}}} of arrays of that shape, the lobes summing
to the total. threads: OpenMP threads (default: OpenMP's count); the GIL is released and every
element is computed on its own, so the values are the same bits for any thread count.
"""


def _batch(a: np.ndarray, what: str) -> tuple:
    if a.ndim == 0 or a.shape[-1] != 3:
        raise ValueError(f"{what}: expected shape (..., 3) (unit vectors), got {a.shape}")
    return a.shape[:-1]


def _flat(a: np.ndarray, batch: tuple, shape: tuple, tail: tuple) -> np.ndarray:
    """a as the C++ loop takes it: one element (broadcast there without a copy) or one per
    element of the broadcast shape, flattened (a view unless a itself broadcasts partly)."""
    if int(np.prod(batch)) == 1:
        return a.reshape(tail)
    return np.ascontiguousarray(np.broadcast_to(a, shape + tail)).reshape((-1,) + tail)


class Model:
    """An analytic model of analysis/models/ (a C++ Scatterer): eval() over numpy arrays, its
    parameters (`params`) and its lobes' names (`lobe_names`)."""

    # Filled in by each model: its lobes, and what it returns below the patch.
    _lobes_doc = "lobe name: f of that lobe, ..."
    _below_doc = "0 for a model without transmission"

    def __init__(self, core: "_core.Model"):
        self._core = core

    @property
    def name(self) -> str:
        return self._core.name

    @property
    def lobe_names(self) -> list[str]:
        return list(self._core.lobe_names)

    @property
    def params(self) -> dict:
        return self._core.params

    def __repr__(self) -> str:
        return f"plumage.models.{type(self).__name__}(**{self.params!r})"

    def eval(self, wi, wo, wavelength_nm, lobes=False, threads=None, transmission=False):
        wi = np.asarray(wi, dtype=np.float64)
        wo = np.asarray(wo, dtype=np.float64)
        lam = np.asarray(wavelength_nm, dtype=np.float64)
        batches = (_batch(wi, "wi"), _batch(wo, "wo"), lam.shape)
        try:
            shape = np.broadcast_shapes(*batches)
        except ValueError:
            raise ValueError(f"wi {wi.shape}, wo {wo.shape}, wavelength_nm {lam.shape}: cannot "
                             "broadcast the arguments together (numpy's rules over all axes "
                             "but the last of wi and wo)") from None
        result = self._core.eval(_flat(wi, batches[0], shape, (3,)),
                                 _flat(wo, batches[1], shape, (3,)),
                                 _flat(lam, batches[2], shape, ()), lobes, threads, transmission)
        shaped = lambda f: f.reshape(shape) if shape else f[0]  # noqa: E731
        if lobes:
            return {k: shaped(v) for k, v in result.items()}
        return shaped(result)


def _eval_docstring(lobes: str, below: str) -> str:
    """_EVAL_DOC for one model, each paragraph wrapped again after the model's text is in."""
    import textwrap

    text = _EVAL_DOC.format(lobes=lobes, below=below)
    paragraphs = [textwrap.fill(" ".join(p.split()), 96) for p in text.split("\n\n")]
    return "\n\n".join(paragraphs) + "\n"


def _eval_doc(cls):
    """Gives the class its own eval(), whose docstring names its lobes (help(Model.eval))."""
    def eval(self, wi, wo, wavelength_nm, lobes=False, threads=None, transmission=False):
        return Model.eval(self, wi, wo, wavelength_nm, lobes, threads, transmission)
    eval.__doc__ = _eval_docstring(cls._lobes_doc, cls._below_doc)
    eval.__qualname__ = f"{cls.__name__}.eval"
    cls.eval = eval
    return cls


Model.eval.__doc__ = _eval_docstring(Model._lobes_doc, Model._below_doc)


@_eval_doc
class Huang2022(Model):
    """Huang et al. 2022, rock-dove barbules (analysis/models/huang2022.h): lobes R (thin-film
    reflection), TRT (through the film, off the melanin and back) and T (light passing between
    the barbules, a Dirac at wo = -wi: 0 in eval). Keywords: b, phi0, phi1, H, d_um, theta_d, mu
    (the C++ Huang2022Params fields, published values by default)."""

    _lobes_doc = ('"R": thin-film reflection, "TRT": through the film, off the melanin and '
                  'back, "T": 0 (a Dirac at wo = -wi, not a density)')
    _below_doc = ("Huang 2022's R lobe, reflected by a facet tilted by mu, can leave below the "
                  "barb plane; its T lobe is a Dirac, not in eval")

    def __init__(self, **params):
        super().__init__(_core.make_huang2022(params))


@_eval_doc
class Filip2024(Model):
    """Filip et al. 2024's five-term BRDF (analysis/models/filip2024.h); preset="parrot" | "rooster" |
    "flamingo" | "stork" (Table 1) sets every parameter first, keywords then override them."""

    _lobes_doc = '"background", "anisotropic_highlight", ... (model.lobe_names)'
    _below_doc = "a BRDF: 0 below the patch either way"

    def __init__(self, preset: str | None = None, **params):
        super().__init__(_core.make_filip2024(preset, params))


@_eval_doc
class PadronGriffe2024(Model):
    """Padrón-Griffe et al. 2024, barb and barbule fibres weighted by their masking
    (analysis/models/padrongriffe2024.h)."""

    _lobes_doc = "one entry per fibre lobe (model.lobe_names)"
    _below_doc = "Padrón-Griffe 2024's fibres transmit: light through the patch"

    def __init__(self, **params):
        super().__init__(_core.make_padrongriffe2024(params))


@_eval_doc
class Lambertian(Model):
    """f = albedo/π above the patch (the instruments' white standard)."""

    _lobes_doc = '"diffuse": albedo/π'
    _below_doc = "a BRDF: 0 below the patch either way"

    def __init__(self, **params):
        super().__init__(_core.make_lambertian(params))


def parameter_table(model: str) -> list[dict]:
    """The parameters of "huang2022" or "filip2024", in order: name (as the keyword arguments and
    the fits take it), unit, default, min, max, min_open, max_open, range (as text) and meaning.
    The C++ model validates against the same table, and the fits take their bounds from it."""
    return _core.parameter_table(model)


def filip2024_presets() -> list[str]:
    """The Table 1 presets Filip2024(preset=...) accepts."""
    return _core.filip2024_presets()


def _scatterogram_arguments(record):
    """The fit's view of an imaging-scatterometer record (plumage.read_record or a path)."""
    import numpy as np

    from .records import RecordError, read_record

    if isinstance(record, dict):  # numpy arrays (docs/user_data.md, "From Python")
        r = record
        return (str(r.get("illumination", "beam")),
                np.asarray(r.get("beam_direction", (0.0, 0.0, 1.0)), dtype=float),
                float(r.get("cone_aperture_rad", np.radians(16.0))),
                np.asarray(r["wavelength_nm"], dtype=float), np.asarray(r["intensity"], dtype=float),
                np.asarray(r["standard_error"], dtype=float),
                np.asarray(r["solid_angle_sr"], dtype=float))
    if not hasattr(record, "kind"):
        record = read_record(record)
    if record.kind != "imaging_scatterometer":
        raise ValueError(f"{record.path}: a {record.kind} record; the Huang fit needs an "
                         "imaging_scatterometer record (a scatterogram)")
    inst = record.instrument
    # A record written by hand may lack these or hold text that is no direction: say which file.
    if "illumination" not in inst:
        raise RecordError(f"{record.path}: /instrument@illumination: missing; expected beam, cone "
                          "or hemisphere")
    text = inst.get("beam_direction", "0 0 1")
    try:
        beam = np.array([float(x) for x in str(text).split()]) if isinstance(text, str) else \
            np.asarray(text, dtype=float)
    except (TypeError, ValueError):
        beam = None
    if beam is None or beam.shape != (3,):
        raise RecordError(f"{record.path}: /instrument@beam_direction = {str(text)[:80]!r}: "
                          "expected \"x y z\", three numbers towards the light")
    return (str(inst["illumination"]), beam,
            float(np.radians(float(inst.get("cone_aperture_deg", 16.0)))),
            np.asarray(record.wavelength_nm), np.asarray(record.image.value),
            np.asarray(record.image.standard_error),
            np.asarray(record.datasets["/image/solid_angle_sr"]))


def _fit_options(options) -> "_core.HuangFitOptions":
    o = _core.HuangFitOptions()
    for key, value in options.items():
        if key.startswith("_") or not hasattr(o, key):
            valid = ", ".join(k for k in dir(o) if not k.startswith("_"))
            raise TypeError(f"fit_huang2022: unknown option '{key}'; valid options: {valid}")
        setattr(o, key, list(value) if key in ("fixed", "wavelengths_nm") else value)
    return o


def fit_huang2022(record, start=None, **options) -> dict:
    """Fits Huang2022's parameters to a scatterogram record by Levenberg–Marquardt in C++
    (analysis/fits/huang2022_fit.h: its header states the objective, weights and cubature).

    record: plumage.read_record(...) of an imaging_scatterometer record, or its path, or a dict
    of numpy arrays: intensity, standard_error [rows, rows, λ], solid_angle_sr [rows, rows],
    wavelength_nm [λ], illumination ("beam"), beam_direction (3,), cone_aperture_rad.
    start: a Huang2022 model or a dict of its parameters (default: the published values).
    options: HuangFitOptions' fields, e.g. fixed=["phi0", "phi1"], pixel_stride=2,
    wavelengths_nm=[550.0], max_function_evaluations=200, global_starts=0 (a local fit from
    start alone; default 3), threads=2.
    Returns a dict: params, standard_errors, at_bound, free_parameters, covariance (free
    parameters' order; None when singular), reduced_chi_square, residual_rms_per_sr,
    observations, pixels, converged, termination, wall_time_s, chi_square, json (the documented
    fitted-parameters JSON, docs/user_data.md), ...
    """
    import os

    start = start.params if isinstance(start, Model) else dict(start or {})
    data_file = os.fspath(record) if isinstance(record, (str, os.PathLike)) else \
        str(getattr(record, "path", ""))
    return _core.fit_huang2022(*_scatterogram_arguments(record), start, _fit_options(options),
                               data_file)


def huang2022_scatterogram(params, record, **options):
    """The model's image [rows, columns, λ] (1/sr) under the record's illumination, pixels and
    wavelengths, by the fit's forward model: what fit_huang2022 compares with the record."""
    params = params.params if isinstance(params, Model) else dict(params)
    return _core.huang2022_scatterogram(*_scatterogram_arguments(record), params,
                                        _fit_options(options))


def fit_filip2024(data, start=None, *, fixed=(), free=(), preset=None, sigma=None,
                  global_starts=None) -> dict:
    """Fits Filip2024's parameters to BRDF data by Levenberg–Marquardt in C++
    (analysis/fits/filip2024_fit.h).

    data: a path to a CSV table or a goniometer record (docs/user_data.md), or a dict of numpy
    arrays with keys theta_i_deg, phi_i_deg, theta_o_deg, phi_o_deg, wavelength_nm, value (1/sr)
    and optionally sigma (1/sr; or give sigma= here). Without σ every observation weighs the same.
    start: a Filip2024 model or a dict of parameter values by the table's names (phi_a, C_b[R],
    ..., alpha, beta, gamma, w, d_w, theta_max, brdf_scale), over preset (default "parrot").
    fixed / free: names to hold / to fit (theta_max and brdf_scale are held by default).
    global_starts: Levenberg–Marquardt runs from the best points of the global stage's grid,
    besides the one from start (0: a local fit from start alone; 0..192; None: the C++ default,
    analysis/fits/filip2024_fit.h).
    Returns a dict: params, standard_errors, at_bound, free_parameters, covariance, chi_square,
    reduced_chi_square, degrees_of_freedom, observations, residual_rms_per_sr, converged,
    termination, model_per_sr and residuals ((model − value)/σ) per observation, json.
    """
    import os

    import numpy as np

    if isinstance(start, Model):
        raise TypeError("fit_filip2024: give start as a dict of the table's names "
                        "(e.g. {'alpha': 3.0}) and preset= for a preset")
    start = dict(start or {})
    starts = {} if global_starts is None else {"global_starts": int(global_starts)}
    if isinstance(data, (str, os.PathLike)):
        return _core.fit_filip2024_file(os.fspath(data), start, list(fixed), list(free),
                                        preset or "", **starts)
    columns = ("theta_i_deg", "phi_i_deg", "theta_o_deg", "phi_o_deg")
    angles = np.stack([np.asarray(data[c], dtype=float) for c in columns], axis=1)
    if sigma is None and "sigma" in data:
        sigma = data["sigma"]
    return _core.fit_filip2024_arrays(angles, np.asarray(data["wavelength_nm"], dtype=float),
                                      np.asarray(data["value"], dtype=float),
                                      None if sigma is None else np.asarray(sigma, dtype=float),
                                      start, list(fixed), list(free), preset or "", **starts)
