"""plumage.run_study: a study from a file or a dict, as `plumage run` runs it."""

import os
import pathlib
import signal
import subprocess
import sys
import time
import tomllib

import h5py
import numpy as np
import pytest

import plumage
from conftest import SOURCE_DIR, run_study as run_binary


def calibration_dict(name: str) -> dict:
    with open(SOURCE_DIR / "studies/calibration.toml", "rb") as handle:
        study = tomllib.load(handle)
    study["name"] = name
    return study


def datasets(path: pathlib.Path) -> dict:
    """Every numeric dataset of a record but provenance and convergence (their wall times
    differ between runs)."""
    found = {}
    with h5py.File(path, "r") as f:
        def visit(name, node):
            if isinstance(node, h5py.Dataset) and "provenance" not in name and \
                    "convergence" not in name and node.dtype.kind in "fiu":
                found[name] = node[()]
        f.visititems(visit)
    return found


def test_dict_study_equals_the_command_line(tmp_path):
    """The same keys as a dict (with numpy values) and as a file through the binary: the same
    records to the bit."""
    study = calibration_dict("from_dict")
    study["standard"]["albedo"] = np.float64(study["standard"]["albedo"])
    summary = plumage.run_study(study, out=tmp_path, threads=2, plots=False)
    assert "agrees" in summary
    text = (SOURCE_DIR / "studies/calibration.toml").read_text().replace(
        'name = "calibration"', 'name = "from_binary"')
    run_binary(text, tmp_path, "from_binary")
    python_values = datasets(tmp_path / "from_dict/brdf.h5")
    binary_values = datasets(tmp_path / "from_binary/brdf.h5")
    assert python_values.keys() == binary_values.keys() and "brdf/value" in python_values
    for name, values in python_values.items():
        np.testing.assert_array_equal(values, binary_values[name], err_msg=name)


def test_toml_of_a_dict_round_trips():
    study = {"study": "x", "a": 1.5e-7, "b": [1, 2.5], "s": 'q"uote', "t": {"u": True, "v": {"w": -3}},
             "inf": float("inf")}
    assert tomllib.loads(plumage.studies.to_toml(study)) == study


def test_bad_values_name_the_key_before_any_work(tmp_path):
    study = calibration_dict("bad")
    study["goniometer"]["passes"] = -1
    with pytest.raises(ValueError, match=r"<dict>: goniometer\.passes = -1: expected an integer"):
        plumage.run_study(study, out=tmp_path, plots=False)
    study["goniometer"]["passes"] = 4
    study["goniometer"]["pases"] = 4
    with pytest.raises(ValueError, match=r"unknown key 'goniometer\.pases'"):
        plumage.run_study(study, out=tmp_path, plots=False)
    with pytest.raises(ValueError, match="threads"):
        plumage.run_study(calibration_dict("t"), out=tmp_path, threads=0)
    with pytest.raises(TypeError, match="set cannot go into a study"):
        plumage.run_study({"study": "calibration", "name": "c", "x": {1, 2}}, out=tmp_path)
    assert list(tmp_path.iterdir()) == []
    assert "calibration" in plumage.study_kinds()


def test_a_study_file_that_is_not_utf8_is_named_with_its_line(tmp_path):
    study = tmp_path / "latin1.toml"
    study.write_bytes(b'study = "calibration"\nname = "caf\xe9"\n')
    with pytest.raises(ValueError, match=r"latin1\.toml:2: byte 0xe9 is not UTF-8"):
        plumage.run_study(study, out=tmp_path / "results", plots=False)
    assert not (tmp_path / "results").exists()


def test_ctrl_c_raises_keyboard_interrupt_and_leaves_nothing_half_written(tmp_path):
    """SIGINT while a study runs in C++: KeyboardInterrupt within seconds, no results folder and
    no staging folder left."""
    script = (
        "import plumage, tomllib\n"
        f"study = tomllib.load(open({str(SOURCE_DIR / 'studies/rock_dove_quick.toml')!r}, 'rb'))\n"
        "print('started', flush=True)\n"
        f"plumage.run_study(study, out={str(tmp_path)!r}, threads=2, plots=False)\n")
    process = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=os.environ.copy())
    assert process.stdout.readline().strip() == "started"
    time.sleep(2.0)
    sent = time.monotonic()
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    stopped_after = time.monotonic() - sent
    assert process.returncode != 0
    assert "KeyboardInterrupt" in stderr, stderr
    assert stopped_after < 10.0, f"{stopped_after:.1f} s to stop"
    left = [p.name for p in tmp_path.iterdir()]
    assert "rock_dove_quick" not in left and not any(".partial-" in n for n in left), left


