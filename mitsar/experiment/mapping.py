"""The mapping step of ``mitsar run``: an experiment's passes over its scene in, a 3-D map of
the scene and its scores against the scene's own ground truth out (issue 23).

:func:`run_mapping` calls :func:`mitsar.map_scene` with the options of ``[mapping]``
(:class:`~mitsar.experiment.options.MappingOptions`: CFAR ``pfa`` and ``method``, the score
threshold ``tau``, how the passes combine); :func:`write_mapping` writes into a folder
(:data:`MAPPING_FILES`): the detections (``detections.nc``, :func:`mitsar.detect`'s product),
the scores (``map_scores.nc``, :func:`mitsar.features.scores.scores_dataset`) and a figure of
the map over the truth (``map.png``), each atomically and never over an existing file unless
asked; :func:`mapping_summary` gives the numbers the report shows as a table (definitions:
docs/features.md "Map scores").
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mitsar.experiment.options import MappingOptions
from mitsar.features.mapping import SceneMap, map_scene
from mitsar.features.scores import scores_dataset, scores_table
from mitsar.io import check_writable, save
from mitsar.plots.figures import save_figure

__all__ = ["MAPPING_FILES", "MAPPING_FOLDER", "mapping_figure", "mapping_summary",
           "run_mapping", "write_mapping"]

MAPPING_FOLDER = "mapping"
"""The folder of a ``mitsar run`` that holds :data:`MAPPING_FILES`."""

MAPPING_FILES: dict[str, str] = {"detections": "detections.nc", "scores": "map_scores.nc",
                                 "figure": "map.png"}
"""Files written by :func:`write_mapping`, by role."""


def run_mapping(raws: Sequence[Any], scene: Any, options: MappingOptions) -> SceneMap:
    """The map of ``scene`` from the raw products ``raws`` (one per pass) and its scores
    (:func:`mitsar.map_scene` with ``options``)."""
    return map_scene(list(raws), scene, pfa=options.pfa, method=options.method, tau=options.tau,
                     combine=options.combine, elevation_window=options.elevation_window)


def mapping_summary(result: SceneMap) -> dict[str, Any]:
    """What the report and the run record show of a map: the scores as rows ``(name, value,
    units, meaning)``, the features' verdicts, the resolution cell [m] and the volume."""
    scores = result.scores
    features = [{"kind": record["kind"], "status": record["status"],
                 "position": [round(float(v), 4) for v in record["position"]],
                 "error_m": (None if not np.isfinite(record["error"])
                             else round(float(record["error"]), 5))}
                for record in scores["features"] if record["scored"]]
    x, y, z = result.grid.axes()
    return {"scores": [[name, float(value), units, meaning]
                       for name, value, units, meaning in scores_table(scores)],
            "features": features, "detections": int(result.detections.sizes.get("detection", 0)),
            "resolution_m": [float(v) for v in result.resolution.cells],
            "volume_shape": [len(z), len(y), len(x)], "tiles": int(result.tiles)}


def mapping_figure(result: SceneMap) -> Any:
    """The map over the truth, from above (x, y) and from the side (y, z): the truth's surface
    samples in grey, the detected cells coloured by SNR, the scored features marked found
    (circle) or missed / not visible (cross)."""
    import matplotlib.pyplot as plt

    truth = np.asarray(result.truth.points)
    found = result.detections
    cells = np.asarray(found["cell_position"].values if "cell_position" in found
                       else found["position"].values).reshape(-1, 3)
    snr = np.asarray(found["cell_snr"].values if "cell_snr" in found
                     else np.ones(len(cells))).ravel()
    axes_xyz = result.grid.axes()
    lo = np.array([a.min() for a in axes_xyz]) - 0.05
    hi = np.array([a.max() for a in axes_xyz]) + 0.05
    near = np.all((truth >= lo) & (truth <= hi), axis=1)
    figure, axes = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
    for ax, (i, j), name in zip(axes, ((0, 1), (1, 2)), ("from above", "from the side"),
                                strict=True):
        ax.scatter(truth[near, i], truth[near, j], s=2, c="0.8", label="scene surface")
        shown = ax.scatter(cells[:, i], cells[:, j], s=8, c=10 * np.log10(np.maximum(snr,
                           1e-12)), cmap="viridis", label="detected cells")
        for record in result.scores["features"]:
            if not record["scored"]:
                continue
            p = np.asarray(record["position"])
            ax.plot(p[i], p[j], "o" if record["status"] == "found" else "x", ms=10,
                    mfc="none", color="tab:red")
        ax.set_xlabel("xyz"[i] + " [m]")
        ax.set_ylabel("xyz"[j] + " [m]")
        ax.set_title(name)
        ax.set_aspect("equal", adjustable="datalim")
    figure.colorbar(shown, ax=axes, label="cell SNR [dB]")
    axes[0].legend(loc="upper right", fontsize="small")
    return figure


def write_mapping(folder: str | Path, result: SceneMap, *, overwrite: bool = False) -> None:
    """Write :data:`MAPPING_FILES` of ``result`` into ``folder`` (created), each atomically;
    refuses existing files unless ``overwrite`` (:func:`mitsar.io.check_writable`)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = {role: folder / name for role, name in MAPPING_FILES.items()}
    for path in paths.values():
        check_writable(path, overwrite)
    save(result.detections, paths["detections"], overwrite=overwrite)
    save(scores_dataset(result.scores), paths["scores"], overwrite=overwrite)
    save_figure(mapping_figure(result), paths["figure"])
