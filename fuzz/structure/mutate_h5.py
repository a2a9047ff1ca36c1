"""Structure-level mutations of HDF5 records (fuzz/structure/fuzz_user_data.py): every operator
takes a well-formed file and leaves a well-formed file whose structure is wrong in one way, as a
user's own h5py or MATLAB writer might make it (or worse). Byte-level fuzzing almost never
produces these.

mutate(path, rnd, count, kind) applies `count` operators drawn from the seeded random.Random
`rnd` and returns [(description, variant)]: a human-readable line per mutation, and whether it is
a "variant" (an equivalent encoding a reader may reasonably accept: float32, big-endian, fixed-
length strings, chunked storage, ...) rather than a damage. The file may get a new name (an
extension change): the path is returned too.

Sites: every group, dataset and attribute of the file (found through hard links; soft and
external links are sites too); 60 % of the draws among those analysis/fits/user_data.cpp reads
(seeds.py, FIT_READS).
"""

from __future__ import annotations

import os
import random
import shutil

import h5py
import numpy as np

from seeds import FIT_READS
from weighted import weighted

SPECIAL_VALUES = [
    ("NaN", np.nan), ("+inf", np.inf), ("-inf", -np.inf), ("0", 0.0), ("negative", None),
    ("1e308", 1e308), ("-1e308", -1e308), ("1e-320 (subnormal)", 1e-320),
    ("5e-324", 5e-324), ("1e6", 1e6), ("4096", 4096.0), ("-1", -1.0),
]

# retype names -> whether the result is a plausible equivalent encoding ("variant")
RETYPES = {
    "float32": True, "big-endian float64": True, "big-endian float32": True,
    "float16": False, "long double": True, "int8": False, "uint8": False, "int16": False,
    "int32": True, "uint32": False, "int64": True, "uint64": False, "big-endian int32": True,
    "bool": False, "complex128": False, "compound(value, error)": False,
    "compound(one field)": False, "enum(int8)": False, "opaque": False,
    "object reference": False, "region reference": False, "vlen sequence of float64": False,
    "HDF5 array type": False, "fixed-length ASCII string": False,
    "fixed-length UTF-8 string": False, "variable-length ASCII string": False,
    "variable-length UTF-8 string": False,
}
STRING_RETYPES = ["fixed-length ASCII string (NULLPAD, exact)",
                  "fixed-length ASCII string (NULLTERM, exact+1)",
                  "fixed-length UTF-8 string (NULLTERM, padded to 64)",
                  "fixed-length ASCII string (SPACEPAD, padded to 40)",
                  "variable-length ASCII string", "variable-length UTF-8 string (bytes)"]
STRING_RETYPE_VARIANT = {STRING_RETYPES[0]: True, STRING_RETYPES[1]: True,
                         STRING_RETYPES[2]: True, STRING_RETYPES[3]: False,
                         STRING_RETYPES[4]: True, STRING_RETYPES[5]: True}


class Skip(Exception):
    """The operator does not apply to this site (the caller draws another)."""


# ---------------------------------------------------------------------------------- sites ---

class Site:
    def __init__(self, kind, path, attr=None, link=None):
        self.kind, self.path, self.attr, self.link = kind, path, attr, link  # kind: group,
        # dataset, attr, link

    @property
    def key(self):
        return f"{self.path}@{self.attr}" if self.kind == "attr" else self.path

    def __str__(self):
        return self.key


def _join(parent, name):
    return "/" + name if parent == "/" else parent + "/" + name


def sites(f):
    """Every object and attribute reachable through hard links, each object once."""
    out, seen = [], set()

    def attrs_of(obj, path):
        try:
            names = list(obj.attrs.keys())
        except Exception:
            names = []
        for a in names:
            out.append(Site("attr", path, a))

    def walk(group, path):
        try:
            addr = h5py.h5o.get_info(group.id).addr
        except Exception:
            addr = path
        if addr in seen:
            return
        seen.add(addr)
        attrs_of(group, path)
        try:
            names = list(group.keys())
        except Exception:
            return
        for name in names:
            p = _join(path, name)
            try:
                link = group.get(name, getlink=True)
            except Exception:
                continue
            if not isinstance(link, h5py.HardLink):
                out.append(Site("link", p, link=link))
                continue
            try:
                obj = group[name]
            except Exception:
                continue
            if isinstance(obj, h5py.Group):
                out.append(Site("group", p))
                walk(obj, p)
            elif isinstance(obj, h5py.Dataset):
                out.append(Site("dataset", p))
                attrs_of(obj, p)

    walk(f["/"], "/")
    return out


# ------------------------------------------------------------------------------- helpers ---

def _parent_and_name(f, path):
    head, name = path.rsplit("/", 1)
    return f[head or "/"], name


def _read_attrs(obj):
    saved = []
    try:
        for k in list(obj.attrs.keys()):
            try:
                saved.append((k, obj.attrs[k]))
            except Exception:
                pass
    except Exception:
        pass
    return saved


def _restore_attrs(obj, saved):
    for k, v in saved:
        try:
            obj.attrs[k] = v
        except Exception:
            pass


def _data_of(d):
    try:
        v = d[()]
    except Exception:
        return np.arange(6, dtype=float)
    if isinstance(v, h5py.Empty):
        return np.zeros(0)
    return np.asarray(v)


def _as_float(data):
    """The data as float64 (strings: their numbers, "x y z" -> [x, y, z]; else 0)."""
    a = np.asarray(data)
    if a.dtype.kind in "biuf":
        return a.astype(np.float64)
    if a.dtype.kind == "c":
        return a.real.astype(np.float64)
    if a.dtype.kind in "SOU":
        flat = []
        for s in a.ravel():
            s = s.decode("utf-8", "replace") if isinstance(s, bytes) else str(s)
            try:
                flat.append([float(x) for x in s.split()] or [0.0])
            except ValueError:
                flat.append([0.0])
        if a.ndim == 0:
            return np.array(flat[0]) if len(flat[0]) > 1 else np.float64(flat[0][0])
        return np.array([x[0] for x in flat]).reshape(a.shape)
    return np.zeros(a.shape)


def _as_text(data):
    a = np.asarray(data)
    if a.dtype.kind in "SO":
        def dec(s):
            return s.decode("utf-8", "replace") if isinstance(s, bytes) else str(s)
        return dec(a.ravel()[0]) if a.size else ""
    if a.dtype.kind == "U":
        return str(a.ravel()[0]) if a.size else ""
    return " ".join(repr(float(x)) for x in np.ravel(_as_float(a))[:3])


