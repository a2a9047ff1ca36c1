#!/usr/bin/python3
"""Full-wave reference for barbule cross-sections: 2D far-field scattering in Meep (issue 16).

    /usr/bin/python3 barbule_far_field_2d.py [--cases single small row3] [--polarisations TE TM]
        [--resolutions 40 60] [--theta-i 0 30] [--out DIR]
    /usr/bin/python3 barbule_far_field_2d.py --report [--prune] [--out DIR]
    /usr/bin/python3 barbule_far_field_2d.py --mie-check [--resolutions 40 60] [--out DIR]

Writes, beside this script (or into --out), merging with the rows already there (same key
replaced), after every run, so an interrupted sweep keeps what it finished:
  far_field.csv    case, polarisation, theta_i_deg, lambda_nm, resolution_px_per_um, theta_s_deg,
                   sigma_um_per_rad: the differential scattering width of the SCATTERED field
                   (total minus the empty cell's) per radian, the full circle every 0.5°;
  totals.csv       case, polarisation, theta_i_deg, lambda_nm, resolution, scattering_width_um
                   (closed flux box, scattered field), absorption_width_um (the same box, total
                   field), wall_s (the run's wall time: the scattering run + its empty run, which
                   give all three wavelengths together);
  checks.csv       the same key, then diagnostics: ∫σ dθ_s, the extinction width from the 2D
                   optical theorem, the empty run's net flux through the box (relative), the
                   incident intensity from the flux line and from |u|², the spread of |u|² over
                   the object's footprint, the back-hemisphere peak of σ, Meep version, decay;
  materials.csv    lambda_nm, the suite's n_keratin, n_melanin, k_melanin, and the n, k of the
                   fitted Lorentzian media the runs used.
--report reads those, writes convergence.csv (coarsest vs finest resolution: max and RMS
relative difference of σ where the finest σ exceeds 1 % of its peak, and of the two widths),
prints the energy and symmetry checks and draws sigma_<case>.png; --prune then keeps only the
finest resolution in far_field.csv (σ to 4 significant digits), to keep the committed file small.
--mie-check runs the same pipeline on a circular cylinder (radius 1 µm) of the fitted melanin
and writes mie_check.csv: σ and the widths against the exact series solution.

Frame and definitions (the contract with the physical-optics solver). Meep's x is our x
(horizontal), Meep's y is our z (up); the invariant axis is Meep's z. TE: E along the invariant
axis (Meep Ez); TM: H along it (Meep Hz). Directions point away from the object: the light comes
from ω_i = (sin θ_i, cos θ_i) and propagates along −ω_i; the far-field direction is
ω_s = (sin θ_s, cos θ_s), θ_s ∈ (−180°, 180°], from +z towards +x. σ(θ_s) = lim r S_r / I_inc
(S: time-averaged Poynting vector of the scattered field, I_inc: the incident plane wave's
intensity), in µm per radian, so ∫σ dθ_s = scattered power per unit length / I_inc.

Shape: a melanin elliptical core (semi-axes a_x, a_z) under a keratin shell of uniform thickness
d whose outer boundary is the outward normal offset of the core ellipse by d: an mp.Prism of
N_VERTICES vertices, parametrised by the normal's angle (largest sagitta 1.5 nm). The core, an
exact ellipse, is mp.Ellipsoid on top of it (later objects win). Meep's subpixel averaging is
OFF (eps_averaging=False, interfaces staircased, first-order convergence): with it, setting up
the polygon took 2–3 minutes per run at 30 px/µm, the whole budget. Cases: "single"
(5.0, 2.0, 0.30) µm, "small" (1.0, 0.4, 0.30) µm, "row3" three "single" at x = −11, 0, +11 µm.

Materials (λ in nm): keratin n = 1.532 + 5890/λ², lossless; melanin n = 1.648 + 23700/λ²,
k = 0.56 exp(−λ/270); air n = 1. A broadband pulse needs dispersive media: each is ε_∞ plus
Lorentzian susceptibilities (keratin one lossless term, melanin two), fitted by least squares in
n and k over 430–670 nm with extra weight at 450, 550, 650 nm, resonances kept at ≤ F0_MAX and
outside the band (a keratin resonance at 9 µm⁻¹ made the update unstable at 20 px/µm). The fit
runs (deterministically) at start-up; materials.csv holds what the runs used.

The simulation. A line source across the whole cell width, through the side PMLs, with
is_integrated=True (Meep's rule for a plane-wave source that extends into PML: without it the
incident |E|² over the object rippled by ±10 %), a Gaussian pulse over 430–670 nm, light going
down (−y). One run gives the three wavelengths. Oblique incidence: the object is turned by −θ_i
instead (the frame turned so the light comes straight down), and σ is read at θ_s − θ_i in Meep's
frame; a Bloch-phased tilted source rippled the incident |E|² over the object by ±5 % (the
tilted wave is damped crossing the side PML). Every run is paired with an empty-cell run (same
cell, source, resolution); the scattered field on the monitor box is the scattering run's DFT
field minus the empty run's (and load_minus_flux_data for the box flux). I_inc: the empty run's
flux through a horizontal line at z = 0 over the box width, per unit width (Meep's Re E* × H).

Far field: the exterior Green's representation on the closed box, evaluated from ONE field
component u (Ez for TE, Hz for TM) on the two grid lines that straddle each side (far_amplitude);
σ = |f|²/|u_0|², u_0 the incident amplitude. Meep's own near2far (closed box, load_minus_
near2far_data) was tried first and not used: it put a mirror image of the huge forward (shadow)
lobe into θ_s = θ_i, about (kΔx/2)² as strong (for "single" at 30 px/µm, 450 nm: a 3°-wide
spike of 12.9 µm/rad where the back lobe is 0.4; 35.6 at 15 px/µm), as an E and H taken half a
cell (or half a step) apart would; this transform removes it (0.23 at 30 px/µm, smooth). Absorption: minus the net
outward flux of the total field through the same box. Stop: when |u|² at a probe under the
object has fallen to DECAY of its peak.

Not rerun in CI: about 20 CPU-minutes for the whole default sweep on one core (README.md lists
the measured times). The committed CSVs are what the tests read.
"""
import argparse
import csv
import pathlib
import time

