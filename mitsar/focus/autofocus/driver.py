"""Autofocus of a back-projection image: estimate the phase per sweep, correct, refocus.

:func:`run_autofocus` works with any back-projection focuser through a ``refocus`` callable
(raw product -> image product): it picks bright scatterers (PGA, entropy on lines) or takes the
pixels (entropy on the image) of the uncorrected image, estimates the phase in the pulse domain
with the BP geometry (:mod:`mitsar.focus.autofocus.contributions`; valid for any focuser whose
image is that BP sum, e.g. BPA or a fast factorised BP), corrects the raw sweeps by
``exp(-j phi_k)`` (:mod:`mitsar.focus.autofocus.apply`) and calls ``refocus`` on them.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import fields

import numpy as np
import xarray as xr

from mitsar.errors import MitsarWarning, ParameterError
from mitsar.focus.autofocus.apply import attach_phase, correct_raw
from mitsar.focus.autofocus.contributions import (
    PulseSettings,
    aperture_weights,
    contributions,
    pulse_data,
)
from mitsar.focus.autofocus.entropy import EntropyOptions, estimate_entropy, image_entropy
from mitsar.focus.autofocus.lines import azimuth_lines
from mitsar.focus.autofocus.pga import PGAOptions, estimate_pga
from mitsar.focus.autofocus.selection import (
    cell_pixels,
    chip_pixels,
    chip_reach,
    select_scatterers,
)

__all__ = ["METHODS", "make_options", "run_autofocus"]

METHODS = ("pga", "entropy")
"""Names of the autofocus methods."""

_OPTIONS = {"pga": PGAOptions, "entropy": EntropyOptions}


def make_options(method: str, options: dict | None) -> PGAOptions | EntropyOptions:
    """Check a method name and its options dict; the options record of that method.

    Raises
    ------
    ParameterError
        Unknown method, unknown option name, or an option out of range.
    """
    if method not in METHODS:
        raise ParameterError("focus", "autofocus", f"None or one of {METHODS}", method)
    record = _OPTIONS[method]
    allowed = sorted(f.name for f in fields(record))
    unknown = sorted(set(options or {}) - set(allowed))
    if unknown:
        raise ParameterError("focus", "autofocus_options",
                             f"options of {method!r}: {allowed}", unknown)
    return record(**(options or {}))


def run_autofocus(raw: xr.Dataset, image: xr.Dataset,
                  refocus: Callable[[xr.Dataset], xr.Dataset], method: str,
                  options: dict | None, settings: PulseSettings) -> xr.Dataset:
    """Autofocus an image focused from ``raw`` and return the refocused image product.

    Parameters
    ----------
    raw : xarray.Dataset
        The raw product the image was focused from.
    image : xarray.Dataset
        Its (uncorrected) image product; its pixels and magnitudes choose the scatterers.
    refocus : callable
        Focuses a raw product onto the same grid, as ``image`` was (e.g. ``mitsar.focus``
        with ``autofocus=None``, or another back-projection focuser).
    method : {"pga", "entropy"}
    options : dict, optional
        Fields of :class:`PGAOptions` or :class:`EntropyOptions`.
    settings : PulseSettings
        How the focuser formed its sum (aperture, windows, RVP, motion correction).

    Returns
    -------
    xarray.Dataset
        The refocused image with ``autofocus_phase`` (sweep) [rad] and attributes
        ``autofocus_method``, ``autofocus_iterations``, ``autofocus_converged`` (PGA),
        ``autofocus_entropy_before`` / ``autofocus_entropy_after`` (of the whole image,
        nats), ``autofocus_scatterers``, ``autofocus_seconds``, ``autofocus_applied`` (0 when
        the correction made the image worse and ``fallback`` returned the uncorrected one),
        ``autofocus_warning`` (the warning's text, empty if none),
        ``autofocus_scatterer_scr_db`` (the scatterers' ratios to their clutter, dB;
        :mod:`mitsar.focus.autofocus.selection`) and the method's options.

    Warns
    -----
    MitsarWarning
        When no scatterer stands out of the clutter (nothing to estimate from: the
        uncorrected image is returned), the method did not converge, or the correction raised
        the image's entropy (:func:`warning_text`: what happened, what was returned, what to
        try).
    """
    record = make_options(method, options)
    start = time.perf_counter()
    data = pulse_data(raw, settings)
    values = np.asarray(image["image"].values)
    magnitude = np.abs(values)
    positions = np.asarray(image["position"].values).reshape(-1, 3)
    used = 0
    if method == "entropy" and record.domain == "image":
        keep = np.argsort(magnitude.ravel())[::-1][: record.max_pixels]
        points = positions[keep]
        terms = contributions(data, points) * aperture_weights(data, points)
        used = len(points)
        phase, info = estimate_entropy(terms, record)
    else:
        chosen, scr_db = select_scatterers(magnitude, record.scatterers,
                                           record.dynamic_range_db, record.separation_cells,
                                           cell_pixels(image), record.min_scr_db,
                                           record.clutter_cells)
        if len(chosen) == 0:
            return _nothing_to_focus(raw, image, method, record, start)
        if method == "pga":
            phase, info = estimate_pga(data, positions[chosen], record)
            used = info.pop("scatterers")
        else:
            lines = azimuth_lines(data, positions[chosen], oversample=record.oversample,
                                  line_cells=record.line_cells,
                                  max_elements=record.max_elements)
            used = lines.history.shape[1]
            # the image chips around the scatterers, with the focuser's own aperture: the
            # stage whose estimate makes them sharpest is kept (estimate_entropy, check)
            chips = positions[chip_pixels(
                magnitude.shape, chosen[:used], cell_pixels(image), record.check_cells,
                chip_reach(image, record.check_cells, record.check_range_cells))]
            weight = aperture_weights(data, chips)
            seen = np.flatnonzero(weight.any(axis=1))  # sweeps in some chip's aperture
            check = np.zeros(weight.shape, dtype=np.complex64)
            check[seen] = contributions(data, chips, seen) * weight[seen]
            phase, info = estimate_entropy(lines, record, check,
                                           cell=image.attrs.get("azimuth_resolution"))
        info["scatterer_scr_db"] = [round(float(v), 2) for v in scr_db[:used]]
    corrected = refocus(correct_raw(raw, phase))
    before, after = image_entropy(values), image_entropy(corrected["image"].values)
    attrs = {"method": method, **info, "scatterers": int(used),
             "entropy_before": before, "entropy_after": after,
             "seconds": time.perf_counter() - start,
             "options": {f.name: getattr(record, f.name) for f in fields(record)}}
    problems = assess(method, record, info, before, after)
    applied = not (problems["degraded"] and record.fallback)
    message = warning_text(method, record, info, before, after, problems, applied)
    attrs.update(applied=applied, converged=bool(info.get("converged", True)),
                 warning=message or "")
    if message:
        warnings.warn(message, MitsarWarning, stacklevel=3)
    return attach_phase(corrected if applied else image, raw, phase, attrs)


def _nothing_to_focus(raw: xr.Dataset, image: xr.Dataset, method: str,
                      record: PGAOptions | EntropyOptions, start: float) -> xr.Dataset:
    """The uncorrected image with a warning: no scatterer stands out of the clutter."""
    message = (f"autofocus {method!r} found no scatterer standing {record.min_scr_db:g} dB "
               f"above the median clutter within {record.clutter_cells:g} cells (and within "
               f"{record.dynamic_range_db:g} dB of the brightest pixel): nothing to estimate "
               "the phase error from; the uncorrected image is returned (autofocus_applied = "
               "0); lower 'min_scr_db' in autofocus_options, image a larger area holding a "
               "bright isolated reflector, or use autofocus='entropy' with domain='image'")
    warnings.warn(message, MitsarWarning, stacklevel=4)
    entropy = image_entropy(image["image"].values)
    attrs = {"method": method, "iterations": 0, "scatterers": 0, "entropy_before": entropy,
             "entropy_after": entropy, "seconds": time.perf_counter() - start,
             "options": {f.name: getattr(record, f.name) for f in fields(record)},
             "applied": False, "converged": False, "warning": message}
    return attach_phase(image, raw, np.zeros(raw.sizes["sweep"]), attrs)


DEGRADED_NATS = 1e-3
"""Entropy rise of the whole image [nats] above which a correction counts as degrading it."""


def assess(method: str, record: PGAOptions | EntropyOptions, info: dict, before: float,
           after: float) -> dict[str, bool]:
    """What went wrong: ``not_converged`` (PGA: the last update above the tolerance; entropy:
    L-BFGS stopped at its iteration limit or the model entropy rose) and ``degraded`` (the
    whole image's entropy rose by more than :data:`DEGRADED_NATS`)."""
    return {"not_converged": not bool(info.get("converged", True)),
            "degraded": after > before + DEGRADED_NATS}


def _entropy_reason(record: EntropyOptions, info: dict) -> str:
    """Why a minimum-entropy estimate counts as not converged (its ``info``), in words."""
    kept = int(info.get("kept_stage", 0))
    stages = info.get("stages", [])
    summary = (f"L-BFGS used {info['iterations']} iterations over {len(stages)} stages and the "
               f"model entropy went {info['entropy_initial']:.3f} -> "
               f"{info['entropy_final']:.3f} nats")
    if kept == 0:
        return f"no stage sharpened the image around the scatterers ({summary})"
    if not info.get("position_settled", True):
        return (f"stage {kept} (kept: the sharpest image around the scatterers) and the finest "
                f"stage put the scatterers {abs(info['position_shift_cells']):.2f} resolution "
                f"cells apart, so where they are is uncertain by that much ({summary})")
    if not info.get("kept_stage_settled", True):
        return (f"stage {kept} (kept) stopped at its bound of {record.iterations} iterations "
                f"before its entropy change fell below {record.tolerance:g} (relative) and its "
                f"phase step below {record.phase_tolerance:g} rad ({summary})")
    return summary


def warning_text(method: str, record: PGAOptions | EntropyOptions, info: dict, before: float,
                 after: float, problems: dict[str, bool], applied: bool) -> str | None:
    """The :class:`~mitsar.errors.MitsarWarning` of an autofocus that did not converge or
    degraded the image (None when neither): what happened, what was returned, what to try."""
    if not (problems["not_converged"] or problems["degraded"]):
        return None
    parts = []
    if problems["not_converged"] and method == "pga":
        parts.append(f"did not converge: the last update was {info['last_update_rms']:.3g} rad "
                     f"rms after {info['iterations']} iterations (tolerance "
                     f"{record.tolerance:g} rad); the estimate of iteration "
                     f"{info.get('kept_iteration', info['iterations'])} (sharpest line images, "
                     f"entropy {info.get('line_entropy_initial', float('nan')):.3f} -> "
                     f"{info.get('line_entropy_final', float('nan')):.3f} nats) was used")
    elif problems["not_converged"]:
        parts.append("did not converge: " + _entropy_reason(record, info))
    if problems["degraded"]:
        parts.append(f"made the image worse (entropy {before:.3f} -> {after:.3f} nats)")
    returned = ("the corrected image is returned (check it: its scatterers may be shifted or "
                "defocused)" if applied else "the uncorrected image is returned "
                "(autofocus_applied = 0; autofocus_phase holds the rejected estimate)")
    advice = ("try autofocus='entropy', more 'iterations', or fewer and brighter "
              "'scatterers' (a higher 'min_scr_db' or a smaller 'dynamic_range_db') in "
              "autofocus_options"
              if method == "pga" else
              "try autofocus='pga', more 'iterations', a coarser 'finest' (sweeps per "
              "phase) or fewer 'scatterers' in autofocus_options")
    return f"autofocus {method!r} " + "; it ".join(parts) + "; " + returned + "; " + advice
