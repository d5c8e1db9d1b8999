"""GPU path (docs/gpu.md): every Dr.Jit kernel family of mitsar on each JIT backend.

Families: the analytic point-target simulator (``simulate_point_targets``), the back-projection
kernel (BPA, ``backproject_drjit``), fast factorised back-projection (FFBP), the ray tracer
(``simulate_scene`` in the Mitsuba variant ``llvm_ad_mono`` / ``cuda_ad_mono``) and the
spectral focusers (RDA, WDA, FSA: NumPy on the CPU whatever the backend, fed with raw data
simulated on it). Each runs on LLVM (CPU) and CUDA (NVIDIA GPU) through
:func:`mitsar.backend.use_backend` and is checked against a backend-free reference (the NumPy
float64 twin of the kernel, exact BPA, the analytic simulator); where both backends run,
``test_cuda_matches_llvm`` compares them directly.

A backend that cannot run here is skipped with the reason in the report (``pytest -rs``): CUDA
without a device or driver, LLVM without libLLVM >= 16. The errors are relative,
``20 log10(||x - reference|| / ||reference||)`` [dB] over the whole product; each test prints
its measured value (``pytest -s``) for the record in docs/gpu.md.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mitsar
from mitsar import backend
from mitsar.backend import BackendError, use_backend
from mitsar.errors import ParameterError
from mitsar.focus.backprojection import backproject_drjit, backproject_numpy
from mitsar.focus.bp_tiled import backproject_tiled
from mitsar.focus.compression import range_spectrum
from mitsar.focus.grid import SlantGrid
from mitsar.focus.windows import window_coefficients
from mitsar.plugins.variant import DEFAULT_VARIANT, GPU_VARIANT, register_plugins
from mitsar.raw.traced import simulate_scene

mi = pytest.importorskip("mitsuba")
dr = pytest.importorskip("drjit")

BACKENDS = ("llvm", "cuda")
VARIANTS = {"llvm": DEFAULT_VARIANT, "cuda": GPU_VARIANT}
CANNED_TARGET = np.array([15.0, 8.0, 0.03])  # scenes/point_target.xml
RADAR = mitsar.Radar()
PAIR = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, 0.05)])  # a vertical interferometer (5 cm)
LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
TARGET = np.array([15.0, 8.0, 0.0])
SLANT = SlantGrid(along_track=[0.7, 1.3, 0.01], slant_range=[7.7, 8.3, 0.01])
SPECTRAL = ("rda", "wda", "fsa")


def error_db(value: np.ndarray, reference: np.ndarray) -> float:
    """Relative error [dB] of ``value`` against ``reference`` over all elements."""
    return 20 * math.log10(np.linalg.norm(value - reference) / np.linalg.norm(reference))


def _report(what: str, name: str, db: float) -> None:
    print(f"\nGPU-CHECK {what} [{name}]: {db:.1f} dB")


def _unavailable(name: str) -> str | None:
    """Why backend ``name`` cannot run here, or None when it can."""
    if name == "cuda":
        if GPU_VARIANT not in mi.variants():
            return f"this Mitsuba build has no {GPU_VARIANT} variant"
        if not backend.cuda_available():
            return "no CUDA device (Dr.Jit has no CUDA backend: no GPU or no driver)"
        return None
    ok, detail = backend.llvm_probe()
    return None if ok else f"Dr.Jit's LLVM backend cannot run (libLLVM >= 16): {detail[-200:]}"


@pytest.fixture(params=BACKENDS)
def jit(request: pytest.FixtureRequest) -> str:
    """The backend under test, active for the test (skipped with the reason if unusable)."""
    if (reason := _unavailable(request.param)) is not None:
        pytest.skip(reason)
    with use_backend(request.param) as name:
        yield name


@pytest.fixture
def variant(jit: str) -> str:
    """The Mitsuba variant of the backend under test, restored to what was active afterwards."""
    before = mi.variant()
    yield register_plugins(VARIANTS[jit])
    if before is not None and before != mi.variant():
        register_plugins(before)


# --------------------------------------------------------------------------------------------
# Workloads (small: the CPU suite runs them too)
# --------------------------------------------------------------------------------------------
def _simulate(kind: str = "drjit") -> np.ndarray:
    """Raw data of two targets and a frozen background (67 scatterers), 100 sweeps."""
    trajectory = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0, 0], 100 / RADAR.prf)
    targets = [mitsar.PointTarget(TARGET), mitsar.PointTarget([14.9, 7.5, 0.2], rcs=0.5)]
    background = mitsar.Background(TARGET, (0.3, 0.3), mode="frozen")
    return mitsar.simulate_point_targets(RADAR, trajectory, LOOK, targets, background, seed=1,
                                         backend=kind)["raw"].values


def _bpa_arguments() -> tuple:
    """Arguments of the BPA kernel: 400 sweeps onto 24 x 24 ground pixels around the target."""
    trajectory = mitsar.Trajectory.linear([14.5, 1.4, 4.5], [0.5, 0, 0], 400 / RADAR.prf)
    raw = mitsar.simulate_point_targets(RADAR, trajectory, LOOK, [mitsar.PointTarget(TARGET)],
                                        normalized=True, backend="numpy")
    frequency, profile = range_spectrum(raw["raw"].values, RADAR, upsample=16)
    side = np.linspace(-0.3, 0.3, 24)
    grid_x, grid_y = np.meshgrid(TARGET[0] + side, TARGET[1] + side, indexing="ij")
    pixels = np.stack([grid_x, grid_y, np.zeros_like(grid_x)], -1).reshape(-1, 3)
    return (profile, frequency, RADAR, pixels, raw["platform_position"].values,
            raw["platform_velocity"].values, raw["boresight"].values @ np.array([1.0, 0, 0]),
            1.0, window_coefficients("rect"))


def _straight_raw(kind: str = "drjit"):  # noqa: ANN202 - xarray.Dataset
    """1000 sweeps (4 s at 0.5 m/s) past the target 8 m away, as tests/test_ffbp.py."""
    trajectory = mitsar.Trajectory.linear([14.0, 1.4, 4.5], [0.5, 0, 0], 4.0)
    return mitsar.simulate_point_targets(RADAR, trajectory, LOOK, [mitsar.PointTarget(TARGET)],
                                         normalized=True, backend=kind)


def _focus(raw, algorithm: str) -> np.ndarray:  # noqa: ANN001 - xarray.Dataset
    return mitsar.focus(raw, algorithm=algorithm, grid=SLANT,
                        azimuth_resolution=0.1)["image"].values


def _traced(radar: mitsar.Radar = RADAR) -> np.ndarray:
    """Traced raw data of the canned point target, 20 sweeps, in the active variant."""
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.08)
    return simulate_scene(radar, track, LOOK, "point_target")["raw"].values


def _pair_raw(kind: str = "drjit"):  # noqa: ANN202 - xarray.Dataset
    """Two receive channels (``PAIR``), 400 sweeps past the target."""
    trajectory = mitsar.Trajectory.linear([14.5, 1.4, 4.5], [0.5, 0, 0], 400 / RADAR.prf)
    return mitsar.simulate_point_targets(PAIR, trajectory, LOOK, [mitsar.PointTarget(TARGET)],
                                         normalized=True, backend=kind)


# --------------------------------------------------------------------------------------------
# Each backend against a backend-free reference
# --------------------------------------------------------------------------------------------
def test_analytic_simulator_matches_its_numpy_twin(jit: str) -> None:
    """float64 geometry and phase, float32 sin/cos of the wrapped phase (error < 1e-6 rad,
    i.e. below -120 dB); measured -145 dB on LLVM."""
    error = error_db(_simulate(), _simulate("numpy"))
    _report("analytic simulator vs NumPy", jit, error)
    assert error < -120.0


def test_bpa_kernel_matches_its_numpy_twin(jit: str) -> None:
    """float32 interpolation, sin/cos and sums against the float64 NumPy sum: 1e-6 of the peak
    (docs/focusing.md, kernel speed), below -100 dB; measured -124 dB on LLVM."""
    arguments = _bpa_arguments()
    kernel, total = backproject_drjit(*arguments)
    reference, reference_total = backproject_numpy(*arguments)
    error = error_db(kernel, reference)
    _report("BPA kernel vs NumPy", jit, error)
    assert error < -100.0
    np.testing.assert_allclose(total, reference_total, rtol=1e-5)


def test_bpa_by_pixel_groups_matches_the_numpy_sum(jit: str) -> None:
    """The pixel-group kernel (``focus(algorithm="bpa")``'s path, mitsar/focus/bp_tiled.py)
    against the float64 NumPy sum of the same profiles: its module docstring's budget (third
    order expansion <= 1e-4 rad, float32 offsets ~1e-5 rad, sin/cos 1.2e-6) gives -100 to
    -130 dB; bound -90 dB."""
    arguments = _bpa_arguments()
    tiled, total, info = backproject_tiled(*arguments, row_length=24)
    reference, reference_total = backproject_numpy(*arguments)
    error = error_db(tiled, reference)
    _report(f"BPA by pixel groups (G = {info['lane_pixels']}) vs NumPy", jit, error)
    assert info["lane_pixels"] > 1  # the lanes ran, not only the exact fallback
    assert error < -85.0
    np.testing.assert_allclose(total, reference_total, rtol=1e-5)


def test_bpa_focus_takes_the_faster_kernel_of_each_backend(jit: str) -> None:
    """focus(algorithm="bpa") sums by pixel groups on the CPU (1.3-1.4x the exact kernel on 16
    cores) and with the exact kernel on a GPU (1.6-1.9x the groups on an H100), docs/gpu.md §6;
    the image records which (``bp_kernel``)."""
    image = mitsar.focus(_straight_raw(), algorithm="bpa", grid=SLANT, azimuth_resolution=0.1)
    expected = ("exact",) if jit == "cuda" else ("tiled", "tiled+exact")
    assert image.attrs["bp_kernel"] in expected


def test_interferometric_phase_on_each_backend(jit: str) -> None:
    """Two receivers focused by BPA onto one grid: the phase of the interferogram at the
    target's pixel equals the exact 2 pi (R1 - R2) / lambda of the two receivers' bistatic
    paths, within 1 mrad (issue 22), on each backend."""
    image = mitsar.focus(_pair_raw(), algorithm="bpa", grid=SLANT)["image"].values
    peak = np.unravel_index(np.argmax(np.abs(image[0])), image[0].shape)
    reference = mitsar.focus(_pair_raw("numpy"), algorithm="bpa", grid=SLANT,
                             backend="numpy")["image"].values
    measured = np.angle(image[0][peak] * np.conj(image[1][peak]))
    expected = np.angle(reference[0][peak] * np.conj(reference[1][peak]))
    difference = abs(np.angle(np.exp(1j * (measured - expected))))
    print(f"\nGPU-CHECK interferometric phase vs NumPy BPA [{jit}]: {difference * 1e3:.2e} mrad")
    assert difference < 1e-3


def test_ffbp_matches_exact_bpa(jit: str) -> None:
    """FFBP's interpolation error against exact BPA on the same backend: the -35 dB requirement
    of tests/test_ffbp.py (measured -44 dB on LLVM)."""
    raw = _straight_raw()
    error = error_db(_focus(raw, "ffbp"), _focus(raw, "bpa"))
    _report("FFBP vs BPA", jit, error)
    assert error < -35.0


@pytest.mark.parametrize("algorithm", SPECTRAL)
def test_spectral_focusers_on_raw_data_of_each_backend(jit: str, algorithm: str) -> None:
    """RDA/WDA/FSA are NumPy on the CPU on every backend (docs/gpu.md); fed with raw data
    simulated on the backend they give the image of the NumPy-simulated raw data to better
    than -120 dB (the simulator's float32 sin/cos; measured -176 dB on LLVM), and agree with
    BPA on the same backend within the frequency-domain bound of tests/test_focus_fft.py
    (-35 dB; measured -42 to -47 dB)."""
    raw = _straight_raw()
    image = _focus(raw, algorithm)
    error = error_db(image, _focus(_straight_raw("numpy"), algorithm))
    against_bpa = error_db(image, _focus(raw, "bpa"))
    _report(f"{algorithm.upper()} (raw from the backend) vs (raw from NumPy)", jit, error)
    _report(f"{algorithm.upper()} vs BPA", jit, against_bpa)
    assert error < -120.0
    assert against_bpa < -35.0


def test_traced_point_target_matches_the_analytic_simulator_in_each_variant(variant: str
                                                                            ) -> None:
    assert mi.variant() == variant
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.08)  # 20 sweeps
    analytic = mitsar.simulate_point_targets(RADAR, track, LOOK,
                                             [mitsar.PointTarget(CANNED_TARGET)])
    error = error_db(_traced(), analytic["raw"].values)
    _report("tracer vs analytic simulator", variant, error)
    # -50 dB: the histogram's first-order tone model against exact per-sample delays
    # (docs/design.md §5.5: -54 to -56 dB); float32 on either backend does not change it.
    assert error < -50.0


# --------------------------------------------------------------------------------------------
# CUDA against LLVM, where both run
# --------------------------------------------------------------------------------------------
def _on(name: str, family: str) -> np.ndarray:
    """The product of one kernel family computed on backend ``name``."""
    with use_backend(name):
        if family == "analytic":
            return _simulate()
        if family == "bpa":
            return backproject_drjit(*_bpa_arguments())[0]
        if family == "bpa_tiled":
            return backproject_tiled(*_bpa_arguments(), row_length=24)[0]
        if family == "bpa_channels":
            return mitsar.focus(_pair_raw(), algorithm="bpa", grid=SLANT)["image"].values
        if family in ("ffbp", *SPECTRAL):
            return _focus(_straight_raw(), family)
        before = mi.variant()
        register_plugins(VARIANTS[name])
        try:
            return _traced(PAIR if family == "tracer_channels" else RADAR)
        finally:
            if before is not None and before != mi.variant():
                register_plugins(before)


# Bounds [dB]: each backend meets its reference bound above, so by the triangle inequality
# the two differ by at most twice that (+6 dB); the spectral images inherit the simulator's
# difference. FFBP is the exception: its merges re-phase in float32 (ranges near 8 m to
# ~1e-6 m, i.e. 3e-3 rad at 2 f_c / c = 513 cycles/m, about -50 dB), and the backends round
# differently there (CUDA fuses multiply-adds), so CUDA and LLVM differ near that floor:
# -53.7 dB measured on an H200 (docs/gpu.md), still below FFBP's own -44 dB against BPA.
# The pixel-group kernel (bpa_tiled) is bounded at -85 dB against NumPy, hence -79 dB here
# (-91.3 dB measured on an H100). Two focused channels (bpa_channels: the bistatic exact
# kernel inside focus()) differ by -76.3 dB on the H100: their interferometric phases differ
# by 3.5e-5 rad from NumPy's on CUDA, 7e-6 rad on LLVM (test_interferometric_phase_...), far
# inside issue 22's 1 mrad; the cause of CUDA's larger difference was not isolated. Bound -70 dB.
# Measured on the H200 otherwise: analytic -188.5, BPA -136.7, RDA/WDA/FSA -222.1,
# tracer -109.1 dB.
CROSS_BOUNDS = {"analytic": -114.0, "bpa": -94.0, "bpa_tiled": -79.0, "bpa_channels": -70.0,
                "ffbp": -45.0, "rda": -114.0, "wda": -114.0, "fsa": -114.0, "tracer": -44.0,
                "tracer_channels": -44.0}


@pytest.mark.parametrize("family", list(CROSS_BOUNDS))
def test_cuda_matches_llvm(family: str) -> None:
    reasons = [f"{name}: {reason}" for name in BACKENDS
               if (reason := _unavailable(name)) is not None]
    if reasons:
        pytest.skip("needs both backends; " + "; ".join(reasons))
    error = error_db(_on("cuda", family), _on("llvm", family))
    _report(f"{family} CUDA vs LLVM", "cuda/llvm", error)
    assert error < CROSS_BOUNDS[family]


# --------------------------------------------------------------------------------------------
# The backend choice (runs everywhere)
# --------------------------------------------------------------------------------------------
def test_backend_choice_follows_argument_block_and_environment(monkeypatch: pytest.MonkeyPatch
                                                               ) -> None:
    monkeypatch.delenv(backend.BACKEND_ENV, raising=False)
    automatic = "cuda" if backend.cuda_available() else "llvm"
    assert backend.backend_name() == automatic
    monkeypatch.setenv(backend.BACKEND_ENV, "LLVM")
    assert backend.backend_name() == "llvm"
    with use_backend("cuda") as name:
        assert name == "cuda" and backend.backend_name() == "cuda"
        assert backend.backend_name("llvm") == "llvm"
        with use_backend(None) as inner:
            assert inner == "cuda"
    assert backend.backend_name() == "llvm"
    monkeypatch.setenv(backend.BACKEND_ENV, "auto")
    assert backend.backend_name() == automatic
    monkeypatch.setenv(backend.BACKEND_ENV, "opencl")
    with pytest.raises(ParameterError, match="MITSAR_BACKEND"):
        backend.backend_name()


@pytest.mark.skipif(_unavailable("llvm") is not None, reason="LLVM backend unusable here")
def test_kernels_build_on_the_chosen_backend() -> None:
    import drjit.llvm

    with use_backend("llvm"):
        namespace = backend.array_namespace()
        assert namespace is drjit.llvm
        assert backend.namespace_of(namespace.Float32([1.0])) is drjit.llvm


@pytest.mark.skipif(backend.cuda_available(), reason="a CUDA device is present")
def test_cuda_without_a_device_fails_early_with_the_fix(monkeypatch: pytest.MonkeyPatch
                                                        ) -> None:
    monkeypatch.setenv(backend.BACKEND_ENV, "cuda")
    with pytest.raises(BackendError, match="MITSAR_BACKEND=llvm"):
        backend.array_namespace()
    with pytest.raises(BackendError, match="no CUDA device"):
        mitsar.simulate_point_targets(RADAR, mitsar.Trajectory.linear(
            [14.8, 1.4, 4.5], [0.5, 0, 0], 4 / RADAR.prf), LOOK, [mitsar.PointTarget(TARGET)])