import numpy as np

WAVELENGTHS_NM = (450.0, 550.0, 650.0)
FIT_BAND_NM = (430.0, 670.0)
CASES = {  # a_x, a_z, d (µm), centres along x (µm)
    "single": (5.0, 2.0, 0.30, (0.0,)),
    "small": (1.0, 0.4, 0.30, (0.0,)),
    "row3": (5.0, 2.0, 0.30, (-11.0, 0.0, 11.0)),
    # --mie-check only: a circular melanin cylinder (d = 0: the keratin polygon lies inside the
    # melanin ellipse drawn over it), which has an exact series solution
    "mie_cylinder": (1.0, 1.0, 0.0, (0.0,)),
}
REFERENCE_CASES = ("single", "small", "row3")
N_VERTICES = 200  # of the keratin outer polygon (largest sagitta 1.5 nm, "single")
THETA_S_STEP_DEG = 0.5
PML_UM = 1.0
MONITOR_GAP_UM = 0.5  # object bounding box → monitor box
SOURCE_GAP_UM = 0.5  # box → source line, and box / source → PML
DECAY = 1e-7  # stop when |field|² at the probe fell to this fraction of its peak
SOURCE_BAND_NM = (430.0, 670.0)
IS_INTEGRATED = True
PERIODIC = True
F0_MAX = 5.0  # 1/µm: the highest Lorentzian resonance allowed in the fits (λ ≥ 200 nm)


# ----------------------------------------------------------------------------- materials
def keratin_nk(lam_nm):
    lam_nm = np.asarray(lam_nm, dtype=float)
    return 1.532 + 5890.0 / lam_nm**2, np.zeros_like(lam_nm)


def melanin_nk(lam_nm):
    lam_nm = np.asarray(lam_nm, dtype=float)
    return 1.648 + 23700.0 / lam_nm**2, 0.56 * np.exp(-lam_nm / 270.0)


def lorentz_eps(params, f):
    """ε(f) of ε_∞ + Σ σ f0² / (f0² − f² − i f γ) (Meep's Lorentzian, exp(−iωt), f in 1/µm)."""
    eps = params[0] + 0j
    for f0, gamma, sigma in np.reshape(params[1:], (-1, 3)):
        eps = eps + sigma * f0**2 / (f0**2 - f**2 - 1j * f * gamma)
    return eps


def fit_lorentzians(nk, n_terms, lossless, seed=0, starts=60):
    """(ε_∞, f0, γ, σ, ...) fitted to n, k over FIT_BAND_NM (deterministic multi-start)."""
    from scipy.optimize import least_squares

    lam = np.linspace(*FIT_BAND_NM, 49)
    lam3 = np.array(WAVELENGTHS_NM)
    n, k = nk(lam)
    n3, k3 = nk(lam3)
    per = 2 if lossless else 3
    f_lo = 1000.0 / 408.0  # resonances kept out of the band (and below the grid's Nyquist)

    def full(x):
        terms = np.reshape(x[1:], (-1, per))
        if lossless:
            terms = np.column_stack([terms[:, 0], np.zeros(len(terms)), terms[:, 1]])
        return np.concatenate([[x[0]], terms.ravel()])

    def residual(x):
        m = np.sqrt(lorentz_eps(full(x), 1000.0 / lam))
        m3 = np.sqrt(lorentz_eps(full(x), 1000.0 / lam3))
        r = [m.real - n, 3 * (m3.real - n3)]
        if not lossless:
            r += [m.imag - k, 3 * (m3.imag - k3)]
        return np.concatenate(r)

    lower = [1.0] + ([f_lo, 0.0] if lossless else [f_lo, 0.0, 0.0]) * n_terms
    # f0 ≤ F0_MAX: a resonance near the grid's Nyquist frequency makes the update unstable
    upper = [6.0] + ([F0_MAX, 20.0] if lossless else [F0_MAX, 30.0, 20.0]) * n_terms
    rng = np.random.Generator(np.random.PCG64(seed))
    best = None
    for _ in range(starts):
        x0 = [rng.uniform(1.0, 2.5)]
        for _ in range(n_terms):
            x0 += [rng.uniform(3, F0_MAX), rng.uniform(0.1, 2)] if lossless else \
                  [rng.uniform(3, F0_MAX), rng.uniform(0.1, 5), rng.uniform(0.1, 2)]
        r = least_squares(residual, x0, bounds=(lower, upper), xtol=1e-15, ftol=1e-15,
                          gtol=1e-15, max_nfev=20000)
        if best is None or r.cost < best.cost:
            best = r
    return full(best.x)


