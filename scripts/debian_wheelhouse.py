#!/usr/bin/python3
"""Wheels of Debian's installed Python packages, for a venv that cannot reach PyPI.

CI and this machine are offline (no PyPI), so a fresh venv cannot download numpy, h5py or pytest;
a user's pip simply gets them from PyPI. This script zips the files Debian installed for
/usr/bin/python3 (/usr/lib/python3/dist-packages) into wheels, with their dependencies (a
requirement whose marker holds for Debian's interpreter is followed when that distribution is
installed; extras are not), so that `pip install --no-index --find-links WHEELHOUSE ...` works in
a venv made from /usr/bin/python3, whose ABI Debian's compiled numpy and h5py were built for.

Usage: /usr/bin/python3 scripts/debian_wheelhouse.py WHEELHOUSE numpy h5py pytest
"""

import base64
import csv
import hashlib
import importlib.metadata
import io
import pathlib
import re
import sys
import sysconfig
import zipfile

SITE = pathlib.Path("/usr/lib/python3/dist-packages")
# Debian installs h5py under a distribution name of its own (a serial and an MPI flavour).
DEBIAN_NAMES = {"h5py": "h5py._debian_h5py_serial"}
# Requirements Debian's metadata leaves out (its requires.txt is empty; these are the package's
# Depends in Python names): matplotlib runs examples/huang_fit.py, which the pytest suite runs.
DEBIAN_REQUIREMENTS = {
    "matplotlib": ["contourpy", "cycler", "fonttools", "kiwisolver", "numpy", "packaging",
                   "Pillow", "pyparsing", "python-dateutil"],
    "python-dateutil": ["six"],
}
ZIP_TIME = (1980, 1, 1, 0, 0, 0)


def normalized(name: str) -> str:
    return re.sub(r"[-_.]+", "_", name).lower()


def distribution(name: str):
    """Debian's installed distribution NAME, or None when it is not installed there."""
    for found in importlib.metadata.distributions(path=[str(SITE)],
                                                  name=DEBIAN_NAMES.get(name, name)):
        return found
    return None


def requirements(name: str, dist) -> list[str]:
    return dist.requires or DEBIAN_REQUIREMENTS.get(name, [])


def requirement_names(name: str, dist) -> list[str]:
    """Names of the requirements that apply to Debian's interpreter (extras left out)."""
    names = []
    for requirement in requirements(name, dist):
        spec, _, marker = requirement.partition(";")
        if "extra" in marker:
            continue
        if marker.strip() and not marker_holds(marker):
            continue
        names.append(re.match(r"\s*([A-Za-z0-9_.-]+)", spec).group(1))
    return names


def marker_holds(marker: str) -> bool:
    """The markers Debian's packages use: python_version, sys_platform and the implementation."""
    values = {"python_version": f"{sys.version_info.major}.{sys.version_info.minor}",
              "sys_platform": sys.platform,
              "platform_python_implementation": "CPython",
              "implementation_name": sys.implementation.name}

    def compare(match):
        left, op, right = match.group(1), match.group(2), match.group(3)
        left, right = values[left], right
        if left.replace(".", "").isdigit() and right.replace(".", "").isdigit():
            left, right = tuple(map(int, left.split("."))), tuple(map(int, right.split(".")))
        return str({"==": left == right, "!=": left != right, "<": left < right,
                    "<=": left <= right, ">": left > right, ">=": left >= right}[op])

    expression = re.sub(r'(\w+)\s*(==|!=|<=|>=|<|>)\s*["\']([^"\']*)["\']', compare, marker)
    if not re.fullmatch(r"[\s()]*(True|False)([\s()]+(and|or)[\s()]+(True|False))*[\s()]*",
                        expression):
        raise SystemExit(f"debian_wheelhouse: cannot evaluate the marker {marker.strip()!r}")
    return eval(expression, {"__builtins__": {}})  # only True/False/and/or/() are left


