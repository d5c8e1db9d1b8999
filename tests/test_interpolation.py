"""Interpolation of the range profiles (mitsar.focus.interpolation) against closed forms.

A profile zero-padded U times is sampled U times finer than its resolution: its components
are ``exp(j 2 pi nu x)`` (x in bins) with ``|nu| <= 1 / (2 U)``. For such a tone the
Lagrange remainder gives the error at fraction t exactly up to where the derivative is taken,
``|2 pi nu|^n / n! * |prod (t - x_j)|`` (n taps), so the error at the band edge, half way
between bins, lies within a few percent of :func:`error_bound` (eq. 2 of the module) and falls
as ``U^-4`` (cubic) or ``U^-2`` (linear). Tolerances: 10 % on the bound's attainment (the
derivative varies by ``cos`` of at most ``pi / U`` across the taps) and 20 % on the slope.
"""

import math

import numpy as np
import pytest

import mitsar
from mitsar.focus import interpolation
from mitsar.focus.backprojection import backproject_drjit, backproject_numpy
from mitsar.focus.bp_tiled import backproject_tiled
from mitsar.focus.compression import range_spectrum
from mitsar.focus.grid import PlaneGrid
from mitsar.focus.windows import window_coefficients

RADAR = mitsar.Radar()
TARGET = np.array([15.0, 8.0, 0.0])


def _interpolate(samples: np.ndarray, position: np.ndarray, kind: str,
                 periodic: bool = False) -> np.ndarray:
    """The NumPy path of the back-projection sums: coefficient table, then Horner."""
    table = interpolation.coefficient_table(samples, kind, periodic)
    lower = np.floor(position).astype(int)
    terms = tuple(table[lower % len(samples)].T)
    return interpolation.horner(terms, position - lower, interpolation.numpy_fma)


def _tone_error(upsample: float, kind: str, fractions: np.ndarray) -> float:
    nu = 1.0 / (2 * upsample)            # the band edge of a U-times zero-padded profile
    x = np.arange(64)
    samples = np.exp(2j * np.pi * nu * x)
    position = 30 + fractions
    exact = np.exp(2j * np.pi * nu * position)
    return float(np.abs(_interpolate(samples, position, kind) - exact).max())


@pytest.mark.parametrize("kind", ["linear", "cubic"])
def test_band_edge_error_follows_the_lagrange_remainder(kind):
    fractions = np.linspace(0.0, 1.0, 201)[:-1]
    for upsample in (4, 8, 16):
        error = _tone_error(upsample, kind, fractions)
        bound = interpolation.error_bound(upsample, kind)
        assert 0.9 * bound <= error <= 1.1 * bound, (upsample, error, bound)
    slope = _tone_error(8, kind, fractions) / _tone_error(16, kind, fractions)
    assert slope == pytest.approx(4.0 if kind == "linear" else 16.0, rel=0.2)


def test_a_shared_cubic_lookup_stays_within_five_thirds_of_the_bound():
    """A packet shared by neighbouring pixels (mitsar.focus.bp_tiled, step 5) is evaluated at
    t in [-1/2, 3/2): the remainder's product reaches 15/16 at both ends instead of 9/16, so
    the band-edge error is 5/3 of the per-pixel bound (attained within 10 %, as above), still
    below -60 dB at 8x; and past that interval (t = 2) it is well above, so the kernel's span
    limit matters."""
    def shared_error(upsample: float, t: np.ndarray) -> float:  # bin 30's packet at t
        nu = 1.0 / (2 * upsample)
        samples = np.exp(2j * np.pi * nu * np.arange(64))
        terms = tuple(interpolation.coefficient_table(samples, "cubic")[30])
        value = interpolation.horner(terms, t, interpolation.numpy_fma)
        return float(np.abs(value - np.exp(2j * np.pi * nu * (30 + t))).max())

    for upsample in (8, 16):
        error = shared_error(upsample, np.linspace(-0.5, 1.5, 401)[:-1])
        bound = interpolation.error_bound(upsample, "cubic", shared=True)
        assert bound == pytest.approx(5 / 3 * interpolation.error_bound(upsample, "cubic"))
        assert 0.9 * bound <= error <= 1.1 * bound, (upsample, error, bound)
    assert 20 * math.log10(interpolation.error_bound(8, "cubic", shared=True)) < -60.0
    beyond = shared_error(8, np.linspace(-1.5, 2.5, 401))
    assert beyond > 5 * interpolation.error_bound(8, "cubic", shared=True)


def test_cubic_at_8x_beats_linear_at_16x_and_the_60_db_bound():
    """The choice of focus()'s defaults (docs/focusing.md, error budget): the cubic's worst
    component at 8x is -65 dB, the old linear 16x default's -46 dB."""
    assert 20 * math.log10(interpolation.error_bound(8, "cubic")) < -60.0
    assert 20 * math.log10(interpolation.error_bound(16, "linear")) > -50.0


