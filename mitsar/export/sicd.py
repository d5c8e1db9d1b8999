"""SICD 1.4.0 export of mitsar images (NGA.STND.0024-1, Sensor Independent Complex Data,
Volume 1 Design & Implementation Description Document, Version 1.4.0, 2024), through sarkit.

What is written (the mapping; details in docs/products.md)
----------------------------------------------------------
* Pixels: the complex ``image`` as ``RE32F_IM32F`` (complex64), with SICD rows along the
  image's range-like dimension (the one ``range_axis`` points along) and columns along the
  other; rows run away from the radar and columns so that ``uRow x uCol`` points up
  (SICD's "shadows down", normal away from the Earth), which for mitsar's left-looking slant
  grid reverses the along-track axis. :func:`sicd_pixels` returns exactly the written array.
* Grid (``Type = PLANE``; every mitsar 2-D grid is a uniform planar grid; NGA.STND.0024-1
  Vol. 1 §4.2): ``UVectECF`` from the pixel positions, ``SS`` the pixel spacing,
  ``ImpRespBW = 1 / rho`` from the image's ``range_resolution`` / ``azimuth_resolution``,
  ``ImpRespWid`` the -3 dB width of the window's response (0.8859 rho for "rect", SICD's
  KAPFAC), ``WgtType`` and ``WgtFunct`` the window the focuser applied (attributes
  ``range_window``, ``window``; :func:`weighting`).
  Back-projection leaves the carrier ``exp(-j 2 pi k l . x)``, ``k = 2 f_c / c``, in the pixels
  (docs/conventions.md, BPA de-rotation): their spectrum, taken with the DFT exponent
  ``+j`` (``Sgn = +1``), sits at the spatial frequency ``k l(COA) . u`` of each pixel's own
  line of sight at its centre of aperture, seen modulo ``1 / SS``. ``KCtr`` is the multiple of
  ``1 / SS`` nearest that frequency at the SCP, ``DeltaKCOAPoly`` the rest, a polynomial over
  the image (order <= 4 in metres from the SCP), and ``DeltaK1/2`` its extremes at the corners
  -+ ``ImpRespBW / 2`` (the whole ``+-1/(2 SS)`` when that wraps, as Vol. 1 allows).
* Centre of aperture (Vol. 1 §4.3): each pixel's COA is its beam-centre crossing
  (:func:`centre_of_aperture`, the focusers' mean-track aspect frame), so a stripmap image has
  a ``TimeCOAPoly`` that varies along the track (-2 s/m at 0.5 m/s); fitted on a 17 x 17 sample
  of pixels and exact at the SCP. ``SCPCOA`` (sarkit's ``compute_scp_coa``) is therefore the
  geometry at the SCP's own COA.
* ``ImageCorners``: the corner pixels projected into the ground plane through the SCP along
  the slant-plane normal at the SCP's COA (Vol. 1 §2.6), as sarkit's checker predicts them.
* ImageFormation: ``ImageFormAlgo`` "RMA" for RDA/WDA/FSA, "OTHER" for BPA/FFBP (attribute
  ``algorithm``), processed band and time from the raw product.
* Geometry: ``Position/ARPPoly`` a polynomial fit (order <= 5) of the mid-sweep antenna
  positions against time (the aperture the image carries, :func:`aperture_of`, or the raw
  product passed), ``GeoData/SCP`` the centre pixel, all in ECF through
  :class:`mitsar.export.frame.LabOrigin`, recorded with the radar parameters in
  ``CollectionInfo/Parameter``.
"""

from __future__ import annotations

import datetime as _dt
import math
import os
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

from mitsar.errors import MitsarWarning, ParameterError
from mitsar.export.frame import DEFAULT_ORIGIN, LabOrigin
from mitsar.export.optional import require_sarkit
from mitsar.focus.aperture import aperture_half_width, mean_track_frame
from mitsar.focus.nesz import unit_peak_amplitude
from mitsar.focus.windows import evaluate_window, window_coefficients
from mitsar.io import atomic_writer
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.version import __version__

__all__ = ["SICD_NAMESPACE", "WEIGHT_SAMPLES", "aperture_of", "boundary_vertices",
           "centre_of_aperture", "impulse_width_factor", "sicd_layout", "sicd_pixels",
           "weighting", "write_sicd"]

SICD_NAMESPACE = "urn:SICD:1.4.0"
"""XML namespace of SICD 1.4.0."""

ALGORITHMS = {"rda": "RMA", "wda": "RMA", "fsa": "RMA", "bpa": "OTHER", "ffbp": "OTHER"}
"""SICD ``ImageFormAlgo`` of each mitsar algorithm."""

WINDOW_NAMES = {"rect": "UNIFORM", "hamming": "HAMMING", "hann": "HANNING", "taylor": "TAYLOR"}
"""SICD ``WgtType/WindowName`` of each mitsar window."""

COLLECT_START = _dt.datetime(2000, 1, 1, tzinfo=_dt.UTC)
"""Collection start written for simulations (no absolute time)."""

COA_SAMPLES = 17
"""Pixels per image dimension on which the centre of aperture is sampled (``TimeCOAPoly``,
``DeltaKCOAPoly``, ``Radiometric``)."""

