"""Structure-level mutations of RGL tensor files (.bsdf, virtual_gonio/rgl_bsdf.h) for
fuzz/structure/fuzz_user_data.py: the fields' names, dtypes, shapes, counts, offsets and values,
each written back as a consistent container (offsets recomputed, 8-byte aligned as
write_tensor_file does) unless the operator damages the container itself on purpose.

Layout: "tensor_file\\0", u8 major, u8 minor, u32 field count; per field u16 name length, name,
u16 rank, u8 dtype, u64 offset, u64 shape[rank]; then the data. dtype codes: 1 uint8, 2 int8,
3 uint16, 4 int16, 5 uint32, 6 int32, 7 uint64, 8 int64, 9 float16, 10 float32, 11 float64.
"""

from __future__ import annotations

import random
import struct

import numpy as np
from weighted import weighted

MAGIC = b"tensor_file\0"
DTYPES = {1: "<u1", 2: "<i1", 3: "<u2", 4: "<i2", 5: "<u4", 6: "<i4", 7: "<u8", 8: "<i8",
          9: "<f2", 10: "<f4", 11: "<f8"}


class Field:
    def __init__(self, name, dtype, shape, data):
        self.name, self.dtype, self.shape, self.data = name, dtype, list(shape), data  # bytes
        self.offset_override = None
        self.name_length_override = None
        self.rank_override = None

    def array(self):
        return np.frombuffer(self.data, dtype=DTYPES.get(self.dtype, "<u1")).copy()


def parse(raw):
    assert raw[:12] == MAGIC
    count = struct.unpack_from("<I", raw, 14)[0]
    pos, fields = 18, []
    for _ in range(count):
        (n,) = struct.unpack_from("<H", raw, pos)
        pos += 2
        name = raw[pos:pos + n].decode()
        pos += n
        rank, dtype, offset = struct.unpack_from("<HBQ", raw, pos)
        pos += 11
        shape = list(struct.unpack_from(f"<{rank}Q", raw, pos))
        pos += 8 * rank
        size = int(np.prod(shape, dtype=np.uint64)) * np.dtype(DTYPES[dtype]).itemsize
        fields.append(Field(name, dtype, shape, raw[offset:offset + size]))
    return fields


class Container:
    def __init__(self, raw):
        self.fields = parse(raw)
        self.version = (1, 0)
        self.count_override = None
        self.tail = b""
        self.magic = MAGIC

    def render(self):
        header = bytearray(self.magic + bytes(self.version))
        header += struct.pack("<I", len(self.fields) if self.count_override is None
                              else self.count_override)
        size = len(header) + sum(2 + len(f.name.encode()) + 2 + 1 + 8 + 8 * len(f.shape)
                                 for f in self.fields)
        offset = (size + 7) // 8 * 8
        offsets = []
        for f in self.fields:
            offsets.append(offset)
            offset = (offset + len(f.data) + 7) // 8 * 8
        for f, off in zip(self.fields, offsets):
            name = f.name.encode("utf-8", "surrogatepass")
            header += struct.pack("<H", len(name) if f.name_length_override is None
                                  else f.name_length_override) + name
            header += struct.pack("<HBQ", len(f.shape) if f.rank_override is None
                                  else f.rank_override, f.dtype,
                                  off if f.offset_override is None else f.offset_override)
            header += b"".join(struct.pack("<Q", e) for e in f.shape)
        out = bytearray(header)
        for f, off in zip(self.fields, offsets):
            out += b"\0" * (off - len(out))
            out += f.data
        return bytes(out) + self.tail


def _field(c, rnd, numeric=False):
    cands = [f for f in c.fields if not numeric or f.dtype in (10, 11, 9)]
    if not cands:
        raise ValueError("no field")
    return rnd.choice(cands)


def f_delete(c, rnd):
    f = _field(c, rnd)
    c.fields.remove(f)
    return f"field {f.name!r} deleted", False


