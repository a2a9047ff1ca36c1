"""The PEP 517 build backend of `pip install .` (pyproject.toml): standard library only.

Plumage is built offline from Debian packages, and pip may not reach PyPI, so the backend needs no
build requirements: it configures CMake for the interpreter running it, builds only the target
plumage_python (ccache reuses the objects of the main build), installs the CMake component
plumage_wheel (the package with our shared libraries in plumage/lib, python/CMakeLists.txt) into a
staging folder and zips that into a wheel for this interpreter and platform.

The CMake build folder is <source>/build-python-<tag>-<hash> (e.g. build-python-cp311-1a2b3c4d):
one per base interpreter (its tag and the hash of its path), so every venv made from one
interpreter reuses one build, and it sits beside build/ at the same depth, which ccache needs to
share objects (CCACHE_BASEDIR makes paths relative to the build folder). `pip install .
--config-settings build-dir=DIR` or PLUMAGE_PYTHON_BUILD_DIR choose another; PLUMAGE_JOBS the
number of compile jobs (2).
"""

import base64
import csv
import fcntl
import hashlib
import io
import os
import pathlib
import re
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import tempfile
import time
import zipfile

SOURCE_DIR = pathlib.Path(__file__).resolve().parents[2]
# Files of a wheel carry one fixed time, so two builds of the same tree are the same bytes.
ZIP_TIME = (1980, 1, 1, 0, 0, 0)


class BuildError(RuntimeError):
    """A build that cannot go on; the message says what was expected."""


def _project() -> dict:
    import tomllib  # Python 3.11+, as pyproject.toml's requires-python says

    path = SOURCE_DIR / "pyproject.toml"
    with open(path, "rb") as handle:
        project = tomllib.load(handle).get("project")
    if not isinstance(project, dict) or "name" not in project:
        raise BuildError(f"{path}: expected a [project] table with a name")
    project = dict(project, version=_version())
    return project


def _version() -> str:
    """The version of CMakeLists.txt's project() call: one place for the binary and the wheel."""
    path = SOURCE_DIR / "CMakeLists.txt"
    match = re.search(r"project\(\s*\w+\s+VERSION\s+([0-9][0-9.]*)", path.read_text())
    if not match:
        raise BuildError(f"{path}: expected project(<name> VERSION x.y.z ...)")
    return match.group(1)


def _tags() -> tuple[str, str, str]:
    """(python, abi, platform) wheel tags of this interpreter, e.g. cp311, cp311, linux_x86_64."""
    if sys.implementation.name != "cpython":
        raise BuildError(f"the plumage module is built for CPython, not {sys.implementation.name}")
    python = f"cp{sys.version_info.major}{sys.version_info.minor}"
    platform = re.sub(r"[^A-Za-z0-9]", "_", sysconfig.get_platform())
    return python, python + sys.abiflags, platform


def _base_interpreter() -> pathlib.Path:
    """The interpreter a venv was made from (the venv's own python when there is none).

    CMake builds against it rather than against the venv's python: the headers and the extension
    suffix are the same, and its path outlives the venv (a test's venv is deleted after the test,
    which would leave the build folder's cache pointing at nothing)."""
    return pathlib.Path(getattr(sys, "_base_executable", None) or sys.executable).resolve()


def _build_dir(config_settings) -> pathlib.Path:
    chosen = (config_settings or {}).get("build-dir") or os.environ.get("PLUMAGE_PYTHON_BUILD_DIR")
    if chosen:
        return pathlib.Path(chosen).resolve()
    digest = hashlib.sha256(str(_base_interpreter()).encode()).hexdigest()[:8]
    return SOURCE_DIR / f"build-python-{_tags()[0]}-{digest}"


def _run(command: list, env: dict) -> None:
    print("plumage build backend:", " ".join(str(part) for part in command), file=sys.stderr,
          flush=True)
    # Output to stderr: pip reads the hooks' results, not their output, but shows it with -v.
    result = subprocess.run([str(part) for part in command], env=env, stdout=sys.stderr)
    if result.returncode != 0:
        raise BuildError(f"{command[0]} {command[1]} failed (exit {result.returncode}); its "
                         "output is above (pip install -v shows it)")