def fitted_nk(params, lam_nm):
    m = np.sqrt(lorentz_eps(params, 1000.0 / np.asarray(lam_nm, dtype=float)))
    return m.real, m.imag


def meep_medium(params):
    import meep as mp

    return mp.Medium(epsilon=params[0], E_susceptibilities=[
        mp.LorentzianSusceptibility(frequency=f0, gamma=g, sigma=s)
        for f0, g, s in np.reshape(params[1:], (-1, 3))])


# ----------------------------------------------------------------------------- geometry
def ellipse_polygons(ax, az, d, n=N_VERTICES):
    """(core, outer) vertex arrays: the ellipse, and its outward normal offset by d.

    The parameter is uniform in the angle of the normal, which puts more vertices where the
    curvature is high (the ends of the major axis)."""
    phi = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    # point of the ellipse whose outward normal is (cos φ, sin φ)
    t = np.arctan2(az * np.sin(phi), ax * np.cos(phi))
    core = np.column_stack([ax * np.cos(t), az * np.sin(t)])
    normal = np.column_stack([np.cos(phi), np.sin(phi)])
    return core, core + d * normal


def rotate(x, z, theta_deg):
    """Turn points so that the direction at angle β (from +z towards +x) goes to β − θ."""
    c, s = np.cos(np.radians(theta_deg)), np.sin(np.radians(theta_deg))
    return x * c - z * s, z * c + x * s


def geometry(case, keratin, melanin, theta_i_deg):
    """The Meep objects: the case's shapes turned by −θ_i about the origin (see simulate).

    The keratin outer boundary is a polygon; the melanin core, an exact ellipse, is Meep's
    Ellipsoid (its inside test is analytic: a 2D prism's costs a loop over the vertices)."""
    import meep as mp

    ax, az, d, centres = CASES[case]
    _, outer = ellipse_polygons(ax, az, d)
    c, s = np.cos(np.radians(theta_i_deg)), np.sin(np.radians(theta_i_deg))
    objects = []
    for cx in centres:  # keratin first, melanin on top (later objects win)
        xo, zo = rotate(cx + outer[:, 0], outer[:, 1], theta_i_deg)
        objects.append(mp.Prism([mp.Vector3(x, z) for x, z in zip(xo, zo)], height=mp.inf,
                                material=keratin))
        xc, zc = rotate(cx, 0.0, theta_i_deg)
        objects.append(mp.Ellipsoid(center=mp.Vector3(xc, zc),
                                    size=mp.Vector3(2 * ax, 2 * az, mp.inf),
                                    e1=mp.Vector3(c, s), e2=mp.Vector3(-s, c),
                                    e3=mp.Vector3(0, 0, 1), material=melanin))
    return objects


def inside_shapes(case, x, z, theta_i_deg):
    """Mask of Meep-frame points inside the shapes' outer boundaries (the ellipse a + d, b + d,
    which contains the offset curve's inside up to O(d²/R))."""
    ax, az, d, centres = CASES[case]
    xb, zb = rotate(x, z, -theta_i_deg)
    mask = np.zeros(np.shape(x), bool)
    for cx in centres:
        mask |= ((xb - cx) / (ax + d)) ** 2 + (zb / (az + d)) ** 2 <= 1.0
    return mask


def layout(case, theta_i_deg):
    """Monitor box half-widths bx, bz and the source height, in the Meep frame."""
    ax, az, d, centres = CASES[case]
    _, outer = ellipse_polygons(ax, az, d)
    bx = bz = 0.0
    for cx in centres:
        x, z = rotate(cx + outer[:, 0], outer[:, 1], theta_i_deg)
        bx, bz = max(bx, np.abs(x).max()), max(bz, np.abs(z).max())
    bx, bz = bx + MONITOR_GAP_UM, bz + MONITOR_GAP_UM
    return bx, bz, bz + SOURCE_GAP_UM


# ----------------------------------------------------------------------------- one run
FIXED_RUN = 0.0  # if > 0: run this long after the sources instead of the decay test (checks)


def stop_condition(mp, component, probe):
    if FIXED_RUN > 0:
        return FIXED_RUN
    return mp.stop_when_fields_decayed(20, component, probe, DECAY)


def strip_fields(sim, cells, component, n_freq):
    """Per side: the two grid lines that straddle it, as (coordinates along the side, the
    line offsets from the side, u on each line per frequency)."""
    out = []
    for cell, axis, at in cells:
        x, y, _, _ = sim.get_array_metadata(dft_cell=cell)
        x, y = np.asarray(x), np.asarray(y)
        across = y if axis == "y" else x
        along = x if axis == "y" else y
        below = np.flatnonzero(across <= at + 1e-9).max()
        rows = (below, below + 1)
        data = []
        for i in range(n_freq):
            u = np.asarray(sim.get_dft_array(cell, component, i))
            u = u.T if axis == "x" else u  # → (along, across)
            data.append((u[:, rows[0]], u[:, rows[1]]))
        out.append((along, across[list(rows)] - at, data))
    return out


