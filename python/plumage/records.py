"""Plumage records (HDF5, virtual_gonio/RECORD.md) as numpy arrays with their units.

    rec = plumage.read_record("results/rock_dove/brdf_simulation.h5")
    rec.kind                      # "goniometer", "imaging_scatterometer", "btf_camera", ...
    rec.brdf.value                # Quantity [pairs, wavelengths], rec.brdf.value.units == "1/sr"
    rec.brdf.standard_error       # same shape and units
    rec.brdf.lobes["R"].value     # per lobe (with its standard error where the record has one)
    rec.wavelength_nm             # Quantity [wavelengths], units "nm"
    rec.instrument                # attributes and arrays of /instrument (a dict)
    rec.convergence               # {"pass": ..., "wall_time_s": ..., ...} or None (BTFs before 2026-11-26)
    rec.provenance                # dict: scatterer, seed, threads, config, git_commit, ...
    rec.datasets                  # every dataset of the file by path, "/brdf/value" → Quantity
    rec.attributes                # every group's attributes by path, "/" the root

Other HDF5 files the studies write (a fit's results, a figure's data, the thin-film chart) read
the same way, with kind "study_data" or "thin_film_chart": their datasets and attributes only.

Every array is read into memory (records are small: the largest, a 61 × 60 BTF, is tens of MB),
so the file is closed when read_record returns. Errors name the file and what is missing.

Files made elsewhere (h5py, MATLAB) are read as the C++ reader reads them
(virtual_gonio/record/hdf5_reader.h): every dataset's size is checked before it is read (at most
MAX_DATASET_VALUES values), links into other files and data stored outside the file are refused,
the record's kind must be one string, and any other fault of the file (a type numpy cannot hold,
a filter HDF5 lacks, damage) is a RecordError naming the file and the object.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

import numpy as np


class RecordError(ValueError):
    """A file that is not a Plumage record, or one that lacks a dataset its kind requires."""


# The most values one dataset may hold (as the C++ reader, virtual_gonio/record/hdf5_reader.h).
MAX_DATASET_VALUES = 1 << 25


class Quantity(np.ndarray):
    """A numpy array that carries its record's `units` and `description` attributes.

    Slices and arithmetic keep the attributes as they are: units are neither checked nor
    converted by operations (`np.asarray(q)` gives a bare array).
    """

    def __new__(cls, values, units: str = "", description: str = ""):
        obj = np.asarray(values).view(cls)
        obj.units = units
        obj.description = description
        return obj

    def __array_finalize__(self, obj):
        self.units = getattr(obj, "units", "")
        self.description = getattr(obj, "description", "")

    def __reduce__(self):
        base = super().__reduce__()
        return base[0], base[1], (base[2], self.units, self.description)

    def __setstate__(self, state):
        super().__setstate__(state[0])
        self.units, self.description = state[1], state[2]


@dataclasses.dataclass(frozen=True)
class Measurement:
    """A measured value with its standard error (None where the record has none) and units."""

    value: Quantity
    standard_error: Quantity | None
    units: str
    lobes: dict[str, "Measurement"] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True)
class Record:
    """One record. The instrument's measurement is in `brdf`, `image` or `btf` (None otherwise)."""

    path: str
    kind: str
    format: str
    wavelength_nm: Quantity | None
    instrument: dict[str, Any]
    provenance: dict[str, Any]
    convergence: dict[str, Quantity] | None
    datasets: dict[str, Quantity]
    attributes: dict[str, dict[str, Any]]
    brdf: Measurement | None = None
    image: Measurement | None = None
    btf: Measurement | None = None
    transmitted_fraction: Measurement | None = None

    def __repr__(self) -> str:
        main = self.brdf or self.image or self.btf
        shape = f" {main.value.shape} {main.units}" if main is not None else ""
        return f"<plumage.Record {self.kind}{shape} from {self.path!r}>"


def _text(value):
    """HDF5 strings arrive as bytes or numpy strings; attributes as numpy scalars."""
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.ndarray) and value.dtype.kind in "SO":
        return np.array([_text(v) for v in value.ravel()], dtype=object).reshape(value.shape)
    if isinstance(value, np.generic):
        return value.item() if value.dtype.kind != "u" or value.dtype.itemsize < 8 else value
    return value


def _attributes(node) -> dict[str, Any]:
    return {key: _text(value) for key, value in node.attrs.items()}


def _quantity(path: str, name: str, dataset) -> Quantity:
    if dataset.size > MAX_DATASET_VALUES:
        raise RecordError(f"{path}: {name}: shape {dataset.shape}, {dataset.size} values; expected "
                          f"at most {MAX_DATASET_VALUES} (the reader's limit)")
    if dataset.is_virtual or dataset.external:
        raise RecordError(f"{path}: {name}: its data lie in other files; expected them in this file")
    attrs = _attributes(dataset)
    data = dataset[()]
    if isinstance(data, bytes) or (isinstance(data, np.ndarray) and data.dtype.kind in "SO"):
        data = _text(data)
    return Quantity(data, str(attrs.get("units", "")), str(attrs.get("description", "")))


