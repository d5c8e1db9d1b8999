"""Features of focused images (a stage above ``quality``): CFAR detections, point features
and line features, each located in 3-D with an uncertainty (docs/features.md)."""

from mitsar.features.cfar import cfar
from mitsar.features.clusters import point_features
from mitsar.features.detection import detect
from mitsar.features.lines import line_features
from mitsar.features.scores import map_scores, scores_dataset, scores_table
from mitsar.features.truth import SceneTruth, TruthFeatures, scene_features, scene_truth

__all__ = ["cfar", "detect", "line_features", "point_features"]
__all__ += ["SceneTruth", "TruthFeatures", "map_scores", "scene_features", "scene_truth",
            "scores_dataset", "scores_table"]