def far_amplitude(sides, side_fields, k, theta_rad):
    """f(θ) with u_s → f(θ) e^{ikr}/√r, from u on a closed box of the field's own grid.

    Exterior Green's representation (outward normal ν, Φ = (i/4) H0(k|x − y|)):
    u(x) = ∮ [u ∂Φ/∂ν − Φ ∂u/∂ν] ds, whose r → ∞ limit is
    f(θ) = e^{iπ/4}/√(8πk) ∮ [−ik (r̂·ν) u − ∂u/∂ν] e^{−ik r̂·y} ds.
    u and ∂u/∂ν are taken midway between the two grid lines that straddle the side
    (mean and difference), so they are consistent on the grid to O((kΔx)²/12). With Meep's own
    near2far a mirror image of the huge forward (shadow) lobe, (kΔx/2)² as strong, appeared at
    θ_s = θ_i (12.9 µm/rad at 30 px/µm for "single" at 450 nm, where the back lobe is 0.4)."""
    rhat = np.column_stack([np.sin(theta_rad), np.cos(theta_rad)])
    total = np.zeros(len(theta_rad), complex)
    for (axis, at, sign, lo, hi), (along, offsets, (u1, u2)) in zip(sides, side_fields):
        keep = (along >= lo - 1e-9) & (along <= hi + 1e-9)
        s = along[keep]
        w = np.gradient(s) if len(s) > 1 else np.ones(1)
        w[0] *= 0.5  # trapezoid ends
        w[-1] *= 0.5
        d = offsets[1] - offsets[0]
        t = (offsets[1] + offsets[0]) / 2  # where the midpoint line sits relative to the side
        u = (u1[keep] + u2[keep]) / 2
        dudn = sign * (u2[keep] - u1[keep]) / d
        nu = np.array([0.0, sign]) if axis == "y" else np.array([sign, 0.0])
        if axis == "y":
            pts = np.column_stack([s, np.full_like(s, at + t)])
        else:
            pts = np.column_stack([np.full_like(s, at + t), s])
        phase = np.exp(-1j * k * (rhat @ pts.T))  # (angles, points)
        rn = rhat @ nu
        total += (phase * (u * w)[None, :]).sum(1) * (-1j * k * rn) - phase @ (dudn * w)
    return np.exp(1j * np.pi / 4) / np.sqrt(8 * np.pi * k) * total


