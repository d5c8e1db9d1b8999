"""GPU readiness: the ray tracer run in each JIT variant mitsar supports, LLVM (CPU) and CUDA.

The ``variant`` fixture selects the Mitsuba variant; the CUDA case is skipped, with the reason,
where this Mitsuba build has no ``cuda_ad_mono`` or Dr.Jit finds no CUDA device (docs/gpu.md).
In every variant the traced raw data of the canned point target must reproduce the analytic
simulator, as in ``tests/test_trace.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mitsar
from mitsar.raw.traced import simulate_scene
from mitsar.scene.variant import DEFAULT_VARIANT, GPU_VARIANT, register_plugins

mi = pytest.importorskip("mitsuba")
dr = pytest.importorskip("drjit")

CANNED_TARGET = np.array([15.0, 8.0, 0.03])  # mitsar/scene/canned/point_target.xml


def _cuda_missing() -> str | None:
    """Why the CUDA variant cannot run here, or None when it can."""
    if GPU_VARIANT not in mi.variants():
        return f"this Mitsuba build has no {GPU_VARIANT} variant"
    try:
        if not dr.has_backend(dr.JitBackend.CUDA):
            return "no CUDA device (Dr.Jit has no CUDA backend: no GPU or no driver)"
    except Exception as error:  # noqa: BLE001 - an old Dr.Jit or a broken driver
        return f"CUDA backend unusable: {error}"
    return None


@pytest.fixture(params=[DEFAULT_VARIANT, GPU_VARIANT])
def variant(request):
    """The Mitsuba variant under test, restored to what was active afterwards."""
    if request.param == GPU_VARIANT and (reason := _cuda_missing()) is not None:
        pytest.skip(reason)
    before = mi.variant()
    yield register_plugins(request.param)
    if before is not None and before != mi.variant():
        register_plugins(before)


def test_traced_point_target_matches_the_analytic_simulator_in_each_variant(variant):
    assert mi.variant() == variant
    radar, look = mitsar.Radar(), mitsar.Look(55.71)
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.08)  # 20 sweeps
    traced = simulate_scene(radar, track, look, "point_target")
    analytic = mitsar.simulate_point_targets(radar, track, look,
                                             [mitsar.PointTarget(CANNED_TARGET)])
    error = np.sum(np.abs(traced["raw"].values - analytic["raw"].values) ** 2)
    relative_db = 10 * math.log10(error / np.sum(np.abs(analytic["raw"].values) ** 2))
    # -50 dB: the histogram's first-order tone model against exact per-sample delays
    # (docs/design.md §5.5: -54 to -56 dB); float32 on either backend does not change it.
    assert relative_db < -50.0