def _is_text(data):
    return np.asarray(data).dtype.kind in "SOU"


def _fixed_string_type(nbytes, pad, cset):
    t = h5py.h5t.C_S1.copy()
    t.set_size(max(1, nbytes))
    t.set_strpad(pad)
    t.set_cset(cset)
    return t


def _write_attr_lowlevel(obj, name, tid, space, buffer):
    if name in obj.attrs:
        del obj.attrs[name]
    aid = h5py.h5a.create(obj.id, name.encode(), tid, space)
    aid.write(buffer, mtype=tid)
    aid.close()


def _fixed_string_attr(obj, name, text_bytes, size, pad, cset, shape=()):
    tid = _fixed_string_type(size, pad, cset)
    space = h5py.h5s.create(h5py.h5s.SCALAR) if shape == () else h5py.h5s.create_simple(shape)
    buf = np.full(shape, text_bytes.ljust(size, b" " if pad == h5py.h5t.STR_SPACEPAD else b"\0")[
        :size], dtype=f"S{size}")
    _write_attr_lowlevel(obj, name, tid, space, buf)


_FLOAT_RETYPES = {"float32": "<f4", "big-endian float64": ">f8", "big-endian float32": ">f4",
                  "float16": "<f2", "long double": np.longdouble}
_INT_RETYPES = ("int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64",
                "big-endian int32")


def _retype_number(name, x, fin, shape):
    """(array, dtype) for the numeric, compound, enum and opaque retypes; None for the others."""
    if name in _FLOAT_RETYPES:
        return x.astype(_FLOAT_RETYPES[name]), None
    if name in _INT_RETYPES:
        dt = np.dtype(">i4" if name.startswith("big") else name)
        info = np.iinfo(dt)
        return np.clip(np.round(fin), info.min, info.max).astype(dt), None
    if name == "bool":
        return fin > 0, None
    if name == "complex128":
        return x.astype(np.complex128) + 1j, None
    if name == "compound(value, error)":
        dt = np.dtype([("value", "<f8"), ("error", "<f8")])
        out = np.zeros(shape, dt)
        out["value"], out["error"] = x, 0.03 * np.abs(x)
        return out, None
    if name == "compound(one field)":
        dt = np.dtype([("x", "<f8")])
        out = np.zeros(shape, dt)
        out["x"] = x
        return out, None
    if name == "enum(int8)":
        dt = h5py.enum_dtype({"BEAM": 0, "CONE": 1, "HEMISPHERE": 2}, basetype="i1")
        return np.clip(np.round(fin), 0, 2).astype("i1"), dt
    if name == "opaque":
        raw = np.ascontiguousarray(x.astype("<f8")).tobytes()
        return np.frombuffer(raw, dtype="V8").reshape(shape), None
    return None


def _retype_reference(f, name, x, rnd, shape):
    """(array, dtype) for the reference, variable-length and HDF5 array retypes; None for the
    others."""
    if name == "object reference":
        out = np.empty(shape, dtype=h5py.ref_dtype)
        ref = f["/"].ref
        for i in np.ndindex(*shape):
            out[i] = ref
        return out, h5py.ref_dtype
    if name == "region reference":
        target = next((o for o in _all_datasets(f)), None)
        if target is None or target.ndim == 0:
            raise Skip("no dataset to refer to")
        out = np.empty(shape, dtype=h5py.regionref_dtype)
        ref = target.regionref[tuple(slice(0, 1) for _ in range(target.ndim))]
        for i in np.ndindex(*shape):
            out[i] = ref
        return out, h5py.regionref_dtype
    if name == "vlen sequence of float64":
        dt = h5py.vlen_dtype(np.float64)
        out = np.empty(shape, dtype=object)
        for i in np.ndindex(*shape):
            out[i] = np.array([x[i], x[i]][: rnd.choice([0, 1, 2])], dtype=np.float64)
        return out, dt
    if name == "HDF5 array type":
        if len(shape) >= 1 and shape[-1] > 0:
            return np.ascontiguousarray(x), np.dtype(("<f8", (shape[-1],)))
        return np.ascontiguousarray(x).reshape(shape + (1,)), np.dtype(("<f8", (1,)))
    return None


def _retype_string(a, name, x, shape):
    """(array, dtype) for the string retypes: text as it is, numbers as their repr."""
    text = np.asarray(a) if _is_text(a) else None
    if text is not None:
        items = [(_as_text(s) if not isinstance(s, str) else s) for s in np.ravel(text)] \
            if text.ndim else [_as_text(text)]
    else:
        items = [repr(float(v)) for v in np.ravel(x)]
    if name == "fixed-length ASCII string":
        n = max([len(s.encode()) for s in items] + [1])
        return np.array([s.encode() for s in items], dtype=f"S{n}").reshape(shape), None
    if name == "fixed-length UTF-8 string":
        n = max([len(s.encode()) for s in items] + [1])
        return (np.array([s.encode() for s in items], dtype=f"S{n}").reshape(shape),
                h5py.string_dtype("utf-8", n))
    if name == "variable-length ASCII string":
        return (np.array([s.encode() for s in items], dtype=object).reshape(shape),
                h5py.string_dtype("ascii"))
    if name == "variable-length UTF-8 string":
        return np.array(items, dtype=object).reshape(shape), h5py.string_dtype("utf-8")
    raise Skip(f"unknown retype {name}")


def _retype(f, data, name, rnd, shape=None):
    """(array, dtype) of `data` converted to the retype `name`."""
    a = np.asarray(data)
    shape = a.shape if shape is None else shape
    x = _as_float(a)
    x = np.broadcast_to(x, shape) if np.ndim(x) == 0 or np.shape(x) == shape else x
    shape = np.shape(x)
    fin = np.nan_to_num(np.asarray(x, dtype=np.float64), nan=0, posinf=1e300, neginf=-1e300)
    converted = _retype_number(name, x, fin, shape)
    if converted is None:
        converted = _retype_reference(f, name, x, rnd, shape)
    return converted if converted is not None else _retype_string(a, name, x, shape)