def simulate(case, pol, theta_i_deg, resolution, keratin_p, melanin_p):
    """One scattering run and its empty run at the three wavelengths: a dict per wavelength.

    Oblique incidence is computed in a frame turned by −θ_i, where the light comes straight
    down (−y) and the object is turned instead; the far-field angle θ_s of our frame is
    θ_s − θ_i in Meep's. The incident plane wave is always the same clean normal-incidence
    one: a line source across the whole cell, through the side PMLs, with is_integrated=True
    (Meep's rule for sources that extend into PML; without it the ends diffract and |E|² over
    the object rippled by ±10 %); a Bloch-phased tilted source instead rippled the incident
    |E|² by ±5 % (the tilted wave is damped while it crosses the side PML)."""
    import meep as mp

    bx, bz, source_z = layout(case, theta_i_deg)
    top, bottom = source_z + SOURCE_GAP_UM, -bz - SOURCE_GAP_UM
    cell = mp.Vector3(2 * (bx + SOURCE_GAP_UM + PML_UM), top - bottom + 2 * PML_UM)
    geometry_center = mp.Vector3(0, (top + bottom) / 2)
    freqs = [1000.0 / lam for lam in WAVELENGTHS_NM]
    f_lo, f_hi = 1000.0 / SOURCE_BAND_NM[1], 1000.0 / SOURCE_BAND_NM[0]
    fcen, df = (f_lo + f_hi) / 2, (f_hi - f_lo) * 1.5
    component = mp.Ez if pol == "TE" else mp.Hz
    sources = [mp.Source(mp.GaussianSource(fcen, fwidth=df, is_integrated=IS_INTEGRATED),
                         component=component, center=mp.Vector3(0, source_z),
                         size=mp.Vector3(cell.x, 0))]
    common = dict(cell_size=cell, geometry_center=geometry_center,
                  boundary_layers=[mp.PML(PML_UM)], sources=sources, resolution=resolution,
                  k_point=mp.Vector3() if PERIODIC else False, eps_averaging=False)
    sides = [  # (normal axis, position, outward sign, extent along the side)
        ("y", bz, 1.0, -bx, bx), ("y", -bz, -1.0, -bx, bx),
        ("x", bx, 1.0, -bz, bz), ("x", -bx, -1.0, -bz, bz),
    ]
    flux_regions = [mp.FluxRegion(center=mp.Vector3(0, at) if ax == "y" else mp.Vector3(at, 0),
                                  size=mp.Vector3(hi - lo, 0) if ax == "y" else
                                  mp.Vector3(0, hi - lo), weight=sg)
                    for ax, at, sg, lo, hi in sides]
    h = 1.0 / resolution
    line = mp.FluxRegion(center=mp.Vector3(0, 0), size=mp.Vector3(2 * bx, 0))
    probe = mp.Vector3(0, -bz)

    def monitors(sim):
        strips = []
        for ax, at, sg, lo, hi in sides:  # 4 cells thick: holds the two lines around the side
            if ax == "y":
                c, s = mp.Vector3(0, at), mp.Vector3(hi - lo + 4 * h, 4 * h)
            else:
                c, s = mp.Vector3(at, 0), mp.Vector3(4 * h, hi - lo + 4 * h)
            strips.append((sim.add_dft_fields([component], freqs, center=c, size=s), ax, at))
        return strips, sim.add_flux(freqs, *flux_regions), sim.add_flux(freqs, *flux_regions)

    began, cpu = time.time(), time.process_time()
    # --- empty cell
    empty = mp.Simulation(**common)
    strips, box_sca, box_tot = monitors(empty)
    incident_line = empty.add_flux(freqs, line)
    foot = empty.add_dft_fields([component], freqs, center=mp.Vector3(0, 0),
                                size=mp.Vector3(2 * bx, 2 * bz))
    empty.run(until_after_sources=stop_condition(mp, component, probe))
    incident_strips = strip_fields(empty, strips, component, len(freqs))
    box_data = empty.get_flux_data(box_sca)
    empty_net = np.array(mp.get_fluxes(box_tot))
    # the line's normal is +y and the light goes down: I = −flux / width
    intensity_flux = -np.array(mp.get_fluxes(incident_line)) / (2 * bx)
    x, y, _, _ = empty.get_array_metadata(dft_cell=foot)
    X, Y = np.meshgrid(np.asarray(x), np.asarray(y), indexing="ij")
    inside = inside_shapes(case, X, Y, theta_i_deg)
    # The optical theorem compares the forward scattered field with the incident one; both
    # reach the box's bottom side through the grid, whose phase velocity differs from c by
    # O((k Δx)²). The incident amplitude is therefore referred to the origin from that side
    # with the exact k (referring it from the origin itself put the grid's phase error over
    # bz into Re A: 5–14 % in σ_ext at 30 px/µm).
    near_bottom = (np.abs(X) <= 0.5) & (Y <= Y.min() + 1.5 / resolution)
    incident = []
    for i, f in enumerate(freqs):
        field = np.asarray(empty.get_dft_array(foot, component, i))
        e0 = np.mean((field * np.exp(1j * 2 * np.pi * f * Y))[near_bottom])
        amp2 = np.abs(field[inside]) ** 2
        incident.append(dict(e0=e0, i_field=np.mean(amp2),
                             spread=(amp2.max() - amp2.min()) / np.mean(amp2)))
    empty.reset_meep()
    empty_wall = time.time() - began

    # --- with the object
    began = time.time()  # includes the geometry's set-up
    sim = mp.Simulation(**common, geometry=geometry(case, meep_medium(keratin_p),
                                                    meep_medium(melanin_p), theta_i_deg))
    strips, box_sca, box_tot = monitors(sim)
    sim.load_minus_flux_data(box_sca, box_data)
    sim.run(until_after_sources=stop_condition(mp, component, probe))
    total_strips = strip_fields(sim, strips, component, len(freqs))
    p_sca = np.array(mp.get_fluxes(box_sca))
    p_abs = -np.array(mp.get_fluxes(box_tot))
    sim_wall = time.time() - began
    cpu = time.process_time() - cpu
    sim.reset_meep()

    theta_s = np.arange(-180 + THETA_S_STEP_DEG, 180 + THETA_S_STEP_DEG / 2, THETA_S_STEP_DEG)
    meep_angle = np.radians(theta_s - theta_i_deg)  # θ_s in Meep's (turned) frame
    backward = np.cos(meep_angle) > 0
    forward = np.argmin(np.abs(((theta_s - theta_i_deg) % 360.0) - 180.0))
    results = []
    for i, (lam, f) in enumerate(zip(WAVELENGTHS_NM, freqs)):
        k = 2 * np.pi * f
        scattered = [(along, off, (t[2][i][0] - e[2][i][0], t[2][i][1] - e[2][i][1]))
                     for t, e, (along, off, _) in zip(total_strips, incident_strips,
                                                      total_strips)]
        amp = far_amplitude(sides, scattered, k, meep_angle) / incident[i]["e0"]
        # σ = r S_r / I = |f|² / |u_0|² (u = Ez or Hz: S_r and I carry the same impedance)
        sigma = np.abs(amp) ** 2
        # 2D optical theorem: σ_ext = −2 √(2π/k) Re[A(forward) e^{iπ/4}], A = f / u_0
        ext_ot = -2 * np.sqrt(2 * np.pi / k) * np.real(amp[forward] * np.exp(1j * np.pi / 4))
        # σ uses |u_0|² at the bottom side for I; the flux line's I (Meep's E × H) is kept
        # in checks.csv for the normalisation check, and the box widths use it
        i_u = np.abs(incident[i]["e0"]) ** 2
        results.append(dict(
            lambda_nm=lam, theta_s=theta_s, sigma=sigma,
            scattering_width=p_sca[i] / intensity_flux[i],
            absorption_width=p_abs[i] / intensity_flux[i],
            far_integral=np.sum(sigma) * np.radians(THETA_S_STEP_DEG),
            extinction_optical_theorem=ext_ot,
            empty_net_flux_rel=empty_net[i] / (intensity_flux[i] * 2 * bx),
            intensity_flux=intensity_flux[i], intensity_field=incident[i]["i_field"],
            intensity_u0=i_u, footprint_spread=incident[i]["spread"],
            # the largest σ among the back directions (ω_s · ω_i > 0): the specular peak
            peak_theta=theta_s[np.argmax(np.where(backward, sigma, -np.inf))],
            wall=empty_wall + sim_wall, empty_wall=empty_wall, sim_wall=sim_wall, cpu=cpu))
    return results