def f_duplicate(c, rnd):
    f = _field(c, rnd)
    c.fields.append(Field(f.name, f.dtype, f.shape, f.data))
    return f"field {f.name!r} appears twice", False


def f_rename(c, rnd):
    f = _field(c, rnd)
    old = f.name
    f.name = rnd.choice([old.upper(), old + " ", old[:-1], "", old + "\0", "x" * 300])
    return f"field {old!r} renamed to {f.name[:40]!r}", False


def f_dtype(c, rnd):
    f = _field(c, rnd)
    old = f.dtype
    how = rnd.choice(["relabel", "convert"])
    new = rnd.choice([d for d in list(DTYPES) + [0, 12, 255] if d != old])
    if how == "convert" and new in DTYPES and old in DTYPES:
        a = f.array().astype(np.float64)
        info = np.iinfo(DTYPES[new]) if np.dtype(DTYPES[new]).kind in "iu" else None
        if info is not None:
            a = np.clip(np.nan_to_num(a), info.min, info.max)
        f.data = a.astype(DTYPES[new]).tobytes()
        f.dtype = new
        return f"field {f.name!r}: converted from dtype {old} to {new}", False
    f.dtype = new
    return f"field {f.name!r}: dtype code {old} relabelled {new} (bytes kept)", False


def f_shape(c, rnd):
    f = _field(c, rnd)
    old = list(f.shape)
    how = rnd.choice(["off by one (data resized)", "off by one (header only)", "rank +1",
                      "rank -1", "zero extent", "transposed", "huge extent (header only)",
                      "extents swapped with another field's", "2^63 extent", "overflowing product"])
    item = np.dtype(DTYPES.get(f.dtype, "<u1")).itemsize
    if how.startswith("off by one") and f.shape:
        k = rnd.randrange(len(f.shape))
        f.shape[k] = max(0, f.shape[k] + rnd.choice([-1, 1]))
        if "data resized" in how:
            n = int(np.prod(f.shape, dtype=np.uint64)) * item
            f.data = (f.data + b"\0" * n)[:n]
    elif how == "rank +1":
        f.shape = f.shape + [1] if rnd.random() < 0.5 else [1] + f.shape
    elif how == "rank -1" and f.shape:
        f.shape = f.shape[:-2] + [f.shape[-2] * f.shape[-1]] if len(f.shape) >= 2 else []
    elif how == "zero extent" and f.shape:
        f.shape[rnd.randrange(len(f.shape))] = 0
        f.data = b""
    elif how == "transposed":
        f.shape = f.shape[::-1]
    elif how.startswith("huge extent") and f.shape:
        f.shape[rnd.randrange(len(f.shape))] = rnd.choice([2**32, 2**31 - 1, 10**9])
    elif how.startswith("extents swapped"):
        other = _field(c, rnd)
        f.shape, other.shape = other.shape, f.shape
    elif how == "2^63 extent" and f.shape:
        f.shape[0] = 2**63
    elif how == "overflowing product":
        f.shape = [2**32, 2**32, 2] + f.shape[3:]
    else:
        raise ValueError("no shape")
    return f"field {f.name!r}: shape {old} -> {f.shape} ({how})", False


def f_values(c, rnd):
    f = _field(c, rnd, numeric=True)
    a = f.array().astype(np.float64)
    if a.size == 0:
        raise ValueError
    label, v = rnd.choice([("NaN", np.nan), ("+inf", np.inf), ("-inf", -np.inf), ("0", 0.0),
                           ("negative", -1.0), ("3e38", 3e38), ("1e-45", 1e-45),
                           ("reversed order", None), ("all equal", "eq")])
    where = rnd.choice(["every element", "one element"])
    if v is None:
        a = a[::-1].copy()
        where = "whole field"
    elif v == "eq":
        a[:] = a[0]
        where = "whole field"
    elif where == "every element":
        a[:] = v
    else:
        a[rnd.randrange(a.size)] = v
    with np.errstate(over="ignore", invalid="ignore"):
        f.data = a.astype(DTYPES[f.dtype]).tobytes()
    return f"field {f.name!r}: {label} in {where}", False