def test_polynomials_interpolate_their_taps_and_wrap_when_periodic():
    rng = np.random.default_rng(3)
    samples = rng.normal(size=12) + 1j * rng.normal(size=12)
    # a cubic through four taps is exact on a cubic: p(x) = 1 - 2x + 0.5x^2 - 0.1x^3 (+ j ...)
    x = np.arange(12.0)
    cubic = (1 - 2 * x + 0.5 * x ** 2 - 0.1 * x ** 3) * (1 + 0.5j)
    position = np.linspace(1.0, 9.0, 37)
    exact = (1 - 2 * position + 0.5 * position ** 2 - 0.1 * position ** 3) * (1 + 0.5j)
    np.testing.assert_allclose(_interpolate(cubic, position, "cubic"), exact, atol=1e-9)
    for kind in ("linear", "cubic"):
        on_bins = _interpolate(samples, np.arange(11.0), kind)
        np.testing.assert_allclose(on_bins, samples[:11], atol=1e-12)
        periodic = _interpolate(samples, np.array([11.5]), kind, periodic=True)
        shifted = _interpolate(np.roll(samples, -6), np.array([5.5]), kind, periodic=True)
        np.testing.assert_allclose(periodic, shifted, atol=1e-12)
        # the kernels' float32 packets hold the same coefficients
        for bins in (2, 3, 5, 6, 12):  # short profiles too (the packets' split into parts)
            packets = interpolation.kernel_packets(samples[None, :bins], kind)
            table = interpolation.coefficient_table(samples[:bins], kind)
            np.testing.assert_allclose(packets.view(np.complex64).reshape(table.shape)[:-1],
                                       table[:-1], atol=1e-6)


@pytest.fixture(scope="module")
def raw():
    trajectory = mitsar.Trajectory.linear([14.6, 1.4, 4.5], [0.5, 0, 0], 1.6)
    look = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
    return mitsar.simulate_point_targets(RADAR, trajectory, look, [mitsar.PointTarget(TARGET)],
                                         normalized=True)


def _error_db(values, reference):
    return 20 * math.log10(np.linalg.norm(values - reference) / np.linalg.norm(reference))


@pytest.mark.parametrize("kind", ["linear", "cubic"])
def test_numpy_and_drjit_kernels_agree(raw, kind):
    """Same profiles, same interpolation: the exact kernel within 1e-6 of the peak of the
    float64 sum (float32 interpolation and sums), the pixel groups within -80 dB (their
    expansion's own bound, tests/test_bpa_fast.py)."""
    frequency, profile = range_spectrum(raw["raw"].values, RADAR, upsample=8)
    u, v = np.meshgrid(np.arange(-0.1, 0.1, 0.004), np.arange(-0.05, 0.05, 0.005))
    pixels = TARGET + np.stack([u, v, 0 * u], -1).reshape(-1, 3)
    arguments = (profile, frequency, RADAR, pixels, raw["platform_position"].values,
                 raw["platform_velocity"].values,
                 raw["boresight"].values @ np.array([1.0, 0, 0]), 0.15,
                 window_coefficients("hann"))
    reference, _ = backproject_numpy(*arguments, interpolation=kind)
    exact, _ = backproject_drjit(*arguments, interpolation=kind)
    grouped, _, _ = backproject_tiled(*arguments, row_length=u.shape[1], interpolation=kind)
    assert np.abs(exact - reference).max() <= 1e-6 * np.abs(reference).max()
    assert _error_db(grouped, reference) <= -80.0
    other, _ = backproject_numpy(*arguments,
                                 interpolation="linear" if kind == "cubic" else "cubic")
    assert _error_db(other, reference) > -80.0  # the option reaches the sum


def test_focus_defaults_within_60_db_of_a_float64_reference(raw):
    """focus()'s defaults (cubic, 8x, Dr.Jit pixel groups) against the float64 NumPy sum on
    64x profiles (cubic error bound -137 dB there: a reference free of interpolation error to
    this test's precision): <= -60 dB with a margin (measured -80 dB here, -70 dB on the
    benchmark's larger image); the old default, linear at 16x, misses it (-57 dB here, -48 dB
    on the benchmark image)."""
    grid = PlaneGrid(origin=TARGET, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=[-0.3, 0.3, 0.01],
                     v=[-0.2, 0.2, 0.01])
    image = mitsar.focus(raw, "bpa", grid)
    assert image.attrs["range_interpolation"] == "cubic"
    assert image.attrs["range_upsample"] == 8
    reference = mitsar.focus(raw, "bpa", grid, backend="numpy", range_upsample=64)
    assert _error_db(image["image"].values, reference["image"].values) <= -63.0
    old = mitsar.focus(raw, "bpa", grid, range_upsample=16, range_interpolation="linear")
    assert old.attrs["range_interpolation"] == "linear"
    assert _error_db(old["image"].values, reference["image"].values) > -60.0


def test_an_unknown_interpolation_is_refused(raw):
    with pytest.raises(mitsar.ParameterError, match="range_interpolation"):
        mitsar.focus(raw, range_interpolation="sinc")
