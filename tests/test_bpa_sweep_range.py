"""Per-pixel sweep ranges of BPA on curved tracks (mitsar.focus.bpa.curved_sweep_range), and
the zoom transform of the range compression (mitsar.focus.compression.zoom_dft).

The sweep range is a bound from a coarse search; it must never drop a sweep that falls inside
the window, edge sweeps included (``|g_k| < h + delta_k / 2``, the sweeps with an edge fraction,
mitsar.focus.backprojection.edge_fraction). Checked two ways on the turn and U-turn of
tests/test_curved_tracks.py: against the exact set of such sweeps (NumPy, float64, ``delta_k``
from central differences of ``g``) for pixels spread over the swath, and
as images: the kernel with the ranges and without them sums the same non-zero terms in the same
order, so the images agree to float32 rounding of the lane grouping (here: exactly).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mitsar
from mitsar.focus.aperture import aperture_half_width, aspect_frames
from mitsar.focus.backprojection import backproject_drjit
from mitsar.focus.bp_setup import prepare
from mitsar.focus.bpa import curved_sweep_range
from mitsar.focus.compression import zoom_dft

RADAR = mitsar.Radar()
LOOK = mitsar.Look(55.7)
HEIGHT = 4.5


def _turn() -> mitsar.Trajectory:
    """A 20-degree left turn of radius 10 m (tests/test_curved_tracks.py)."""
    turn = math.radians(20.0)
    points = [[12.0, 1.4, HEIGHT], [15.0, 1.4, HEIGHT],
              [15.0 + 3 * math.cos(turn), 1.4 + 3 * math.sin(turn), HEIGHT]]
    return mitsar.Trajectory.flight(points, 0.5, turn_radius=10.0)


def _u_turn() -> mitsar.Trajectory:
    """A lawn-mower U-turn of radius 2 m to the right (tests/test_curved_tracks.py)."""
    y = 1.4 - 4.0
    points = [[12.0, 1.4, HEIGHT], [15.0, 1.4, HEIGHT], [15.0, y, HEIGHT], [12.0, y, HEIGHT]]
    return mitsar.Trajectory.flight(points, 0.5, turn_radius=2.0)


@pytest.fixture(scope="module", params=[_turn, _u_turn], ids=["turn20", "u-turn"])
def scene(request):
    """Raw data of a point seen from the track's middle, and pixels over the swath."""
    track = request.param()
    middle = track.position(np.array([track.duration / 2]))[0]
    heading = track.velocity(np.array([track.duration / 2]))[0]
    heading /= np.linalg.norm(heading)
    left = np.array([-heading[1], heading[0], 0.0])
    target = np.array([middle[0], middle[1], 0.0]) + HEIGHT * math.tan(
        math.radians(LOOK.off_nadir_deg)) * left
    raw = mitsar.simulate_point_targets(RADAR, track, LOOK, [mitsar.PointTarget(target)],
                                        normalized=True)
    rng = np.random.default_rng(7)
    # pixels over 8 m x 8 m around the target (far beyond the beam too): 400 random ones
    pixels = target + np.column_stack([rng.uniform(-4, 4, (400, 2)), np.zeros(400)])
    return raw, target, pixels


def _exact_offsets(pixels, positions, velocities, centroid, aspect):
    """``g_k`` of every sweep and pixel in float64 (the kernel's window argument)."""
    sight = pixels[None] - positions[:, None]
    distance = np.linalg.norm(sight, axis=-1)
    if aspect is None:
        unit = velocities / np.linalg.norm(velocities, axis=-1, keepdims=True)
        return np.einsum("spi,si->sp", sight, unit) / distance - centroid[:, None]
    return np.einsum("spi,pi->sp", sight, aspect[0]) / distance - aspect[1][None]