def test_geometry_from_a_dict_equals_the_file(tmp_path):
    """plumage.build_geometry on the rock-dove row as a dict and as its file: the same meshes."""
    path = SOURCE_DIR / "studies/geometry/rock_dove_row.toml"
    with open(path, "rb") as handle:
        geometry = tomllib.load(handle)
    geometry["name"] = "from_dict"
    geometry["geometry"]["row"]["barbules"] = 2  # small and quick
    built = plumage.build_geometry(geometry, out=tmp_path, threads=2, plots=False)
    assert built["kind"] == "barbule_row" and built["triangles"] > 0
    text = path.read_text().replace("barbules = 8", "barbules = 2")
    (tmp_path / "from_file.toml").write_text(text)
    from_file = plumage.build_geometry(tmp_path / "from_file.toml", out=tmp_path, plots=False)
    assert from_file["triangles"] == built["triangles"]
    meshes = sorted(p.name for p in (tmp_path / "from_dict").glob("*.ply"))
    assert meshes
    for mesh in meshes:
        assert (tmp_path / "from_dict" / mesh).read_bytes() == \
            (tmp_path / "from_file" / mesh).read_bytes(), mesh
    geometry["geometry"]["row"]["H"] = -1
    with pytest.raises(ValueError, match=r"<dict>: geometry\.row\.H = -1"):
        plumage.build_geometry(geometry, out=tmp_path, plots=False)
    del geometry["name"]
    with pytest.raises(ValueError, match="needs a name"):
        plumage.build_geometry(geometry, out=tmp_path, plots=False)


def spongy_spheres_dict(name: str, route: str) -> dict:
    """The quick spongy study on one small packing of air spheres (f = 0.7, a = 0.08 µm, φ = 0.3),
    fewer paths, one angle, with medium.route = `route`."""
    with open(SOURCE_DIR / "studies/spongy_quick.toml", "rb") as handle:
        study = tomllib.load(handle)
    study["name"] = name
    volume = study["volume"]
    del volume["length_scales_um"], volume["shell_relative_width"]
    volume.update(morphology="spheres", keratin_fractions="0.7", sphere_radii_um="0.08")
    study["slab"]["paths_per_wavelength"] = 1000
    study["angles"].update(incidence_deg="30", paths_per_wavelength=500)
    study["baseline"]["paths_per_wavelength"] = 200
    study["medium"] = {"route": route}
    return study


def test_spongy_medium_route_from_a_dict(tmp_path):
    """The spongy study's medium.route through a dict: a route the volume cannot take is refused
    before any work, naming the key and the limit; the sphere route runs on a packing, with first
    Born beside it in the record."""
    channel = spongy_spheres_dict("refused", "sphere")
    channel["volume"] = {"box_um": 1.6, "voxel_um": 0.025}
    with pytest.raises(ValueError, match=r'medium\.route = "sphere" refused: volume\.morphology = '
                                         r'"channel": a channel network is not a sphere packing'):
        plumage.run_study(channel, out=tmp_path, plots=False)
    poly = spongy_spheres_dict("refused", "sphere")
    poly["medium"]["polydispersity"] = 0.1
    with pytest.raises(ValueError, match=r"medium\.polydispersity = 0\.1: the sphere route "
                                         r"accepts 0 only"):
        plumage.run_study(poly, out=tmp_path, plots=False)
    assert not (tmp_path / "refused").exists()
    plumage.run_study(spongy_spheres_dict("spheres", "sphere"), out=tmp_path, threads=2,
                      plots=False)
    with h5py.File(tmp_path / "spheres" / "spongy.h5", "r") as f:
        assert f.attrs["medium_route"] == "sphere"
        assert f["other_route"].attrs["route"] == "born"
        sphere, born = f["mu_s_per_um"][()], f["other_route/mu_s_per_um"][()]
        phi = f["sphere_fraction"][()].item()
    # μ_s(Born) / μ_s(sphere) near 1/(1 − φ)² (sim/wave/volume/born_medium.h; tolerance as the C++
    # test SpherePackingReportCarriesBothRoutes: the O(Δn) terms at keratin contrast).
    ratio = born[0, 0, born.shape[2] // 2] / sphere[0, 0, sphere.shape[2] // 2]
    assert ratio == pytest.approx(1.0 / (1.0 - phi) ** 2, rel=0.25)