COA_ORDER = 4
"""Order of ``TimeCOAPoly`` and ``DeltaKCOAPoly``: on the curved, wandering test flight order 2
left ``k l(COA).u`` off by up to 2.0 cyc/m (RMS 0.84) over the covered pixels, order 4 by
0.54 (RMS 0.27)."""

WEIGHT_SAMPLES = 64
"""Samples of ``Grid/{Row,Col}/WgtFunct`` (uniformly spaced across ImpRespBW, ends included)."""

APERTURE_VARIABLES = {"platform_position": "aperture_position",
                      "platform_velocity": "aperture_velocity",
                      "boresight": "aperture_boresight", "attitude": "aperture_attitude"}
"""Raw product variable -> the image product's copy of it (:func:`mitsar.focus`)."""


def weighting(window: str) -> dict:
    """SICD ``WgtType`` and ``WgtFunct`` (NGA.STND.0024-1 Vol. 1 §4.2, Grid) of a mitsar window.

    ``WgtFunct`` holds the window the focusers apply across the processed band
    (:func:`mitsar.focus.windows.evaluate_window` of
    :func:`mitsar.focus.windows.window_coefficients`, the same cosine series the kernels
    evaluate) at :data:`WEIGHT_SAMPLES` points uniformly spaced from -ImpRespBW/2 to
    +ImpRespBW/2, ends included; none for the uniform window (SICD needs it only for a
    non-uniform one). ``WgtType`` names it with the parameters sarpy reads to rebuild it
    (``sarpy.io.complex.sicd_elements.Grid.DirParamType.define_weight_function``): Hamming's
    pedestal ``COEFFICIENT = 0.54``; Taylor's ``NBAR = 4`` and ``SLL = 35`` (the sidelobe
    suppression in dB, positive as ``scipy.signal.windows.taylor`` reads it).

    Parameters
    ----------
    window : {"rect", "hamming", "hann", "taylor"}

    Returns
    -------
    dict
        ``{"WgtType": {...}}`` plus ``"WgtFunct"`` (ndarray) for a non-uniform window.
    """
    name = WINDOW_NAMES.get(window, window.upper())
    parameters = {"HAMMING": {"COEFFICIENT": "0.54"},
                  "TAYLOR": {"NBAR": "4", "SLL": "35"}}.get(name, {})
    result: dict = {"WgtType": {"WindowName": name}}
    if parameters:
        result["WgtType"]["Parameter"] = [(key, value) for key, value in parameters.items()]
    if name != "UNIFORM":
        result["WgtFunct"] = evaluate_window(window_coefficients(window),
                                             np.linspace(0.0, 1.0, WEIGHT_SAMPLES))
    return result


def impulse_width_factor(window: str) -> float:
    """-3 dB width of a window's impulse response in cells (1/bandwidth): 0.8859 for "rect"
    (SICD's KAPFAC), from a 64x zero-padded FFT of the window (Cumming & Wong 2005 §2.6)."""
    if window == "rect":
        return 0.8859
    samples = 256
    weights = evaluate_window(window_coefficients(window), (np.arange(samples) + 0.5) / samples)
    response = np.abs(np.fft.fftshift(np.fft.fft(weights, n=64 * samples)))
    response /= response.max()
    above = np.flatnonzero(response >= math.sqrt(0.5))
    return float((above[-1] - above[0] + 1) / 64)


def _check_image(image: object) -> xr.Dataset:
    if not isinstance(image, xr.Dataset) or image.attrs.get("product") != "image" \
            or "image" not in image.variables:
        found = image.attrs.get("product") if isinstance(image, xr.Dataset) \
            else type(image).__name__
        raise ParameterError("write_sicd", "image_product",
                             "a mitsar image product (product='image')", found)
    if image["image"].ndim != 2 or image.attrs.get("grid_kind") not in ("slant", "plane"):
        raise ParameterError("write_sicd", "image_product",
                             "a 2-D image on a slant or plane grid (metre coordinates)",
                             image.attrs.get("grid_kind"))
    for dim in image["image"].dims:
        step = np.diff(np.asarray(image[dim].values, dtype=float))
        if len(step) < 1 or np.ptp(step) > 1e-9 * abs(step[0]):
            raise ParameterError("write_sicd", f"image_product.{dim}",
                                 "uniformly spaced coordinates [m]", "non-uniform spacing")
    return image


