"""Film optics of sim/optics, vectorised: materials, Airy thin films, transfer-matrix stacks.

    plumage.optics.index("keratin", wavelengths)                    # complex n + ik, λ in nm
    R = plumage.optics.thin_film_reflectance(0.59, wavelengths, theta_rad=angles[:, None])
    r = plumage.optics.transfer_matrix([("keratin", 0.59), ("melanin", 0.2)], wavelengths)
    r.reflectance, r.transmittance, r.absorptance

Arguments broadcast as numpy's do (the result has the broadcast shape). Materials: "keratin"
(n = 1.532 + 5890/λ²), "melanin" (n = 1.648 + 23700/λ² + 0.56 i exp(−λ/270)), "air", or a
constant complex index. Thickness in µm, wavelength in nm (vacuum), θ in radians in the
incidence medium (lossless, index `above` / `ambient`). Polarisation "s", "p" or "unpolarised"
(the mean of the s and p intensities, as everywhere in the suite). The loops run in C++ without
the GIL; invalid values raise ValueError with the C++ message.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import _core

__all__ = ["index", "keratin", "melanin", "thin_film", "thin_film_reflectance", "transfer_matrix",
           "Intensities"]


class Intensities(NamedTuple):
    """Fractions of the incident power: reflected, transmitted into the exit medium, absorbed."""

    reflectance: np.ndarray
    transmittance: np.ndarray
    absorptance: np.ndarray


def index(material, wavelength_nm):
    """Complex refractive index n + ik of a material at vacuum wavelengths (nm)."""
    lam = np.asarray(wavelength_nm, dtype=float)
    return _core.index(material, np.ascontiguousarray(lam))


def keratin(wavelength_nm):
    return index("keratin", wavelength_nm)


def melanin(wavelength_nm):
    return index("melanin", wavelength_nm)


def _flat(*arrays):
    b = np.broadcast_arrays(*[np.asarray(a, dtype=float) for a in arrays])
    return b[0].shape, [np.ascontiguousarray(x).ravel() for x in b]


def _shaped(shape, result):
    return Intensities(*(np.asarray(x).reshape(shape) for x in result))


def thin_film(thickness_um, wavelength_nm, theta_rad=0.0, film="keratin", below="air",
              above: float = 1.0, polarisation: str = "unpolarised", threads=None) -> Intensities:
    """A film between a lossless medium `above` and `below` (Airy; sim/optics/thin_film.h)."""
    shape, (d, lam, theta) = _flat(thickness_um, wavelength_nm, theta_rad)
    return _shaped(shape, _core.thin_film(d, lam, np.cos(theta), float(above), film, below,
                                          polarisation, threads))


def thin_film_reflectance(thickness_um, wavelength_nm, theta_rad=0.0, film="keratin",
                          below="air", above: float = 1.0, polarisation: str = "unpolarised"):
    """The reflectance of thin_film(): e.g. a keratin film in air, the rock-dove barbule cortex."""
    return thin_film(thickness_um, wavelength_nm, theta_rad, film, below, above,
                     polarisation).reflectance


def transfer_matrix(layers, wavelength_nm, theta_rad=0.0, ambient: float = 1.0,
                    substrate="air", polarisation: str = "unpolarised",
                    threads=None) -> Intensities:
    """A planar stack (sim/optics/multilayer.h), top to bottom: layers are (material,
    thickness_um) or (material, thickness_um, "incoherent"); light arrives from `ambient`."""
    shape, (lam, theta) = _flat(wavelength_nm, theta_rad)
    return _shaped(shape, _core.transfer_matrix([tuple(x) for x in layers], lam, np.cos(theta),
                                                float(ambient), substrate, polarisation,
                                                threads))