# ----------------------------------------------------------------------------- CSV I/O
def merge_csv(path, header, n_key, rows):
    """Write rows to path, replacing existing rows whose first n_key columns match."""
    old = []
    if path.exists():
        with open(path, newline="") as src:
            reader = csv.reader(src)
            if next(reader, None) == header:
                old = list(reader)
    new_keys = {tuple(map(str, r[:n_key])) for r in rows}
    kept = [r for r in old if tuple(r[:n_key]) not in new_keys]
    with open(path, "w", newline="") as out:
        w = csv.writer(out)
        w.writerow(header)
        w.writerows(kept + [list(map(str, r)) for r in rows])


FAR_HEADER = ["case", "polarisation", "theta_i_deg", "lambda_nm", "resolution_px_per_um",
              "theta_s_deg", "sigma_um_per_rad"]
TOTALS_HEADER = ["case", "polarisation", "theta_i_deg", "lambda_nm", "resolution",
                 "scattering_width_um", "absorption_width_um", "wall_s"]
CHECKS_HEADER = ["case", "polarisation", "theta_i_deg", "lambda_nm", "resolution",
                 "far_field_integral_um", "extinction_optical_theorem_um",
                 "empty_box_net_flux_rel", "intensity_flux_line", "intensity_field_mean",
                 "incident_footprint_spread", "back_peak_theta_s_deg", "meep_version", "decay"]


def write_materials(out, keratin_p, melanin_p):
    rows = []
    for lam in WAVELENGTHS_NM:
        nk_, _ = keratin_nk(lam)
        nm_, km_ = melanin_nk(lam)
        fk, _ = fitted_nk(keratin_p, lam)
        fn, fkm = fitted_nk(melanin_p, lam)
        rows.append([f"{lam:.0f}", f"{nk_:.6f}", f"{nm_:.6f}", f"{km_:.6f}", f"{fk:.6f}",
                     f"{fn:.6f}", f"{fkm:.6f}"])
    with open(out / "materials.csv", "w", newline="") as dst:
        w = csv.writer(dst)
        w.writerow(["lambda_nm", "n_keratin", "n_melanin", "k_melanin", "n_keratin_fitted",
                    "n_melanin_fitted", "k_melanin_fitted"])
        w.writerows(rows)
    lam = np.linspace(*FIT_BAND_NM, 241)
    errs = dict(keratin_n=np.abs(fitted_nk(keratin_p, lam)[0] - keratin_nk(lam)[0]).max(),
                melanin_n=np.abs(fitted_nk(melanin_p, lam)[0] - melanin_nk(lam)[0]).max(),
                melanin_k=np.abs(fitted_nk(melanin_p, lam)[1] - melanin_nk(lam)[1]).max())
    print("Lorentzian fits: keratin", np.round(keratin_p, 6), "melanin", np.round(melanin_p, 6))
    print("max |error| over 430-670 nm:", {k: f"{v:.2e}" for k, v in errs.items()})
    for r in rows:
        print("  λ", r[0], "keratin n", r[1], "→", r[4], "| melanin n", r[2], "→", r[5], "k", r[3],
              "→", r[6])


def read_far_field(out):
    curves = {}
    with open(out / "far_field.csv", newline="") as src:
        for r in csv.DictReader(src):
            key = (r["case"], r["polarisation"], r["theta_i_deg"], r["lambda_nm"],
                   int(r["resolution_px_per_um"]))
            curves.setdefault(key, []).append((float(r["theta_s_deg"]),
                                               float(r["sigma_um_per_rad"])))
    return {k: np.array(sorted(v)) for k, v in curves.items()}


def read_keyed(path):
    with open(path, newline="") as src:
        return {(r["case"], r["polarisation"], r["theta_i_deg"], r["lambda_nm"],
                 int(r["resolution"])): r for r in csv.DictReader(src)}