@pytest.mark.parametrize("resolution", [0.1, None], ids=["aspect-0.1m", "whole-beam"])
def test_no_sweep_inside_the_window_falls_outside_the_range(scene, resolution):
    """Every sweep with ``|g_k| < h + delta_k / 2`` (exact, float64; 0.6 delta_k for the
    difference between the kernel's derivative and the central difference) lies in
    [first, end); and the range is a real bound (on average under 60 % of the track), so the
    test can fail both ways."""
    raw, _, pixels = scene
    half_width = aperture_half_width(RADAR, resolution)
    bp = prepare(raw, half_width=half_width, window="rect", range_window="rect",
                 remove_rvp=True, range_upsample=1)
    aspect = None if resolution is None else aspect_frames(pixels, bp.positions,
                                                           bp.velocities, bp.centroid)
    first, end = curved_sweep_range(pixels, bp.positions, bp.velocities, bp.centroid,
                                    bp.kernel_half_width, aspect)
    offsets = _exact_offsets(pixels, bp.positions, bp.velocities, bp.centroid, aspect)
    step = np.abs(np.gradient(offsets, axis=0))
    inside = np.abs(offsets) <= bp.kernel_half_width + 0.6 * step
    sweep = np.arange(len(bp.positions))[:, None]
    dropped = inside & ((sweep < first[None]) | (sweep >= end[None]))
    assert not dropped.any()
    assert inside.any()
    assert np.mean(end - first.astype(int)) < 0.6 * len(bp.positions)


@pytest.mark.parametrize("resolution", [0.1, None], ids=["aspect-0.1m", "whole-beam"])
def test_image_with_sweep_ranges_equals_the_unbounded_one(scene, resolution):
    """The kernel with and without the ranges: same image to float32 rounding (1e-6 of the
    peak; skipped sweeps add exact zeros, so any larger difference is a dropped sweep)."""
    raw, target, _ = scene
    axis = np.linspace(-0.3, 0.3, 25)
    pixels = (target + axis[:, None, None] * np.array([1.0, 0, 0])
              + axis[None, :, None] * np.array([0, 1.0, 0])).reshape(-1, 3)
    half_width = aperture_half_width(RADAR, resolution)
    bp = prepare(raw, half_width=half_width, window="hamming", range_window="rect",
                 remove_rvp=True, range_upsample=16, points=pixels)
    aspect = None if resolution is None else aspect_frames(pixels, bp.positions,
                                                           bp.velocities, bp.centroid)
    arguments = (bp.profile, bp.frequency, RADAR, pixels, bp.positions, bp.velocities,
                 bp.centroid, bp.kernel_half_width, bp.kernel_window)
    ranges = curved_sweep_range(pixels, bp.positions, bp.velocities, bp.centroid,
                                bp.kernel_half_width, aspect)
    bounded, bounded_total = backproject_drjit(*arguments, sweep_range=ranges, aspect=aspect)
    full, full_total = backproject_drjit(*arguments, aspect=aspect)
    peak = np.abs(full).max()
    assert peak > 0
    assert np.abs(bounded - full).max() <= 1e-6 * peak
    assert np.abs(bounded_total - full_total).max() <= 1e-6 * full_total.max()


def test_zoom_dft_equals_the_zero_padded_fft():
    """Bins of Bluestein's zoom transform against numpy's zero-padded FFT (float64: 1e-10)."""
    rng = np.random.default_rng(3)
    samples = rng.normal(size=(3, 50)) + 1j * rng.normal(size=(3, 50))
    size = 50 * 16
    spectrum = np.fft.fft(samples, n=size, axis=-1)
    for first, count in [(0, 40), (-30, 77), (size // 2 - 20, 20)]:
        bins = np.arange(first, first + count) % size
        assert np.allclose(zoom_dft(samples, size, first, count), spectrum[:, bins],
                           rtol=0, atol=1e-10 * np.abs(spectrum).max())


def test_band_limited_range_compression_matches_the_whole_profile():
    """range_spectrum with a band: the whole profile's bins in that band (1e-10 of the peak)."""
    raw = mitsar.simulate_point_targets(
        RADAR, mitsar.Trajectory.linear([14.9, 1.4, HEIGHT], [0.5, 0, 0], 0.2), LOOK,
        [mitsar.PointTarget([15.0, 8.0, 0.0])], normalized=True)
    pixels = np.array([[14.5, 7.5, 0.0], [15.5, 8.5, 0.0]])
    whole = prepare(raw, half_width=0.3, window="rect", range_window="hann", remove_rvp=True,
                    range_upsample=16)
    band = prepare(raw, half_width=0.3, window="rect", range_window="hann", remove_rvp=True,
                   range_upsample=16, points=pixels)
    assert len(band.frequency) < len(whole.frequency) // 4
    start = np.searchsorted(whole.frequency, band.frequency[0])
    assert np.allclose(whole.frequency[start:start + len(band.frequency)], band.frequency)
    peak = np.abs(whole.profile).max()
    assert np.abs(whole.profile[:, start:start + len(band.frequency)]
                  - band.profile).max() <= 1e-10 * peak
