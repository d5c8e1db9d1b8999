"""The interferogram of two channels of a multi-channel image, down to heights and positions.

Input: an image product with a ``channel`` dim (docs/interferometry.md §1, the contract):
``image`` (channel, ROW, COL) complex, ``position`` (ROW, COL, xyz) [m], ``transmitter_offset``
and ``receiver_offset`` (channel, xyz) [m] in the body frame, the processed aperture's
``aperture_position`` (aperture, xyz) [m] and ``aperture_attitude`` (aperture, angle) [rad], and
the attribute ``radar_carrier_frequency`` [Hz]. Every channel was back-projected onto the same
pixels with its own exact path, so ``s_1 s_2*`` is the *flat* interferogram: zero phase for a
scatterer on the reference surface (the grid).

Steps: multilook ``s_1 s_2*`` and the powers over ``looks`` windows (masked pixels and pixels of
zero amplitude left out), boxcar coherence (Touzi et al. 1999), wrapped phase, SNAPHU unwrapping
(Chen & Zebker 2001) tied to the reference surface, the exact two-path position of the scatterer
(Rosen et al. 2000; :mod:`mitsar.interferometry.geolocation`), and the predicted height noise:
the Cramér–Rao phase noise (Rodriguez & Martin 1992) times ``|dz/dphi|``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.interferometry.coherence import coherence as coherence_estimate
from mitsar.interferometry.geolocation import (
    ambiguity_height,
    first_order_ambiguity_height,
    height_sensitivity,
    phase_to_position,
)
from mitsar.interferometry.geometry import (
    PairGeometry,
    baseline,
    pair_geometry,
    reference_phase,
)
from mitsar.interferometry.multilook import check_looks, look_sum, multilook
from mitsar.interferometry.phase_statistics import predicted_phase_std
from mitsar.interferometry.unwrapping import tie_to_reference
from mitsar.interferometry.unwrapping import unwrap as snaphu_unwrap
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.products.interferogram import INTERFEROGRAM_SCHEMA, validate_interferogram

__all__ = ["INTERFEROGRAM_VARIABLES", "interferogram"]

WHERE = "interferogram"

INTERFEROGRAM_VARIABLES: dict[str, tuple[str, str]] = {
    name: (variable.units, variable.long_name)
    for name, variable in INTERFEROGRAM_SCHEMA.variables.items()}
"""Variables of the interferogram dataset: (CF units, long_name), from its schema
(:data:`mitsar.products.interferogram.INTERFEROGRAM_SCHEMA`)."""

_REQUIRED = ("image", "position", "transmitter_offset", "receiver_offset",
             "aperture_position", "aperture_attitude")


def _check_image(image: xr.Dataset, pair: tuple[int, int]) -> tuple[tuple[str, str], int, int]:
    """The grid dims and the pair's channel indices; raise on a product off the contract."""
    if not isinstance(image, xr.Dataset):
        raise ParameterError(WHERE, "image", "a multi-channel image product (xarray Dataset)",
                             type(image).__name__)
    missing = [name for name in _REQUIRED if name not in image.variables]
    if missing:
        raise ParameterError(WHERE, missing[0], f"the multi-channel image's variables "
                             f"{_REQUIRED} (focus a raw product with channels by 'bpa')",
                             sorted(map(str, image.variables)))
    dims = tuple(map(str, image["image"].dims))
    if len(dims) != 3 or dims[0] != "channel":
        raise ParameterError(WHERE, "image", "dims ('channel', ROW, COL)", dims)
    if "radar_carrier_frequency" not in image.attrs:
        raise ParameterError(WHERE, "radar_carrier_frequency", "the attribute [Hz]",
                             sorted(image.attrs))
    channels = image.sizes["channel"]
    try:
        first, second = (int(k) for k in pair)
    except (TypeError, ValueError):
        raise ParameterError(WHERE, "pair", "two channel indices", pair) from None
    if first == second or not (0 <= first < channels and 0 <= second < channels):
        raise ParameterError(WHERE, "pair", f"two different channels in 0..{channels - 1}",
                             pair)
    return (dims[1], dims[2]), first, second


def _block_mean(values: NDArray, size: int) -> NDArray:
    """Mean of a 1-D coordinate over consecutive blocks of ``size`` (remainder dropped)."""
    n = values.shape[0] // size
    return values[: n * size].reshape(n, size).mean(axis=1)


