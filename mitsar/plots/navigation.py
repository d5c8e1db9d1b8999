"""Figures of real flight: true against navigation track, injected against estimated phase.

* :func:`navigation_phase` — the two-way phase the navigation error puts on a scene point,
  ``4 pi (|x - p_true| - |x - p_nav|) / lambda`` per sweep [rad];
* :func:`plot_tracks` — the true and the recorded track from above, and their difference along,
  across and up against time;
* :func:`plot_phase` — the injected phase against an autofocus estimate (the image's
  ``autofocus_phase``), both with their mean and linear trend removed (a constant is invisible,
  a trend only shifts the image);
* :func:`plot_autofocus_phase` — an autofocused image's estimate per sweep, against the
  injected phase at its metrics target when the raw product knows the true track (the
  report's autofocus figure).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.plots import figures  # noqa: F401 - selects the Agg backend first
from mitsar.products.raw import radar_of
from mitsar.products.requests import metrics_request

__all__ = ["detrend", "navigation_phase", "plot_autofocus_phase", "plot_phase",
           "plot_tracks"]


def _require_truth(raw: xr.Dataset, where: str) -> None:
    if "true_platform_position" not in raw.variables:
        raise ParameterError(where, "raw", "a raw product simulated with navigation errors "
                             "(variables true_platform_*)", "no true track in the product")


def navigation_phase(raw: xr.Dataset, point: ArrayLike) -> NDArray[np.float64]:
    """Two-way phase error per sweep that the navigation error causes at ``point`` [rad].

    ``4 pi (R_true - R_nav) / lambda`` with ``R = |point - p|`` at mid-sweep (the focuser
    assumes the echo came from the navigation position).
    """
    _require_truth(raw, "navigation_phase")
    x = np.asarray(point, dtype=float)
    true = np.linalg.norm(x - raw["true_platform_position"].values, axis=-1)
    nav = np.linalg.norm(x - raw["platform_position"].values, axis=-1)
    return 4 * np.pi * (true - nav) / radar_of(raw).wavelength


def detrend(phase: ArrayLike) -> NDArray[np.float64]:
    """``phase`` minus its least-squares line against the sweep index [rad]."""
    phase = np.asarray(phase, dtype=float)
    index = np.arange(len(phase))
    return phase - np.polyval(np.polyfit(index, phase, 1), index)


def plot_tracks(raw: xr.Dataset, axes: tuple[Axes, Axes] | None = None
                ) -> tuple[Axes, Axes]:
    """True and navigation track: plan view [m], and their difference [mm] against time [s]
    along the mean track direction, across it (horizontal) and up."""
    _require_truth(raw, "plot_tracks")
    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(10.0, 4.0), layout="constrained")
    true = raw["true_platform_position"].values
    nav = raw["platform_position"].values
    time = raw["slow_time"].values
    plan, diff = axes
    plan.plot(true[:, 0], true[:, 1], label="true", lw=2)
    plan.plot(nav[:, 0], nav[:, 1], "--", label="navigation")
    plan.set(xlabel="x [m]", ylabel="y [m]", title="tracks (plan view)")
    plan.axis("equal")
    plan.legend()
    along = true[-1] - true[0]
    along = along / max(np.linalg.norm(along), 1e-12)
    across = np.cross([0.0, 0.0, 1.0], along)
    across = across / max(np.linalg.norm(across), 1e-12)
    delta = nav - true
    for vector, name in ((along, "along"), (across, "across"), (np.array([0, 0, 1.0]), "up")):
        diff.plot(time, 1e3 * delta @ vector, label=name)
    diff.set(xlabel="slow time [s]", ylabel="navigation − true [mm]",
             title="navigation error")
    diff.legend()
    return plan, diff


def plot_phase(raw: xr.Dataset, point: ArrayLike, estimates: dict[str, ArrayLike],
               ax: Axes | None = None) -> Axes:
    """Injected phase at ``point`` against autofocus estimates (name -> phase per sweep),
    all detrended [rad]."""
    if ax is None:
        _, ax = plt.subplots(figsize=(7.0, 4.0), layout="constrained")
    time = raw["slow_time"].values
    injected = detrend(navigation_phase(raw, point))
    ax.plot(time, injected, "k", lw=2, label="injected (navigation error)")
    for name, phase in estimates.items():
        estimate = detrend(phase)
        rms = float(np.sqrt(np.mean((estimate - injected) ** 2)))
        ax.plot(time, estimate, "--", label=f"{name} (residual {rms:.2f} rad rms)")
    ax.set(xlabel="slow time [s]", ylabel="phase, trend removed [rad]",
           title="phase error: injected and estimated")
    ax.legend()
    return ax


def plot_autofocus_phase(raw: xr.Dataset, image: xr.Dataset, ax: Axes | None = None) -> Axes:
    """An autofocused image's estimated phase error per sweep [rad] against slow time [s].

    With the true track in ``raw`` (a simulation with navigation errors) and a metrics target
    in the image (:func:`mitsar.products.requests.metrics_request`), the injected phase at the
    target is drawn too (:func:`plot_phase`, both detrended); otherwise the estimate alone,
    detrended likewise (its mean and linear trend only shift the image). The title names the
    method and whether the correction was applied (``autofocus_applied``).

    Parameters
    ----------
    raw : xarray.Dataset
        The raw product the image was focused from (its ``slow_time``).
    image : xarray.Dataset
        An image with ``autofocus_phase`` (sweep) [rad]
        (:func:`mitsar.focus.autofocus.driver.run_autofocus`).
    ax : matplotlib Axes, optional

    Returns
    -------
    Axes

    Raises
    ------
    ParameterError
        If the image has no ``autofocus_phase``.
    """
    if "autofocus_phase" not in image.variables:
        raise ParameterError("plot_autofocus_phase", "image", "an autofocused image (variable "
                             "autofocus_phase)", sorted(image.data_vars))
    if ax is None:
        _, ax = plt.subplots(figsize=(7.0, 4.0), layout="constrained")
    method = str(image.attrs.get("autofocus_method", "autofocus"))
    estimate = np.asarray(image["autofocus_phase"].values, dtype=float)
    target = metrics_request(image)[0]
    if "true_platform_position" in raw.variables and target is not None:
        plot_phase(raw, target, {f"{method.upper()} estimate": estimate}, ax=ax)
    else:
        ax.plot(raw["slow_time"].values, detrend(estimate), "--",
                label=f"{method.upper()} estimate")
        ax.set(xlabel="slow time [s]", ylabel="phase, trend removed [rad]")
        ax.legend()
    applied = bool(image.attrs.get("autofocus_applied", 1))
    ax.set_title(f"{method.upper()}: estimated phase error per sweep"
                 + ("" if applied else " (not applied: it made the image worse)"))
    ax.grid(True, alpha=0.3)
    return ax