def _exact(before, after):
    """Whether a retype kept every value (int32 of 0.94 does not): integer retypes are variants
    only then; float32 and the like are, whatever their rounding."""
    try:
        a = np.asarray(before, dtype=np.float64)
        b = np.asarray(after).astype(np.float64)
        return a.shape == b.shape and bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))
    except (TypeError, ValueError):
        return False


def _all_datasets(f):
    out = []
    f.visititems(lambda n, o: out.append(o) if isinstance(o, h5py.Dataset) else None)
    return out


def _replace_dataset(f, path, data=None, dtype=None, keep_attrs=True, **kw):
    """The dataset at path replaced (its attributes kept); made under a temporary name first, so
    that a combination h5py refuses leaves the file as it was."""
    parent, name = _parent_and_name(f, path)
    saved = _read_attrs(parent[name]) if keep_attrs and name in parent else []
    temporary = name + "__fuzz_new"
    try:
        if data is not None:
            d = parent.create_dataset(temporary, data=data, dtype=dtype, **kw)
        else:
            d = parent.create_dataset(temporary, dtype=dtype, **kw)
    except BaseException:
        if temporary in parent:
            del parent[temporary]
        raise
    _restore_attrs(d, saved)
    if name in parent:
        del parent[name]
    parent.move(temporary, name)
    return parent[name]


def _replace_attr(obj, name, data, dtype=None, shape=None):
    if name in obj.attrs:
        del obj.attrs[name]
    obj.attrs.create(name, data, dtype=dtype, shape=shape)


# ----------------------------------------------------------------------- dataset operators ---

def ds_delete(f, s, rnd):
    parent, name = _parent_and_name(f, s.path)
    del parent[name]
    return f"{s.path}: dataset deleted", False


def ds_retype(f, s, rnd):
    d = f[s.path]
    data = _data_of(d)
    if _is_text(data) and rnd.random() < 0.5:
        name = rnd.choice(["fixed-length ASCII string", "variable-length UTF-8 string",
                           "float64", "int32"])
        if name == "float64":
            arr, dt = _as_float(data), None
        else:
            arr, dt = _retype(f, data, name, rnd)
        variant = False
    else:
        name = rnd.choice(list(RETYPES))
        arr, dt = _retype(f, data, name, rnd)
        variant = RETYPES[name] and ("int" not in name or _exact(data, arr))
    _replace_dataset(f, s.path, arr, dt)
    return f"{s.path}: dataset retyped to {name} (shape {np.shape(arr)}, values kept)", variant


def _reshape_choices(shape):
    c = ["scalar", "flattened to 1-D", "extra leading axis of 1", "extra trailing axis of 1",
         "zero-length first axis", "null dataspace (h5py.Empty)", "off by one",
         "transposed (axes reversed, as MATLAB writes)", "1-D of 1000-4096 values",
         "4-D (x2 x2)"]
    if len(shape) >= 2:
        c.append("last axis dropped")
    return c


def _off_by_one(a, rnd):
    if a.ndim == 0:
        return np.array([a, a]), "scalar -> 2 values"
    axis = rnd.randrange(a.ndim)
    if rnd.random() < 0.5 and a.shape[axis] > 0:
        sl = [slice(None)] * a.ndim
        sl[axis] = slice(0, a.shape[axis] - 1)
        return a[tuple(sl)], f"axis {axis} shortened by one"
    pad = np.take(a, [0], axis=axis) if a.shape[axis] else np.zeros(
        tuple(1 if i == axis else n for i, n in enumerate(a.shape)), a.dtype)
    return np.concatenate([a, pad], axis=axis), f"axis {axis} lengthened by one"


def ds_reshape(f, s, rnd):
    d = f[s.path]
    a = _data_of(d)
    how = rnd.choice(_reshape_choices(a.shape))
    if a.ndim < 2 and (how.startswith("transposed") or how.startswith("4-D")):
        raise Skip("no axes to transpose")
    kw = {}
    if how == "scalar":
        new = a.ravel()[0] if a.size else np.float64(0)
    elif how == "flattened to 1-D":
        new = a.ravel()
    elif how == "extra leading axis of 1":
        new = a[None, ...]
    elif how == "extra trailing axis of 1":
        new = a[..., None]
    elif how == "zero-length first axis":
        new = np.zeros((0,) + a.shape[1:], a.dtype) if a.ndim else np.zeros(0, a.dtype)
    elif how == "null dataspace (h5py.Empty)":
        new = h5py.Empty(a.dtype if a.dtype.kind in "biuf" else np.float64)
    elif how == "off by one":
        new, detail = _off_by_one(a, rnd)
        how = f"off by one ({detail})"
    elif how.startswith("transposed"):
        new = np.ascontiguousarray(a.T)
    elif how.startswith("1-D of"):
        n = rnd.randint(1000, 4096)
        base = a.ravel() if a.size else np.zeros(1)
        new = np.resize(base, n)
        how = f"1-D of {n} values"
    elif how == "4-D (x2 x2)":
        new = np.broadcast_to(a, (2, 2) + a.shape).copy() if a.ndim <= 2 else a[None, ...]
    else:  # last axis dropped
        new = a[..., 0]
    _replace_dataset(f, s.path, new, **kw)
    return f"{s.path}: {how} (shape {a.shape} -> {np.shape(new) if not isinstance(new, h5py.Empty) else 'null'})", False


def _special(rnd, a):
    label, v = rnd.choice(SPECIAL_VALUES)
    if v is None:
        return label, -np.abs(a)
    return label, v


def ds_values(f, s, rnd):
    d = f[s.path]
    a = _data_of(d)
    if a.dtype.kind not in "fiu" or a.size == 0:
        raise Skip("not numeric")
    a = a.astype(np.float64)
    label, v = _special(rnd, a)
    where = rnd.choice(["every cell", "one cell", "half the cells", "first element"])
    out = a.copy()
    if where == "every cell":
        out[...] = v
    elif where == "one cell":
        i = rnd.randrange(a.size)
        out.flat[i] = np.ravel(v)[i] if np.ndim(v) else v
        where = f"cell {np.unravel_index(i, a.shape)}"
    elif where == "half the cells":
        mask = np.random.default_rng(rnd.randrange(2**32)).random(a.shape) < 0.5
        out[mask] = (v[mask] if np.ndim(v) else v)
    else:
        out.flat[0] = np.ravel(v)[0] if np.ndim(v) else v
    _replace_dataset(f, s.path, out)
    return f"{s.path}: {label} in {where}", False


