"""Point features: CFAR detections grouped into connected clusters, each one located in 3-D.

A cluster is a connected component of detected cells (``scipy.ndimage.label``, cells touching
by a face, edge or corner). Each becomes one point feature with

* ``position``: the power-weighted centroid of its cells' world positions [m];
* ``amplitude``: the peak ``|x|`` of its cells (image units);
* ``snr``: the peak's signal-to-noise power ratio, ``(P_peak - N) / N`` with ``N`` the CFAR
  noise estimate at the peak (linear, not dB);
* ``uncertainty``: the 1-sigma position error per world axis [m], from the Cramér–Rao bound of
  a peak position, ``sigma_d = sqrt(3) rho_d / (pi sqrt(2 SNR))`` along each image dim ``d``
  with resolution ``rho_d`` (docs/features.md eq. 5; Skolnik 2001 ch. 6), rotated onto x, y, z.

Every detected cell is kept beside them (dim ``cell``) with its cluster's index, so that line
fits and map scores can read the cells themselves (a wall is one long cluster).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from scipy import ndimage

from mitsar.features.cfar import cfar

__all__ = ["peak_position_sigma", "point_features"]

CRAMER_RAO = math.sqrt(3.0) / math.pi
"""``sqrt(3)/pi``: the Cramér–Rao bound of a peak position in resolution cells at
``2 SNR = 1`` for a rectangular spectrum (rms bandwidth ``pi B / sqrt(3)``; docs/features.md
eq. 5)."""


def peak_position_sigma(resolution: NDArray[np.float64] | float,
                        snr: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """1-sigma error of a peak's position along an axis of resolution ``rho``, docs/features.md
    eq. 5: ``sigma = sqrt(3) rho / (pi sqrt(2 SNR))`` (Cramér–Rao bound for a sinc response of
    a rectangular spectrum; Skolnik 2001 ch. 6).

    Parameters
    ----------
    resolution : float or ndarray
        Resolution cell ``rho`` along the axis [m] (broadcast against ``snr``).
    snr : float or ndarray
        Peak signal-to-noise power ratio per pixel (linear, > 0).

    Returns
    -------
    ndarray
        ``sigma`` [m].
    """
    return CRAMER_RAO * np.asarray(resolution, float) / np.sqrt(
        2.0 * np.maximum(np.asarray(snr, float), 1e-12))


def _attrs(units: str, long_name: str) -> dict[str, str]:
    return {"units": units, "long_name": long_name}


def point_features(source: Any, **options: Any) -> xr.Dataset:
    """Cluster a CFAR map (:func:`mitsar.features.cfar.cfar`) into point features.

    Parameters
    ----------
    source : xarray.Dataset or array_like
        The output of :func:`~mitsar.features.cfar.cfar` (``power``, ``noise``, ``detected``,
        ``position`` and the ``resolution``/``axes`` attributes), or an image, which
        :func:`~mitsar.features.cfar.cfar` tests first.
    **options
        Keywords of :func:`~mitsar.features.cfar.cfar` (``pfa``, ``method``, ``guard``, ...)
        for an image.

    Returns
    -------
    xarray.Dataset
        dim ``detection`` (one per cluster, strongest first): ``position`` (detection, xyz) [m],
        ``amplitude`` [image units], ``snr`` [1, linear], ``snr_db`` [dB], ``uncertainty``
        (detection, xyz) [m, 1 sigma], ``cells`` (cluster size); dim ``cell`` (every detected
        cell): ``cell_position`` (cell, xyz) [m], ``cell_amplitude``, ``cell_snr`` [1],
        ``cell_detection`` (index of its cluster). Attributes: the CFAR map's.
    """
    is_map = isinstance(source, xr.Dataset) and source.attrs.get("product") == "cfar"
    cfar_map = source if is_map else cfar(source, **options)
    dims = tuple(cfar_map.attrs["dims"])
    power = cfar_map["power"].transpose(*dims).values
    noise = cfar_map["noise"].transpose(*dims).values
    detected = cfar_map["detected"].transpose(*dims).values
    position = cfar_map["position"].transpose(*dims, "xyz").values
    ndim = len(dims)
    labels, count = ndimage.label(detected, ndimage.generate_binary_structure(ndim, ndim))
    index = np.arange(1, count + 1)
    weight = ndimage.sum_labels(power, labels, index) if count else np.zeros(0)
    centroid = np.stack([ndimage.sum_labels(power * position[..., c], labels, index)
                         for c in range(3)], axis=-1).reshape(count, 3) / np.maximum(
                             weight, np.finfo(float).tiny)[:, None]
    peaks = (np.array(ndimage.maximum_position(power, labels, index), dtype=int)
             .reshape(count, ndim))
    peak_power = power[tuple(peaks.T)]
    peak_noise = noise[tuple(peaks.T)]
    snr = np.maximum(peak_power / peak_noise - 1.0, np.finfo(float).tiny)
    sizes = np.bincount(labels.ravel(), minlength=count + 1)[1:]
    # Covariance sum_d sigma_d^2 e_d e_d^T of the image axes e_d, its diagonal per world axis.
    resolution = np.asarray(cfar_map.attrs["resolution"], float)
    axes = np.asarray(cfar_map.attrs["axes"], float).reshape(ndim, 3)
    sigma = peak_position_sigma(resolution[None, :], snr[:, None])
    uncertainty = np.sqrt(np.square(sigma) @ np.square(axes))
    order = np.argsort(-peak_power, kind="stable")
    rank_of = np.empty(count, dtype=int)
    rank_of[order] = np.arange(count)
    cells = np.nonzero(detected)
    cell_snr = power[cells] / noise[cells] - 1.0
    out = xr.Dataset(
        {"position": (("detection", "xyz"), centroid[order], _attrs(
            "m", "power-weighted centroid of the cluster's cells")),
         "amplitude": ("detection", np.sqrt(peak_power[order]), _attrs(
             "1", "peak amplitude |x| of the cluster (image units)")),
         "snr": ("detection", snr[order], _attrs(
             "1", "peak signal-to-noise power ratio (linear)")),
         "snr_db": ("detection", 10.0 * np.log10(snr[order]), _attrs(
             "dB", "peak signal-to-noise power ratio")),
         "uncertainty": (("detection", "xyz"), uncertainty[order], _attrs(
             "m", "1-sigma position error per world axis (Cramer-Rao, docs/features.md eq. 5)")),
         "cells": ("detection", sizes[order], _attrs("1", "detected cells in the cluster")),
         "cell_position": (("cell", "xyz"), position[cells].reshape(-1, 3), _attrs(
             "m", "world position of the detected cell")),
         "cell_amplitude": ("cell", np.sqrt(power[cells]), _attrs(
             "1", "amplitude |x| of the detected cell (image units)")),
         "cell_snr": ("cell", cell_snr, _attrs(
             "1", "signal-to-noise power ratio of the cell (linear)")),
         "cell_detection": ("cell", rank_of[labels[cells] - 1], _attrs(
             "1", "index along 'detection' of the cell's cluster"))},
        coords={"xyz": ["x", "y", "z"]})
    out.attrs.update({k: v for k, v in cfar_map.attrs.items() if k != "product"},
                     product="detections")
    return out