def sicd_layout(image_product: xr.Dataset, arp: np.ndarray | None = None) -> dict:
    """How an image maps onto SICD rows and columns (module docstring).

    Returns
    -------
    dict
        ``row_dim``, ``col_dim`` (image dims), ``flip_row``, ``flip_col`` (reversed),
        ``u_row``, ``u_col`` (lab unit vectors), ``row_spacing``, ``col_spacing`` [m].
    """
    image = _check_image(image_product)
    dims = image["image"].dims
    axis = np.abs(np.asarray(image.attrs.get("range_axis", [0.0, 1.0]), dtype=float))
    row_index = int(np.argmax(axis))
    row_dim, col_dim = dims[row_index], dims[1 - row_index]
    position = image["position"].transpose(row_dim, col_dim, "xyz").values
    u_row = position[1, 0] - position[0, 0]
    u_col = position[0, 1] - position[0, 0]
    row_spacing, col_spacing = float(np.linalg.norm(u_row)), float(np.linalg.norm(u_col))
    u_row, u_col = u_row / row_spacing, u_col / col_spacing
    centre = position[position.shape[0] // 2, position.shape[1] // 2]
    flip_row = arp is not None and float(u_row @ (centre - arp)) < 0
    if flip_row:
        u_row = -u_row
    flip_col = float(np.cross(u_row, u_col)[2]) < 0
    if flip_col:
        u_col = -u_col
    return {"row_dim": row_dim, "col_dim": col_dim, "flip_row": bool(flip_row),
            "flip_col": bool(flip_col), "u_row": u_row, "u_col": u_col,
            "row_spacing": row_spacing, "col_spacing": col_spacing}


def sicd_pixels(image_product: xr.Dataset, layout: dict | None = None) -> np.ndarray:
    """The (rows, cols) complex64 array :func:`write_sicd` writes for an image product."""
    layout = layout or sicd_layout(image_product)
    pixels = image_product["image"].transpose(layout["row_dim"], layout["col_dim"]).values
    if layout["flip_row"]:
        pixels = pixels[::-1]
    if layout["flip_col"]:
        pixels = pixels[:, ::-1]
    return np.ascontiguousarray(pixels, dtype=np.complex64)


def boundary_vertices(rows: int, cols: int, per_edge: int) -> np.ndarray:
    """(row, col) vertices [pixels] of the whole image's boundary, ``per_edge`` along each
    edge (corners once), clockwise as SICD's ValidData wants them (NGA.STND.0024-1 Vol. 1
    §2.3: first vertex the minimum row, then minimum column; the order of the four corners
    ``(0, 0), (0, cols-1), (rows-1, cols-1), (rows-1, 0)``). Shape (V, 2), integers."""
    def edge(count: int) -> np.ndarray:
        return np.unique(np.linspace(0, count - 1, max(2, min(per_edge, count))).round()
                         ).astype(int)
    along_cols, along_rows = edge(cols), edge(rows)
    top = np.c_[np.zeros(len(along_cols), int), along_cols]
    right = np.c_[along_rows[1:], np.full(len(along_rows) - 1, cols - 1)]
    bottom = np.c_[np.full(len(along_cols) - 1, rows - 1), along_cols[::-1][1:]]
    left = np.c_[along_rows[::-1][1:-1], np.zeros(len(along_rows) - 2, int)]
    return np.concatenate([top, right, bottom, left])


def _oriented(array: np.ndarray, layout: dict) -> np.ndarray:
    if layout["flip_row"]:
        array = array[::-1]
    if layout["flip_col"]:
        array = array[:, ::-1]
    return array


def centre_of_aperture(points: np.ndarray, time: np.ndarray, positions: np.ndarray,
                       velocities: np.ndarray, boresight: np.ndarray) -> np.ndarray:
    """Geometric centre-of-aperture time [s] of lab points: the beam-centre crossing.

    The crossing is where the line of sight ``l = (x - p_k) / |x - p_k|`` has the Doppler
    centroid's direction sine, ``v_hat_k . l = v_hat_k . b_k`` (b the boresight), in the mean
    track's frame (:func:`mitsar.focus.aperture.mean_track_frame`: a wander of the velocity
    moves no line of sight): the sweep the processed band is centred on
    (:mod:`mitsar.focus.aperture`, "doppler" and "pixel" band selection);
    among several crossings the one nearest the track; linear between the two sweeps around
    it, extrapolated from the track's first or last two sweeps for points whose crossing lies
    beyond the track (the edge pixels of a stripmap image, which see part of their band).
    This is SICD's COA (NGA.STND.0024-1 Vol. 1 §2.4 and §4.3, ``TimeCOAPoly``) for a
    stripmap image, each pixel at its own broadside.

    Parameters
    ----------
    points : ndarray, shape (P, 3)
        Lab positions [m].
    time : ndarray, shape (S,)
        Sweep times [s] (mid-sweep).
    positions, velocities, boresight : ndarray, shape (S, 3)
        Antenna positions [m], velocities [m/s], boresight unit vectors.

    Returns
    -------
    ndarray, shape (P,)
        COA times [s].
    """
    speed = np.linalg.norm(velocities, axis=1, keepdims=True)
    unit = velocities / np.where(speed > 0, speed, 1.0)
    centroid = np.einsum("si,si->s", boresight, unit)
    if len(time) > 1:  # the mean track's frame, as the focusers' aspect window
        mean_velocity, centroid = mean_track_frame(positions, velocities, centroid,
                                                   sweep_interval=float(np.median(np.diff(time))))
        mean_speed = np.linalg.norm(mean_velocity, axis=1, keepdims=True)
        unit = mean_velocity / np.where(mean_speed > 0, mean_speed, 1.0)
    sight = points[None, :, :] - positions[:, None, :]
    distance = np.linalg.norm(sight, axis=2)
    offset = np.einsum("spi,si->sp", sight, unit) / distance - centroid[:, None]
    result = np.empty(len(points))
    for index in range(len(points)):
        o = offset[:, index]
        crosses = np.flatnonzero((o[:-1] * o[1:] <= 0) & (o[:-1] != o[1:]))
        if len(crosses):
            k = crosses[np.argmin(distance[crosses, index])]
            fraction = o[k] / (o[k] - o[k + 1])
            result[index] = time[k] + fraction * (time[k + 1] - time[k])
        elif len(o) > 1:  # beyond the track's ends: the crossing extrapolated linearly
            k = 0 if abs(o[0]) <= abs(o[-1]) else len(o) - 2
            step = o[k] - o[k + 1]
            fraction = o[k] / step if step != 0 else 0.0
            result[index] = time[k] + fraction * (time[k + 1] - time[k])
        else:
            result[index] = time[0]
    return result


def _track_at(when: np.ndarray, time: np.ndarray, positions: np.ndarray,
              velocities: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Antenna position [m] and velocity [m/s] at times ``when`` [s]: linear between sweeps,
    along the end sweeps' velocity beyond the track (a polynomial would smooth a wander)."""
    position = np.stack([np.interp(when, time, positions[:, a]) for a in range(3)], 1)
    velocity = np.stack([np.interp(when, time, velocities[:, a]) for a in range(3)], 1)
    before, after = when < time[0], when > time[-1]
    position[before] = positions[0] + (when[before] - time[0])[:, None] * velocities[0]
    position[after] = positions[-1] + (when[after] - time[-1])[:, None] * velocities[-1]
    return position, velocity


def ground_points(points: np.ndarray, arp: np.ndarray, velocity: np.ndarray,
                  height: float) -> np.ndarray:
    """Where the scatterers imaged at ``points`` [m] lie on the horizontal surface
    ``z = height`` [m]: the same range from the antenna ``arp`` at each point's COA and the same
    along-track offset along ``velocity`` (the range sphere and Doppler cone, SICD Vol. 1 §4.3,
    R/Rdot), on the point's side of the track."""
    unit = velocity / np.linalg.norm(velocity, axis=1, keepdims=True)
    offset = points - arp
    along = np.einsum("pi,pi->p", offset, unit)
    centre = arp + along[:, None] * unit
    radius = np.sqrt(np.maximum(np.einsum("pi,pi->p", offset, offset) - along ** 2, 0.0))
    side = offset - along[:, None] * unit
    side[:, 2] = 0.0
    side -= np.einsum("pi,pi->p", side, unit)[:, None] * unit
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-300)
    lift = np.cross(unit, side)
    lift *= np.sign(lift[:, 2:3] + (lift[:, 2:3] == 0))
    sine = np.clip((height - centre[:, 2]) / np.where(np.abs(lift[:, 2]) > 1e-12,
                                                      lift[:, 2], 1e-12) / radius, -1.0, 1.0)
    return centre + radius[:, None] * (np.sqrt(1 - sine ** 2)[:, None] * side
                                       + sine[:, None] * lift)


def radiometric(raw: xr.Dataset, image: xr.Dataset, points: np.ndarray, ground: np.ndarray,
                xrow: np.ndarray, ycol: np.ndarray, order: int, row_bandwidth: float,
                col_bandwidth: float, window: str, range_window: str) -> dict | None:
    """SICD ``Radiometric`` (NGA.STND.0024-1 Vol. 1 §4.10; Vol. 3 radiometric calibration)
    from mitsar's radar equation, or None for normalised echoes (no watts).

    SICD's factors hold for scatterers on the surface at the SCP's height (Vol. 1 §4.10), so
    they are evaluated at ``ground``, where the scatterers imaged at the sample pixels
    ``points`` lie (:func:`ground_points`). A point of RCS sigma focuses to the peak
    ``sqrt(sigma) |h_0|``, ``|h_0|`` the focused peak of a 1 m^2 point at the pixel
    (:func:`mitsar.focus.nesz.unit_peak_amplitude`: radar equation and two-way pattern over
    the processed aperture). SICD's RCS is the scale factor times the pixel power integrated
    over the response and normalised by the oversampling,
    ``SS_r SS_c ImpRespBW_r ImpRespBW_c sum |p|^2``, which for a window ``w`` per dimension is
    the peak power times ``prod mean(w^2) / mean(w)^2`` (Parseval). Hence
    ``RCSSF = 1 / (|h_0|^2 prod mean(w^2)/mean(w)^2)``,
    ``BetaZeroSF = RCSSF ImpRespBW_r ImpRespBW_c`` (per unit slant-plane area),
    ``SigmaZeroSF = BetaZeroSF sin(theta_i)`` (per unit ground area, ``theta_i`` the incidence
    on a horizontal surface) and ``GammaZeroSF = SigmaZeroSF / cos(theta_i)``; all fitted over
    the image's sample pixels (order <= 2, metres from the SCP). ``NoiseLevel`` (``ABSOLUTE``,
    ``NoisePoly`` in dB of pixel power) from the image's ``noise_power`` variable when the
    focuser computed it (mitsar.focus.nesz, the NESZ's noise floor).
    """
    if int(raw.attrs.get("normalized", 0)):
        return None
    radar = Radar.from_attrs(image.attrs)
    resolution = image.attrs.get("azimuth_resolution_requested",
                                 image.attrs.get("azimuth_resolution"))
    half_width = aperture_half_width(radar, None if resolution is None else float(resolution))
    peak, sin_incidence = unit_peak_amplitude(raw, ground, half_width, window)

    def shape(name: str) -> float:
        weights = evaluate_window(window_coefficients(name), (np.arange(256) + 0.5) / 256)
        return float(np.mean(weights ** 2) / np.mean(weights) ** 2)

    rcs = 1.0 / (peak ** 2 * shape(window) * shape(range_window))
    beta = rcs * row_bandwidth * col_bandwidth
    sigma = beta * sin_incidence
    gamma = sigma / np.sqrt(np.clip(1.0 - sin_incidence ** 2, 1e-12, 1.0))
    result = {name: _fit_poly2d(xrow, ycol, values, order) for name, values in
              (("RCSSFPoly", rcs), ("SigmaZeroSFPoly", sigma), ("BetaZeroSFPoly", beta),
               ("GammaZeroSFPoly", gamma))}
    if "noise_power" in image.variables:
        noise = np.asarray(image["noise_power"].values, float)
        index = [np.argmin(np.linalg.norm(image["position"].values - point, axis=-1))
                 for point in points]
        level = noise.ravel()[index]
        if np.all(level > 0):
            result = {"NoiseLevel": {"NoiseLevelType": "ABSOLUTE", "NoisePoly": _fit_poly2d(
                xrow, ycol, 10 * np.log10(level), order)}, **result}
    return result


def _fit_poly2d(x: np.ndarray, y: np.ndarray, values: np.ndarray, order: int,
                weights: np.ndarray | None = None) -> np.ndarray:
    """Least-squares 2-D polynomial ``c[i, j] x^i y^j`` (i + j <= order) [value units], each
    sample weighted by ``weights`` (default equal; zero leaves a sample out)."""
    terms = [(i, j) for i in range(order + 1) for j in range(order + 1 - i)]
    scale_x = max(float(np.abs(x).max()), 1e-12)
    scale_y = max(float(np.abs(y).max()), 1e-12)
    design = np.column_stack([(x / scale_x) ** i * (y / scale_y) ** j for i, j in terms])
    root = np.ones(len(values)) if weights is None else np.sqrt(np.asarray(weights, float))
    solution = np.linalg.lstsq(design * root[:, None], values * root, rcond=None)[0]
    coefficients = np.zeros((order + 1, order + 1))
    for (i, j), value in zip(terms, solution, strict=True):
        coefficients[i, j] = value / scale_x ** i / scale_y ** j
    return coefficients


def aperture_of(image_product: xr.Dataset) -> xr.Dataset | None:
    """The aperture an image was formed from, as the raw product's track variables.

    :func:`mitsar.focus` copies the raw product's mid-sweep ``platform_position``,
    ``platform_velocity``, ``boresight`` and ``attitude`` into the image as ``aperture_*``
    (dim ``aperture``), with ``aperture_time`` (mid-sweep time [s]) and ``raw_normalized``;
    this returns them as a track-only raw product (``slow_time`` = sweep start, the radar and
    look attributes of the image), everything :func:`write_sicd` reads of ``raw``. None for an
    image without them (written by a mitsar before issue 25, or assembled by hand).
    """
    names = ["aperture_time", *APERTURE_VARIABLES.values()]
    if any(name not in image_product.variables for name in names):
        return None
    radar = Radar.from_attrs(image_product.attrs)
    data = {raw_name: (("sweep", image_product[name].dims[-1]), image_product[name].values)
            for raw_name, name in APERTURE_VARIABLES.items()}
    data["slow_time"] = ("sweep", np.asarray(image_product["aperture_time"].values, float)
                         - radar.sweep_duration / 2)
    attrs = {key: value for key, value in image_product.attrs.items()
             if key.startswith(("radar_", "look_"))}
    return xr.Dataset(data, attrs={**attrs, "product": "raw",
                                   "normalized": int(image_product.attrs.get("raw_normalized",
                                                                             0))})


def _track_source(image: xr.Dataset, raw: xr.Dataset | None) -> xr.Dataset:
    """``raw`` when given (checked against the aperture the image carries), else the image's
    own aperture (:func:`aperture_of`)."""
    carried = aperture_of(image)
    if raw is None:
        if carried is None:
            raise ParameterError("write_sicd", "raw", "the raw product the image was focused "
                                 "from, or an image that carries its aperture (aperture_* "
                                 "variables: focus it with this mitsar)", None)
        return carried
    if not isinstance(raw, xr.Dataset) or raw.attrs.get("product") != "raw":
        raise ParameterError("write_sicd", "raw", "None or the raw product the image was "
                             "focused from (SICD needs the antenna positions and times)",
                             type(raw).__name__)
    if carried is not None:
        ours, theirs = (np.asarray(d["platform_position"].values, float) for d in (carried, raw))
        if ours.shape != theirs.shape or not np.allclose(ours, theirs, rtol=0, atol=1e-6):
            warnings.warn(MitsarWarning(
                "write_sicd: raw's track differs from the aperture the image was formed from "
                f"({theirs.shape[0]} against {ours.shape[0]} sweeps, or positions more than "
                "1 um apart; e.g. a motion-compensated reference track): the SICD describes "
                "raw's; leave raw out to describe the image's own"), stacklevel=3)
    return raw


def write_sicd(image_product: xr.Dataset, path: str | os.PathLike, *,
               raw: xr.Dataset | None = None, origin: LabOrigin = DEFAULT_ORIGIN,
               overwrite: bool = False) -> Path:
    """Write a mitsar image product as a SICD 1.4.0 NITF file (module docstring).

    Parameters
    ----------
    image_product : xarray.Dataset
        Image product on a slant or plane grid.
    path : path-like
        Output file (conventionally ``*.nitf``), written atomically.
    raw : xarray.Dataset, optional
        The raw product the image was focused from. SICD needs the collection geometry
        (antenna positions, velocities, boresights and times), which an image focused by
        :func:`mitsar.focus` carries itself (:func:`aperture_of`): the same metadata either
        way. A raw whose track differs from the image's gets a :class:`MitsarWarning` and is
        used.
    origin : LabOrigin
        Where the lab frame sits on the Earth.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path

    Raises
    ------
    ParameterError
        For a non-image, an image on a points grid, or no ``raw`` for an image that does not
        carry its aperture.
    OutputExistsError
        If ``path`` exists and ``overwrite`` is false.
    """
    image = _check_image(image_product)
    raw = _track_source(image, raw)
    if not isinstance(origin, LabOrigin):
        raise ParameterError("write_sicd", "origin", "a LabOrigin", type(origin).__name__)
    sksicd = require_sarkit("sarkit.sicd")
    wgs84 = require_sarkit("sarkit.wgs84")
    etree = require_sarkit("lxml.etree")
    radar = Radar.from_attrs(image.attrs)
    time = np.asarray(raw["slow_time"].values, float) + radar.sweep_duration / 2
    time = time - time[0] + radar.sweep_duration / 2
    arp_lab = np.asarray(raw["platform_position"].values, float)
    mid = len(time) // 2
    layout = sicd_layout(image, arp_lab[mid])
    pixels = sicd_pixels(image, layout)
    rows, cols = pixels.shape
    position = _oriented(image["position"].transpose(layout["row_dim"], layout["col_dim"],
                                                     "xyz").values, layout)
    scp_index = (rows // 2, cols // 2)
    scp_lab = position[scp_index]
    scp = origin.to_ecf(scp_lab)
    order = int(min(5, len(time) - 1))
    arp_poly = np.polynomial.polynomial.polyfit(time, origin.to_ecf(arp_lab), order)
    velocity_lab = np.asarray(raw["platform_velocity"].values, float)
    boresight = np.asarray(raw["boresight"].values, float)
    wavenumber = 2.0 * radar.carrier_frequency / SPEED_OF_LIGHT
    window = str(image.attrs.get("window", "rect"))
    range_window = str(image.attrs.get("range_window", window))
    algorithm = str(image.attrs.get("algorithm", "bpa"))

    # Centre of aperture over the image (Vol. 1 §2.4): sampled on a coarse grid of pixels,
    # fitted as TimeCOAPoly(xrow, ycol) [s] with xrow, ycol [m] from the SCP.
    samples = [np.unique(np.linspace(0, n - 1, min(n, COA_SAMPLES)).round().astype(int))
               for n in (rows, cols)]
    sample_rows, sample_cols = np.meshgrid(*samples, indexing="ij")
    sample_points = position[sample_rows, sample_cols].reshape(-1, 3)
    xrow = ((sample_rows - scp_index[0]) * layout["row_spacing"]).ravel()
    ycol = ((sample_cols - scp_index[1]) * layout["col_spacing"]).ravel()
    coa = centre_of_aperture(sample_points, time, arp_lab, velocity_lab, boresight)
    poly_order = int(min(COA_ORDER, len(samples[0]) - 1, len(samples[1]) - 1))
    # the pixels the aperture covers hold the data: the COA polynomials are fitted there (a
    # pixel past the track's end has a COA extrapolated, and no signal)
    covered = None
    if "coverage" in image.variables:
        covered = _oriented(image["coverage"].transpose(layout["row_dim"],
                                                       layout["col_dim"]).values,
                            layout)[sample_rows, sample_cols].ravel()
        if np.count_nonzero(covered > 0) < 2 * (poly_order + 1) ** 2:
            covered = None
    time_coa_poly = _fit_poly2d(xrow, ycol, coa, poly_order, covered)
    scp_coa = float(centre_of_aperture(scp_lab[None], time, arp_lab, velocity_lab,
                                       boresight)[0])
    time_coa_poly[0, 0] += scp_coa - float(time_coa_poly[0, 0])  # exact at the SCP
    arp_at_coa, _ = _track_at(coa, time, arp_lab, velocity_lab)
    sight = sample_points - arp_at_coa
    sight /= np.linalg.norm(sight, axis=1, keepdims=True)
    corner_rows = np.array([0, 0, rows - 1, rows - 1]) - scp_index[0]
    corner_cols = np.array([0, cols - 1, cols - 1, 0]) - scp_index[1]
    # ValidData (Vol. 1 §2.3, ImageData): the whole image, its edges sampled so that the
    # readers' DeltaK1/2 (extremes of DeltaKCOAPoly at these vertices) see the support's
    # extremes along the edges, not only at the four corners
    valid = boundary_vertices(rows, cols, COA_SAMPLES)
    valid_rows, valid_cols = valid[:, 0] - scp_index[0], valid[:, 1] - scp_index[1]

    def grid_dim(u: np.ndarray, spacing: float, resolution: float, applied: str) -> dict:
        # mitsar's pixels hold exp(-j 2 pi k l.x) (back-projection leaves the carrier,
        # docs/conventions.md): Sgn = +1, the support at k = (2 f_c / c) l(COA) . u, seen in
        # the pixels modulo 1/SS; KCtr the multiple of 1/SS nearest k at the SCP and
        # DeltaKCOAPoly = k - KCtr over the image (Vol. 1 §4.2, Grid).
        bandwidth = 1.0 / resolution
        nyquist = 0.5 / spacing
        spatial = wavenumber * (sight @ u)
        k_scp = float(_fit_poly2d(xrow, ycol, spatial, poly_order, covered)[0, 0])
        k_ctr = round(k_scp * spacing) / spacing
        delta_poly = _fit_poly2d(xrow, ycol, spatial - k_ctr, poly_order, covered)
        corners = np.polynomial.polynomial.polyval2d(
            valid_rows * layout["row_spacing"], valid_cols * layout["col_spacing"],
            delta_poly)
        low = float(corners.min()) - bandwidth / 2
        high = float(corners.max()) + bandwidth / 2
        if low < -nyquist or high > nyquist:
            low, high = -nyquist, nyquist
        return {"UVectECF": origin.vectors_to_ecf(u), "SS": spacing,
                "ImpRespWid": impulse_width_factor(applied) / bandwidth, "Sgn": 1,
                "ImpRespBW": bandwidth, "KCtr": k_ctr, "DeltaK1": low, "DeltaK2": high,
                "DeltaKCOAPoly": delta_poly, **weighting(applied)}

    row_is_range = layout["row_dim"] == image["image"].dims[
        int(np.argmax(np.abs(image.attrs.get("range_axis", [0.0, 1.0]))))]
    row_resolution = float(image.attrs["range_resolution"] if row_is_range
                           else image.attrs["azimuth_resolution"])
    col_resolution = float(image.attrs["azimuth_resolution"] if row_is_range
                           else image.attrs["range_resolution"])
    normal = np.cross(layout["u_row"], layout["u_col"])
    plane = ("SLANT" if image.attrs.get("grid_kind") == "slant"
             else "GROUND" if abs(normal[2]) > 0.999 else "OTHER")
    low = radar.carrier_frequency - radar.bandwidth / 2
    high = radar.carrier_frequency + radar.bandwidth / 2
    # ImageCorners (Vol. 1 §2.6, GeoData): the corner pixels projected into the ground plane
    # through the SCP along the slant-plane normal at the SCP's centre of aperture
    arp_scp, velocity_scp = (v[0] for v in _track_at(np.array([scp_coa]), time, arp_lab,
                                                      velocity_lab))
    normal_slant = np.cross(arp_scp - scp_lab, velocity_scp)
    normal_slant /= np.linalg.norm(normal_slant)
    up = np.array([0.0, 0.0, 1.0])
    if normal_slant @ up < 0:
        normal_slant = -normal_slant
    ground = [u - (u @ up) * normal_slant / (normal_slant @ up)
              for u in (layout["u_row"], layout["u_col"])]
    corners_lab = [scp_lab + ground[0] * r * layout["row_spacing"]
                   + ground[1] * c * layout["col_spacing"]
                   for r, c in zip(corner_rows, corner_cols, strict=True)]
    corners = wgs84.cartesian_to_geodetic(origin.to_ecf(np.array(corners_lab)))[:, :2]
    valid_lab = (scp_lab + ground[0] * (valid_rows * layout["row_spacing"])[:, None]
                 + ground[1] * (valid_cols * layout["col_spacing"])[:, None])
    valid_geo = wgs84.cartesian_to_geodetic(origin.to_ecf(valid_lab))[:, :2]
    # RadarCollection/Area (Vol. 1 §4.8): the imaged ground corners, clockwise seen from above
    ring = np.array(corners_lab)[:, :2]
    clockwise = float(np.sum(ring[:, 0] * np.roll(ring[:, 1], -1)
                             - np.roll(ring[:, 0], -1) * ring[:, 1])) < 0
    area_corners = wgs84.cartesian_to_geodetic(
        origin.to_ecf(np.array(corners_lab if clockwise else corners_lab[::-1])))

    ns = SICD_NAMESPACE
    root = etree.Element(f"{{{ns}}}SICD", nsmap={None: ns})
    xml = sksicd.ElementWrapper(root)
    xml["CollectionInfo"] = {
        "CollectorName": "mitsar FMCW SAR", "CoreName": f"mitsar-{__version__}",
        "CollectType": "MONOSTATIC", "RadarMode": {"ModeType": "STRIPMAP"},
        "Classification": "UNCLASSIFIED"}
    xml["ImageCreation"] = {"Application": f"mitsar {__version__}",
                            "DateTime": _dt.datetime.now(_dt.UTC).replace(microsecond=0)}
    xml["ImageData"] = {"PixelType": "RE32F_IM32F", "NumRows": rows, "NumCols": cols,
                        "FirstRow": 0, "FirstCol": 0,
                        "FullImage": {"NumRows": rows, "NumCols": cols},
                        "SCPPixel": list(scp_index), "ValidData": valid}
    xml["GeoData"] = {"EarthModel": "WGS_84",
                      "SCP": {"ECF": scp, "LLH": wgs84.cartesian_to_geodetic(scp)},
                      "ImageCorners": corners, "ValidData": valid_geo}
    xml["Grid"] = {
        "ImagePlane": plane, "Type": "PLANE", "TimeCOAPoly": time_coa_poly,
        "Row": grid_dim(layout["u_row"], layout["row_spacing"], row_resolution,
                        range_window if row_is_range else window),
        "Col": grid_dim(layout["u_col"], layout["col_spacing"], col_resolution,
                        window if row_is_range else range_window)}
    # Timeline/IPP (Vol. 1 §4.5): one set, sweep index = rate x time from the first sweep's
    # start, the rate the sweeps' mean spacing (prf, or prf / N_tx for a TDM channel)
    timeline: dict = {"CollectStart": COLLECT_START,
                      "CollectDuration": float(time[-1] + radar.sweep_duration / 2)}
    if len(time) > 1 and time[-1] > time[0]:
        rate = (len(time) - 1) / float(time[-1] - time[0])
        timeline["IPP"] = {"Set": [{"TStart": 0.0, "TEnd": len(time) / rate, "IPPStart": 0,
                                    "IPPEnd": len(time) - 1, "IPPPoly": [0.0, rate]}]}
    xml["Timeline"] = timeline
    xml["Position"] = {"ARPPoly": arp_poly}
    xml["RadarCollection"] = {
        "TxFrequency": {"Min": low, "Max": high},
        "Waveform": {"WFParameters": [{
            "TxPulseLength": radar.sweep_duration, "TxRFBandwidth": radar.bandwidth,
            "TxFreqStart": low, "TxFMRate": radar.chirp_rate, "RcvDemodType": "STRETCH",
            "RcvWindowLength": radar.sweep_duration, "ADCSampleRate": radar.sampling_frequency,
            "RcvFMRate": radar.chirp_rate}]},
        "TxPolarization": "V",
        "RcvChannels": {"ChanParameters": [{"TxRcvPolarization": "V:V"}]},
        "Area": {"Corner": area_corners}}
    _, velocity_at_coa = _track_at(coa, time, arp_lab, velocity_lab)
    calibration = radiometric(raw, image, sample_points,
                              ground_points(sample_points, arp_at_coa, velocity_at_coa,
                                            float(scp_lab[2])), xrow, ycol, min(poly_order, 2),
                              1.0 / row_resolution, 1.0 / col_resolution, window, range_window)
    if calibration is not None:
        xml["Radiometric"] = calibration
    xml["ImageFormation"] = {
        "RcvChanProc": {"NumChanProc": 1, "ChanIndex": [1]},
        "TxRcvPolarizationProc": "V:V", "TStartProc": float(time[0]),
        "TEndProc": float(time[-1]), "TxFrequencyProc": {"MinProc": low, "MaxProc": high},
        "ImageFormAlgo": ALGORITHMS.get(algorithm, "OTHER"), "STBeamComp": "NO",
        "ImageBeamComp": "NO", "AzAutofocus": "NO", "RgAutofocus": "NO"}
    parameters = {**origin.to_parameters(), "mitsar.algorithm": algorithm,
                  "mitsar.row_dim": str(layout["row_dim"]),
                  "mitsar.col_dim": str(layout["col_dim"]),
                  "mitsar.flip_row": str(int(layout["flip_row"])),
                  "mitsar.flip_col": str(int(layout["flip_col"])),
                  **{k: repr(v) for k, v in image.attrs.items() if k.startswith("radar_")}}
    for parent, child in (("RadarCollection/{ns}Waveform", "WFParameters"),
                          ("RadarCollection/{ns}RcvChannels", "ChanParameters"),
                          ("Timeline/{ns}IPP", "Set")):
        node = root.find(f"{{{ns}}}" + parent.format(ns=f"{{{ns}}}"))
        if node is None:
            continue
        node.set("size", str(len(node)))
        for index, item in enumerate(node.findall(f"{{{ns}}}{child}"), start=1):
            item.set("index", str(index))
    info = root.find(f"{{{ns}}}CollectionInfo")
    for key, value in parameters.items():
        etree.SubElement(info, f"{{{ns}}}Parameter", name=key).text = value
    tree = etree.ElementTree(root)
    xml["SCPCOA"] = sksicd.compute_scp_coa(tree)
    security = sksicd.NitfSecurityFields(clas="U")
    metadata = sksicd.NitfMetadata(
        xmltree=tree,
        file_header_part=sksicd.NitfFileHeaderPart(ostaid="mitsar", security=security),
        im_subheader_part=sksicd.NitfImSubheaderPart(isorce="mitsar FMCW SAR",
                                                     security=security),
        de_subheader_part=sksicd.NitfDeSubheaderPart(security=security))

    def write(tmp: Path) -> None:
        with tmp.open("wb") as handle, sksicd.NitfWriter(handle, metadata) as writer:
            writer.write_image(pixels)

    return atomic_writer(path, overwrite, write)
