"""Reception per interferometric channel and per pass, and in the report (issue 27 item 1;
docs/reliability.md §"Echoes that cannot be received"): a bistatic channel beats at its half
path (|q - t| + |q - r|) / 2, so a receiver a few centimetres away can put a target at the edge
of the band out of it while the radar's reference point still receives it."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import mitsar
from mitsar.errors import MitsarWarning
from mitsar.model.reception import channel_warnings, fraunhofer_distance, reception

SWEEPS = 9
STILL = np.zeros((SWEEPS, 3))  # the reference point at the origin in every sweep
LEVEL = np.broadcast_to(np.eye(3), (SWEEPS, 3, 3))  # body frame = world frame


def _said(radar: mitsar.Radar, target: list[float]) -> list[str]:
    seen = reception(radar, [target], STILL, LEVEL)
    return channel_warnings(radar, [target], STILL, LEVEL, ["T"], seen)


def test_a_receiver_behind_the_reference_puts_an_edge_target_out_of_band() -> None:
    """Closed form: target at R = max_range - 1 cm on +x, receiver 10 cm behind on -x: the
    channel's half path is (R + R + 0.1) / 2 = max_range + 4 cm, the reference's R."""
    radar = mitsar.Radar(receivers=[(0.0, 0.0, 0.0), (-0.1, 0.0, 0.0)])
    target = [radar.max_range - 0.01, 0.0, 0.0]
    said = _said(radar, target)
    assert len(said) == 1 and "channels [1]" in said[0] and "beyond max_range" in said[0]
    assert f"{radar.max_range + 0.04:.3f} m" in said[0]
    # the same receiver in front (half path max_range - 6 cm): nothing to say
    assert _said(mitsar.Radar(receivers=[(0.0, 0.0, 0.0), (0.1, 0.0, 0.0)]), target) == []


def test_a_receiver_near_the_target_is_in_its_own_near_field() -> None:
    radar = mitsar.Radar(receivers=[(0.0, 0.0, 0.0), (0.3, 0.0, 0.0)])
    far = fraunhofer_distance(radar)
    target = [0.3 + 0.5 * far, 0.0, 0.0]  # beyond far from the reference, within from rx 1
    assert target[0] > far
    said = _said(radar, target)
    assert len(said) == 1 and "near field" in said[0] and "[0.3, 0.0, 0.0]" in said[0]


def test_single_channel_radar_says_nothing_more() -> None:
    assert _said(mitsar.Radar(), [29.99, 0.0, 0.0]) == []


def _simulate(radar: mitsar.Radar, target: np.ndarray) -> tuple[object, list[str]]:
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.4)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raw = mitsar.simulate_point_targets(radar, track, mitsar.Look(55.7),
                                            [mitsar.PointTarget(target)])
    return raw, [str(w.message) for w in caught if issubclass(w.category, MitsarWarning)]


def test_the_analytic_simulator_names_the_channel_and_records_it() -> None:
    """End to end: a target 5 mm inside max_range along the mid-track line of sight, the
    second receiver 5 cm behind the antenna along that line (body frame = world frame here:
    the track flies along +x, level): only channel 1 is out of band."""
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.4)
    middle = np.asarray(track.position(0.2))
    sight = np.array([15.0, 8.0, 0.3]) - middle
    sight /= np.linalg.norm(sight)
    radar = mitsar.Radar(max_range=8.0, receivers=[(0.0, 0.0, 0.0),
                                                   tuple(-0.05 * sight)])
    start, end = (np.linalg.norm(np.array([15.0, 8.0, 0.3]) - track.position(t))
                  for t in (0.0, 0.4))
    target = middle + (radar.max_range - 0.005 - max(start, end)
                       + np.linalg.norm(np.array([15.0, 8.0, 0.3]) - middle)) * sight
    raw, said = _simulate(radar, target)
    channel = [s for s in said if "channels [1]" in s]
    assert len(channel) == 1 and "targets[0]" in channel[0]
    assert not any("beyond max_range in" in s for s in said)  # the reference receives it
    assert channel[0].removeprefix("simulate_point_targets: ") in raw.attrs["reception_warnings"]


@pytest.mark.parametrize("passes", [False, True])
def test_the_report_lists_reception_warnings_per_pass(tmp_path, passes: bool) -> None:
    """run_pipeline records the raw product's reception sentences as warnings, with the pass
    when the product is one pass's (mitsar.report.pipeline)."""
    from mitsar.report.pipeline import RunFolder, run_pipeline

    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.4)
    raw = mitsar.simulate_point_targets(mitsar.Radar(), track, mitsar.Look(55.7),
                                        [mitsar.PointTarget([15.0, 8.0, 0.3])])
    raw.attrs["reception_warnings"] = "targets[0] at [1, 2, 3] m is beyond max_range\nB"
    if passes:
        raw.attrs["pass"] = 2
    run = RunFolder(tmp_path, overwrite=True)
    experiment = mitsar.experiment.load_experiment(
        mitsar.experiment.example_path("paper_point_target"))
    run_pipeline(run, experiment, [], raw=raw)
    label = " (pass 2)" if passes else ""
    assert run.record["warnings"] == [
        f"reception{label}: targets[0] at [1, 2, 3] m is beyond max_range",
        f"reception{label}: B"]


def test_each_pass_says_its_own_reception_warnings_naming_the_pass() -> None:
    """Two passes of the paper's point target, the second 3 m further away: only its echo is
    beyond max_range = 9 m, said with the pass's index and name (mitsar.experiment.runs)."""
    import tomllib

    from mitsar.experiment import example_path, experiment_from_dict, simulate_passes

    document = tomllib.loads(example_path("paper_point_target").read_text())
    document["radar"]["max_range"] = 9.0
    document["trajectory"].update(start=[14.8, 1.4, 4.5], duration=0.2)
    document.pop("background")
    document["passes"] = [{"name": "near"}, {"name": "far", "offset": [0.0, -3.0, 0.0]}]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raws = simulate_passes(experiment_from_dict(document))
    said = [str(w.message) for w in caught if issubclass(w.category, MitsarWarning)
            and "max_range" in str(w.message)]
    assert len(said) == 1 and said[0].startswith("pass 1 (far): ")
    assert "reception_warnings" not in raws[0].attrs
    assert "beyond max_range" in raws[1].attrs["reception_warnings"]


def test_the_tracer_checks_a_scene_point_target_per_channel() -> None:
    """The canned point_target scene (T_p = [15, 8, 0.03] m) traced by an interferometer whose
    second receiver is 5 cm behind the antenna along the line of sight, max_range 5 mm beyond
    the reference point's farthest range: the tracer names channel 1 (and records it)."""
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.02)
    aim = np.array([15.0, 8.0, 0.03])
    middle = np.asarray(track.position(0.01))
    sight = (aim - middle) / np.linalg.norm(aim - middle)
    far = max(np.linalg.norm(aim - track.position(t)) for t in (0.0, 0.02))
    radar = mitsar.Radar(max_range=far + 0.005, receivers=[(0.0, 0.0, 0.0),
                                                           tuple(-0.05 * sight)])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raw = mitsar.simulate_scene(radar, track, mitsar.Look(55.7), "point_target")
    said = [str(w.message) for w in caught if "channels [1]" in str(w.message)]
    assert len(said) == 1 and "the scene's point target 0" in said[0]
    assert "channels [1]" in raw.attrs["reception_warnings"]
