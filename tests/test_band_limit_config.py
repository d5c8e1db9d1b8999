"""``band_limit`` from the experiment to the image: the ``[focus]`` key (validated, naming it),
the raw product's ``focus_band_limit`` request, ``mitsar focus --band-limit/--no-band-limit``,
and :func:`mitsar.experiment.runs.run_focus` passing it to :func:`mitsar.focus`."""

from __future__ import annotations

import copy
import dataclasses

import pytest
import xarray as xr

from mitsar.cli.parser import build_parser
from mitsar.cli.stages import _focus_options
from mitsar.errors import ParameterError
from mitsar.experiment import runs
from mitsar.experiment.loading import experiment_from_dict
from mitsar.experiment.options import FocusOptions
from mitsar.products.requests import focus_request, request_attrs

BASE = {
    "trajectory": {"kind": "linear", "start": [14.9, 1.4, 4.5], "velocity": [0.5, 0.0, 0.0],
                   "duration": 0.4},
    "look": {"off_nadir_deg": 55.7},
    "targets": [{"position": [15.0, 8.0, 0.0]}],
}


def _focus(**keys) -> FocusOptions:
    data = copy.deepcopy(BASE)
    data["focus"] = keys
    return experiment_from_dict(data, source="exp.toml").focus


def test_focus_table_band_limit():
    assert _focus().band_limit is True
    assert _focus(band_limit=False).band_limit is False
    with pytest.raises(ParameterError, match=r"band_limit.*true or false"):
        _focus(band_limit="no")


@pytest.mark.parametrize("value", [True, False])
def test_raw_product_records_band_limit(value):
    attrs = request_attrs(focus=dataclasses.asdict(FocusOptions(band_limit=value)))
    assert attrs["focus_band_limit"] == int(value)  # netCDF has no boolean attribute
    assert focus_request(xr.Dataset(attrs=attrs))["band_limit"] is value
    assert "band_limit" not in focus_request(xr.Dataset())  # an older product: the default


@pytest.mark.parametrize(("flags", "recorded", "expected"),
                         [((), 0, False), (("--band-limit",), 0, True),
                          (("--no-band-limit",), 1, False), ((), None, True)])
def test_cli_flag_over_the_recorded_option(flags, recorded, expected):
    args = build_parser().parse_args(["focus", "raw.nc", "-o", "image.nc", *flags])
    raw = xr.Dataset(attrs={} if recorded is None else {"focus_band_limit": recorded})
    assert _focus_options(args, raw).band_limit is expected


def test_run_focus_passes_band_limit(monkeypatch):
    seen = {}

    def fake_focus(raw, **kwargs):
        seen.update(kwargs)
        return xr.Dataset()

    monkeypatch.setattr(runs, "focus", fake_focus)
    runs.run_focus(xr.Dataset(), FocusOptions(band_limit=False))
    assert seen["band_limit"] is False