def f_scalar_field(c, rnd):
    name = rnd.choice(["jacobian", "description"])
    f = next((x for x in c.fields if x.name == name), None)
    if f is None:
        raise ValueError
    how = rnd.choice(["value 2", "value 255", "empty", "10 MB", "non-UTF-8"])
    if name == "jacobian":
        if how == "empty":
            f.shape, f.data = [0], b""
        elif how == "10 MB":
            f.shape, f.data = [10 * 1024 * 1024], b"\1" * (10 * 1024 * 1024)
        else:
            f.data = bytes([2 if how == "value 2" else 255]) + f.data[1:]
    else:
        data = {"empty": b"", "10 MB": b"d" * (10 * 1024 * 1024), "non-UTF-8": b"\xff\xfe\0x"}.get(
            how, b"\2")
        f.shape, f.data = [len(data)], data
    return f"field {name!r}: {how}", False


def c_header(c, rnd):
    how = rnd.choice(["field count +1", "field count 0", "field count 2^32-1", "version 2.0",
                      "version 1.1", "offset past the end", "offset 0 (into the header)",
                      "name length past the end", "rank 65535",
                      "trailing garbage", "truncated data"])
    f = _field(c, rnd)
    if how == "field count +1":
        c.count_override = len(c.fields) + 1
    elif how == "field count 0":
        c.count_override = 0
    elif how == "field count 2^32-1":
        c.count_override = 2**32 - 1
    elif how == "version 2.0":
        c.version = (2, 0)
    elif how == "version 1.1":
        c.version = (1, 1)
    elif how == "offset past the end":
        f.offset_override = 2**62
    elif how.startswith("offset 0"):
        f.offset_override = 0
    elif how == "name length past the end":
        f.name_length_override = 65535
    elif how == "rank 65535":
        f.rank_override = 65535
    elif how == "trailing garbage":
        c.tail = b"\xde\xad\xbe\xef" * 1000
        return "4000 bytes of garbage after the last field", True
    else:
        c.tail = b""
        c.fields[-1].data = c.fields[-1].data[: len(c.fields[-1].data) // 2]
        return f"the last field {c.fields[-1].name!r} cut to half its bytes (header unchanged)", False
    return f"container: {how}" + (f" (field {f.name!r})" if "offset" in how or "name" in how
                                   or "rank" in how else ""), False


def f_extra(c, rnd):
    how = rnd.choice(["unknown float32 field", "unknown field of rank 0", "100 unknown fields",
                      "unknown field named ''"])
    if how == "unknown float32 field":
        c.fields.append(Field("zz_extra", 10, [4], np.arange(4, dtype="<f4").tobytes()))
    elif how == "unknown field of rank 0":
        c.fields.append(Field("zz_scalar", 10, [], np.float32(1).tobytes()))
    elif how == "100 unknown fields":
        for i in range(100):
            c.fields.append(Field(f"zz_{i}", 1, [1], b"\1"))
    else:
        c.fields.append(Field("", 1, [1], b"\1"))
    return f"extra: {how}", True


OPS = [(f_delete, 1), (f_duplicate, 0.7), (f_rename, 0.7), (f_dtype, 2), (f_shape, 3),
       (f_values, 3), (f_scalar_field, 1), (c_header, 1.5), (f_extra, 0.5)]


def mutate(path, rnd: random.Random, count):
    with open(path, "rb") as fh:
        c = Container(fh.read())
    done, tries = [], 0
    while len(done) < count and tries < 30:
        tries += 1
        op = weighted(rnd, OPS)
        try:
            desc, variant = op(c, rnd)
        except (ValueError, IndexError, StopIteration):
            continue
        done.append((desc, variant, op.__name__))
    with open(path, "wb") as fh:
        fh.write(c.render())
    return path, done