def ds_wavelength_order(f, s, rnd):
    d = f[s.path]
    a = _data_of(d)
    if a.ndim != 1 or a.dtype.kind != "f":
        raise Skip("not a wavelength list")
    how = rnd.choice(["reversed", "duplicated", "all equal", "shifted to 1e4 nm", "0.5 nm"])
    if how == "reversed":
        new = a[::-1].copy()
    elif how == "duplicated":
        new = np.full_like(a, a[0])
    elif how == "all equal":
        new = np.full_like(a, 550.0)
    elif how == "shifted to 1e4 nm":
        new = a + 1e4
    else:
        new = np.full_like(a, 0.5)
    _replace_dataset(f, s.path, new)
    return f"{s.path}: values {how}", False


def ds_directions(f, s, rnd):
    """Direction lists [pairs, 3] that are not unit vectors above the patch."""
    d = f[s.path]
    a = _data_of(d)
    if not s.path.endswith("directions") or a.ndim != 2 or a.shape[1] != 3 or \
            a.dtype.kind != "f" or a.shape[0] == 0:
        raise Skip("not a direction list")
    how = rnd.choice(["scaled by 1000 (not unit)", "zero vector", "below the patch (z < 0)",
                      "in the patch plane (z = 0)", "exactly the normal (0, 0, 1)",
                      "light and view swapped sign in x, y", "scaled by 1e-300"])
    out = a.copy()
    i = rnd.randrange(a.shape[0])
    rows = slice(None) if rnd.random() < 0.5 else slice(i, i + 1)
    if how.startswith("scaled by 1000"):
        out[rows] *= 1000.0
    elif how == "zero vector":
        out[rows] = 0.0
    elif how.startswith("below"):
        out[rows, 2] = -np.abs(out[rows, 2])
    elif how.startswith("in the patch plane"):
        xy = np.hypot(out[rows, 0], out[rows, 1])[..., None]
        out[rows, :2] /= np.where(xy > 0, xy, 1.0)
        out[rows, 2] = 0.0
    elif how.startswith("exactly the normal"):
        out[rows] = (0.0, 0.0, 1.0)
    elif how.startswith("light and view"):
        out[rows, :2] *= -1.0
    else:
        out[rows] *= 1e-300
    _replace_dataset(f, s.path, out)
    where = "every pair" if rows == slice(None) else f"pair {i}"
    return f"{s.path}: {how} in {where}", how.startswith("exactly") or how.startswith("light")


