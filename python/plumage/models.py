"""The analytic feather models of analysis/, vectorised over directions and wavelengths.

    m = plumage.models.Huang2022(d_um=0.55, mu=-0.3)    # keywords: the C++ parameter fields
    f = m.eval(wi, wo, wavelength_nm)                   # wi, wo: (N, 3) or (3,); λ: (N,) or scalar
    parts = m.eval(wi, wo, 550.0, lobes=True)           # {"total": f, "R": ..., "TRT": ..., "T": ...}

eval() returns f(ωi, ωo, λ) in 1/sr as a float64 array of length N (the arguments broadcast: a
single direction or wavelength is used for every element). It releases the GIL and loops in C++
with OpenMP (`threads=` sets the count, default OpenMP's); every element is computed on its own by
the same eval() the instruments call, so the result is the same for any thread count.

Parameters are the C++ struct fields, with the C++ defaults (the published values):
  Huang2022          analysis/huang2022.h  Huang2022Params: b, phi0, phi1, H, d_um, theta_d, mu
  Filip2024          analysis/filip2024.h  Filip2024Parameters: phi_a_rad, c_b, c_a, c_s, c_r
                     (R, G, B triples), alpha, beta, gamma, w, d_w, theta_max_rad,
                     brdf_scale_per_sr; preset="parrot" | "rooster" | "flamingo" | "stork"
                     (Table 1) sets them all first (default: the parrot's)
  PadronGriffe2024   analysis/padrongriffe2024.h  PadronGriffe2024Params' own fields and its
                     geometry's (geometry/barb.h BarbulePatchParams and BarbParams) by their names
  Lambertian         analysis/lambertian.h  albedo (f = albedo/π)
An unknown keyword raises TypeError naming it and the valid ones; a value outside its range
raises ValueError with the C++ message (InputError), as does an invalid direction in eval().
`model.params` is every parameter's value; `model.lobe_names` the lobes' names.
"""

from __future__ import annotations

from . import _core

__all__ = ["Huang2022", "Filip2024", "PadronGriffe2024", "Lambertian", "Model", "filip2024_presets"]

Model = _core.Model


def Huang2022(**params) -> Model:
    """Huang et al. 2022, rock-dove barbules: lobes R, TRT, T (T is a Dirac: 0 in eval)."""
    return _core.make_huang2022(params)


def Filip2024(preset: str | None = None, **params) -> Model:
    """Filip et al. 2024's five-term BRDF; lobes background, anisotropic_highlight, ..."""
    return _core.make_filip2024(preset, params)


def PadronGriffe2024(**params) -> Model:
    """Padrón-Griffe et al. 2024, barb and barbule fibres weighted by their masking."""
    return _core.make_padrongriffe2024(params)


def Lambertian(**params) -> Model:
    """f = albedo/π above the patch (the instruments' white standard)."""
    return _core.make_lambertian(params)


def filip2024_presets() -> list[str]:
    """The Table 1 presets Filip2024(preset=...) accepts."""
    return _core.filip2024_presets()
