"""Studies from Python: `plumage run` and `plumage geometry` on a file or on a dict of its keys.

    import plumage
    summary = plumage.run_study("studies/rock_dove_quick.toml", out="results")
    study = tomllib.load(open("studies/ablation_quick.toml", "rb"))
    study["name"] = "my_ablation"
    plumage.run_study(study, out="results", threads=2, plots=False)
    rec = plumage.read_record("results/my_ablation/...h5")
    plumage.build_geometry({"name": "row", "geometry": {"kind": "barbule_row"}}, out="results")
    spongy = tomllib.load(open("studies/spongy_quick.toml", "rb"))
    spongy["volume"] |= {"morphology": "spheres", "keratin_fractions": "0.7",
                         "sphere_radii_um": "0.08"}     # air spheres in keratin, phi = 0.3
    del spongy["volume"]["length_scales_um"], spongy["volume"]["shell_relative_width"]
    spongy["medium"] = {"route": "sphere"}  # Mie x S(q); "born" (the default) on any volume
    plumage.run_study(spongy, out="results")  # both routes side by side in its report

A dict is written as TOML and read by the same parser as a file, so every key, range and
cross-key rule is checked the same way and a bad value raises ValueError naming its full key and
what was expected ("<dict>: geometry.row.H = -1: expected a number > 0 ..."). Paths inside a
dict (a mesh, a reference folder) are relative to `base_dir` (default: the working directory),
as a file's are relative to the file. The study runs in C++ without the GIL, on `threads` threads
(default: all cores), writing its progress to stderr; Ctrl-C stops it at its next check (its
staging folder removed, finished passes kept in checkpoints, so the same call resumes) and
raises KeyboardInterrupt. Results, records and report are those of the command line, bit for bit.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Mapping
from typing import Any

from . import _core

__all__ = ["run_study", "build_geometry", "study_kinds", "to_toml"]

_DICT_SOURCE = "<dict>"
_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def study_kinds() -> list[str]:
    """The values the `study` key may take (studies/README.md describes each)."""
    return list(_core.study_kinds())


def _key(name: Any, path: str) -> str:
    if not isinstance(name, str):
        raise TypeError(f"{path or 'study'}: keys must be strings, not {type(name).__name__}")
    return name if _BARE_KEY.match(name) else json.dumps(name)


def _value(value: Any, path: str) -> str:
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):  # numpy scalars, arrays
        value = value.tolist()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a valid TOML basic string
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v, f"{path}[{k}]") for k, v in enumerate(value)) + "]"
    if isinstance(value, Mapping):
        items = (f"{_key(k, path)} = {_value(v, f'{path}.{k}')}" for k, v in value.items())
        return "{ " + ", ".join(items) + " }"
    raise TypeError(f"{path}: a {type(value).__name__} cannot go into a study (expected a "
                    "number, bool, string, list or dict)")


def to_toml(study: Mapping[str, Any]) -> str:
    """The TOML text of a study dict: scalars and lists as `key = value`, dicts as tables."""
    lines: list[str] = []

    def table(node: Mapping[str, Any], path: str) -> None:
        tables = []
        if path:
            lines.append(f"\n[{path}]")
        for name, value in node.items():
            key = _key(name, path)
            if isinstance(value, Mapping):
                tables.append((f"{path}.{key}" if path else key, value))
            else:
                lines.append(f"{key} = {_value(value, f'{path}.{name}' if path else name)}")
        for sub_path, sub in tables:
            table(sub, sub_path)

    if not isinstance(study, Mapping):
        raise TypeError("study: expected a dict or a path to a study file")
    table(study, "")
    return "\n".join(lines).lstrip("\n") + "\n"


def _text_and_source(study, base_dir) -> tuple[str, str]:
    if isinstance(study, Mapping):
        if "name" not in study:
            raise ValueError(f"{_DICT_SOURCE}: name: a dict needs a name (its results folder)")
        folder = os.fspath(base_dir) if base_dir is not None else os.getcwd()
        return to_toml(study), os.path.join(folder, _DICT_SOURCE)
    path = os.fspath(study)
    with open(path, "rb") as handle:
        data = handle.read()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        # Python's message names neither the file nor the line.
        line = data.count(b"\n", 0, error.start) + 1
        raise ValueError(f"{path}:{line}: byte 0x{data[error.start]:02x} is not UTF-8: expected a "
                         "UTF-8 study file (TOML)") from None
    # As a text-mode read gives it (universal newlines).
    return text.replace("\r\n", "\n").replace("\r", "\n"), path


def _call(study, function, *arguments):
    try:
        return function(*arguments)
    except ValueError as error:
        if not isinstance(study, Mapping):
            raise
        # Lines and columns of the generated text mean nothing to the dict's owner: the message
        # keeps the full key, which is what names the value.
        message = re.sub(r"\S*" + re.escape(_DICT_SOURCE) + r"(:\d+)*", _DICT_SOURCE, str(error))
        raise ValueError(message) from None


def run_study(study: Mapping[str, Any] | str | os.PathLike, out: str | os.PathLike = "results",
              *, threads: int | None = None, time_budget_s: float | None = None,
              target_error: float | None = None, plots: bool = True,
              base_dir: str | os.PathLike | None = None) -> str:
    """Runs a study (a file or a dict of its keys) into out/<name>/; returns the summary line.

    threads, time_budget_s and target_error are the command line's --threads, --time-budget and
    --target-error; plots=False is --no-plots.
    """
    text, source = _text_and_source(study, base_dir)
    return _call(study, _core.run_study_text, text, source, os.fspath(out), threads,
                 float(time_budget_s or 0.0), float(target_error or 0.0), bool(plots))


def build_geometry(geometry: Mapping[str, Any] | str | os.PathLike,
                   out: str | os.PathLike = "results", *, threads: int | None = None,
                   plots: bool = True, base_dir: str | os.PathLike | None = None) -> dict:
    """`plumage geometry`: builds a geometry file's (or dict's) geometry into out/<name>/.

    Returns output_dir, kind, triangles, instances, memory_bytes and wall_seconds.
    """
    text, source = _text_and_source(geometry, base_dir)
    return _call(geometry, _core.build_geometry_text, text, source, os.fspath(out), threads,
                 bool(plots))
