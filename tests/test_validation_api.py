"""Wrong arguments at the public API get mitsar's ParameterError naming the parameter, not
Python's TypeError or an AttributeError from deep inside (issue 27 item 1; mitsar.errors.public,
docs/reliability.md §1)."""

from __future__ import annotations

import inspect
import pickle

import numpy as np
import pytest

import mitsar
from mitsar import ParameterError

RADAR, LOOK = mitsar.Radar(), mitsar.Look(55.71)
TRACK = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0, 0], 0.4)

WRONG = {
    "simulate_point_targets trajectory": (lambda: mitsar.simulate_point_targets(
        RADAR, "track", LOOK, []), "trajectory"),
    "simulate_point_targets radar": (lambda: mitsar.simulate_point_targets(
        {"prf": 250}, TRACK, LOOK, []), "radar"),
    "simulate_scene look": (lambda: mitsar.simulate_scene(RADAR, TRACK, 55.7, "point_target"),
                            "look"),
    "trace missing scene": (lambda: mitsar.trace(RADAR, TRACK, LOOK), "scene"),
    "measure_impulse_response image": (lambda: mitsar.measure_impulse_response(
        "image.nc", (15, 8, 0)), "image"),
    "range_compress raw": (lambda: mitsar.range_compress([1, 2, 3]), "raw"),
    "save path": (lambda: mitsar.save(None, 3), "ds"),
    "read_raw path": (lambda: mitsar.read_raw(42), "path"),
    "read_cphd path": (lambda: mitsar.read_cphd(["a.cphd"]), "path"),
    "read_gotcha folder": (lambda: mitsar.read_gotcha(None), "folder"),
    "load unknown keyword": (lambda: mitsar.load("x.nc", bogus=1), "bogus"),
    "boresight heading text": (lambda: mitsar.boresight(LOOK, "north"), "heading"),
    "raw_from_arrays ragged": (lambda: mitsar.raw_from_arrays(
        np.zeros((2, 8)), [[94e9], [94e9, 95e9]], np.zeros((2, 3))), "frequencies"),
    "interferogram image": (lambda: mitsar.interferogram(object()), "image"),
    "histogram_to_raw_product": (lambda: mitsar.histogram_to_raw_product({"a": 1}),
                                 "histogram"),
}


@pytest.mark.parametrize("case", sorted(WRONG))
def test_wrong_argument_refused_by_name(case: str) -> None:
    call, name = WRONG[case]
    with pytest.raises(ParameterError) as info:
        call()
    assert info.value.name == name, str(info.value)


def test_wrapped_functions_keep_signature_docs_and_pickle() -> None:
    for name in ("focus", "simulate_point_targets", "save", "boresight"):
        function = getattr(mitsar, name)
        assert function is getattr(mitsar, name)  # one wrapper, cached
        assert pickle.loads(pickle.dumps(function)) is function
        assert inspect.signature(function) == inspect.signature(function.__wrapped__)
        assert function.__doc__ == function.__wrapped__.__doc__


def test_valid_arguments_pass_through() -> None:
    # numbers of NumPy types, a pathlib path and None where the annotation allows them
    assert np.allclose(mitsar.boresight(LOOK, np.float32(0.0)), mitsar.boresight(LOOK, 0.0))
    with pytest.raises(mitsar.MitsarError, match="no_such_file"):
        mitsar.load(__import__("pathlib").Path("no_such_file.nc"))


BOUNDED = {
    "PointTarget position": (lambda: mitsar.PointTarget([1e300, 0, 0]), "position"),
    "PointTarget velocity": (lambda: mitsar.PointTarget([1, 0, 0], velocity=[0, 2e3, 0]),
                             "velocity"),
    "Background center": (lambda: mitsar.Background([0, 2e4, 0], (1, 1)), "center"),
    "Background size": (lambda: mitsar.Background([0, 0, 0], (1e300, 1)), "size"),
    "Radar noise figure": (lambda: mitsar.Radar(noise_figure_db=1e300), "noise_figure_db"),
    "NavigationErrors noise": (lambda: mitsar.NavigationErrors(position_noise=(1e300, 0, 0)),
                               "position_noise"),
    "NavigationErrors correlation time": (lambda: mitsar.NavigationErrors(
        position_correlation_time=1e7), "position_correlation_time"),
    "Vibration frequency": (lambda: mitsar.Vibration((1e-3, 0, 0), 1e300),
                            "vibration.frequency"),
}


@pytest.mark.parametrize("case", sorted(BOUNDED))
def test_api_records_bounded_as_the_experiment_files(case: str) -> None:
    """The bounds by unit of mitsar.checks.MAGNITUDE_BOUNDS hold for the classes as for
    their TOML tables (10 km, 1 km/s, 1e6 s, 1000 dB, 10 THz)."""
    call, name = BOUNDED[case]
    with pytest.raises(ParameterError) as info:
        call()
    assert info.value.name == name, str(info.value)


def test_bounds_leave_ordinary_and_infinite_meanings_alone() -> None:
    mitsar.PointTarget([1e4, -1e4, 0.0], velocity=[1e3, 0, 0])  # on the bounds
    mitsar.Radar(noise_figure_db=8.0)
    mitsar.NavigationErrors(position_noise=(1e-3, 0, 0), position_correlation_time=1e6)