def _snr_coherence(image: xr.Dataset, s1: NDArray, s2: NDArray, window: tuple[int, int],
                   invalid: NDArray) -> NDArray[np.float64]:
    """Thermal-noise coherence ``1 / sqrt((1 + 1/SNR_1)(1 + 1/SNR_2))`` of each multilooked
    pixel (Zebker & Villasenor 1992 eq. 6, docs/interferometry.md §4), with SNR_k the
    channel's mean power over the window less the image's ``noise_power`` [W] (the same in
    every channel: one receiver design), over it; 1 where the image carries no noise power
    (noise-free simulations)."""
    if "noise_power" not in image.variables:
        return np.ones(multilook(s1, window, invalid)[0].shape)
    noise = multilook(np.asarray(image["noise_power"].values, float), window, invalid)[0]
    factors = []
    for values in (s1, s2):
        power = multilook(np.abs(values) ** 2, window, invalid)[0]
        with np.errstate(invalid="ignore", divide="ignore"):
            snr = np.maximum(power - noise, 0.0) / noise
            factors.append(np.where(noise > 0, 1.0 + 1.0 / snr, 1.0))
    return 1.0 / np.sqrt(factors[0] * factors[1])


def interferogram(image: xr.Dataset, pair: tuple[int, int] = (0, 1),
                  looks: tuple[int, int] = (1, 1), unwrap: bool = True,
                  mask: NDArray[np.bool_] | xr.DataArray | None = None, *,
                  min_coherence: float = 0.3,
                  reference_pixel: tuple[int, int] | None = None,
                  unwrap_options: Mapping[str, Any] | None = None) -> xr.Dataset:
    """Interferogram, coherence, unwrapped phase, heights and 3-D positions of a channel pair.

    Parameters
    ----------
    image : xarray.Dataset
        Multi-channel image product (module docstring; docs/interferometry.md §1).
    pair : (int, int)
        Channels (1, 2) of ``s_1 s_2*``.
    looks : (int, int)
        Multilook window (rows, cols) [pixels] on the grid's (ROW, COL).
    unwrap : bool
        Unwrap with SNAPHU (Chen & Zebker 2001); False takes the wrapped phase as unwrapped
        (right when every scatterer lies within half an ambiguity height of the grid).
    mask : array of bool, shape (ROW, COL), optional
        True where a pixel is invalid (layover, shadow); pixels of zero amplitude in either
        channel are always masked.
    min_coherence : float
        Multilooked pixels of lower coherence [1] are left out of unwrapping (NaN heights).
    reference_pixel : (int, int), optional
        (row, col) on the multilooked grid whose scatterer is taken to lie within half an
        ambiguity height of the reference surface; default: the pixel of highest coherence of
        each connected component.
    unwrap_options : mapping, optional
        Passed to :func:`mitsar.interferometry.unwrapping.unwrap` (SNAPHU tiling etc.).

    Returns
    -------
    xarray.Dataset
        Variables of :data:`INTERFEROGRAM_VARIABLES` on the multilooked (ROW, COL) grid, with
        CF ``units`` and ``long_name``; attributes ``product = "interferogram"``, ``pair``,
        ``wavelength`` [m], ``looks_azimuth``/``looks_range`` (window), ``baseline`` (effective
        baseline ``(t_2 + r_2) - (t_1 + r_1)`` at the scene centre, world frame) [m],
        ``perpendicular_baseline`` [m], ``ambiguity_height`` (exact, numerical) [m] and its
        first-order value ``ambiguity_height_first_order`` [m] (Rosen et al. 2000),
        ``scene_centre_range`` [m], ``scene_centre_look_angle`` [rad], ``reference_pixel``.
    """
    (row, col), first, second = _check_image(image, pair)
    values = image["image"].values
    s1, s2 = values[first], values[second]
    window = check_looks(looks, s1.shape, WHERE)
    invalid = ~np.isfinite(s1) | ~np.isfinite(s2) | (s1 == 0) | (s2 == 0)
    if mask is not None:
        extra = np.asarray(mask, bool)
        if extra.shape != s1.shape:
            raise ParameterError(WHERE, "mask", f"a boolean array of shape {s1.shape}",
                                 extra.shape)
        invalid |= extra
    wavelength = SPEED_OF_LIGHT / float(image.attrs["radar_carrier_frequency"])

    ifg, count = multilook(s1 * np.conj(s2), window, invalid)
    power = np.sqrt(look_sum(np.where(invalid, 0, np.abs(s1) ** 2), window)
                    * look_sum(np.where(invalid, 0, np.abs(s2) ** 2), window))
    with np.errstate(invalid="ignore", divide="ignore"):
        amplitude = np.where(count > 0, np.sqrt(power / np.maximum(count, 1)), np.nan)
    gamma = coherence_estimate(s1, s2, window, invalid)
    phase = np.where(count > 0, np.angle(ifg), np.nan)
    pixels = np.moveaxis(multilook(np.moveaxis(
        image["position"].transpose(row, col, "xyz").values, -1, 0), window)[0], 0, -1)

    geometry = pair_geometry(image["aperture_position"].transpose("aperture", "xyz").values,
                             image["aperture_attitude"].transpose("aperture", "angle").values,
                             image["transmitter_offset"].transpose("channel", "xyz").values,
                             image["receiver_offset"].transpose("channel", "xyz").values,
                             pixels, (first, second))
    phi_ref = reference_phase(pixels, geometry, wavelength)

    excluded = (count == 0) | ~(gamma >= min_coherence)
    if unwrap:
        unwrapped, components = snaphu_unwrap(ifg, gamma, float(window[0] * window[1]),
                                              mask=excluded, **_unwrap_kwargs(unwrap_options))
        unwrapped = tie_to_reference(unwrapped, phase, components, gamma, reference_pixel)
    else:
        unwrapped = np.where(excluded, np.nan, phase)
        components = np.where(excluded, 0, 1)
    position = phase_to_position(unwrapped, pixels, geometry, wavelength)
    # The thermal decorrelation the image's own noise power predicts (Zebker & Villasenor
    # 1992): a bound on the coherence that holds for one look too, where the estimate is 1.
    gamma_snr = _snr_coherence(image, s1, s2, window, invalid)
    sigma_phi = predicted_phase_std(np.fmin(gamma, gamma_snr), count)
    height_std = sigma_phi * np.abs(height_sensitivity(unwrapped, pixels, geometry, wavelength))

    grid = (row, col)
    data = {
        "interferogram": (grid, ifg), "amplitude": (grid, amplitude), "phase": (grid, phase),
        "reference_phase": (grid, phi_ref), "coherence": (grid, gamma),
        "coherence_snr": (grid, gamma_snr),
        "unwrapped_phase": (grid, unwrapped), "connected_component": (grid, components),
        "height": (grid, position[..., 2]), "position": ((*grid, "xyz"), position),
        "pixel_position": ((*grid, "xyz"), pixels), "height_std": (grid, height_std),
        "looks": (grid, count),
    }
    coords: dict[str, Any] = {"xyz": ["x", "y", "z"]}
    for dim, size in zip(grid, window, strict=True):
        if dim in image.coords:
            coords[dim] = (dim, _block_mean(np.asarray(image[dim].values, float), size),
                           dict(image[dim].attrs))
    out = xr.Dataset(data, coords=coords)
    for name, (units, long_name) in INTERFEROGRAM_VARIABLES.items():
        out[name].attrs.update(units=units, long_name=long_name)
    out.attrs.update(_scene_centre_attrs(pixels, geometry, wavelength))
    out.attrs.update(product="interferogram", pair=[first, second], wavelength=wavelength,
                     radar_carrier_frequency=float(image.attrs["radar_carrier_frequency"]),
                     looks_azimuth=window[0], looks_range=window[1], unwrapped=int(unwrap),
                     min_coherence=float(min_coherence),
                     reference_pixel=[-1, -1] if reference_pixel is None
                     else [int(i) for i in reference_pixel])
    return validate_interferogram(out, WHERE)


