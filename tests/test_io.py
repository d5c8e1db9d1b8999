"""Products on disk: complex round trip, attribute sanitising, overwrite protection, atomicity."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from mitsar import io
from mitsar.errors import MitsarError


def _product(kind: str = "raw") -> xr.Dataset:
    rng = np.random.default_rng(1)
    data = rng.standard_normal((4, 5)) + 1j * rng.standard_normal((4, 5))
    return xr.Dataset(
        {"raw": (("sweep", "sample"), data, {"units": "sqrt(W)", "flag": True}),
         "single": (("sweep",), data[:, 0].astype(np.complex64)),
         "mask": (("sweep",), np.array([True, False, True, True]))},
        coords={"slow_time": ("sweep", np.arange(4) * 4e-3, {"units": "s"})},
        attrs={"product": kind, "rvp": True, "noise_figure_db": None,
               "config": {"seed": 3, "look": {"off_nadir_deg": 55.7}},
               "range_axis": [0.0, 1.0], "nested": [[1, 2], [3, 4]], "name": "test"})


def test_complex_round_trip_with_plain_xarray(tmp_path):
    ds = _product()
    path = io.save(ds, tmp_path / "raw.nc")
    with xr.open_dataset(path) as back:  # any reader, not only mitsar.io.load
        assert back["raw"].dtype == np.complex128
        np.testing.assert_array_equal(back["raw"].values, ds["raw"].values)
        assert back["single"].dtype == np.complex64
        np.testing.assert_array_equal(back["single"].values, ds["single"].values)
        np.testing.assert_array_equal(back["slow_time"].values, ds["slow_time"].values)


def test_attributes_are_sanitised(tmp_path):
    back = io.load(io.save(_product(), tmp_path / "raw.nc"))
    assert back.attrs["product"] == "raw"
    assert back.attrs["rvp"] == 1
    assert "noise_figure_db" not in back.attrs
    assert json.loads(back.attrs["config"]) == {"seed": 3, "look": {"off_nadir_deg": 55.7}}
    np.testing.assert_array_equal(back.attrs["range_axis"], [0.0, 1.0])
    assert json.loads(back.attrs["nested"]) == [[1, 2], [3, 4]]
    assert back["raw"].attrs["flag"] == 1
    assert back["mask"].dtype == bool


def test_sanitize_attrs_values():
    clean = io.sanitize_attrs({"a": True, "b": None, "c": {"x": np.float64(1.5)},
                               "d": (1, 2, 3), "e": "text", "f": 2.5})
    assert clean["a"] == 1 and "b" not in clean
    assert json.loads(clean["c"]) == {"x": 1.5}
    np.testing.assert_array_equal(clean["d"], [1, 2, 3])
    assert clean["e"] == "text" and clean["f"] == 2.5


def test_load_is_detached_from_the_file(tmp_path):
    path = io.save(_product(), tmp_path / "raw.nc")
    back = io.load(path)
    path.unlink()  # the file is closed and the data already in memory
    assert back["raw"].values.shape == (4, 5)


def test_no_overwrite_without_flag(tmp_path):
    path = io.save(_product(), tmp_path / "raw.nc")
    before = path.read_bytes()
    with pytest.raises(io.OutputExistsError, match="--overwrite") as info:
        io.save(_product("image"), path)
    assert str(path) in str(info.value)
    assert isinstance(info.value, MitsarError) and isinstance(info.value, FileExistsError)
    assert path.read_bytes() == before
    io.save(_product("image"), path, overwrite=True)
    assert io.load(path).attrs["product"] == "image"


def test_failed_write_leaves_nothing(tmp_path, monkeypatch):
    def broken_writer(ds, path):
        path.write_bytes(b"partial")
        raise RuntimeError("disk full")

    monkeypatch.setattr(io.products, "_write_netcdf", broken_writer)
    with pytest.raises(RuntimeError, match="disk full"):
        io.save(_product(), tmp_path / "raw.nc")
    assert list(tmp_path.iterdir()) == []


def test_failed_overwrite_keeps_the_old_file(tmp_path, monkeypatch):
    path = io.save(_product(), tmp_path / "raw.nc")
    before = path.read_bytes()

    def broken_writer(ds, target):
        raise OSError("interrupted")

    monkeypatch.setattr(io.products, "_write_netcdf", broken_writer)
    with pytest.raises(OSError, match="interrupted"):
        io.save(_product("image"), path, overwrite=True)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["raw.nc"]


def test_load_missing_file(tmp_path):
    with pytest.raises(io.ProductFileError, match="no such file"):
        io.load(tmp_path / "nothing.nc")


def test_load_non_netcdf_file(tmp_path):
    path = tmp_path / "notes.nc"
    path.write_text("not a netCDF file\n")
    with pytest.raises(io.ProductFileError, match="not a readable netCDF4/HDF5"):
        io.load(path)


def test_load_non_mitsar_file(tmp_path):
    path = tmp_path / "other.nc"
    xr.Dataset({"x": ("i", np.arange(3))}).to_netcdf(path, engine="h5netcdf")
    with pytest.raises(io.ProductFileError, match="not a mitsar product.*'product'"):
        io.load(path)


def test_load_checks_the_product_type(tmp_path):
    path = io.save(_product("image"), tmp_path / "image.nc")
    with pytest.raises(io.ProductFileError, match="expected a product of type 'raw'.*'image'"):
        io.load(path, product="raw")
    assert io.load(path, product=("raw", "image")).attrs["product"] == "image"


def test_missing_output_folder(tmp_path):
    with pytest.raises(io.ProductFileError, match="does not exist"):
        io.save(_product(), tmp_path / "missing" / "raw.nc")


def test_write_json_atomic_and_protected(tmp_path):
    path = io.write_json({"a": np.float64(1.5), "b": float("nan"), "c": np.arange(2)},
                         tmp_path / "m.json")
    assert json.loads(path.read_text()) == {"a": 1.5, "b": None, "c": [0, 1]}
    with pytest.raises(io.OutputExistsError):
        io.write_json({}, path)
