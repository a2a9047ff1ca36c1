"""Every figure kind of studies/plots.py, built from a small synthetic input written here, and
checked on the matplotlib objects (not pixels): each panel has a title, axis labels where the
kind has axes, a colour bar where the kind promises one; and the CLI saves a PNG.

Run by CTest (tests/CMakeLists.txt: plots.figures) with Debian's /usr/bin/python3:
    python3 plots_figures_test.py PATH/TO/studies/plots.py
"""
import csv
import importlib.util
import os
import sys
import tempfile
import unittest

import h5py
import numpy as np

PLOTS = None  # the module under test, loaded in main


def load(path):
    spec = importlib.util.spec_from_file_location("plumage_plots", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def write_csv(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)
    return path


# ---- Synthetic inputs, one writer per kind, in the layout its study writes. ----------------

def spectra(d):
    wl = np.arange(400, 701, 50)
    return write_csv(os.path.join(d, "spectra.csv"),
                     ["wavelength_nm", "R_530nm", "R_plus_TRT_530nm", "R_595nm", "R_plus_TRT_595nm"],
                     [[w, 0.1, 0.15, 0.2, 0.25] for w in wl])


def chart(d):
    path = os.path.join(d, "chart.h5")
    with h5py.File(path, "w") as f:
        f["chart/srgb8"] = np.random.default_rng(1).integers(0, 255, (5, 7, 3), dtype=np.uint8)
        f["chart/thickness_nm"] = np.linspace(400, 700, 7)
        f["chart/incidence_deg"] = np.linspace(0, 80, 5)
    return path


def convergence(d):
    rows = [[label, t, 0.1 / t ** 0.5, 0.12 / t ** 0.5] for label in ("a", "b") for t in (1, 2, 4)]
    return write_csv(os.path.join(d, "convergence.csv"),
                     ["label", "wall_time_s", "estimated_error", "true_error"], rows)


def curves(d):
    return write_csv(os.path.join(d, "curves.csv"),
                     ["light angle (deg)", "simulation", "simulation_err", "model", "model_err"],
                     [[x, 1 + 0.01 * x, 0.1, 1.0, 0.0] for x in range(-60, 61, 20)])


def brdf_wavelengths(d, wavelengths=13, angles=13):
    """As studies/measure_study.cpp writes brdf_curves.csv: 13 light angles x 13 wavelengths
    (the in-plane set at a 25 nm step), a column pair per wavelength."""
    nm = np.linspace(400, 700, wavelengths)
    header = ["signed light angle (deg; view at 45 deg)"]
    for n in nm:
        header += [f"{n:g} nm", f"{n:g} nm error"]
    rows = []
    for x in np.linspace(-81, 81, angles):
        row = [x]
        for n in nm:
            v = 1.0 + np.exp(-((x + 45) / 10) ** 2) * (1 + np.sin(n / 40))
            row += [v, 0.05 * v]
        rows.append(row)
    return write_csv(os.path.join(d, "brdf_curves.csv"), header, rows)


def contact_sheet(d):
    import matplotlib.pyplot as plt

    for name in ("s.png", "m.png"):
        plt.imsave(os.path.join(d, name), np.random.default_rng(2).random((8, 8, 3)))
    return write_csv(os.path.join(d, "sheet.csv"), ["label", "simulation", "model", "note"],
                     [["base", "s.png", "m.png", "e = 0.1"], ["b = 0.3", "s.png", "m.png", "e = 0.2"],
                      ["b = 0.9", "", "", "rejected: the geometry overlaps itself"]])


def sweep_error(d):
    return write_csv(os.path.join(d, "sweep.csv"), ["b", "error", "floor", "is_base"],
                     [[0.1, 0.2, 0.05, 0], [0.25, 0.1, 0.05, 1], [0.5, "nan", "nan", 0]])


def energy_bars(d):
    return write_csv(os.path.join(d, "energy.csv"), ["label", "energy", "error", "status"],
                     [["flat film", 0.9, 0.01, "ok"], ["grazing", 1.0, 0.0, "by construction"],
                      ["bad", 1.2, 0.02, "violation"]])


def luminance(d):
    return write_csv(os.path.join(d, "luminance.csv"),
                     ["light angle (deg)", "parrot", "parrot error", "parrot fit"],
                     [[x, 40 + x / 10, 1.0, 41] for x in range(-81, 82, 27)])


def masking(d):
    path = os.path.join(d, "masking.h5")
    k, a = 2, 6
    rng = np.random.default_rng(3)
    with h5py.File(path, "w") as f:
        f["angles_deg"] = np.linspace(-75, 75, a)
        f["analytic"] = rng.random((k, a, 3))
        f["mc"] = rng.random((k, a, 3))
        f["mc_standard_error"] = 0.01 + 0.01 * rng.random((k, a, 3))
        f["z"] = rng.normal(size=(k, a, 3))
        f["stratified_bound"] = 0.02 * np.ones((k, a))
        f.attrs["configurations"] = "dense,sparse"
        f.attrs["z_bound"] = 3.5
    return path


def spongy(d):
    path = os.path.join(d, "spongy.h5")
    nf, nl, nw = 2, 2, 9
    wl = np.linspace(400, 700, nw)
    r = 0.2 * np.exp(-((wl - 480) / 40) ** 2) * np.ones((nf, nl, nw))
    with h5py.File(path, "w") as f:
        f["wavelength_nm"] = wl
        f["keratin_fraction"] = np.array([0.5, 0.4])
        f["length_scale_um"] = np.array([0.2, 0.15])
        f["reflectance"] = r
        f["reflectance_standard_error"] = 0.01 * np.ones_like(r)
        f["single_scattering_reflectance"] = 0.8 * r
        for name, value in (("peak_wavelength_nm", 480.0), ("reflectance_at_peak", 0.2),
                            ("peak_wavelength_sigma_nm", 5.0), ("bragg_wavelength_nm", 470.0),
                            ("single_scattering_peak_wavelength_nm", 475.0),
                            ("peak_at_spectrum_edge", 0.0), ("hue_deg", 220.0),
                            ("luminance_Y", 0.1)):
            f[name] = value * np.ones((nf, nl))
        f["srgb8"] = 100 * np.ones((nf, nl, 3), dtype=np.uint8)
        f.attrs["slab_thickness_um"] = 5.0
        g = f.create_group("angles")
        g["incidence_deg"] = np.array([0.0, 30.0])
        g["reflectance"] = r[0]
        g["reflectance_standard_error"] = 0.01 * np.ones((2, nw))
        g["peak_wavelength_nm"] = np.array([480.0, 700.0])
        g["peak_wavelength_sigma_nm"] = np.array([5.0, 5.0])
        g["single_scattering_reflectance"] = 0.8 * r[0]
        b = f.create_group("baseline")
        b["reflectance"] = 0.05 * np.ones(nw)
        b["reflectance_standard_error"] = 0.005 * np.ones(nw)
        b.attrs["thickness_um"] = 5.0
    return path


def hemisphere_disc(n=21):
    """A scatterogram's pixel grid: r (disc radius), theta and phi (deg, NaN off the disc)."""
    u = (np.arange(n) + 0.5) * 2 / n - 1
    uu, vv = np.meshgrid(u, -u)
    r = np.hypot(uu, vv)
    theta = np.where(r <= 1, 90 * r, np.nan)
    phi = np.where(r <= 1, np.degrees(np.arctan2(vv, uu)), np.nan)
    return r, theta, phi


def scatterogram_comparison(d):
    """As studies/figure_data.cpp writes it into <illumination>_comparison.h5."""
    path = os.path.join(d, "beam_comparison.h5")
    r, theta, phi = hemisphere_disc()
    y_sim = np.where(r <= 1, np.exp(-(theta / 20) ** 2), np.nan)
    y_mod = np.where(r <= 1, 0.8 * np.exp(-(theta / 25) ** 2), np.nan)
    with h5py.File(path, "w") as f:
        f["relative_error"] = np.array([0.23, 0.2, 0.3, 0.1, 0.1, 0.05])
        g = f.create_group("figure")
        g["simulation_srgb"] = np.nan_to_num(np.repeat(y_sim[..., None], 3, axis=2)).astype(np.float32)
        g["model_srgb"] = np.nan_to_num(np.repeat(y_mod[..., None], 3, axis=2)).astype(np.float32)
        g["simulation_luminance"] = y_sim
        g["model_luminance"] = y_mod
        g["difference_luminance"] = y_sim - y_mod
        g["theta_deg"] = theta
        g["phi_deg"] = phi
        g.attrs["title"] = "beam illumination"
        g.attrs["white_luminance_per_sr"] = 1.0
    return path


def scatterogram_levels(d):
    """As studies/figure_data.cpp writes it into beam_levels.h5 (three scatterers)."""
    path = os.path.join(d, "beam_levels.h5")
    r, theta, phi = hemisphere_disc()
    with h5py.File(path, "w") as f:
        g = f.create_group("figure")
        for k, (title, width) in enumerate((("physical optics (2.5D)", 15),
                                            ("ray optics + thin film", 20),
                                            ("Huang 2022 model", 25))):
            y = np.where(r <= 1, np.exp(-(theta / width) ** 2), np.nan)
            p = g.create_group(f"panel{k}")
            p["srgb"] = np.nan_to_num(np.repeat(y[..., None], 3, axis=2)).astype(np.float32)
            p["luminance"] = y
            p.attrs["title"] = title
            p.attrs["peak_luminance_per_sr"] = float(np.nanmax(y))
        g["theta_deg"] = theta
        g["phi_deg"] = phi
        g.attrs["panels"] = np.int64(3)
        g.attrs["title"] = "beam illumination by level"
        g.attrs["white_luminance_per_sr"] = 1.0
        g.attrs["note"] = "relative L1 against the model: physical optics 0.5"
    return path


def fingerprints(d, count=3):
    """As studies/figure_data.cpp writes fingerprints.h5 (Filip 2024 set: 61 x 60)."""
    path = os.path.join(d, f"fingerprints{count}.h5")
    lights = np.array([[0.0, 0.0]] + [[t, p] for t in (15, 30, 45, 60, 75) for p in range(0, 360, 30)])
    views = lights[1:]
    rng = np.random.default_rng(4)
    with h5py.File(path, "w") as f:
        f["light_angles_deg"] = lights
        f["view_angles_deg"] = views
        for k, title in enumerate(("simulation", "fitted model", "Table 1 model")[:count]):
            y = rng.random((61, 60))
            f[f"panel{k}/srgb"] = np.repeat(y[..., None], 3, axis=2).astype(np.float32)
            f[f"panel{k}/luminance"] = y
            f[f"panel{k}"].attrs["title"] = title
            f[f"panel{k}"].attrs["peak_luminance_per_sr"] = float(y.max())
        f.attrs["panels"] = np.int64(count)
        f.attrs["title"] = "parrot: BRDF fingerprints"
        f.attrs["white_luminance_per_sr"] = 1.0
    return path


def btf_tiles(d):
    path = os.path.join(d, "btf_figure9.h5")
    with h5py.File(path, "w") as f:
        f["srgb"] = np.random.default_rng(5).random((12, 8, 8, 3)).astype(np.float32)
        f["luminance"] = np.ones((12, 8, 8))
        f["angles_deg"] = np.array([[30, 30 * k, 30, 0] for k in range(12)], dtype=float)
        f.attrs["title"] = "parrot: virtual BTF"
        f.attrs["patch_size_um"] = 200.0
        f.attrs["pixels"] = np.int64(8)
        f.attrs["white_luminance_per_sr"] = 0.5
    return path


def _preview_header(f, names, colours, filled, caption):
    f.attrs["phase_names"] = "|".join(names)
    f.attrs["phase_colours"] = "|".join(colours)
    f.attrs["phase_filled"] = "|".join("1" if x else "0" for x in filled)
    f.attrs["caption"] = caption
    f.attrs["x_label"] = "x (µm)"
    f.attrs["y_label"] = "z (µm)"


def geometry_lines(d):
    """Open outlines (a barbule row's film and melanin surfaces) and one closed loop."""
    path = os.path.join(d, "preview_lines.h5")
    t = np.linspace(0, np.pi, 20)
    arc = np.stack([10 * np.cos(t), 2 * np.sin(t)], axis=1)
    loop = np.stack([3 + np.cos(2 * t), 5 + np.sin(2 * t)], axis=1)
    segs = [np.concatenate([a, b]) for a, b in zip(arc[:-1], arc[1:])]
    segs += [np.concatenate([a, b]) for a, b in zip(loop[:-1], loop[1:])]
    segs.append(np.concatenate([loop[-1], loop[0]]))
    with h5py.File(path, "w") as f:
        _preview_header(f, ["film", "keratin"], ["#28aa5a", "#d9a441"], [False, True], "a cut")
        f["segments"] = np.array(segs)
        f["segment_phase"] = np.array([0.0] * (len(arc) - 1) + [1.0] * len(loop))
    return path


def geometry_polygons(d):
    path = os.path.join(d, "preview_polygons.h5")
    with h5py.File(path, "w") as f:
        _preview_header(f, ["cortex", "medulla"], ["#aaaaaa", "#ebebe1"], [True, True], "barbs")
        f["polygon_vertices"] = np.array([[0, 0], [4, 0], [4, 3], [0, 3], [1, 1], [3, 1], [2, 2]],
                                         dtype=float)
        f["polygon_offsets"] = np.array([0.0, 4.0, 7.0])
        f["polygon_phase"] = np.array([0.0, 1.0])
    return path


def wave_validity_map(d):
    """Two incidences x 3 values x 4 widths, L1 falling through 5 % with width (the contour)."""
    path = os.path.join(d, "wave_validity.h5")
    widths = np.array([1.0, 3.0, 8.0, 20.0])
    values = np.array([0.2, 0.4, 0.59])
    l1 = np.array([[[0.5 / w * (1 + v) for w in widths] for v in values] for _ in range(2)])
    with h5py.File(path, "w") as f:
        f["widths_um"] = widths
        f["incidence_deg"] = np.array([0.0, 30.0])
        f["wavelengths_nm"] = np.array([500.0, 600.0])
        f["map/values"] = values
        f["map/relative_l1"] = l1
        f["map/relative_l1_noise_floor"] = 0.1 * l1
        f["map/boundary_width_um"] = np.full((2, 3), 12.0)
        f["map"].attrs["axis_label"] = "film thickness d (µm)"
        f.attrs["title"] = "PO vs GO: relative L1"
        f.attrs["threshold"] = 0.05
        f.attrs["window_half_angle_deg"] = 5.0
        f.attrs["window_kernel"] = "gaussian"
    return path


def level_spectra(d):
    """Seven wavelengths of one scene: full wave on two grids, physical and ray optics."""
    path = os.path.join(d, "live_spectra.h5")
    wl = np.linspace(400.0, 700.0, 7)
    with h5py.File(path, "w") as f:
        f["lambda_nm"] = wl
        f["full_wave"] = 0.1 + 0.05 * np.sin(wl / 50.0)
        f["full_wave_coarse"] = 0.1 + 0.051 * np.sin(wl / 50.0)
        f["physical_optics"] = 0.12 + 0.05 * np.sin(wl / 50.0)
        f["ray_optics"] = 0.13 + 0.05 * np.sin(wl / 50.0)
        f.attrs["title"] = "base, width 8 µm, θ_i = 0°: physical optics +20 % (band)"
    return path


def instrument_curves(d):
    path = os.path.join(d, "instrument_curves.h5")
    wl = np.arange(400.0, 701.0, 50.0)
    with h5py.File(path, "w") as f:
        f["wavelength_nm"] = wl
        for k, label in enumerate(("reflectance R", "transmittance T")):
            f[f"curves/{k}/value"] = 0.3 + 0.1 * k + 0.0 * wl
            f[f"curves/{k}/standard_error"] = 0.01 + 0.0 * wl
            f[f"curves/{k}"].attrs["label"] = label
        f.attrs["title"] = "Integrating sphere"
        f.attrs["quantity"] = "fraction (1)"
        f.attrs["curves"] = 2.0
    return path


def fit_residuals(d):
    """Four panels (one grid cell left empty) of residuals with gaps, as studies/fit_command.cpp
    writes them."""
    path = os.path.join(d, "residuals.h5")
    z = np.random.default_rng(1).standard_normal((4, 5, 6))
    z[:, 0, 0] = np.nan
    with h5py.File(path, "w") as f:
        f["residual"] = z
        f.attrs["panel_titles"] = "450 nm|550 nm|650 nm|700 nm"
        f.attrs["title"] = "fit: residuals"
        f.attrs["x_label"] = "view direction (index)"
        f.attrs["y_label"] = "light direction (index)"
        f.attrs["colour_label"] = "(model - data) / sigma"
        f.attrs["extent"] = "-0.5 5.5 4.5 -0.5"
        f.attrs["aspect"] = "auto"
    return path


# kind -> (input writers, what every panel must have, colour bar expected)
#   panels: "all" (every non-colour-bar axes has a title and x and y labels),
#           "titled" (every axes a title, labels on at least one), "sheet" (contact sheet:
#           column titles on the first row, a row label on each row)
CASES = {
    "spectra": ([spectra], "all", False),
    "chart": ([chart], "all", False),
    "convergence": ([convergence], "all", False),
    "curves": ([curves], "all", False),
    "brdf_wavelengths": ([brdf_wavelengths], "all", True),
    "contact_sheet": ([contact_sheet], "sheet", False),
    "sweep_error": ([sweep_error], "all", False),
    "energy_bars": ([energy_bars], "all", False),
    "luminance": ([luminance], "all", False),
    "masking": ([masking], "titled", False),
    "spongy_spectra": ([spongy], "all", False),
    "spongy_map": ([spongy], "all", True),
    "spongy_angles": ([spongy], "all", False),
    "scatterogram_comparison": ([scatterogram_comparison], "all", True),
    "scatterogram": ([scatterogram_comparison], "all", False),
    "scatterogram_levels": ([scatterogram_levels], "all", True),
    "fingerprints": ([fingerprints], "all", True),
    "btf_tiles": ([btf_tiles], "titled", False),
    "geometry_preview": ([geometry_lines, geometry_polygons], "all", False),
    "wave_validity_map": ([wave_validity_map], "all", True),
    "level_spectra": ([level_spectra], "all", False),
    "fit_residuals": ([fit_residuals], "all", True),
    "instrument_curves": ([instrument_curves], "all", False),
}


def is_colour_bar(ax):
    return ax.get_label() == "<colorbar>" or hasattr(ax, "_colorbar")


def panels(fig):
    return [a for a in fig.axes if a.get_visible() and not is_colour_bar(a)]


def colour_bars(fig):
    return [a for a in fig.axes if is_colour_bar(a)]


def title_of(ax):
    return " ".join(ax.get_title(loc=loc) for loc in ("left", "center", "right")).strip()


class EveryKind(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name

    def tearDown(self):
        PLOTS.plt.close("all")
        self.tmp.cleanup()

    def test_the_test_covers_every_kind(self):
        self.assertEqual(set(CASES), set(PLOTS.KINDS))

    def check(self, kind, fig, rule, colour_bar):
        self.assertIsNotNone(fig, kind)
        axes = panels(fig)
        self.assertTrue(axes, kind)
        if rule == "sheet":
            columns = len({a.get_subplotspec().colspan.start for a in axes})
            for a in axes[:columns]:
                self.assertTrue(title_of(a), f"{kind}: a column without a title")
            for a in axes[::columns]:
                self.assertTrue(a.get_ylabel(), f"{kind}: a row without a label")
        for a in axes:
            if rule in ("all", "titled"):
                self.assertTrue(title_of(a), f"{kind}: an axes without a title")
            if rule == "all":
                self.assertTrue(a.get_xlabel(), f"{kind}: '{title_of(a)}' has no x label")
                self.assertTrue(a.get_ylabel(), f"{kind}: '{title_of(a)}' has no y label")
        if rule == "titled":
            self.assertTrue(any(a.get_xlabel() for a in axes), f"{kind}: no x label")
            self.assertTrue(any(a.get_ylabel() for a in axes), f"{kind}: no y label")
        if colour_bar:
            bars = colour_bars(fig)
            self.assertTrue(bars, f"{kind}: no colour bar")
            for b in bars:
                self.assertTrue(b.get_ylabel() or b.get_xlabel(), f"{kind}: colour bar without units")

    def test_every_kind_builds_a_labelled_figure(self):
        for kind, (writers, rule, colour_bar) in CASES.items():
            for writer in writers:
                with self.subTest(kind=kind, input=writer.__name__):
                    builder, _ = PLOTS.KINDS[kind]
                    fig = builder(writer(self.dir))
                    self.check(kind, fig, rule, colour_bar)
                    PLOTS.plt.close("all")

    def test_scatterogram_difference_is_symmetric_about_zero(self):
        fig = PLOTS.build_scatterogram_comparison(scatterogram_comparison(self.dir))
        diff = [a for a in panels(fig) if "−" in title_of(a)]
        self.assertEqual(len(diff), 1)
        image = diff[0].get_images()[0]
        low, high = image.get_clim()
        self.assertAlmostEqual(low, -high)
        self.assertGreater(high, 0.0)
        titles = " ".join(title_of(a) for a in panels(fig))
        for name in ("simulation", "Huang 2022 model", "simulation − model"):
            self.assertIn(name, titles)
        self.assertIn("white = luminance", fig._suptitle.get_text())

    def test_scatterogram_levels_share_one_scale(self):
        """Every level's luminance on one logarithmic scale (one colour bar), its colour at one
        exposure stated in the title."""
        fig = PLOTS.build_scatterogram_levels(scatterogram_levels(self.dir))
        luminance = [a for a in panels(fig) if "luminance" in title_of(a)]
        self.assertEqual(len(luminance), 3)
        self.assertEqual(len({a.get_images()[0].get_clim() for a in luminance}), 1)
        self.assertEqual(len(colour_bars(fig)), 1)
        self.assertIn("one exposure for every panel", fig._suptitle.get_text())

    def test_fingerprints_state_one_exposure(self):
        fig = PLOTS.build_fingerprints(fingerprints(self.dir))
        self.assertIn("one exposure", fig._suptitle.get_text())
        # one luminance scale for every panel (the other bar is the differences')
        luminance = [b for b in colour_bars(fig) if b.get_ylabel().startswith("luminance Y")]
        self.assertEqual(len(luminance), 1)

    def test_fingerprints_have_a_difference_panel_per_compared_panel(self):
        """Under each compared panel its signed luminance difference from the simulation, on one
        diverging scale symmetric about 0 shared by all, with a colour bar in 1/sr; a single
        panel (the measure study's sample) has nothing to compare and no difference row."""
        for count in (2, 3):
            with self.subTest(panels=count):
                fig = PLOTS.build_fingerprints(fingerprints(self.dir, count))
                diff = [a for a in panels(fig) if "−" in title_of(a)]
                self.assertEqual(len(diff), count - 1)
                limits = {a.get_images()[0].get_clim() for a in diff}
                self.assertEqual(len(limits), 1, "difference panels on different scales")
                low, high = limits.pop()
                self.assertAlmostEqual(low, -high)
                self.assertGreater(high, 0.0)
                for a in diff:
                    self.assertEqual(a.get_images()[0].get_cmap().name, "RdBu_r")
                    self.assertIn("simulation", title_of(a))
                labels = [b.get_ylabel() for b in colour_bars(fig)]
                self.assertTrue(any("difference" in t and "1/sr" in t for t in labels), labels)
                PLOTS.plt.close("all")
        fig = PLOTS.build_fingerprints(fingerprints(self.dir, 1))
        self.assertFalse([a for a in panels(fig) if "−" in title_of(a)])

    def test_convergence_has_three_x_ticks_and_a_legend_off_the_data(self):
        """A quick study's passes span less than a decade of wall time, where a plain log axis
        labels one tick or none; the default study's passes (and the simulation's two, later)
        fill the axes, where the legend came to lie over lines and points. Neither may happen:
        three labelled ticks on each axis, and no point nor any part of a line under the
        legend."""
        header = ["label", "wall_time_s", "estimated_error", "true_error", "reference_floor"]
        lobe = "Huang R lobe (photon estimator)"
        quick = [[lobe, t, 0.27 / t ** 0.5, 0.25 / t ** 0.4, 0.013] for t in (1.15, 2.2, 3.3)]
        quick.append(["simulation BRDF", 1.8, 0.21, -1, -1])
        full = [[lobe, t, 0.25 * (4.5 / t) ** 0.5, 0.28 * (4.5 / t) ** 0.9, 0.0105]
                for t in np.geomspace(4.5, 33, 10)]
        full += [["simulation BRDF", 34, 0.15, -1, -1], ["simulation BRDF", 79, 0.105, -1, -1]]
        for name, rows in (("quick", quick), ("full", full)):
            with self.subTest(passes=name):
                fig = PLOTS.build_convergence(write_csv(os.path.join(self.dir, name + ".csv"),
                                                        header, rows))
                fig.canvas.draw()
                ax = panels(fig)[0]
                for axis, (low, high) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
                    labelled = [t.label1.get_text() for t in axis.get_major_ticks()
                                if low <= t.get_loc() <= high and t.label1.get_visible()
                                and t.label1.get_text()]
                    self.assertGreaterEqual(len(labelled), 3, labelled)
                legend = ax.get_legend().get_window_extent(fig.canvas.get_renderer())
                for line in ax.get_lines():
                    xy = ax.transData.transform(line.get_xydata())
                    # each point, and 40 samples along every segment between points
                    samples = np.concatenate([xy[:1]] + [np.linspace(a, b, 40)
                                                         for a, b in zip(xy[:-1], xy[1:])])
                    under = sum(legend.contains(x, y) for x, y in samples)
                    self.assertEqual(under, 0, f"the legend covers '{line.get_label()}'")
                PLOTS.plt.close("all")

    def test_hemisphere_paints_no_pixel_outside_the_disc(self):
        """Every pixel drawn in one pure colour: rendered, no pixel of that colour lies outside
        the ϑ = 90° circle (a rim pixel's centre is inside, its square is not)."""
        path = scatterogram_comparison(self.dir)
        with h5py.File(path, "r+") as f:
            g = f["figure"]
            rgb = np.zeros(g["simulation_srgb"].shape, dtype=np.float32)
            rgb[..., 1] = 1.0  # pure green everywhere; the disc's mask is theta
            g["simulation_srgb"][...] = rgb
            g["model_srgb"][...] = rgb
        for build in (PLOTS.build_scatterogram_comparison, PLOTS.build_scatterogram):
            with self.subTest(kind=build.__name__):
                fig = build(path)
                fig.canvas.draw()
                image = np.asarray(fig.canvas.buffer_rgba())[..., :3].astype(int)
                height = image.shape[0]
                rows, cols = np.mgrid[0:height, 0:image.shape[1]]
                green = (image[..., 1] > 200) & (image[..., 0] < 60) & (image[..., 2] < 60)
                self.assertTrue(green.any(), "the test colour was not drawn")
                for ax in panels(fig)[:2 if "comparison" in build.__name__ else 1]:
                    cx, cy = ax.transData.transform((0.0, 0.0))
                    rim = ax.transData.transform((90.0, 0.0))[0] - cx
                    # display y runs upwards, the buffer's rows downwards
                    r = np.hypot(cols + 0.5 - cx, (height - rows - 0.5) - cy)
                    box = ax.get_window_extent()
                    near = (np.abs(cols - cx) < box.width / 2) & (np.abs(height - rows - cy) <
                                                                   box.height / 2)
                    outside = green & near & (r > rim + 1.5)
                    self.assertEqual(int(outside.sum()), 0, f"{title_of(ax)}: pixels outside")
                PLOTS.plt.close("all")

    def test_brdf_wavelengths_draws_few_curves_per_panel(self):
        """13 wavelengths: no panel carries more than four curves; the map holds them all on a
        logarithmic colour scale with a colour bar in 1/sr."""
        fig = PLOTS.build_brdf_wavelengths(brdf_wavelengths(self.dir))
        for ax in panels(fig):
            self.assertLessEqual(len(ax.containers), 4, title_of(ax))
            self.assertLessEqual(len(ax.get_legend_handles_labels()[0]), 4, title_of(ax))
        maps = [a for a in panels(fig) if a.get_images()]
        self.assertEqual(len(maps), 1)
        self.assertEqual(maps[0].get_images()[0].get_array().shape, (13, 13))
        self.assertIn("1/sr", colour_bars(fig)[0].get_ylabel())

    def test_chart_states_its_exposure(self):
        path = chart(self.dir)
        with h5py.File(path, "r+") as f:
            f["chart"].attrs["exposure"] = 0.85
        fig = PLOTS.build_chart(path)
        self.assertIn("one exposure", title_of(panels(fig)[0]))

    def test_geometry_preview_has_a_legend_and_a_scale_bar(self):
        from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

        for writer in (geometry_lines, geometry_polygons):
            with self.subTest(input=writer.__name__):
                fig = PLOTS.build_geometry_preview(writer(self.dir))
                ax = panels(fig)[0]
                self.assertIsNotNone(ax.get_legend())
                self.assertTrue(any(isinstance(c, AnchoredSizeBar) for c in ax.get_children()))
                PLOTS.plt.close("all")

    def test_cli_saves_pngs_in_a_batch(self):
        jobs = os.path.join(self.dir, "jobs.csv")
        pngs = [os.path.join(self.dir, "a.png"), os.path.join(self.dir, "b.png")]
        write_csv(jobs, ["kind", "input", "png"],
                  [["curves", curves(self.dir), pngs[0]],
                   ["btf_tiles", btf_tiles(self.dir), pngs[1]]])
        PLOTS.main(["plots.py", "batch", jobs, "unused.png"])
        for png in pngs:
            self.assertTrue(os.path.getsize(png) > 0, png)


if __name__ == "__main__":
    PLOTS = load(sys.argv.pop(1))
    unittest.main(verbosity=2)
