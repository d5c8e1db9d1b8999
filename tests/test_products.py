"""The product schemas (mitsar.products): makers and validators agree, validators name what is
missing, and what a run asks of later stages survives a file."""

from __future__ import annotations

import numpy as np
import pytest

import mitsar
from mitsar.errors import ParameterError
from mitsar.io import load, save
from mitsar.products.image import validate_image
from mitsar.products.raw import validate_raw
from mitsar.products.requests import (
    focus_request,
    metrics_request,
    request_attrs,
    scene_of,
    target_positions,
)
from mitsar.products.schema import OPTIONAL_DIMS


@pytest.fixture(scope="module")
def products():
    radar = mitsar.Radar()
    trajectory = mitsar.Trajectory.linear([0.0, 8.0, 1.0], [0.5, 0, 0], 0.2)
    raw = mitsar.simulate_point_targets(radar, trajectory, mitsar.Look(60.0),
                                        [mitsar.PointTarget([0.05, 9.7, 0.0])], normalized=True)
    image = mitsar.focus(raw, grid=mitsar.grid.SlantGrid(along_track=[0, 0.1, 0.05],
                                                        slant_range=[1.0, 3.0, 0.5]))
    return raw, image


def test_makers_and_validators_agree(products):
    raw, image = products
    assert validate_raw(raw) is raw
    assert validate_image(image) is image
    np.testing.assert_allclose(target_positions(raw), [[0.05, 9.7, 0.0]])
    np.testing.assert_allclose(target_positions(image), [[0.05, 9.7, 0.0]])


def test_validators_name_what_is_missing(products):
    raw, image = products
    with pytest.raises(ParameterError, match="'raw'"):
        validate_raw(raw.drop_vars("raw"))
    with pytest.raises(ParameterError, match="look_off_nadir_deg"):
        validate_raw(_without(raw, "look_off_nadir_deg"))
    with pytest.raises(ParameterError, match="coverage"):
        validate_image(image.drop_vars("coverage"))
    with pytest.raises(ParameterError, match="product='raw'"):
        validate_raw(image)


def test_optional_dims_are_declared(products):
    raw, _ = products
    assert set(OPTIONAL_DIMS) == {"channel", "pass"}
    stacked = raw.expand_dims(channel=2)
    stacked["slow_time"] = raw["slow_time"]
    validate_raw(stacked.assign_coords(slow_time=raw["slow_time"]))


def test_requests_survive_a_file(products, tmp_path):
    raw, _ = products
    raw = raw.copy()
    raw.attrs.update(request_attrs(
        config={"name": "x"}, source="x.toml", name="x", scene="point_target",
        targets=[[1.0, 2.0, 3.0]], islr_extent=5.0,
        focus={"algorithm": "rda", "window": "hann", "azimuth_resolution": None,
               "grid": {"kind": "slant", "along_track": [0, 1, 0.1]}, "autofocus": None}))
    back = load(save(raw, tmp_path / "raw.nc"))
    assert metrics_request(back) == ([1.0, 2.0, 3.0], 5.0)
    assert focus_request(back) == {"algorithm": "rda", "window": "hann",
                                   "grid": {"kind": "slant", "along_track": [0, 1, 0.1]}}
    assert scene_of(back) == "point_target"
    np.testing.assert_allclose(target_positions(back), [[1.0, 2.0, 3.0]])


def _without(product, key):
    out = product.copy()
    out.attrs = {k: v for k, v in product.attrs.items() if k != key}
    return out
