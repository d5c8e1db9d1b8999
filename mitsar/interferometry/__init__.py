"""Interferometry: two channels of a multi-channel image to phase, coherence, heights, points.

One concept a module: ``multilook`` (boxcar look windows), ``coherence`` (the estimator and the
thermal-noise term), ``phase_statistics`` (Cramér–Rao phase noise), ``geometry`` (the pair's
exact bistatic geometry per pixel, reference phase, baseline), ``geolocation`` (unwrapped phase to
3-D position, height sensitivity, ambiguity height), ``unwrapping`` (SNAPHU), ``interferogram``
(the stage's entry point) and ``point_cloud`` (points and PLY). docs/interferometry.md.
"""

from mitsar.interferometry.coherence import coherence, snr_coherence
from mitsar.interferometry.geolocation import (
    ambiguity_height,
    first_order_ambiguity_height,
    height_sensitivity,
    phase_to_position,
)
from mitsar.interferometry.geometry import pair_geometry, path_length, reference_phase
from mitsar.interferometry.interferogram import interferogram
from mitsar.interferometry.multilook import multilook
from mitsar.interferometry.phase_statistics import predicted_phase_std
from mitsar.interferometry.point_cloud import point_cloud, write_ply
from mitsar.interferometry.unwrapping import UnwrappingError, unwrap

__all__ = ["UnwrappingError", "ambiguity_height", "coherence", "first_order_ambiguity_height",
           "height_sensitivity", "interferogram", "multilook", "pair_geometry", "path_length",
           "phase_to_position", "point_cloud", "predicted_phase_std", "reference_phase",
           "snr_coherence", "unwrap", "write_ply"]