def _cached_interpreter(build: pathlib.Path) -> str:
    cache = build / "CMakeCache.txt"
    if not cache.exists():
        return ""
    match = re.search(r"^Python_EXECUTABLE:[A-Z]+=(.*)$", cache.read_text(), re.MULTILINE)
    return match.group(1) if match else ""


def _cmake_build(build: pathlib.Path, staging: pathlib.Path) -> None:
    """Configures (first time, or for another interpreter), builds and stages the package."""
    if shutil.which("cmake") is None:
        raise BuildError("cmake not found on PATH (Debian: scripts/install-deps.sh installs it)")
    env = dict(os.environ)
    # As scripts/build.sh: paths relative to the checkout, so ccache reuses the main build's
    # objects.
    env.setdefault("CCACHE_BASEDIR", str(SOURCE_DIR))
    env.setdefault("CCACHE_NOHASHDIR", "true")
    interpreter = str(_base_interpreter())
    if _cached_interpreter(build) != interpreter:
        generator = ["-G", "Ninja"] if shutil.which("ninja") else []
        _run(["cmake", "-S", SOURCE_DIR, "-B", build, *generator, "-DCMAKE_BUILD_TYPE=Release",
              f"-DPython_EXECUTABLE={interpreter}", "-DPLUMAGE_PYTHON_WHEEL=ON",
              "-DPLUMAGE_BUILD_TESTS=OFF", "-DPLUMAGE_BUILD_BENCHMARKS=OFF"], env)
    _run(["cmake", "--build", build, "--parallel", env.get("PLUMAGE_JOBS", "2"), "--target",
          "plumage_python"], env)
    _run(["cmake", "--install", build, "--component", "plumage_wheel", "--prefix", staging], env)
    _check_staged(staging / "plumage", build)


def _check_staged(package: pathlib.Path, build: pathlib.Path) -> None:
    """The extension carries this interpreter's suffix and loads nothing from the build folder."""
    core = package / ("_core" + sysconfig.get_config_var("EXT_SUFFIX"))
    if not core.exists():
        found = sorted(path.name for path in package.glob("_core*"))
        raise BuildError(f"expected {core.name} in the staged package, found {found}")
    if shutil.which("ldd") is None:
        return
    env = {key: value for key, value in os.environ.items() if key != "LD_LIBRARY_PATH"}
    listing = subprocess.run(["ldd", str(core)], env=env, capture_output=True, text=True).stdout
    bad = [line.strip() for line in listing.splitlines()
           if "not found" in line or str(build) in line]
    if bad:
        raise BuildError(f"{core.name} would not load from the installed package: {bad}")


def _metadata(project: dict) -> str:
    lines = ["Metadata-Version: 2.1", f"Name: {project['name']}", f"Version: {project['version']}"]
    if "description" in project:
        lines.append(f"Summary: {project['description']}")
    if "requires-python" in project:
        lines.append(f"Requires-Python: {project['requires-python']}")
    license_text = project.get("license", {})
    if "text" in license_text:
        lines.append(f"License: {license_text['text']}")
    lines += [f"Requires-Dist: {requirement}" for requirement in project.get("dependencies", [])]
    for extra, requirements in project.get("optional-dependencies", {}).items():
        lines.append(f"Provides-Extra: {extra}")
        lines += [f'Requires-Dist: {requirement}; extra == "{extra}"'
                  for requirement in requirements]
    for label, url in project.get("urls", {}).items():
        lines.append(f"Project-URL: {label}, {url}")
    return "\n".join(lines) + "\n"


def _dist_info_files(project: dict, tag: str) -> dict:
    """The .dist-info files but RECORD, by name."""
    wheel = ("Wheel-Version: 1.0\nGenerator: plumage_build_backend\nRoot-Is-Purelib: false\n"
             f"Tag: {tag}\n")
    files = {"METADATA": _metadata(project).encode(), "WHEEL": wheel.encode()}
    license_file = SOURCE_DIR / "LICENSE"
    if license_file.exists():
        files["LICENSE"] = license_file.read_bytes()
    return files


def _dist_info_name(project: dict) -> str:
    return f"{_normalized(project['name'])}-{project['version']}.dist-info"


