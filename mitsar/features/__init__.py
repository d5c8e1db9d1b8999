"""Features of focused images (a stage above ``quality``): CFAR detections, point features
and line features, each located in 3-D with an uncertainty (docs/features.md)."""

from mitsar.features.cfar import cfar
from mitsar.features.clusters import point_features
from mitsar.features.detection import detect
from mitsar.features.lines import line_features

__all__ = ["cfar", "detect", "line_features", "point_features"]