def consistent_resize(f, kind, rnd):
    """Every array the fit reads resized together, so that the shapes agree: images from 1 x 1
    to 4096 x 4096 pixels, 0 to 1000 wavelengths, 0 to 100000 goniometer pairs. Values stay
    sensible (nearest-neighbour resampling of the seed; zeros for the biggest images)."""
    from seeds import pixel_geometry

    try:
        wl = np.asarray(f["wavelength_nm"][()], float) if isinstance(
            f.get("wavelength_nm"), h5py.Dataset) else None
    except Exception:
        raise Skip("wavelengths unreadable") from None
    if wl is None or wl.ndim != 1:
        raise Skip("no wavelength list")
    if kind == "imaging_scatterometer":
        try:
            img = np.asarray(f["image/intensity"][()], float)
            err = np.asarray(f["image/standard_error"][()], float)
        except Exception:
            raise Skip("no image") from None
        if img.ndim != 3 or err.shape != img.shape or img.shape[2] != wl.size or img.size == 0:
            raise Skip("image already damaged")
        n = rnd.choice([1, 2, 8, 9, 10, 31, 64, 128, 256, 1024, 4096])
        nl = rnd.choice([wl.size, wl.size, 0, 1, 16, 200]) if n <= 64 else min(wl.size, 2)
        zeros = n >= 1024
        rows = np.minimum((np.arange(n) * img.shape[0]) // n, img.shape[0] - 1)
        lam = np.minimum((np.arange(nl) * wl.size) // max(nl, 1), wl.size - 1)
        omega = pixel_geometry(n)[0]
        new_wl = np.linspace(400.0, 700.0, nl) if nl != wl.size else wl
        chunk = dict(chunks=True, compression="gzip") if n >= 256 else {}
        if zeros:
            ni = np.zeros((n, n, nl))
            ne = np.zeros((n, n, nl))
        else:
            ni = img[rows][:, rows][:, :, lam] * (omega[..., None] > 0)
            ne = err[rows][:, rows][:, :, lam] * (omega[..., None] > 0)
        _replace_dataset(f, "/wavelength_nm", new_wl)
        _replace_dataset(f, "/image/intensity", ni, **chunk)
        _replace_dataset(f, "/image/standard_error", ne, **chunk)
        _replace_dataset(f, "/image/solid_angle_sr", omega, **chunk)
        if "image/directions" in f:
            del f["image/directions"]
        return (f"image resized consistently to {n} x {n} px x {nl} wavelengths"
                f"{' (all zero)' if zeros else ' (nearest-neighbour copy of the seed)'}"), False
    if kind == "goniometer":
        try:
            val = np.asarray(f["brdf/value"][()], float)
        except Exception:
            raise Skip("no brdf") from None
        pairs = rnd.choice([0, 1, 2, 7, 5000, 100000])
        nl = rnd.choice([wl.size, 0, 1, 100])
        g = np.random.default_rng(rnd.randrange(2**32))
        def dirs(k):
            t, p = np.radians(g.uniform(0, 80, k)), np.radians(g.uniform(-180, 180, k))
            return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
        v = np.abs(g.normal(np.mean(val) if val.size else 0.5, 0.1, (pairs, nl)))
        _replace_dataset(f, "/wavelength_nm", np.linspace(420.0, 680.0, nl))
        _replace_dataset(f, "/instrument/light_directions", dirs(pairs))
        _replace_dataset(f, "/instrument/view_directions", dirs(pairs))
        _replace_dataset(f, "/brdf/value", v)
        _replace_dataset(f, "/brdf/standard_error", 0.03 * v + 0.002)
        return f"BRDF resized consistently to {pairs} pairs x {nl} wavelengths", False
    raise Skip("kind")


HUGE_SHAPES = {1: [(30000 * 4096,), (2**40,)], 2: [(100000, 100000), (1_000_000_000, 3)],
               3: [(100000, 100000, 50), (30000, 30000, 2)]}


def ds_huge_unwritten(f, s, rnd):
    d = f[s.path]
    rank = d.ndim if d.ndim in HUGE_SHAPES else rnd.choice([1, 2, 3])
    shape = rnd.choice(HUGE_SHAPES[rank])
    chunks = tuple(min(n, 64) for n in shape)
    fill = rnd.choice([None, np.nan, 1.0])
    kw = dict(shape=shape, dtype="<f8", chunks=chunks, maxshape=tuple(None for _ in shape))
    if fill is not None:
        kw["fillvalue"] = fill
    _replace_dataset(f, s.path, None, **kw)
    return (f"{s.path}: declared {shape} float64, chunked {chunks}, maxshape unlimited, never "
            f"written (fill {fill}; {np.prod(shape, dtype=float) * 8 / 1e9:.3g} GB if read)"), False


def ds_unwritten(f, s, rnd):
    d = f[s.path]
    shape = d.shape if d.shape is not None else (3,)
    layout = rnd.choice(["contiguous", "chunked"])
    kw = dict(shape=shape, dtype="<f8")
    if layout == "chunked" and len(shape):
        kw["chunks"] = True
    _replace_dataset(f, s.path, None, **kw)
    return f"{s.path}: same shape {shape}, {layout}, never written (fill value 0)", False


def ds_storage(f, s, rnd):
    d = f[s.path]
    a = _data_of(d)
    if a.ndim == 0 or a.size == 0:
        raise Skip("scalar")
    how = rnd.choice(["chunked + gzip 9", "chunked + shuffle + gzip + fletcher32",
                      "compact layout", "chunked + LZF (h5py's filter, absent from plain HDF5)",
                      "chunked + scale-offset", "chunks of 1 element"])
    kw, variant = {}, True
    if how.startswith("chunked + gzip"):
        kw = dict(chunks=True, compression="gzip", compression_opts=9)
    elif how.startswith("chunked + shuffle"):
        kw = dict(chunks=True, shuffle=True, compression="gzip", fletcher32=True)
    elif how == "compact layout":
        if a.nbytes > 60000:
            raise Skip("too big for compact")
        dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
        dcpl.set_layout(h5py.h5d.COMPACT)
        parent, name = _parent_and_name(f, s.path)
        saved = _read_attrs(d)
        del parent[name]
        tid = h5py.h5t.py_create(a.dtype)
        space = h5py.h5s.create_simple(a.shape)
        dsid = h5py.h5d.create(parent.id, name.encode(), tid, space, dcpl=dcpl)
        dsid.write(h5py.h5s.ALL, h5py.h5s.ALL, np.ascontiguousarray(a))
        dsid.close()
        _restore_attrs(parent[name], saved)
        return f"{s.path}: rewritten with the compact layout", True
    elif how.startswith("chunked + LZF"):
        kw = dict(chunks=True, compression="lzf")
        variant = False
    elif how == "chunked + scale-offset":
        if a.dtype.kind != "f":
            raise Skip("not float")
        kw = dict(chunks=True, scaleoffset=6)
        variant = False  # lossy
    else:
        kw = dict(chunks=tuple(1 for _ in a.shape))
    _replace_dataset(f, s.path, a, **kw)
    return f"{s.path}: rewritten {how}", variant


def ds_to_group(f, s, rnd):
    parent, name = _parent_and_name(f, s.path)
    a = _data_of(parent[name])
    saved = _read_attrs(parent[name])
    del parent[name]
    g = parent.create_group(name)
    how = rnd.choice(["empty group", "group holding the data as 'value'", "group with attrs"])
    if how == "group holding the data as 'value'":
        g.create_dataset("value", data=a)
    elif how == "group with attrs":
        _restore_attrs(g, saved)
    return f"{s.path}: dataset replaced by an {how}" if how.startswith("empty") else \
        f"{s.path}: dataset replaced by a {how}", False


def _other_object(f, s, rnd, want=None):
    cands = [x for x in sites(f) if x.kind in (want or ("dataset", "group")) and x.path != s.path]
    if not cands:
        raise Skip("no other object")
    return rnd.choice(cands).path


def obj_soft_link(f, s, rnd):
    parent, name = _parent_and_name(f, s.path)
    how = rnd.choice(["another object", "a dangling path", "itself", "a link loop"])
    del parent[name]
    if how == "another object":
        target = _other_object(f, s, rnd)
    elif how == "a dangling path":
        target = "/does/not/exist"
    elif how == "itself":
        target = s.path
    else:
        parent[name + "_loop"] = h5py.SoftLink(s.path)
        target = s.path + "_loop"
    parent[name] = h5py.SoftLink(target)
    return f"{s.path}: replaced by a soft link to {how} ({target})", False


def obj_external_link(f, s, rnd):
    parent, name = _parent_and_name(f, s.path)
    keep = rnd.random() < 0.5
    how = rnd.choice(["a missing file", "the file itself", "/dev/zero", "an absolute missing path"])
    fname = {"a missing file": "missing_companion.h5",
             "the file itself": os.path.basename(f.filename), "/dev/zero": "/dev/zero",
             "an absolute missing path": "/nonexistent/dir/x.h5"}[how]
    if keep:
        parent[name + "_ext"] = h5py.ExternalLink(fname, s.path)
        return f"{s.path}_ext: extra external link to {how} ({fname}:{s.path})", False
    del parent[name]
    parent[name] = h5py.ExternalLink(fname, s.path)
    return f"{s.path}: replaced by an external link to {how} ({fname}:{s.path})", False


def ds_soft_link_valid(f, s, rnd):
    """A dataset stored once and linked (a valid layout some writers produce)."""
    parent, name = _parent_and_name(f, s.path)
    a = _data_of(parent[name])
    saved = _read_attrs(parent[name])
    del parent[name]
    d = f.create_dataset("/__stored_" + name, data=a)
    _restore_attrs(d, saved)
    parent[name] = h5py.SoftLink("/__stored_" + name)
    return f"{s.path}: moved to /__stored_{name}, a soft link left in its place", True


# ------------------------------------------------------------------------- group operators ---

def grp_delete(f, s, rnd):
    parent, name = _parent_and_name(f, s.path)
    del parent[name]
    return f"{s.path}: group deleted (with everything in it)", False


def grp_to_dataset(f, s, rnd):
    parent, name = _parent_and_name(f, s.path)
    saved = _read_attrs(parent[name])
    del parent[name]
    d = parent.create_dataset(name, data=np.arange(4.0))
    keep = rnd.random() < 0.5
    if keep:
        _restore_attrs(d, saved)
    return f"{s.path}: group replaced by a float64 dataset [4]" + (
        " carrying the group's attributes" if keep else ""), False


def grp_cycle(f, s, rnd):
    g = f[s.path]
    target = rnd.choice(["/", s.path])
    name = rnd.choice(["loop", "zz_cycle"])
    if name in g:
        raise Skip("exists")
    g[name] = f[target]
    return f"{s.path}/{name}: hard link back to {target} (a cycle)", False


def grp_extra(f, s, rnd):
    g = f[s.path]
    how = rnd.choice(["unknown dataset", "unknown group tree", "1000 unknown attributes",
                      "unknown attribute of 4096 strings", "unknown big dataset (1M float32)",
                      "unknown dataset of vlen strings", "unknown named datatype"])
    variant = True
    if how == "unknown dataset":
        g.create_dataset("zz_unknown", data=np.arange(10.0))
    elif how == "unknown group tree":
        t = g.create_group("zz_tree")
        for i in range(3):
            t.create_group(f"level{i}").create_dataset("x", data=[i])
    elif how == "1000 unknown attributes":
        for i in range(1000):
            g.attrs[f"zz_{i:04d}"] = float(i)
    elif how == "unknown attribute of 4096 strings":
        g.attrs.create("zz_strings", ["x" * 10] * 4096, dtype=h5py.string_dtype())
    elif how.startswith("unknown big dataset"):
        g.create_dataset("zz_big", data=np.zeros(1_000_000, np.float32), chunks=True,
                         compression="gzip")
    elif how == "unknown dataset of vlen strings":
        g.create_dataset("zz_text", data=np.array(["a", "ß", "日本"], dtype=object),
                         dtype=h5py.string_dtype())
    else:
        g["zz_type"] = np.dtype([("a", "<i4"), ("b", "<f8")])
    return f"{s.path}: extra {how}", variant


def obj_rename(f, s, rnd):
    parent, name = _parent_and_name(f, s.path)
    new = rnd.choice([name.upper(), name.capitalize(), name + " ", " " + name, name + "_",
                      name.replace("_", "-") if "_" in name else name + "s"])
    if new == name or new in parent:
        raise Skip("same name")
    parent.move(name, new)
    return f"{s.path}: renamed to {new!r}", False


# --------------------------------------------------------------------- attribute operators ---

def at_delete(f, s, rnd):
    del f[s.path].attrs[s.attr]
    return f"{s.key}: attribute deleted", False


def _attr_value(obj, name):
    try:
        return obj.attrs[name]
    except Exception:
        return None


def at_retype(f, s, rnd):
    obj = f[s.path]
    v = _attr_value(obj, s.attr)
    if v is None:
        v = np.float64(0)
    if _is_text(v) or isinstance(v, str):
        text = _as_text(np.asarray(v, dtype=object) if isinstance(v, str) else v)
        name = rnd.choice(STRING_RETYPES + ["float64 of its numbers", "int32", "bool",
                                            "complex128", "compound(value, error)",
                                            "enum(int8)", "opaque", "object reference",
                                            "vlen sequence of float64"])
        if name in STRING_RETYPES:
            raw = text.encode()
            if "NULLPAD, exact" in name:
                _fixed_string_attr(obj, s.attr, raw, len(raw), h5py.h5t.STR_NULLPAD,
                                   h5py.h5t.CSET_ASCII)
            elif "NULLTERM, exact+1" in name:
                _fixed_string_attr(obj, s.attr, raw, len(raw) + 1, h5py.h5t.STR_NULLTERM,
                                   h5py.h5t.CSET_ASCII)
            elif "padded to 64" in name:
                _fixed_string_attr(obj, s.attr, raw, 64, h5py.h5t.STR_NULLTERM,
                                   h5py.h5t.CSET_UTF8)
            elif "SPACEPAD" in name:
                _fixed_string_attr(obj, s.attr, raw, 40, h5py.h5t.STR_SPACEPAD,
                                   h5py.h5t.CSET_ASCII)
            elif name == "variable-length ASCII string":
                _replace_attr(obj, s.attr, raw, dtype=h5py.string_dtype("ascii"))
            else:
                _replace_attr(obj, s.attr, raw, dtype=h5py.string_dtype("utf-8"))
            return f"{s.key}: {text[:40]!r} stored as {name}", STRING_RETYPE_VARIANT[name]
        if name == "float64 of its numbers":
            arr, dt = _as_float(np.asarray(text, dtype=object)), None
            variant = np.ndim(arr) == 1 and np.size(arr) == 3  # beam_direction as 3 numbers
        else:
            arr, dt = _retype(f, np.asarray(text, dtype=object), name, rnd)
            variant = False
        _replace_attr(obj, s.attr, arr, dtype=dt)
        return f"{s.key}: {text[:40]!r} stored as {name} ({np.asarray(arr).ravel()[:3]!r})", variant
    name = rnd.choice(list(RETYPES))
    arr, dt = _retype(f, np.asarray(v), name, rnd)
    _replace_attr(obj, s.attr, arr, dtype=dt)
    return f"{s.key}: {np.asarray(v).ravel()[:3]} stored as {name}", RETYPES[name] and (
        "int" not in name or _exact(v, arr))


def at_reshape(f, s, rnd):
    obj = f[s.path]
    v = _attr_value(obj, s.attr)
    if v is None:
        raise Skip("unreadable")
    text = _is_text(v) or isinstance(v, str)
    how = rnd.choice(["1-element array (as MATLAB writes)", "2 elements", "[2, 2]",
                      "null dataspace (h5py.Empty)", "zero-length array", "big array",
                      "big array"])
    if text:
        s0 = v if isinstance(v, str) else _as_text(v)
        if how == "big array":
            n = rnd.randint(1000, 2000)
            if rnd.random() < 0.5:
                _replace_attr(obj, s.attr, [s0] * n, dtype=h5py.string_dtype())
                how = f"array of {n} variable-length strings"
            else:
                raw = s0.encode()
                _replace_attr(obj, s.attr, np.array([raw] * n, dtype=f"S{max(1, len(raw))}"))
                how = f"array of {n} fixed-length strings"
        elif how.startswith("1-element"):
            _replace_attr(obj, s.attr, [s0], dtype=h5py.string_dtype())
        elif how == "2 elements":
            _replace_attr(obj, s.attr, [s0, "goniometer"], dtype=h5py.string_dtype())
        elif how == "[2, 2]":
            _replace_attr(obj, s.attr, [[s0, s0], [s0, s0]], dtype=h5py.string_dtype())
        elif how.startswith("null"):
            _replace_attr(obj, s.attr, h5py.Empty(h5py.string_dtype()))
        else:
            _replace_attr(obj, s.attr, np.zeros(0, dtype=object), dtype=h5py.string_dtype(),
                          shape=(0,))
        return f"{s.key}: {s0[:40]!r} as {how}", how.startswith("1-element")
    a = np.asarray(v)
    x = float(np.ravel(_as_float(a))[0]) if a.size else 0.0
    if how == "big array":
        n = rnd.choice([1000, 4096, rnd.randint(1000, 4096)])
        _replace_attr(obj, s.attr, np.full(n, x))
        how = f"array of {n} values"
    elif how.startswith("1-element"):
        _replace_attr(obj, s.attr, np.array([x]))
    elif how == "2 elements":
        _replace_attr(obj, s.attr, np.array([x, x + 1]))
    elif how == "[2, 2]":
        _replace_attr(obj, s.attr, np.full((2, 2), x))
    elif how.startswith("null"):
        _replace_attr(obj, s.attr, h5py.Empty("<f8"))
    else:
        _replace_attr(obj, s.attr, np.zeros(0))
    return f"{s.key}: {x!r} as {how}", how.startswith("1-element")


TEXT_VALUES = {
    "kind": ["goniometer", "imaging_scatterometer ", "Imaging_Scatterometer", "btf_camera",
             "imaging-scatterometer", "thin_film_chart", "imaging_scatterometer\0goniometer"],
    "illumination": ["beam", "cone", "hemisphere", "Beam", " cone", "cone ", "laser", "BEAM",
                     "hemisphere\0", "beam;cone"],
    "beam_direction": ["0 0 -1", "0 0 0", "1 0 0", "nan nan nan", "inf 0 1", "0 0 inf", "a b c",
                       "1 2", "1 2 3 4", "1e400 0 1", "0,0,1", "0 0 1e-320", "-0 -0 1e308",
                       "(0, -0.34, 0.94)", "0x1p-2 0 1", "0\t-0.34\n0.94", "  0 0 1  ",
                       "0 0 1 garbage", "1e308 1e308 1e308"],
}


def at_value(f, s, rnd):
    obj = f[s.path]
    v = _attr_value(obj, s.attr)
    if v is None:
        raise Skip("unreadable")
    if _is_text(v) or isinstance(v, str):
        generic = ["", "x" * rnd.choice([1000, 100_000, 1_000_000]), "\u00e9\u65e5\u672c\u20ac",
                   "\ufeff" + (v if isinstance(v, str) else _as_text(v)), "\0"]
        choices = TEXT_VALUES.get(s.attr, []) + generic + ["<non-UTF-8 bytes>"]
        new = rnd.choice(choices)
        if new == "<non-UTF-8 bytes>":
            raw = rnd.choice([b"\xff\xfe\xfd", b"beam\xc3", b"\x80imaging_scatterometer"])
            _replace_attr(obj, s.attr, raw, dtype=h5py.string_dtype("utf-8"))
            return f"{s.key}: non-UTF-8 bytes {raw!r} in a UTF-8 string", False
        if "\0" in new:
            raw = new.encode()
            _fixed_string_attr(obj, s.attr, raw, len(raw), h5py.h5t.STR_NULLPAD,
                               h5py.h5t.CSET_UTF8)
            return f"{s.key}: {new!r} (embedded NUL, fixed-length)", False
        _replace_attr(obj, s.attr, new, dtype=h5py.string_dtype("utf-8"))
        shown = new if len(new) < 60 else f"{new[:10]!r}... ({len(new)} chars)"
        return f"{s.key}: value {shown!r}", False
    a = np.asarray(v)
    if a.dtype.kind not in "fiu":
        raise Skip("not numeric")
    label, val = rnd.choice(SPECIAL_VALUES + [("1e6", 1e6), ("180", 180.0), ("360", 360.0),
                                              ("1e-9", 1e-9)])
    if val is None:
        val = -np.abs(a.astype(float))
    _replace_attr(obj, s.attr, np.asarray(val, dtype=np.float64)
                  if a.dtype.kind == "f" else np.asarray(val).astype(np.float64))
    return f"{s.key}: value {label}", False


def at_rename(f, s, rnd):
    obj = f[s.path]
    v = _attr_value(obj, s.attr)
    if v is None:
        raise Skip("unreadable")
    new = rnd.choice([s.attr.upper(), s.attr.capitalize(), s.attr + " ", s.attr + "_deg"])
    if new in obj.attrs:
        raise Skip("exists")
    del obj.attrs[s.attr]
    obj.attrs[new] = v
    return f"{s.key}: renamed to {new!r}", False


def link_ops(f, s, rnd):
    parent, name = _parent_and_name(f, s.path)
    how = rnd.choice(["removed", "retargeted to a missing path"])
    del parent[name]
    if how != "removed":
        parent[name] = h5py.SoftLink("/nowhere/" + name)
    return f"{s.path}: link {how}", False


def add_missing_attr(f, s, rnd):
    """An attribute the reader may need, added where the seed lacks it (cone_aperture_deg, ...)."""
    try:
        if not isinstance(f["instrument"], h5py.Group):
            raise Skip("no /instrument")
    except (KeyError, OSError):
        raise Skip("no /instrument") from None
    g = f["instrument"]
    name, value = rnd.choice([("cone_aperture_deg", rnd.choice([16.0, 0.0, -5.0, 400.0, np.nan])),
                              ("illumination", "cone"), ("beam_direction", "0 0 1"),
                              ("kind", "imaging_scatterometer")])
    old = _attr_value(g, name)
    if isinstance(value, str):
        _replace_attr(g, name, value, dtype=h5py.string_dtype())
    else:
        _replace_attr(g, name, np.float64(value))
    return f"/instrument@{name}: set to {value!r} (was {old!r})", False


OPS = {
    "dataset": [(ds_delete, 2), (ds_retype, 4), (ds_reshape, 4), (ds_values, 3),
                (ds_huge_unwritten, 1.5), (ds_unwritten, 0.7), (ds_storage, 1.2),
                (ds_to_group, 1), (obj_soft_link, 1), (obj_external_link, 0.7),
                (ds_soft_link_valid, 0.5), (obj_rename, 0.5), (ds_wavelength_order, 0.5),
                (ds_directions, 1)],
    "group": [(grp_delete, 1), (grp_to_dataset, 1), (grp_cycle, 1), (grp_extra, 1.2),
              (obj_soft_link, 0.7), (obj_external_link, 0.5), (obj_rename, 0.5)],
    "attr": [(at_delete, 2), (at_retype, 4), (at_reshape, 3), (at_value, 4), (at_rename, 0.5)],
    "link": [(link_ops, 1)],
}


# ------------------------------------------------------------------------ file operators ---

def file_truncate(path, rnd):
    size = os.path.getsize(path)
    frac = rnd.choice([0.1, 0.5, 0.9, 0.99])
    with open(path, "r+b") as fh:
        fh.truncate(int(size * frac))
    return path, f"file truncated to {frac:.0%} of {size} bytes (an interrupted copy)", False


def file_userblock(path, rnd):
    """A 512-byte user block holding a MATLAB 7.3 header: the format MATLAB's save -v7.3 writes."""
    tmp = path + ".ub"
    with h5py.File(path, "r") as src, h5py.File(tmp, "w", userblock_size=512) as dst:
        _copy_tree(src, dst)
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Thu Nov 27 2026 HDF5 schema 1.00 ."
    with open(tmp, "r+b") as fh:
        fh.write(text.ljust(116, b" "))
    os.replace(tmp, path)
    return path, "rewritten with a 512-byte user block (MATLAB 7.3 MAT-file header)", True


def file_libver(path, rnd):
    tmp = path + ".lv"
    with h5py.File(path, "r") as src, h5py.File(tmp, "w", libver="latest", track_order=True) as dst:
        _copy_tree(src, dst)
    os.replace(tmp, path)
    return path, "rewritten with libver='latest' (new-style groups, track_order)", True


def _copy_tree(src, dst):
    for k, v in _read_attrs(src):
        try:
            dst.attrs[k] = v
        except Exception:
            pass
    for name in src:
        try:
            src.copy(src[name], dst, name=name)
        except Exception:
            pass


def file_extension(path, rnd):
    ext = rnd.choice([".hdf5", ".H5", ".HDF5", ".mat", ".txt", "", ".h5.bak", ".csv"])
    new = os.path.splitext(path)[0] + ext
    os.replace(path, new)
    return new, f"file renamed to extension {ext!r}", ext == ".hdf5"


def file_name(path, rnd):
    folder = os.path.dirname(path)
    stem = rnd.choice(["mon échantillon 日本", "with space", "a" * 200, "x;rm -rf y", "-dash",
                       "quote'\"", "%s%n", "tab\tname", "new\nline"])
    new = os.path.join(folder, stem + os.path.splitext(path)[1])
    os.replace(path, new)
    return new, f"file named {os.path.basename(new)!r}", True


def file_empty(path, rnd):
    how = rnd.choice(["0 bytes", "an empty HDF5 file (root group only)", "a directory",
                      "a CSV table", "a symbolic link to the record"])
    if how == "0 bytes":
        open(path, "wb").close()
    elif how.startswith("an empty HDF5"):
        h5py.File(path, "w").close()
    elif how == "a directory":
        os.remove(path)
        os.mkdir(path)
    elif how == "a CSV table":
        with open(path, "w") as fh:
            fh.write("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,wavelength_nm,value_per_sr\n"
                     "30,0,30,180,550,1\n")
    else:
        real = path + ".target.h5"
        os.replace(path, real)
        os.symlink(os.path.basename(real), path)
        return path, "the input is a symbolic link to the record (beside it)", True
    return path, f"the file replaced by {how}", False


FILE_OPS = [(file_truncate, 1), (file_userblock, 0.6), (file_libver, 0.6),
            (file_extension, 0.6), (file_name, 0.4), (file_empty, 0.6)]


# ------------------------------------------------------------------------------- driver ---

def mutate(path, rnd: random.Random, count, kind):
    """Applies `count` mutations to the HDF5 file at `path`; returns (new path, [(desc, variant)])."""
    done = []
    tries = 0
    while len(done) < count and tries < 40:
        tries += 1
        if not os.path.isfile(path) or not h5py.is_hdf5(path):
            break  # a previous file-level mutation left no HDF5 file to mutate further
        if rnd.random() < 0.07:
            op = weighted(rnd, FILE_OPS)
            try:
                path, desc, variant = op(path, rnd)
            except Skip:
                continue
            done.append((desc, variant, op.__name__))
            continue
        extra = rnd.random()
        if extra < 0.1:
            op = add_missing_attr if extra < 0.04 else consistent_resize
            try:
                f = h5py.File(path, "r+")
            except OSError:
                break  # truncated: HDF5 no longer opens it
            with f:
                try:
                    desc, variant = op(f, None if op is add_missing_attr else kind, rnd)
                except Skip:
                    continue
                except (ValueError, TypeError, KeyError, OSError, RuntimeError) as e:
                    desc, variant = (f"{op.__name__} stopped by h5py after a partial change "
                                     f"({type(e).__name__}: {e!s:.100})"), False
            done.append((desc, variant, op.__name__))
            continue
        try:
            f = h5py.File(path, "r+")
        except OSError:
            break  # truncated: HDF5 no longer opens it
        with f:
            all_sites = sites(f)
            if not all_sites:
                break
            read = [s for s in all_sites if s.key in FIT_READS.get(kind, [])]
            if read and rnd.random() < 0.6:
                site = rnd.choice(read)  # what analysis/fits/user_data.cpp reads
            else:
                site = rnd.choice(all_sites)
            op = weighted(rnd, OPS[site.kind])
            try:
                desc, variant = op(f, site, rnd)
            except Skip:
                continue
            except (ValueError, TypeError, KeyError, OSError, RuntimeError, OverflowError) as e:
                # h5py refused this combination, possibly after part of the change (the object
                # deleted, not yet recreated): say so, the mutant stays reproducible
                desc, variant = (f"{site}: {op.__name__} stopped by h5py after a partial change "
                                 f"({type(e).__name__}: {e!s:.100})"), False
        done.append((desc, variant, op.__name__))
    return path, done


def copy_seed(seed, dest):
    shutil.copyfile(seed, dest)
    return dest