def _normalized(name: str) -> str:
    return re.sub(r"[-_.]+", "_", name).lower()


def _record_line(path: str, data: bytes) -> list:
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return [path, f"sha256={digest}", str(len(data))]


def _write_wheel(target: pathlib.Path, package: pathlib.Path, project: dict, tag: str) -> None:
    dist_info = _dist_info_name(project)
    record = io.StringIO()
    writer = csv.writer(record, lineterminator="\n")
    with zipfile.ZipFile(target, "w", compression=zipfile.ZIP_DEFLATED) as wheel:
        def add(name: str, data: bytes, mode: int = 0o644) -> None:
            info = zipfile.ZipInfo(name, ZIP_TIME)
            info.external_attr = (0o100000 | mode) << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            wheel.writestr(info, data)
            writer.writerow(_record_line(name, data))

        for path in sorted(package.rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                mode = 0o755 if os.access(path, os.X_OK) else 0o644
                add(path.relative_to(package.parent).as_posix(), path.read_bytes(), mode)
        for name, data in _dist_info_files(project, tag).items():
            add(f"{dist_info}/{name}", data)
        writer.writerow([f"{dist_info}/RECORD", "", ""])
        info = zipfile.ZipInfo(f"{dist_info}/RECORD", ZIP_TIME)
        info.external_attr = (0o100000 | 0o644) << 16
        wheel.writestr(info, record.getvalue(), compress_type=zipfile.ZIP_DEFLATED)


# The PEP 517 hooks.

def get_requires_for_build_wheel(config_settings=None):
    return []  # nothing from PyPI: CMake, the compiler and pybind11 come from Debian


def get_requires_for_build_sdist(config_settings=None):
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    """Metadata without a build, so pip resolves numpy and h5py before compiling anything."""
    project = _project()
    python, abi, platform = _tags()
    dist_info = pathlib.Path(metadata_directory) / _dist_info_name(project)
    dist_info.mkdir(parents=True, exist_ok=True)
    for name, data in _dist_info_files(project, f"{python}-{abi}-{platform}").items():
        (dist_info / name).write_bytes(data)
    return dist_info.name


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    project = _project()
    python, abi, platform = _tags()
    tag = f"{python}-{abi}-{platform}"
    build = _build_dir(config_settings)
    build.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    # One build at a time per folder: two pip runs in one ninja tree would spoil each other.
    with open(build / ".plumage-wheel.lock", "w") as lock, tempfile.TemporaryDirectory() as staging:
        fcntl.flock(lock, fcntl.LOCK_EX)
        _cmake_build(build, pathlib.Path(staging))
        name = f"{_normalized(project['name'])}-{project['version']}-{tag}.whl"
        _write_wheel(pathlib.Path(wheel_directory) / name, pathlib.Path(staging) / "plumage",
                     project, tag)
    print(f"plumage build backend: {name} from {build} in {time.monotonic() - started:.0f} s",
          file=sys.stderr)
    return name


def build_sdist(sdist_directory, config_settings=None):
    """The files git tracks (the whole C++ project: the module links most of it) and PKG-INFO."""
    project = _project()
    if not (SOURCE_DIR / ".git").exists() or shutil.which("git") is None:
        raise BuildError(f"an sdist is made from a git checkout (the tracked files); {SOURCE_DIR} "
                         "is none, or git is not installed")
    listed = subprocess.run(["git", "-C", str(SOURCE_DIR), "ls-files", "-z"], check=True,
                            capture_output=True).stdout.decode().split("\0")
    base = f"{_normalized(project['name'])}-{project['version']}"
    name = f"{base}.tar.gz"
    target = pathlib.Path(sdist_directory) / name
    with tarfile.open(target, "w:gz", format=tarfile.PAX_FORMAT) as tar:
        for path in sorted(filter(None, listed)):
            if (SOURCE_DIR / path).is_file():
                tar.add(SOURCE_DIR / path, arcname=f"{base}/{path}", recursive=False)
        pkg_info = _metadata(project).encode()
        info = tarfile.TarInfo(f"{base}/PKG-INFO")
        info.size, info.mode, info.mtime = len(pkg_info), 0o644, 315532800
        tar.addfile(info, io.BytesIO(pkg_info))
    return name