def report(out, prune):
    """convergence.csv, the checks printed, sigma_<case>.png; optionally prune far_field.csv."""
    curves = read_far_field(out)
    totals, checks = read_keyed(out / "totals.csv"), read_keyed(out / "checks.csv")
    rows = []
    for key in sorted(totals):
        res = sorted(r for (*k, r) in totals if tuple(k) == key[:4])
        if key[4] != res[-1] or len(res) < 2 or (key[:4] + (res[0],)) not in curves:
            continue
        coarse = key[:4] + (res[0],)
        fine_s, coarse_s = curves[key][:, 1], curves[coarse][:, 1]
        mask = fine_s > 0.01 * fine_s.max()
        rel = (coarse_s[mask] - fine_s[mask]) / fine_s[mask]
        widths = [float(totals[coarse][c]) / float(totals[key][c]) - 1
                  for c in ("scattering_width_um", "absorption_width_um")]
        rows.append(list(key[:4]) + [res[0], res[-1], f"{np.abs(rel).max():.4f}",
                                     f"{np.sqrt(np.mean(rel ** 2)):.4f}",
                                     f"{widths[0]:+.4f}", f"{widths[1]:+.4f}"])
        print("convergence", *rows[-1])
    if not rows:  # far_field.csv already pruned: keep the convergence.csv made before it was
        print("one resolution per curve in far_field.csv: convergence.csv left as it is")
    else:
        with open(out / "convergence.csv", "w", newline="") as dst:
            w = csv.writer(dst)
            w.writerow(["case", "polarisation", "theta_i_deg", "lambda_nm", "coarse_px_per_um",
                        "fine_px_per_um", "sigma_max_rel_diff", "sigma_rms_rel_diff",
                        "scattering_width_rel_diff", "absorption_width_rel_diff"])
            w.writerows(rows)
    for key in sorted(totals):
        t, c = totals[key], checks[key]
        sca, ab = float(t["scattering_width_um"]), float(t["absorption_width_um"])
        line = (f"{key}: C_sca {sca:.3f} C_abs {ab:.3f} | ∫σ/C_sca − 1 "
                f"{float(c['far_field_integral_um']) / sca - 1:+.4f} | OT/(C_sca + C_abs) − 1 "
                f"{float(c['extinction_optical_theorem_um']) / (sca + ab) - 1:+.4f} | empty net "
                f"{c['empty_box_net_flux_rel']} | I_field/I_flux "
                f"{float(c['intensity_field_mean']) / float(c['intensity_flux_line']):.4f} | "
                f"spread {c['incident_footprint_spread']} | back peak "
                f"{c['back_peak_theta_s_deg']}")
        if key[2] == "0" and key in curves:  # mirror symmetry σ(θ) = σ(−θ)
            th, sg = curves[key][:, 0], curves[key][:, 1]
            inner = (th > 0) & (th < 180)
            mirror = np.interp(-th[inner], th, sg)
            big = np.maximum(sg[inner], mirror) > 0.01 * sg.max()
            asym = np.abs(sg[inner] - mirror)[big] / np.maximum(sg[inner], mirror)[big]
            line += f" | mirror asymmetry max {asym.max():.1e}"
        print(line)
    for case in sorted({k[0] for k in curves}):
        plot(out, case, curves)
    if prune:
        with open(out / "far_field.csv", "w", newline="") as dst:
            w = csv.writer(dst)
            w.writerow(FAR_HEADER)
            for key in sorted(curves, key=lambda k: (list(CASES).index(k[0]), k[1],
                                                     float(k[2]), float(k[3]), k[4])):
                finest = max(r for (*k, r) in curves if tuple(k) == key[:4])
                if key[4] == finest:
                    w.writerows([*key, f"{t:.1f}", f"{s:.4g}"] for t, s in curves[key])


def mie_series(radius, m, lam_um, pol, theta_s_deg):
    """Exact 2D scattering of a plane wave by a homogeneous circular cylinder (Bohren & Huffman
    §8.4): σ(θ_s) per radian for light coming from θ_s = 0, and the widths C_sca, C_ext."""
    from scipy.special import h1vp, hankel1, jv, jvp

    k = 2 * np.pi / lam_um
    x = k * radius
    n = np.arange(0, int(abs(m) * x + 4 * (abs(m) * x) ** (1 / 3) + 10))
    jmx, djmx, jx, djx = jv(n, m * x), jvp(n, m * x), jv(n, x), jvp(n, x)
    hx, dhx = hankel1(n, x), h1vp(n, x)
    if pol == "TE":  # E along the axis: BH's case I, b_n
        c = (jmx * djx - m * djmx * jx) / (jmx * dhx - m * djmx * hx)
    else:  # H along the axis: case II, a_n
        c = (m * djx * jmx - jx * djmx) / (m * jmx * dhx - djmx * hx)
    phi = np.radians(np.asarray(theta_s_deg) - 180.0)  # from the forward direction
    t = c[0] + 2 * sum(c[i] * np.cos(i * phi) for i in range(1, len(n)))
    sigma = 2 / (np.pi * k) * np.abs(t) ** 2
    c_sca = 4 / k * (abs(c[0]) ** 2 + 2 * np.sum(np.abs(c[1:]) ** 2))
    c_ext = 4 / k * np.real(c[0] + 2 * np.sum(c[1:]))
    return sigma, c_sca, c_ext


def mie_check(out, resolutions, keratin_p, melanin_p):
    """mie_check.csv: the pipeline on a melanin cylinder of radius 1 µm (the fitted medium)
    against the exact series with the fitted n, k."""
    import meep as mp

    radius = CASES["mie_cylinder"][0]
    rows = []
    for resolution in resolutions:
        for pol in ("TE", "TM"):
            for r in simulate("mie_cylinder", pol, 0.0, resolution, keratin_p, melanin_p):
                n, k = fitted_nk(melanin_p, r["lambda_nm"])
                exact, c_sca, c_ext = mie_series(radius, n + 1j * k, r["lambda_nm"] / 1000, pol,
                                                 r["theta_s"])
                big = exact > 0.01 * exact.max()
                rel = (r["sigma"][big] - exact[big]) / exact[big]
                rows.append([pol, f"{r['lambda_nm']:.0f}", resolution,
                             f"{np.abs(rel).max():.4f}", f"{np.sqrt(np.mean(rel ** 2)):.4f}",
                             f"{r['scattering_width']:.4f}", f"{c_sca:.4f}",
                             f"{r['absorption_width']:.4f}", f"{c_ext - c_sca:.4f}",
                             f"{r['extinction_optical_theorem']:.4f}", f"{c_ext:.4f}",
                             f"{r['cpu']:.0f}", mp.__version__])
                print("mie check", *rows[-1], flush=True)
    with open(out / "mie_check.csv", "w", newline="") as dst:
        w = csv.writer(dst)
        w.writerow(["polarisation", "lambda_nm", "resolution", "sigma_max_rel_diff",
                    "sigma_rms_rel_diff", "scattering_width_meep_um", "scattering_width_exact_um",
                    "absorption_width_meep_um", "absorption_width_exact_um",
                    "extinction_optical_theorem_meep_um", "extinction_exact_um", "cpu_s",
                    "meep_version"])
        w.writerows(rows)


