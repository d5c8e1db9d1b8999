"""Motion compensation of dechirped FMCW data to a straight reference line (RDA, WDA, FSA).

The frequency-domain algorithms need sweeps taken on a straight line at uniform spacing. A
drone's track wanders; :func:`compensate` turns a raw product recorded on a near-straight track
into the one the reference line would have recorded, for the scene the image grid covers
(Zaugg & Long 2008 for FMCW; the two-step scheme of Moreira & Huang 1994):

1. **reference line** (:func:`reference_line`): least-squares line through the antenna
   positions against the sweep index, so sweep k sits at ``p_ref,k = p_0 + k s a_hat``;
2. **along-track resampling**: where the sweeps are not uniformly spaced along the line, every
   fast-time sample is interpolated in azimuth (cubic, after removing the Doppler-centroid
   carrier) from the recorded along-track positions onto the uniform ones;
3. **first order** (range-independent, at the grid's centre range ``r_0``): the two-way delay
   error ``dtau = 2 (R_act - R_ref) / c`` of the centre-range point abeam of each sweep and its
   rate multiply the sweep by ``exp{-j 2 pi [f_c dtau + (K dtau + f_c dtau') t]}`` — carrier
   phase, envelope (beat frequency) and in-sweep motion (the continuous-motion term of
   Meta et al. 2007) at once;
4. **second order** (range-dependent): after a range FFT, bin ``j`` (apparent range ``r_j``) is
   multiplied by ``exp{-j 4 pi [dR(r_j) - dR(r_0)] / lambda}`` and transformed back, with
   ``dR(r)`` exact for the point at range ``r`` abeam of the sweep (the grid's mid-azimuth row).

What remains after compensation is the residual of any line-of-sight correction evaluated
abeam: a cross-track deviation ``d`` seen at direction sine ``u`` off the centroid differs by
``d u^2 / 2``; over the processed half width ``h`` that is a phase ``pi/4`` when
``d = lambda / (8 h^2)`` (:func:`deviation_limit`; 6.2 cm for the whole 9.1 deg beam of paper
Table 1, 1.6 m at 0.1 m azimuth resolution). The envelope is corrected at ``r_0`` only: across
the grid's ranges the range error left must stay below a quarter of a range cell. Beyond
either, :func:`compensate` refuses and names back-projection, which needs no compensation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline

from mitsar.errors import ParameterError
from mitsar.focus.motion import centroid_sines
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import fast_time
from mitsar.products.raw import sweep_rate

__all__ = ["ReferenceLine", "compensate", "deviation_limit", "reference_line",
           "reference_product"]

ENVELOPE_TOLERANCE_CELLS = 0.25
"""Largest range error left by the range-independent envelope correction, in range cells."""


@dataclass(frozen=True)
class ReferenceLine:
    """The straight line the data are compensated to.

    Attributes
    ----------
    origin : ndarray (3,)
        Reference position of sweep 0 [m].
    along : ndarray (3,)
        Unit vector along the line.
    spacing : float
        Along-track distance between sweeps [m].
    along_uniform : ndarray (sweeps,)
        Along-line coordinate of every reference position [m] (same origin as
        ``along_recorded``).
    positions : ndarray (sweeps, 3)
        Reference antenna positions [m].
    along_recorded : ndarray (sweeps,)
        Along-line coordinate of every recorded position [m].
    deviation : ndarray (sweeps, 3)
        Recorded minus reference position, after along-track resampling (cross-track part) [m].
    """

    origin: NDArray[np.float64]
    along: NDArray[np.float64]
    spacing: float
    along_uniform: NDArray[np.float64]
    positions: NDArray[np.float64]
    along_recorded: NDArray[np.float64]
    deviation: NDArray[np.float64]

    @property
    def velocity(self) -> NDArray[np.float64]:
        """Constant reference velocity per sweep interval, ``spacing a_hat`` (times the PRF)."""
        return self.spacing * self.along


def _refuse(name: str, expected: str, found: object) -> ParameterError:
    return ParameterError("focus", name, f"{expected} (motion compensation to a straight "
                          "line, docs/focusing.md; use algorithm='bpa' or 'ffbp', which focus any "
                          "track)", found)


def reference_line(raw: xr.Dataset) -> ReferenceLine:
    """Fit the reference line to a raw product's antenna positions (step 1).

    Raises
    ------
    ParameterError
        If the platform does not advance monotonically along the fitted line.
    """
    positions = np.asarray(raw["platform_position"].values, dtype=float)
    sweeps = len(positions)
    if sweeps < 8:
        raise _refuse("raw.sweep", "at least 8 sweeps", sweeps)
    index = np.arange(sweeps)
    slope, intercept = np.polyfit(index, positions, 1)  # per axis: p = intercept + k slope
    if not np.linalg.norm(slope) > 0:
        raise _refuse("raw.platform_position", "a moving platform", "no net motion")
    along = slope / np.linalg.norm(slope)
    coordinate = (positions - intercept) @ along
    if np.any(np.diff(coordinate) <= 0):
        raise _refuse("raw.platform_position", "a platform advancing along the track in every "
                      "sweep", "it stops or turns back")
    uniform = np.linspace(coordinate[0], coordinate[-1], sweeps)
    spacing = float(uniform[1] - uniform[0])
    reference = intercept + np.outer(uniform, along)
    # Cross-track deviation at the reference along-track positions (after resampling).
    cross = positions - intercept - np.outer(coordinate, along)
    deviation = CubicSpline(coordinate, cross, axis=0)(uniform)
    return ReferenceLine(origin=reference[0], along=along, spacing=spacing,
                         along_uniform=uniform, positions=reference, along_recorded=coordinate,
                         deviation=deviation)


def deviation_limit(radar: Radar, half_width: float) -> float:
    """Largest cross-track deviation that compensation abeam leaves below pi/4 at the edge of
    a processed aperture of half width ``half_width`` (direction sine): ``lambda / (8 h^2)``
    [m]."""
    return radar.wavelength / (8.0 * half_width**2)


def reference_product(raw: xr.Dataset, line: ReferenceLine, radar: Radar) -> xr.Dataset:
    """A copy of ``raw`` whose track is the reference line (samples not yet compensated)."""
    out = raw.copy()
    sweeps = len(line.positions)
    out["platform_position"] = (("sweep", "xyz"), line.positions, {"units": "m"})
    out["platform_velocity"] = (("sweep", "xyz"),
                                np.tile(line.velocity * sweep_rate(raw, radar), (sweeps, 1)),
                                {"units": "m/s"})
    boresight = np.asarray(raw["boresight"].values, dtype=float).mean(axis=0)
    out["boresight"] = (("sweep", "xyz"), np.tile(boresight / np.linalg.norm(boresight),
                                                  (sweeps, 1)), {"units": "1"})
    out.attrs["trajectory_straight"] = 1
    return out


def compensate(raw: xr.Dataset, reference: xr.Dataset, line: ReferenceLine, radar: Radar,
               layout: dict, half_width: float) -> tuple[xr.Dataset, dict]:
    """Motion-compensate ``raw`` onto ``reference`` (:func:`reference_product`), steps 2-4.

    Parameters
    ----------
    raw : xarray.Dataset
        The recorded product (its platform variables are the recorded track).
    reference : xarray.Dataset
        :func:`reference_product` of it; its samples are replaced.
    line : ReferenceLine
    radar : Radar
    layout : dict
        The slant grid resolved on ``reference`` (``position`` (azimuth, range, 3)).
    half_width : float
        Processed aperture half width in direction sine (the deviation limit depends on it).

    Returns
    -------
    compensated : xarray.Dataset
    info : dict
        ``mocomp_max_deviation_m``, ``mocomp_deviation_limit_m``, ``mocomp_resampled``,
        ``mocomp_envelope_residual_cells`` (processing attributes of the image).
    """
    deviation = float(np.linalg.norm(line.deviation, axis=1).max())
    limit = deviation_limit(radar, half_width)
    if deviation > limit:
        raise _refuse("raw.platform_position", f"deviations from the straight reference line "
                      f"<= lambda / (8 h^2) = {limit * 100:.3g} cm for the processed aperture "
                      f"half width h = {half_width:.3g} (coarser azimuth_resolution allows "
                      "more)", f"{deviation * 100:.3g} cm")
    samples = np.asarray(raw["raw"].values, dtype=complex)
    # 2. Along-track resampling onto the uniform positions, carrier of the centroid removed.
    uniform = line.along_uniform
    resampled = bool(np.abs(line.along_recorded - uniform).max() > radar.wavelength / 64)
    if resampled:
        centroid = float(np.mean(centroid_sines(raw)))
        carrier = np.exp(-2j * np.pi * 2 * centroid / radar.wavelength * line.along_recorded)
        spline = CubicSpline(line.along_recorded, samples * carrier[:, None], axis=0)
        samples = spline(uniform) * np.exp(2j * np.pi * 2 * centroid / radar.wavelength
                                           * uniform)[:, None]
    # 3.-4. Delay errors of the points abeam of each sweep, from the grid's mid-azimuth row.
    row = np.asarray(layout["position"], dtype=float)
    row = row[row.shape[0] // 2]
    row_along = uniform[0] + (row[0] - line.origin) @ line.along
    abeam = row[None, :, :] + (uniform - row_along)[:, None, None] * line.along
    actual = line.positions + line.deviation
    per_second = sweep_rate(raw, radar)  # the PRF; PRF / N_tx for one TDM-MIMO channel
    actual_velocity = np.gradient(actual, axis=0) * per_second
    to_actual = abeam - actual[:, None, :]
    to_reference = abeam - line.positions[:, None, :]
    range_actual = np.linalg.norm(to_actual, axis=-1)
    range_reference = np.linalg.norm(to_reference, axis=-1)
    error = range_actual - range_reference  # (sweeps, ranges) [m]
    rate = (-np.einsum("srx,sx->sr", to_actual, actual_velocity) / range_actual
            + np.einsum("srx,x->sr", to_reference, line.velocity * per_second)
            / range_reference)
    centre = row.shape[0] // 2
    residual = np.abs(error - error[:, centre:centre + 1]).max()
    if residual > ENVELOPE_TOLERANCE_CELLS * radar.range_resolution:
        raise _refuse("raw.platform_position", f"a range error across the grid below "
                      f"{ENVELOPE_TOLERANCE_CELLS:g} range cell after the first-order "
                      "correction (a narrower grid in range, or smaller deviations)",
                      f"{residual / radar.range_resolution:.3g} cells")
    t = fast_time(radar)
    dtau = 2.0 * error[:, centre] / SPEED_OF_LIGHT
    dtau_rate = 2.0 * rate[:, centre] / SPEED_OF_LIGHT
    samples = samples * np.exp(-2j * np.pi * (radar.carrier_frequency * dtau[:, None]
                                              + (radar.chirp_rate * dtau[:, None]
                                                 + radar.carrier_frequency * dtau_rate[:, None])
                                              * t[None, :]))
    # Second order: per range bin of an unpadded range FFT (exactly invertible).
    count = samples.shape[1]
    bin_range = (SPEED_OF_LIGHT * np.fft.fftfreq(count, 1.0 / radar.sampling_frequency)
                 / (2.0 * radar.chirp_rate))
    # The abeam ranges are the same for every sweep (the reference is straight): interpolate
    # every sweep's error curve linearly on them, in one vectorised step.
    order = np.argsort(range_reference[0])
    grid_ranges = range_reference[0, order]
    curves = (error - error[:, centre:centre + 1])[:, order]
    slopes = np.diff(curves, axis=1) / np.diff(grid_ranges)[None, :]
    position = np.clip(np.searchsorted(grid_ranges, bin_range) - 1, 0, len(grid_ranges) - 2)
    extra = curves[:, position] + slopes[:, position] * (
        np.clip(bin_range, grid_ranges[0], grid_ranges[-1]) - grid_ranges[position])[None, :]
    spectrum = np.fft.fft(samples, axis=1) * np.exp(-4j * np.pi * extra / radar.wavelength)
    samples = np.fft.ifft(spectrum, axis=1)
    out = reference.copy()
    out["raw"] = (("sweep", "sample"), samples, raw["raw"].attrs)
    info = {"mocomp_max_deviation_m": deviation, "mocomp_deviation_limit_m": limit,
            "mocomp_resampled": int(resampled),
            "mocomp_envelope_residual_cells": float(residual / radar.range_resolution)}
    return out, info
