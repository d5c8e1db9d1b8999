"""Ambiguity fractions in sweeps: ``mitsar sweep AMBIGUITY.toml --vary ... --ambiguity``.

The sweep machinery (:mod:`mitsar.experiment.sweep`) sits below this stage and cannot import it
(imports run down, docs/design.md §3); this module hands it a
:class:`~mitsar.experiment.sweep.PointMeasure` instead. Every point of the sweep is the
ambiguity file with the variations applied; it is mapped exactly as ``mitsar ambiguity`` maps
a file (:func:`~mitsar.ambiguity.run.ambiguity_products`), and its summary numbers, the area
fractions of :func:`~mitsar.ambiguity.maps.overall_fractions` per trajectory (docs/ambiguity.md,
the product), become variables of the sweep's table with the dimension ``trajectory``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import xarray as xr

from mitsar.ambiguity.config import ambiguity_from_dict
from mitsar.ambiguity.maps import overall_fractions
from mitsar.ambiguity.run import ambiguity_products
from mitsar.errors import ParameterError
from mitsar.experiment.loading import read_toml
from mitsar.experiment.sweep import PointMeasure, Variation, run_sweep

__all__ = ["AMBIGUITY_MEASURE", "FRACTIONS", "is_ambiguity_document", "point_fractions",
           "run_ambiguity_sweep"]

FRACTIONS = ("fraction_resolved", "fraction_observed", "fraction_only_ambiguous",
             "fraction_shadowed", "fraction_outside_beam")
"""The summary numbers of a map (:func:`~mitsar.ambiguity.maps.overall_fractions`), area
fractions of all surfaces together."""


def is_ambiguity_document(document: Mapping[str, Any]) -> bool:
    """True for an ambiguity file (``[trajectories]``, or ``[ambiguity]`` without targets).

    The rule ``mitsar run`` uses to tell ambiguity files from experiments.
    """
    return "trajectories" in document or ("ambiguity" in document
                                          and "targets" not in document)


def _spec(document: dict, source: str, where: str) -> dict[str, Any]:
    """The validated ambiguity file of one point (relative paths against the file's folder)."""
    return ambiguity_from_dict(document, where, Path(source).parent, Path(source).stem)


def check_point(document: dict, source: str, where: str) -> None:
    """Validate one point's ambiguity document; the error names the key (``PointMeasure``)."""
    _spec(document, source, where)


def point_fractions(document: dict, source: str) -> dict[str, dict[str, float]]:
    """The area fractions of every trajectory of one point, as ``mitsar ambiguity`` reports
    them in ``summary.json`` (``trajectories.NAME.overall``).

    Parameters
    ----------
    document : dict
        The ambiguity TOML document with the point's variations applied.
    source : str
        Absolute path of the swept file (its name and folder).

    Returns
    -------
    dict
        Trajectory name -> :data:`FRACTIONS` -> value (1, area fractions).
    """
    products = ambiguity_products(_spec(document, source, source))
    return {name: overall_fractions(product) for name, product in products.items()}


AMBIGUITY_MEASURE = PointMeasure("ambiguity", point_fractions, check_point, "trajectory",
                                 FRACTIONS, "1")
"""The ambiguity fractions as a sweep measure (one task per point)."""


def run_ambiguity_sweep(path: str | os.PathLike, variations: Sequence[Variation | str],
                        out_dir: str | os.PathLike, **options: Any) -> xr.Dataset:
    """Sweep an ambiguity file: the fractions of every point, one table.

    Parameters
    ----------
    path : path-like
        An ambiguity TOML file (docs/ambiguity.md).
    variations, out_dir
        As :func:`~mitsar.experiment.sweep.run_sweep` (any key of the file, dotted).
    **options
        Further keywords of :func:`~mitsar.experiment.sweep.run_sweep` (``overrides``,
        ``scheduler``, ``workers``, ``restart``, ``progress``, ``figures``, ...).

    Returns
    -------
    xarray.Dataset
        Dims: the varied keys, ``trajectory``; variables :data:`FRACTIONS` and
        ``ambiguity_error``. Written as ``sweep.nc`` and ``sweep_ambiguity.csv``.

    Raises
    ------
    ParameterError
        When the file is an experiment (it has no ``[ambiguity]`` table) or a point is invalid.
    """
    document = read_toml(Path(path))
    if not is_ambiguity_document(document):
        raise ParameterError(str(path), "ambiguity", "an ambiguity file ([trajectory] or "
                             "[trajectories.NAME] with an [ambiguity] table, docs/ambiguity.md) "
                             "to sweep ambiguity fractions; drop --ambiguity to sweep image "
                             "metrics of an experiment", "an experiment file")
    return run_sweep(path, variations, out_dir, measures=[AMBIGUITY_MEASURE], images=False,
                     **options)