def plot(out, case, curves):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = sorted({(k[2], k[1]) for k in curves if k[0] == case},
                    key=lambda p: (float(p[0]), p[1]))
    fig, axes = plt.subplots(len(panels), 1, figsize=(7, 2.0 * len(panels)), sharex=True,
                             squeeze=False)
    for axis, (ti, pol) in zip(axes[:, 0], panels):
        res = sorted({k[4] for k in curves if k[:3] == (case, pol, ti)})
        for lam, colour in zip(WAVELENGTHS_NM, ("tab:blue", "tab:green", "tab:red")):
            for r, style in zip(res[::-1], ("-", ":")):
                c = curves.get((case, pol, ti, f"{lam:.0f}", r))
                if c is not None:
                    axis.semilogy(c[:, 0], np.maximum(c[:, 1], 1e-5), style, color=colour,
                                  lw=0.6, label=f"{lam:.0f} nm, {r} px/µm")
        axis.set_title(f"{case}  {pol}  θi = {ti}°", fontsize=8)
        axis.set_ylabel("σ (µm/rad)", fontsize=7)
        axis.tick_params(labelsize=7)
        axis.grid(alpha=0.3, lw=0.4)
    axes[0, 0].legend(fontsize=5, ncol=3, loc="upper center")
    axes[-1, 0].set_xlabel("θs (deg)", fontsize=8)
    axes[-1, 0].set_xlim(-180, 180)
    axes[-1, 0].set_xticks(range(-180, 181, 30))
    fig.tight_layout()
    fig.savefig(out / f"sigma_{case}.png", dpi=60)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(REFERENCE_CASES))
    parser.add_argument("--polarisations", nargs="+", default=["TE", "TM"])
    parser.add_argument("--resolutions", type=int, nargs="+", default=[40, 60])
    parser.add_argument("--theta-i", type=float, nargs="+", default=[0.0, 30.0],
                        help="incidence angles; non-zero ones only for 'single'")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path(__file__).parent)
    parser.add_argument("--report", action="store_true",
                        help="no runs: convergence.csv, the checks, sigma_<case>.png")
    parser.add_argument("--prune", action="store_true",
                        help="with --report: keep only the finest resolution in far_field.csv")
    parser.add_argument("--mie-check", action="store_true",
                        help="no reference runs: mie_check.csv (melanin cylinder vs exact series)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if args.report:
        report(args.out, args.prune)
        return
    import meep as mp

    keratin_p = fit_lorentzians(keratin_nk, 1, lossless=True)
    melanin_p = fit_lorentzians(melanin_nk, 2, lossless=False)
    write_materials(args.out, keratin_p, melanin_p)
    if args.mie_check:
        mie_check(args.out, args.resolutions, keratin_p, melanin_p)
        return
    for case in args.cases:
        for theta_i in args.theta_i:
            if theta_i != 0 and case != "single":
                continue
            for resolution in args.resolutions:
                for pol in args.polarisations:
                    results = simulate(case, pol, theta_i, resolution, keratin_p, melanin_p)
                    key = [case, pol, f"{theta_i:g}"]
                    far, tot, chk = [], [], []
                    for r in results:
                        k2 = key + [f"{r['lambda_nm']:.0f}", resolution]
                        far += [k2 + [f"{t:.1f}", f"{s:.4g}"]
                                for t, s in zip(r["theta_s"], r["sigma"])]
                        tot.append(k2 + [f"{r['scattering_width']:.6f}",
                                         f"{r['absorption_width']:.6f}", f"{r['wall']:.1f}"])
                        chk.append(k2 + [f"{r['far_integral']:.6f}",
                                         f"{r['extinction_optical_theorem']:.6f}",
                                         f"{r['empty_net_flux_rel']:.2e}",
                                         f"{r['intensity_flux']:.6e}",
                                         f"{r['intensity_field']:.6e}",
                                         f"{r['footprint_spread']:.4f}",
                                         f"{r['peak_theta']:.1f}", mp.__version__, DECAY])
                        print(f"{case} {pol} θi={theta_i:g} λ={r['lambda_nm']:.0f} "
                              f"res={resolution}: C_sca={r['scattering_width']:.4f} "
                              f"(far {r['far_integral']:.4f}) C_abs="
                              f"{r['absorption_width']:.4f} C_ext(OT)="
                              f"{r['extinction_optical_theorem']:.4f} I flux/field="
                              f"{r['intensity_flux'] / r['intensity_field']:.4f} spread="
                              f"{r['footprint_spread']:.3f} back peak θs={r['peak_theta']:.1f} "
                              f"wall empty {r['empty_wall']:.0f}s + sim {r['sim_wall']:.0f}s, cpu {r['cpu']:.0f}s",
                              flush=True)
                    merge_csv(args.out / "far_field.csv", FAR_HEADER, 6, far)
                    merge_csv(args.out / "totals.csv", TOTALS_HEADER, 5, tot)
                    merge_csv(args.out / "checks.csv", CHECKS_HEADER, 5, chk)


if __name__ == "__main__":
    main()
