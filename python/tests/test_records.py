"""plumage.read_record on records the built binary writes (virtual_gonio/RECORD.md)."""

import h5py
import numpy as np
import pytest

import plumage


def test_goniometer_record(rock_dove_results):
    rec = plumage.read_record(rock_dove_results / "validation/model.h5")
    assert rec.kind == "goniometer"
    assert rec.format.startswith("plumage record")
    pairs, nl = rec.brdf.value.shape
    assert nl == len(rec.wavelength_nm) == 3 and rec.wavelength_nm.units == "nm"
    assert rec.brdf.units == rec.brdf.value.units == rec.brdf.standard_error.units == "1/sr"
    assert rec.brdf.standard_error.shape == (pairs, nl)
    assert rec.instrument["kind"] == "goniometer"
    assert rec.instrument["light_directions"].shape == (pairs, 3)
    assert rec.instrument["detector_solid_angle_sr"] > 0
    assert set(rec.brdf.lobes) == {"R", "TRT", "T"}
    r = rec.brdf.lobes["R"]
    assert r.value.shape == (pairs, nl) and r.standard_error.shape == (pairs, nl)
    # The arrays are the file's, bit for bit.
    with h5py.File(rec.path) as f:
        np.testing.assert_array_equal(rec.brdf.value, f["brdf/value"][...])
        np.testing.assert_array_equal(rec.brdf.lobes["TRT"].value, f["brdf/lobes/TRT"][...])
    # Slices keep their units.
    assert rec.brdf.value[:2, 0].units == "1/sr"


def test_provenance_and_convergence(rock_dove_results):
    rec = plumage.read_record(rock_dove_results / "brdf/simulation.h5")
    p = rec.provenance
    assert p["scatterer"] and p["plumage_version"] and "study" in p["config"]
    assert isinstance(p["seed"], np.uint64)  # exact to the last bit
    assert int(p["threads"]) == 2 and p["wall_time_s"] > 0
    c = rec.convergence
    assert set(c) == {"pass", "wall_time_s", "quanta", "relative_error"}
    assert c["wall_time_s"].units == "s" and len(c["pass"]) >= 1
    assert np.all(np.diff(c["wall_time_s"]) >= 0)


def test_scatterometer_record(rock_dove_results):
    rec = plumage.read_record(rock_dove_results / "scatterograms/beam_simulation.h5")
    assert rec.kind == "imaging_scatterometer" and rec.brdf is None
    rows, cols, nl = rec.image.value.shape
    assert rec.image.units == "1/sr" and rec.image.standard_error.shape == (rows, cols, nl)
    assert rec.datasets["/image/directions"].shape == (rows, cols, 3)
    assert rec.datasets["/image/solid_angle_sr"].units == "sr"
    assert {"R", "TRT"} <= set(rec.image.lobes)
    assert rec.transmitted_fraction.value.shape == (nl,)
    assert rec.instrument["illumination"] == "beam"


def test_btf_record(species_results):
    rec = plumage.read_record(species_results / "rooster/btf.h5")
    assert rec.kind == "btf_camera"
    assert rec.convergence["pass"].shape == (1,) and 0 < rec.convergence["wall_time_s"][0]
    pairs, rows, cols, nl = rec.btf.value.shape
    assert rec.btf.units == "1/sr" and rec.btf.standard_error.shape == rec.btf.value.shape
    assert rec.instrument["view_directions"].shape == (pairs, 3)
    assert rec.provenance["scatterer"]


def test_study_data_file(rock_dove_results):
    rec = plumage.read_record(rock_dove_results / "fit/huang2022_fit.h5")
    assert rec.kind == "study_data"
    assert rec.datasets["/fit/values"].shape == (7,)
    assert rec.attributes["/fit"]["reduced_chi_square"] > 0


def test_missing_dataset_names_file_and_dataset(rock_dove_results, tmp_path):
    broken = tmp_path / "broken.h5"
    with h5py.File(rock_dove_results / "validation/model.h5") as src, h5py.File(broken, "w") as dst:
        for key in src:
            src.copy(key, dst)
        for k, v in src.attrs.items():
            dst.attrs[k] = v
        del dst["brdf/standard_error"]
    with pytest.raises(plumage.RecordError, match=r"broken\.h5: missing dataset /brdf/standard_error"):
        plumage.read_record(broken)


def test_bad_illumination_of_a_record_names_the_file(rock_dove_results, tmp_path):
    """The Huang fit's view of a scatterogram record a user changed by hand."""
    from plumage import models

    broken = tmp_path / "hand_made.h5"
    for change, message in ((lambda a: a.__delitem__("illumination"),
                             r"hand_made\.h5: /instrument@illumination: missing"),
                            (lambda a: a.__setitem__("beam_direction", "up"),
                             r"hand_made\.h5: /instrument@beam_direction = 'up': expected")):
        with h5py.File(rock_dove_results / "fit/simulation.h5") as src, \
                h5py.File(broken, "w") as dst:
            for key in src:
                src.copy(key, dst)
            for k, v in src.attrs.items():
                dst.attrs[k] = v
            change(dst["instrument"].attrs)
        with pytest.raises(plumage.RecordError, match=message):
            models.fit_huang2022(broken)


def test_not_a_record(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.h5"):
        plumage.read_record(tmp_path / "nothing.h5")
    text = tmp_path / "text.h5"
    text.write_text("not hdf5")
    with pytest.raises(plumage.RecordError, match=r"text\.h5: not an HDF5 file"):
        plumage.read_record(text)


def test_thin_film_chart(tmp_path):
    import subprocess

    from conftest import _binary

    subprocess.run([str(_binary()), "thin-film", "--out", str(tmp_path), "--no-plots"],
                   check=True, capture_output=True)
    rec = plumage.read_record(tmp_path / "thin_film/thin_film_chart.h5")
    assert rec.kind == "thin_film_chart" and rec.wavelength_nm is None
    angles, thicknesses, nl = rec.datasets["/chart/reflectance"].shape
    assert len(rec.datasets["/chart/wavelength_nm"]) == nl
    assert rec.provenance["plumage_version"] and "config" in rec.provenance
