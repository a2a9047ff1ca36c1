"""Seeds of the structure-aware fuzzer (fuzz/structure/fuzz_user_data.py): small, valid user data
in every layout `plumage fit` and `plumage.read_record` take (docs/user_data.md), with values from
the models themselves so that a fit of an unmutated seed converges in about a second.

    /usr/bin/python3 fuzz/structure/seeds.py --out DIR --plumage build/studies/plumage

Needs the `plumage` Python module of the same build (models, huang2022_scatterogram): the driver
runs this file in a subprocess with PYTHONPATH pointing at <build>/python, so the driver itself
never imports the compiled module.

Seeds written (the driver reads SEEDS below for their names and kinds):
  sc_beam.h5        imaging scatterometer, beam, 13 x 13 px, 2 wavelengths, the suite's layout
                    (units/description on every dataset, /image/directions, /convergence,
                    /provenance with the RECORD.md attribute types)
  sc_hemisphere.h5  hemisphere light, 11 x 11 px, 2 wavelengths
  sc_cone.h5        cone light (16 deg), 9 x 9 px (the smallest image), 1 wavelength (each pixel integrates the cone)
  sc_minimal.h5     the minimal user layout of docs/user_data.md only (beam, 11 px, 2 wavelengths)
  gonio.h5          goniometer, 30 pairs, 3 wavelengths, Filip 2024 parrot values
  brdf.csv          BRDF table, 30 pairs x 3 wavelengths, with sigma_per_sr
  brdf_rgb.csv      the same with a channel column (R, G, B) and without sigma_per_sr
  huang.bsdf        `plumage export-bsdf huang2022` on a 3 x 3 x 4^2 grid, 3 wavelengths
  filip_iso.bsdf    `plumage export-bsdf filip2024:parrot`, isotropic, 3 x 1 x 4^2
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

# name -> (format, kind): format "h5", "csv" or "bsdf"
SEEDS = {
    "sc_beam.h5": ("h5", "imaging_scatterometer"),
    "sc_hemisphere.h5": ("h5", "imaging_scatterometer"),
    "sc_cone.h5": ("h5", "imaging_scatterometer"),
    "sc_minimal.h5": ("h5", "imaging_scatterometer"),
    "gonio.h5": ("h5", "goniometer"),
    "brdf.csv": ("csv", "brdf"),
    "brdf_rgb.csv": ("csv", "brdf"),
    "huang.bsdf": ("bsdf", "huang2022"),
    "filip_iso.bsdf": ("bsdf", "filip2024"),
}

# Objects each reader of plumage reads (analysis/fits/user_data.cpp): the mutation sites the fuzzer
# picks more often (the rest are read by plumage.read_record only).
FIT_READS = {
    "imaging_scatterometer": ["/instrument", "/instrument@kind", "/instrument@illumination",
                              "/instrument@beam_direction", "/instrument@cone_aperture_deg",
                              "/wavelength_nm", "/image", "/image/intensity",
                              "/image/standard_error", "/image/solid_angle_sr"],
    "goniometer": ["/instrument", "/instrument@kind", "/instrument/light_directions",
                   "/instrument/view_directions", "/wavelength_nm", "/brdf", "/brdf/value",
                   "/brdf/standard_error"],
}


def pixel_geometry(n):
    """The azimuthal equidistant map of virtual_gonio/scatterometer.cpp: solid angles [n, n]
    (0 outside the disc) and pixel-centre directions [n, n, 3] (NaN outside)."""
    pixel = 2.0 / n
    col = (np.arange(n) + 0.5) * pixel - 1.0
    row = 1.0 - (np.arange(n) + 0.5) * pixel
    u, v = np.meshgrid(col, row)  # [row, column]
    r = np.hypot(u, v)
    inside = r <= 1.0
    with np.errstate(invalid="ignore", divide="ignore"):
        jac = np.where(r > 1e-12, 0.5 * np.pi * np.sin(0.5 * np.pi * r) / r, 0.25 * np.pi ** 2)
    omega = np.where(inside, jac * pixel * pixel, 0.0)
    theta, phi = 0.5 * np.pi * r, np.arctan2(v, u)
    d = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
    d[~inside] = np.nan
    return omega, d


def _string_attrs(node, **attrs):
    import h5py

    for k, v in attrs.items():
        if isinstance(v, str):
            node.attrs.create(k, v, dtype=h5py.string_dtype("utf-8"))
        else:
            node.attrs[k] = v


def _dataset(f, path, data, units, description):
    d = f.create_dataset(path, data=data)
    _string_attrs(d, units=units, description=description)
    return d


def _provenance(f, config):
    g = f.create_group("provenance")
    _string_attrs(g, scatterer="fuzz seed (fuzz/structure/seeds.py)", plumage_version="0.1.0",
                  git_commit="unknown", date="2026-11-27T00:00:00Z", host="fuzz",
                  compiler="GNU 12.2.0", embree_version="3.13.5", hdf5_version="1.10.8",
                  eigen_version="3.4.0", openvdb_version="10.0.1", cgal_version="5.5.1",
                  config=config)
    g.attrs["seed"] = np.uint64(12345678901234567890)
    g.attrs["threads"] = np.int64(1)
    g.attrs["wall_time_s"] = 1.5
    g.attrs["cpu_time_s"] = 1.4
    g.attrs["cpu_per_wall"] = 1.4 / 1.5


def _polarisation(g):
    _string_attrs(g, polarisation="unpolarised: fuzz seed")


def _convergence(f):
    c = _dataset(f, "convergence", np.array([[1, 0.5, 1000, 0.1], [2, 1.0, 2000, 0.07]], float),
                 "1, s, 1, 1 (per column)", "pass, wall time, quanta, relative error")
    _string_attrs(c, columns="pass, wall_time_s, quanta per wavelength, relative_error")


def scatterogram(path, illumination, n, wavelengths, beam=(0.0, -0.34, 0.94), cone_deg=16.0,
                 minimal=False, seed=1):
    import h5py

    from plumage import models

    omega, directions = pixel_geometry(n)
    wl = np.asarray(wavelengths, float)
    beam = np.asarray(beam, float) / np.linalg.norm(beam)
    geometry = dict(illumination=illumination, beam_direction=np.asarray(beam, float),
                    cone_aperture_rad=np.radians(cone_deg), wavelength_nm=wl,
                    intensity=np.zeros((n, n, wl.size)), standard_error=np.zeros((n, n, wl.size)),
                    solid_angle_sr=omega)
    image = np.asarray(models.huang2022_scatterogram(models.Huang2022().params, geometry), float)
    rng = np.random.default_rng(seed)
    sigma = 0.03 * image + 1e-4 * image.max()
    sigma[omega == 0.0] = 0.0
    value = np.where(omega[..., None] > 0, image + sigma * rng.standard_normal(image.shape), 0.0)
    value = np.maximum(value, 0.0)
    beam_text = "{:.9f} {:.9f} {:.9f}".format(*beam)
    with h5py.File(path, "w") as f:
        inst = f.create_group("instrument")
        _string_attrs(inst, kind="imaging_scatterometer", illumination=illumination)
        if illumination != "hemisphere" or not minimal:
            _string_attrs(inst, beam_direction=beam_text)
        if illumination == "cone":
            inst.attrs["cone_aperture_deg"] = float(cone_deg)
        if minimal:
            f.create_dataset("wavelength_nm", data=wl)
            f.create_dataset("image/intensity", data=value)
            f.create_dataset("image/standard_error", data=sigma)
            f.create_dataset("image/solid_angle_sr", data=omega)
            f.create_group("provenance")
            return
        _string_attrs(f, format="plumage record 1 (virtual_gonio/RECORD.md)")
        if illumination != "cone":
            inst.attrs["cone_aperture_deg"] = float(cone_deg)  # the suite writes it always
        inst.attrs["beam_radius_um"] = 50.0
        _string_attrs(inst, mapping="azimuthal equidistant: theta = 90 deg * hypot(u, v), "
                                    "phi = atan2(v, u) from +x; row 0 at the top")
        _polarisation(inst)
        _dataset(f, "wavelength_nm", wl, "nm", "vacuum wavelengths of the measurement")
        _dataset(f, "image/directions", directions, "1", "unit vector of each pixel centre")
        _dataset(f, "image/solid_angle_sr", omega, "sr", "solid angle each pixel spans")
        _dataset(f, "image/intensity", value, "1/sr", "radiant intensity per unit incident power")
        _dataset(f, "image/standard_error", sigma, "1/sr", "standard error of image/intensity")
        _dataset(f, "image/lobes/R", 0.9 * value, "1/sr", "lobe R")
        _dataset(f, "transmitted_fraction", np.full(wl.size, 0.3), "1", "power below the patch")
        _dataset(f, "transmitted_lobes/T", np.full(wl.size, 0.2), "1", "lobe T below")
        _convergence(f)
        _provenance(f, f"[instrument]\nkind = \"scatterometer\"\nillumination = \"{illumination}\"\n")


def _directions(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)


def brdf_pairs():
    """30 (light, view) pairs over the upper hemisphere, angles in degrees."""
    rng = np.random.default_rng(7)
    ti = rng.uniform(5, 70, 30).round(1)
    pi = rng.uniform(-180, 180, 30).round(1)
    to = rng.uniform(5, 75, 30).round(1)
    po = rng.uniform(-180, 180, 30).round(1)
    return ti, pi, to, po


def goniometer(path, wavelengths=(450.0, 550.0, 650.0)):
    import h5py

    from plumage import models

    ti, pi, to, po = brdf_pairs()
    wi, wo = _directions(ti, pi), _directions(to, po)
    wl = np.asarray(wavelengths, float)
    m = models.Filip2024("parrot")
    value = np.stack([m.eval(wi, wo, float(l)) for l in wl], axis=1)  # [pairs, λ]
    sigma = 0.03 * value + 0.002
    value = value + sigma * np.random.default_rng(3).standard_normal(value.shape)
    with h5py.File(path, "w") as f:
        _string_attrs(f, format="plumage record 1 (virtual_gonio/RECORD.md)")
        inst = f.create_group("instrument")
        _string_attrs(inst, kind="goniometer", direction_set="custom",
                      aperture="view_cone: fuzz seed", estimator="eval")
        inst.attrs["detector_half_angle_deg"] = 2.0
        inst.attrs["detector_solid_angle_sr"] = 0.0038
        inst.attrs["beam_radius_um"] = 50.0
        _polarisation(inst)
        _dataset(f, "instrument/light_directions", wi, "1", "towards the light")
        _dataset(f, "instrument/view_directions", wo, "1", "towards the detector")
        _dataset(f, "instrument/angles_deg", np.stack([ti, pi, to, po], 1), "deg",
                 "theta_light, phi_light, theta_view, phi_view")
        _dataset(f, "wavelength_nm", wl, "nm", "vacuum wavelengths")
        _dataset(f, "brdf/value", value, "1/sr", "BRDF")
        _dataset(f, "brdf/standard_error", sigma, "1/sr", "standard error")
        _dataset(f, "brdf/lobes/background", 0.5 * value, "1/sr", "lobe")
        _dataset(f, "brdf/lobe_standard_errors/background", 0.5 * sigma, "1/sr", "lobe error")
        _convergence(f)
        _provenance(f, "[instrument]\nkind = \"goniometer\"\n")
    return ti, pi, to, po, wl, value, sigma


def csv_tables(folder, gonio_data):
    ti, pi, to, po, wl, value, sigma = gonio_data
    with open(os.path.join(folder, "brdf.csv"), "w", newline="") as f:
        f.write("# fuzz seed: Filip 2024 parrot, 30 pairs x 3 wavelengths\n")
        f.write("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,wavelength_nm,value_per_sr,"
                "sigma_per_sr\n")
        for p in range(ti.size):
            for k, l in enumerate(wl):
                f.write(f"{ti[p]:g},{pi[p]:g},{to[p]:g},{po[p]:g},{l:g},"
                        f"{value[p, k]:.6g},{sigma[p, k]:.6g}\n")
    with open(os.path.join(folder, "brdf_rgb.csv"), "w", newline="") as f:
        f.write("channel,theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,value_per_sr\n")
        for p in range(ti.size):
            for k, ch in enumerate("BGR"):
                f.write(f"{ch},{ti[p]:g},{pi[p]:g},{to[p]:g},{po[p]:g},{value[p, k]:.6g}\n")


def bsdf_seeds(folder, plumage):
    """`plumage export-bsdf` on tiny grids, in an empty folder with its own TMPDIR."""
    jobs = [("huang.bsdf", ["huang2022", "--theta-nodes", "3", "--phi-nodes", "3"]),
            ("filip_iso.bsdf", ["filip2024:parrot", "--theta-nodes", "3", "--phi-nodes", "1"])]
    for name, args in jobs:
        with tempfile.TemporaryDirectory() as tmp:
            # --threads before the subcommand: export-bsdf does not take it after (exit 109)
            cmd = [plumage, "--threads", "1", "export-bsdf", *args, "--resolution", "4",
                   "--first-nm", "450", "--last-nm", "650", "--step-nm", "100", "-o",
                   os.path.join(os.path.abspath(folder), name)]
            run = subprocess.run(cmd, cwd=tmp, env=dict(os.environ, TMPDIR=tmp),
                                 capture_output=True, text=True, timeout=600)
            if run.returncode != 0:
                raise SystemExit(f"seeds: {' '.join(cmd)} failed ({run.returncode}):\n"
                                 f"{run.stderr[-2000:]}")


def make_all(folder, plumage, with_bsdf=True):
    os.makedirs(folder, exist_ok=True)
    scatterogram(os.path.join(folder, "sc_beam.h5"), "beam", 13, (500.0, 600.0))
    scatterogram(os.path.join(folder, "sc_hemisphere.h5"), "hemisphere", 11, (500.0, 600.0))
    scatterogram(os.path.join(folder, "sc_cone.h5"), "cone", 9, (550.0,))
    scatterogram(os.path.join(folder, "sc_minimal.h5"), "beam", 11, (500.0, 600.0), minimal=True)
    csv_tables(folder, goniometer(os.path.join(folder, "gonio.h5")))
    if with_bsdf:
        bsdf_seeds(folder, plumage)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--plumage", required=True)
    ap.add_argument("--no-bsdf", action="store_true")
    a = ap.parse_args()
    try:
        import plumage  # noqa: F401
    except ImportError:  # not installed (scripts/install_python_path.sh): the build's own
        sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(
            os.path.abspath(a.plumage))), "python"))
    make_all(a.out, os.path.abspath(a.plumage), not a.no_bsdf)


if __name__ == "__main__":
    sys.exit(main())
