"""The interferometry workflow of ``mitsar interferogram`` and ``mitsar run``: a multi-channel
image in, the interferogram product, its point cloud and its figures out, with a summary.

:func:`run_interferometry` forms the interferogram of two channels
(:func:`mitsar.interferometry.interferogram`, with the options of ``[interferometry]``,
:class:`~mitsar.experiment.options.InterferometryOptions`) and its point cloud
(:func:`mitsar.interferometry.point_cloud`), with the layover and shadow masks of the scene's
geometry left out when the experiment has a scene (:func:`mitsar.scene.layover_shadow_masks`,
kept in the product as :data:`MASK_VARIABLES`); :func:`write_interferometry` writes them into a
folder (:data:`INTERFEROMETRY_FILES`: ``interferogram.nc`` through :func:`mitsar.io.save`,
``points.ply``, one PNG a map of :data:`mitsar.plots.interferometry.INTERFEROGRAM_MAPS`), each
atomically and never over an existing file unless asked; :func:`interferometry_summary` gives
the numbers both commands print and the report shows. docs/interferometry.md, docs/cli.md.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from mitsar.errors import ParameterError
from mitsar.experiment.options import InterferometryOptions
from mitsar.interferometry import interferogram, point_cloud, write_ply
from mitsar.io import check_writable, save
from mitsar.plots.figures import save_figure
from mitsar.plots.interferometry import INTERFEROGRAM_MAPS, interferogram_figures
from mitsar.scene.masks import layover_shadow_masks

__all__ = ["INTERFEROMETRY_FILES", "MASK_VARIABLES", "InterferometryResult",
           "check_multichannel", "format_interferometry_summary",
           "interferometry_figure_entries", "interferometry_summary", "run_interferometry",
           "scene_masks", "write_interferometry"]

INTERFEROMETRY_FILES: dict[str, str] = {
    "interferogram": "interferogram.nc",
    "points": "points.ply",
    **{name: f"{name}.png" for name in INTERFEROGRAM_MAPS},
}
"""Files written by :func:`write_interferometry`, by role: the product, the point cloud and
one figure a map."""

MASK_VARIABLES: dict[str, str] = {"shadow": "shadow", "layover": "layover",
                                  "mask": "layover_shadow_mask",
                                  "visible_surfaces": "visible_surfaces"}
"""Variables of :func:`mitsar.scene.layover_shadow_masks` kept in the interferogram product, by
their names there; they lie on the image's full grid, dims ``image_<ROW>``, ``image_<COL>``
(the interferogram's own grid is multilooked)."""

_CAPTIONS = {
    "phase": "flat phase s1 s2* after the reference surface (the focusing grid) is removed: "
             "zero for a scatterer on the grid",
    "coherence": "boxcar coherence estimate over the look window (1 for one look)",
    "unwrapped_phase": "flat phase unwrapped (SNAPHU) and tied to the reference surface; the "
                       "wrapped phase where unwrapping is off",
    "height": "world z of each pixel's scatterer from the exact two-path geometry",
    "height_std": "Cramer-Rao height noise from the coherence (and the image's noise power)",
}


@dataclass
class InterferometryResult:
    """An interferogram (:func:`mitsar.interferometry.interferogram`) and its point cloud
    (:func:`mitsar.interferometry.point_cloud`)."""

    interferogram: xr.Dataset
    cloud: xr.Dataset


def check_multichannel(image: Any, where: str) -> None:
    """Refuse an image without a ``channel`` dim of two or more receive channels.

    Parameters
    ----------
    image : xarray.Dataset
        An image product.
    where : str
        The file or command named in the error.

    Raises
    ------
    ParameterError
        Naming the image's dims and how to make a multi-channel image.
    """
    dims = tuple(map(str, image["image"].dims)) if "image" in image else ()
    if "channel" not in dims or image.sizes["channel"] < 2:
        raise ParameterError(where, "image", "an image with a 'channel' dim of two or more "
                             "receive channels: focus a multi-channel raw product (BPA, FFBP, ...) "
                             "([radar] receivers = [[0, 0, 0], [0, 0, 0.05]] in the experiment, "
                             "then mitsar simulate and mitsar focus -a bpa)",
                             f"image dims {dims}")


@contextmanager
def snaphu_log_to_stderr(quiet: bool = False) -> Iterator[None]:
    """Send what child processes (the SNAPHU executable) print on stdout to stderr, or to
    nothing when ``quiet``, so that a command's stdout holds only its results."""
    sys.stdout.flush()
    saved = os.dup(1)
    target = os.open(os.devnull, os.O_WRONLY) if quiet else os.dup(2)
    try:
        os.dup2(target, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(target)


def scene_masks(scene: Any, image: xr.Dataset, options: InterferometryOptions
                ) -> xr.Dataset:
    """The layover and shadow masks of ``image`` in ``scene`` (a loaded scene, an XML file or
    a canned name; :func:`mitsar.scene.layover_shadow_masks`) for the options' pair, as the
    interferogram product keeps them (:data:`MASK_VARIABLES`, full-grid dims ``image_*``)."""
    masks = layover_shadow_masks(scene, image, pair=options.pair)
    rename = {str(d): f"image_{d}" for d in masks.dims}
    out = masks.rename({**rename, **MASK_VARIABLES})
    out.attrs = {f"mask_{key}": value for key, value in masks.attrs.items()}
    return out


def run_interferometry(image: xr.Dataset, options: InterferometryOptions,
                       where: str = "interferogram", quiet: bool = False, scene: Any = None
                       ) -> InterferometryResult:
    """The interferogram of a multi-channel image and its point cloud.

    Parameters
    ----------
    image : xarray.Dataset
        A multi-channel image product (BPA; docs/interferometry.md §1).
    options : InterferometryOptions
        Pair, looks, unwrapping and the coherence threshold [1] of both the unwrapping and the
        point cloud.
    where : str
        The file or command named in errors.
    quiet : bool
        Silence SNAPHU's log (else it goes to stderr).
    scene : mitsuba.Scene, str or os.PathLike, optional
        The scene the image was simulated from: its layover and shadow pixels
        (:func:`scene_masks`) are left out of the interferogram (``mask=``) and the masks kept
        in it.

    Returns
    -------
    InterferometryResult
    """
    check_multichannel(image, where)
    masks = None if scene is None else scene_masks(scene, image, options)
    with snaphu_log_to_stderr(quiet):
        ifg = interferogram(image, pair=options.pair, looks=options.looks,
                            unwrap=options.unwrap, min_coherence=options.min_coherence,
                            mask=None if masks is None else masks[MASK_VARIABLES["mask"]].values)
    if masks is not None:
        ifg = ifg.assign(masks.data_vars).assign_attrs(masks.attrs)
    return InterferometryResult(ifg, point_cloud(ifg, min_coherence=options.min_coherence))


def interferometry_figure_entries(prefix: str = "") -> list[dict[str, str]]:
    """The figures of :func:`write_interferometry` as run-record entries (``file``, ``title``,
    ``caption``), their files under ``prefix``."""
    return [{"file": f"{prefix}{INTERFEROMETRY_FILES[name]}",
             "title": f"Interferometry: {spec.title}", "caption": _CAPTIONS[name]}
            for name, spec in INTERFEROGRAM_MAPS.items()]


def write_interferometry(folder: str | os.PathLike, result: InterferometryResult,
                         overwrite: bool = False) -> dict[str, Path]:
    """Write the interferogram product, the point cloud and the maps into ``folder``.

    Every output is checked before anything is written (an existing file is refused unless
    ``overwrite``), and each is written atomically.

    Parameters
    ----------
    folder : path-like
        Output folder (created).
    result : InterferometryResult
        Output of :func:`run_interferometry`.
    overwrite : bool
        Replace existing files.

    Returns
    -------
    dict of str to Path
        The files written, by the roles of :data:`INTERFEROMETRY_FILES`.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = {role: folder / name for role, name in INTERFEROMETRY_FILES.items()}
    for path in paths.values():
        check_writable(path, overwrite)
    save(result.interferogram, paths["interferogram"], overwrite=overwrite)
    write_ply(result.cloud, paths["points"], overwrite=overwrite)
    for name, figure in interferogram_figures(result.interferogram).items():
        save_figure(figure, paths[name], overwrite=overwrite, dpi=110)
    return paths


def _median(values: Any) -> float:
    finite = np.asarray(values, float)
    finite = finite[np.isfinite(finite)]
    return float(np.median(finite)) if finite.size else float("nan")


def interferometry_summary(result: InterferometryResult) -> dict[str, Any]:
    """The numbers of an interferogram worth a line each (JSON-ready).

    Returns
    -------
    dict
        ``pair``, ``looks`` (rows, cols), ``unwrapped`` (bool), ``baseline_m`` (effective
        baseline vector, world frame), ``baseline_length_m``, ``perpendicular_baseline_m``,
        ``ambiguity_height_m`` (exact) and ``ambiguity_height_first_order_m``,
        ``median_coherence``, ``median_height_std_m`` (over pixels with a height),
        ``points`` (in the point cloud), ``min_coherence``, and at the brightest pixel
        ``brightest_pixel_position_m`` (on the grid), ``brightest_height_m`` and
        ``brightest_position_m`` (its scatterer) and ``brightest_height_std_m``.
    """
    ifg = result.interferogram
    attrs = ifg.attrs
    baseline = [float(v) for v in np.ravel(attrs["baseline"])]
    grid = tuple(str(d) for d in ifg["phase"].dims)
    amplitude = ifg["amplitude"].transpose(*grid).values
    index = (np.unravel_index(int(np.nanargmax(amplitude)), amplitude.shape)
             if np.isfinite(amplitude).any() else None)

    def at(name: str) -> Any:
        if index is None:
            return None
        value = ifg[name].transpose(*grid, ...).values[index]
        return float(value) if np.ndim(value) == 0 else [float(v) for v in value]

    heights = ifg["height"].values
    fractions = {f"{name}_fraction": float(np.mean(ifg[name].values))
                 for name in ("shadow", "layover") if name in ifg.variables}
    return {
        "pair": [int(k) for k in np.ravel(attrs["pair"])],
        "looks": [int(attrs["looks_azimuth"]), int(attrs["looks_range"])],
        "unwrapped": bool(attrs.get("unwrapped", 0)),
        "baseline_m": baseline,
        "baseline_length_m": float(np.linalg.norm(baseline)),
        "perpendicular_baseline_m": float(attrs["perpendicular_baseline"]),
        "ambiguity_height_m": float(attrs["ambiguity_height"]),
        "ambiguity_height_first_order_m": float(attrs["ambiguity_height_first_order"]),
        "median_coherence": _median(ifg["coherence"].values),
        "median_height_std_m": _median(np.where(np.isfinite(heights),
                                                ifg["height_std"].values, np.nan)),
        "points": int(result.cloud.sizes.get("point", 0)),
        "min_coherence": float(attrs.get("min_coherence", 0.0)),
        "brightest_pixel_position_m": at("pixel_position"),
        "brightest_position_m": at("position"),
        "brightest_height_m": at("height"),
        "brightest_height_std_m": at("height_std"),
        **fractions,
    }


def format_interferometry_summary(summary: dict[str, Any]) -> str:
    """:func:`interferometry_summary` as a few lines of text."""
    def vector(values: Any) -> str:
        return "[" + ", ".join(f"{v:.4f}" for v in values) + "]" if values else "none"

    pair, looks = summary["pair"], summary["looks"]
    lines = [
        f"pair {pair[0]}-{pair[1]}, {looks[0]} x {looks[1]} looks, "
        f"{'unwrapped (SNAPHU)' if summary['unwrapped'] else 'not unwrapped'}",
        f"baseline {vector(summary['baseline_m'])} m ({summary['baseline_length_m'] * 100:.2f} "
        f"cm; perpendicular {summary['perpendicular_baseline_m'] * 100:.2f} cm)",
        f"ambiguity height {summary['ambiguity_height_m']:.4f} m (first order "
        f"{summary['ambiguity_height_first_order_m']:.4f} m)",
        f"median coherence {summary['median_coherence']:.3f}, median height std "
        f"{summary['median_height_std_m'] * 1e3:.3f} mm",
        f"{summary['points']} points with coherence >= {summary['min_coherence']:g}",
    ]
    if "shadow_fraction" in summary:
        lines.append(f"scene masks: {summary['shadow_fraction'] * 100:.1f} % of the pixels in "
                     f"shadow, {summary['layover_fraction'] * 100:.1f} % in layover (left out)")
    if summary.get("brightest_height_m") is not None:
        lines.append(f"brightest pixel {vector(summary['brightest_pixel_position_m'])} m: "
                     f"height {summary['brightest_height_m']:.4f} m "
                     f"(std {summary['brightest_height_std_m'] * 1e3:.3f} mm), scatterer at "
                     f"{vector(summary['brightest_position_m'])} m")
    return "\n".join(lines)
