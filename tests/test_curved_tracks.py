"""Back-projection on curved drone tracks: the azimuth window on the pixel's aspect angle.

A window on the direction sine along each sweep's *own* velocity processes, on a turn, an
angular span of the line of sight that follows the turn rate (the heading turns the beam and
the velocity together): measured on these tracks the azimuth IRW came out at -66 % to +310 %
of theory. With the aspect-angle window (mitsar/focus/aperture.py, ``aspect_frames``) every
pixel's processed span of line-of-sight angle is ``lambda / (2 rho)`` on any track, so a point
focuses to the rect-window IRW ``0.886 rho`` (docs/focusing.md, "Curved tracks").

The IRW is measured on a cut of pixels along the azimuth axis (horizontal, perpendicular to
the line of sight at the aperture centre) sampled at 2.5 mm: a curved aperture leaves a phase
curvature across the image several times the straight track's, too fast for the FFT upsampling
of ``measure_impulse_response`` at usual pixel spacings, so the cut is sampled directly instead.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mitsar
from mitsar.focus.grid import PointsGrid
from mitsar.quality.cuts import irw, pslr_db

RADAR = mitsar.Radar()
LOOK = mitsar.Look(55.7)
HEIGHT = 4.5
RHO = 0.1
SPEED = 0.5
SPACING = 0.0025  # [m] 1/40 cell: IRW to ~0.1 % by the cut's half-power interpolation


def _turn(radius: float, side: int) -> tuple[mitsar.Trajectory, float]:
    """A 20-degree turn (left +1, right -1) and the time of its middle."""
    turn = math.radians(20.0) * side
    points = [[12.0, 1.4, HEIGHT], [15.0, 1.4, HEIGHT],
              [15.0 + 3 * math.cos(turn), 1.4 + 3 * math.sin(turn), HEIGHT]]
    middle = 3 - radius * math.tan(abs(turn) / 2) + radius * abs(turn) / 2
    return mitsar.Trajectory.flight(points, SPEED, turn_radius=radius), middle / SPEED


def _u_turn(radius: float, side: int) -> tuple[mitsar.Trajectory, float]:
    """A lawn-mower U-turn (two 90-degree corners of ``radius``) and the time of its middle."""
    y = 1.4 + side * 2 * radius
    points = [[12.0, 1.4, HEIGHT], [15.0, 1.4, HEIGHT], [15.0, y, HEIGHT], [12.0, y, HEIGHT]]
    middle = 3 - radius + math.pi * radius / 2
    return mitsar.Trajectory.flight(points, SPEED, turn_radius=radius), middle / SPEED


def _broadside_point(track: mitsar.Trajectory, time: float) -> tuple:
    """Raw data of a point seen broadside at ``time``, the point and its azimuth axis."""
    position, velocity = track.position(np.array([time]))[0], track.velocity(np.array([time]))[0]
    heading = velocity / np.linalg.norm(velocity)
    left = np.array([-heading[1], heading[0], 0.0])
    target = np.array([position[0], position[1], 0.0]) + HEIGHT * math.tan(
        math.radians(LOOK.off_nadir_deg)) * left
    raw = mitsar.simulate_point_targets(RADAR, track, LOOK, [mitsar.PointTarget(target)],
                                        normalized=True)
    return raw, target, np.cross([0.0, 0.0, 1.0], left)


def _azimuth_cut(track: mitsar.Trajectory, time: float) -> np.ndarray:
    """Focus a point seen broadside at ``time`` onto a 2.5 mm cut along its azimuth axis."""
    raw, target, along = _broadside_point(track, time)
    offsets = np.arange(-0.3, 0.3 + 1e-9, SPACING)
    image = mitsar.focus(raw, grid=PointsGrid(target + offsets[:, None] * along),
                         azimuth_resolution=RHO)
    return image["image"].values.ravel()


@pytest.mark.parametrize(("shape", "radius", "side"), [
    (_turn, 10.0, +1), (_turn, 10.0, -1), (_u_turn, 2.0, +1), (_u_turn, 2.0, -1)],
    ids=["turn20-left", "turn20-right", "u-turn-left", "u-turn-right"])
def test_curved_track_focuses_to_the_rect_irw(shape, radius, side):
    """IRW within 3 % of 0.886 rho (the issue's bound; measured within -0.1 % ... +1.6 % on the
    NumPy reference), PSLR within 1.5 dB of -13.26 dB (the aperture is a short arc, not a line:
    the antenna pattern turns across it)."""
    cut = _azimuth_cut(*shape(radius, side))
    assert irw(cut, spacing_cells=SPACING / RHO) == pytest.approx(0.8859, rel=0.03)
    assert pslr_db(cut) == pytest.approx(-13.26, abs=1.5)


@pytest.mark.parametrize("side", [+1, -1], ids=["u-turn-left", "u-turn-right"])
def test_ffbp_focuses_a_u_turn_as_exact_bpa(side):
    """FFBP on a lawn-mower U-turn (radius 2 m), the whole beam (narrower bands on turns:
    tests/test_ffbp_turns.py, docs/focusing.md § FFBP): its azimuth cut through the point against
    exact BPA's on the same 1 mm points. Measured: IRW within 0.2 % (17.9 and 33.4 mm: the beam
    holds the point over 9.6 deg of aspect turning one way, 5.1 deg the other), the cut within -41
    dB; 1 % and -35 dB are the bounds (the issue's FFBP error bound)."""
    raw, target, along = _broadside_point(*_u_turn(2.0, side))
    offsets = np.arange(-0.06, 0.06 + 1e-9, 0.001)
    grid = PointsGrid(target + offsets[:, None] * along)
    exact = mitsar.focus(raw, grid=grid)["image"].values.ravel()
    fast = mitsar.focus(raw, grid=grid, algorithm="ffbp")["image"].values.ravel()
    assert irw(fast, spacing_cells=1.0) == pytest.approx(irw(exact, spacing_cells=1.0), rel=0.01)
    assert 20 * math.log10(np.linalg.norm(fast - exact) / np.linalg.norm(exact)) < -35.0