def top_level_paths(dist) -> list[pathlib.Path]:
    """The package folders and modules the distribution installed, from its top-level names."""
    names = (dist.read_text("top_level.txt") or "").split()
    if not names:  # a dist-info without top_level.txt: the first parts of its RECORD paths
        names = sorted({pathlib.PurePath(str(f)).parts[0] for f in dist.files or []
                        if not str(f).startswith((".", "..")) and ".dist-info" not in str(f)})
    paths = []
    for name in names:
        paths += [SITE / name] if (SITE / name).is_dir() else sorted(SITE.glob(f"{name}.*"))
    return [p for p in paths if not p.name.endswith((".dist-info", ".egg-info"))]


def metadata_text(name: str, dist) -> str:
    """Debian's version and requirements under the name pip asks for (the rest is left out)."""
    lines = ["Metadata-Version: 2.1", f"Name: {name}", f"Version: {dist.version}"]
    for key in ("Summary", "Requires-Python"):
        if dist.metadata.get(key):
            lines.append(f"{key}: {dist.metadata[key]}")
    lines += [f"Requires-Dist: {requirement}" for requirement in requirements(name, dist)]
    return "\n".join(lines) + "\n"


def make_wheel(name: str, dist, wheelhouse: pathlib.Path) -> pathlib.Path:
    files = []
    for top in top_level_paths(dist):
        files += [top] if top.is_file() else sorted(p for p in top.rglob("*") if p.is_file())
    files = [f for f in files if "__pycache__" not in f.parts]
    if not files:
        raise SystemExit(f"debian_wheelhouse: no files of {name} under {SITE}")
    compiled = any(f.name.endswith(".so") for f in files)
    python = f"cp{sys.version_info.major}{sys.version_info.minor}"
    platform = re.sub(r"[^A-Za-z0-9]", "_", sysconfig.get_platform())
    tag = f"{python}-{python}-{platform}" if compiled else "py3-none-any"
    version = dist.version
    dist_info = f"{normalized(name)}-{version}.dist-info"
    wheel_text = (f"Wheel-Version: 1.0\nGenerator: debian_wheelhouse\n"
                  f"Root-Is-Purelib: {str(not compiled).lower()}\nTag: {tag}\n")
    target = wheelhouse / f"{normalized(name)}-{version}-{tag}.whl"
    record = io.StringIO()
    writer = csv.writer(record, lineterminator="\n")
    # Stored, not deflated: these wheels live for one test and numpy's is large.
    with zipfile.ZipFile(target, "w", compression=zipfile.ZIP_STORED) as wheel:
        def add(arcname: str, data: bytes) -> None:
            info = zipfile.ZipInfo(arcname, ZIP_TIME)
            info.external_attr = (0o100644 if not arcname.endswith(".so") else 0o100755) << 16
            wheel.writestr(info, data)
            digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=")
            writer.writerow([arcname, f"sha256={digest.decode()}", len(data)])

        for path in files:
            add(path.relative_to(SITE).as_posix(), path.read_bytes())
        add(f"{dist_info}/METADATA", metadata_text(name, dist).encode())
        add(f"{dist_info}/WHEEL", wheel_text.encode())
        writer.writerow([f"{dist_info}/RECORD", "", ""])
        wheel.writestr(zipfile.ZipInfo(f"{dist_info}/RECORD", ZIP_TIME), record.getvalue())
    return target


def main(arguments: list[str]) -> None:
    if len(arguments) < 2:
        raise SystemExit(__doc__)
    wheelhouse = pathlib.Path(arguments[0])
    wheelhouse.mkdir(parents=True, exist_ok=True)
    pending, done = list(arguments[1:]), set()
    while pending:
        name = pending.pop()
        if normalized(name) in done:
            continue
        done.add(normalized(name))
        dist = distribution(name)
        if dist is None:
            if name in arguments[1:]:
                raise SystemExit(f"debian_wheelhouse: {name} is not installed in {SITE} "
                                 f"(Debian: apt-get install python3-{name})")
            print(f"debian_wheelhouse: {name} not installed, left out", file=sys.stderr)
            continue
        print(f"debian_wheelhouse: {make_wheel(name, dist, wheelhouse).name}", file=sys.stderr)
        pending += requirement_names(name, dist)


if __name__ == "__main__":
    main(sys.argv[1:])