class _Reader:
    """The open file, its datasets by path, and the errors that name both."""

    def __init__(self, path: str, handle, kind_hint: str):
        self.path = path
        self.file = handle
        self.datasets: dict[str, Quantity] = {}
        self.attributes: dict[str, dict[str, Any]] = {"/": _attributes(handle)}
        self.kind_hint = kind_hint
        import h5py

        def visit(name, node):
            if isinstance(node, h5py.Dataset):
                self.datasets["/" + name] = _quantity(path, "/" + name, node)
            else:
                self.attributes["/" + name] = _attributes(node)

        handle.visititems(visit)

    def require(self, name: str) -> Quantity:
        if name not in self.datasets:
            raise RecordError(
                f"{self.path}: missing dataset {name} (required in a {self.kind_hint} record, "
                "virtual_gonio/RECORD.md)"
            )
        return self.datasets[name]

    def optional(self, name: str) -> Quantity | None:
        return self.datasets.get(name)

    def measurement(self, group: str, value: str, error: str | None, lobe_errors: str | None):
        v = self.require(f"/{group}/{value}")
        e = self.require(f"/{group}/{error}") if error else None
        lobes = {}
        prefix = f"/{group}/lobes/"
        for name, q in self.datasets.items():
            if name.startswith(prefix):
                lobe = name[len(prefix):]
                le = self.optional(f"/{group}/{lobe_errors}/{lobe}") if lobe_errors else None
                lobes[lobe] = Measurement(q, le, q.units)
        return Measurement(v, e, v.units, lobes)


_INSTRUMENTS = ("goniometer", "imaging_scatterometer", "btf_camera")
_CONVERGENCE_NAMES = ("pass", "wall_time_s", "quanta", "relative_error")


def _convergence(reader: _Reader) -> dict[str, Quantity] | None:
    table = reader.optional("/convergence")
    if table is None:
        return None
    if table.ndim != 2 or table.shape[1] != 4:
        raise RecordError(f"{reader.path}: /convergence has shape {table.shape}, expected [passes, 4]")
    units = [u.strip() for u in table.units.split("(")[0].split(",")]
    if len(units) != 4:
        units = ["1", "s", "1", "1"]
    columns = {}
    for k, name in enumerate(_CONVERGENCE_NAMES):
        columns[name] = Quantity(np.array(table[:, k]), units[k], table.description)
    return columns


def read_record(path: str | os.PathLike) -> Record:
    """Reads a Plumage record (one HDF5 file of virtual_gonio/RECORD.md) into memory.

    Raises FileNotFoundError for a missing file and RecordError for any fault of the file."""
    import h5py

    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: no such record")
    try:
        handle = h5py.File(path, "r")
    except OSError as e:
        raise RecordError(f"{path}: not an HDF5 file ({e})") from e
    with handle:
        try:
            return _read_open_record(path, handle)
        except RecordError:
            raise
        except (OSError, KeyError, TypeError, ValueError, RuntimeError, UnicodeError,
                OverflowError, MemoryError) as e:
            raise RecordError(f"{path}: cannot be read as a record ({type(e).__name__}: {e})") from e


def _external_link(handle, name: str) -> bool:
    import h5py

    return isinstance(handle.get(name, getlink=True), h5py.ExternalLink)


def _read_open_record(path: str, handle) -> Record:
    import h5py

    for name in ("instrument", "provenance", "chart"):
        if name in handle.keys() and _external_link(handle, name):
            raise RecordError(f"{path}: /{name} is a link into another file; expected it in this file")
    kind = ""
    if "instrument" in handle:
        if not isinstance(handle["instrument"], h5py.Group):
            raise RecordError(f"{path}: /instrument is a dataset; expected a group")
        kind_value = _text(handle["instrument"].attrs.get("kind", ""))
        if not isinstance(kind_value, str):
            raise RecordError(f"{path}: /instrument@kind: found {type(kind_value).__name__} "
                              f"{getattr(kind_value, 'shape', '')}; expected one string")
        kind = kind_value
    elif "chart" in handle:
        kind = "thin_film_chart"
    elif len(handle) > 0:
        # Study data beside the records (a fit's /fit, a figure's /figure, ...): read as is.
        kind = "study_data"
    else:
        raise RecordError(f"{path}: an empty HDF5 file, not a Plumage record")
    reader = _Reader(path, handle, kind)
    instrument = {}
    if "instrument" in handle:
        instrument = _attributes(handle["instrument"])
        for name, q in reader.datasets.items():
            if name.startswith("/instrument/"):
                instrument[name[len("/instrument/"):]] = q
    if "provenance" in handle:
        if not isinstance(handle["provenance"], h5py.Group):
            raise RecordError(f"{path}: /provenance is a dataset; expected a group")
        provenance = _attributes(handle["provenance"])
    elif kind in _INSTRUMENTS:
        raise RecordError(f"{path}: missing group /provenance (virtual_gonio/RECORD.md)")
    else:
        provenance = _attributes(handle)  # the chart keeps its provenance at the root
    convergence = _convergence(reader)
    fields: dict[str, Any] = {}
    if kind == "goniometer":
        fields["brdf"] = reader.measurement("brdf", "value", "standard_error", "lobe_standard_errors")
        reader.require("/instrument/light_directions")
        reader.require("/instrument/view_directions")
    elif kind == "imaging_scatterometer":
        fields["image"] = reader.measurement("image", "intensity", "standard_error", None)
        reader.require("/image/solid_angle_sr")
        t = reader.optional("/transmitted_fraction")
        if t is not None:
            lobes = {
                n[len("/transmitted_lobes/"):]: Measurement(q, None, q.units)
                for n, q in reader.datasets.items()
                if n.startswith("/transmitted_lobes/")
            }
            fields["transmitted_fraction"] = Measurement(t, None, t.units, lobes)
    elif kind == "btf_camera":
        fields["btf"] = reader.measurement("btf", "value", "standard_error", None)
    wavelength = reader.optional("/wavelength_nm")
    if wavelength is None and kind in _INSTRUMENTS:
        reader.require("/wavelength_nm")
    return Record(
        path=path,
        kind=kind,
        format=str(_text(handle.attrs.get("format", ""))),
        wavelength_nm=wavelength,
        instrument=instrument,
        provenance=provenance,
        convergence=convergence,
        datasets=reader.datasets,
        attributes=reader.attributes,
        **fields,
    )