def _unwrap_kwargs(options: Mapping[str, Any] | None) -> dict[str, Any]:
    """Split user unwrap options into the wrapper's keywords and SNAPHU's own."""
    options = dict(options or {})
    own = {key: options.pop(key) for key in ("cost", "init") if key in options}
    return {**own, "options": options}


def _scene_centre_attrs(pixels: NDArray, geometry: PairGeometry, wavelength: float
                        ) -> dict[str, Any]:
    """Baseline, ambiguity height (exact and first order), range and look angle at the centre
    pixel of the grid."""
    index = (pixels.shape[0] // 2, slice(pixels.shape[1] // 2, pixels.shape[1] // 2 + 1))
    centre, p = geometry.at(index), pixels[index]
    vector, perpendicular = baseline(centre.at(0), p[0])
    los = centre.platform[0] - p[0]
    slant = float(np.linalg.norm(los))
    look_angle = float(np.arccos(np.clip(los[2] / slant, -1.0, 1.0)))
    return {"baseline": [float(v) for v in vector],
            "perpendicular_baseline": perpendicular,
            "ambiguity_height": float(ambiguity_height(p, centre, wavelength)[0]),
            "ambiguity_height_first_order": float(first_order_ambiguity_height(
                wavelength, slant, look_angle, perpendicular)),
            "scene_centre_range": slant, "scene_centre_look_angle": look_angle}
