"""The localization result: the contract between the localizer and everything downstream.

JSON form (units mm, coordinates in the left camera's unrectified optical frame;
``left_px``/``right_px`` are pixels of the original, distorted images)::

    {"features": [{"id", "kind": "endpoint"|"bifurcation", "left_px": [u, v],
                   "right_px": [u, v], "xyz_mm": [X, Y, Z], "radius_mm",
                   "safe_depth_mm"}],
     "branches": [{"id", "feature_ids": [a, b], "polyline_mm": [[X, Y, Z], ...],
                   "radius_mm", "recovered": bool}],
     "withheld": [{"kind", "left_px": [u, v], "disparity_px", "check_disparity_px",
                   "reason": "texture"|"pieces_agree"}]}

``withheld`` lists tips and forks the matcher found but did not report because an independent
check disagreed with their depth: not obstacles for the arm, an explanation for a replay.
Extra fields are allowed (``timings_ms`` and ``stamp_ns`` at the top level).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np


@dataclass(frozen=True)
class Feature:
    """A branch tip (``endpoint``) or fork (``bifurcation``) located in 3D."""

    id: int
    kind: Literal["endpoint", "bifurcation"]
    left_px: tuple[float, float]
    right_px: tuple[float, float]
    xyz_mm: tuple[float, float, float]
    radius_mm: float
    safe_depth_mm: float

    def to_dict(self) -> dict:
        return {
            "id": self.id, "kind": self.kind,
            "left_px": [float(v) for v in self.left_px],
            "right_px": [float(v) for v in self.right_px],
            "xyz_mm": [float(v) for v in self.xyz_mm],
            "radius_mm": float(self.radius_mm), "safe_depth_mm": float(self.safe_depth_mm),
        }

    @classmethod
    def from_dict(cls, d: dict) -> Feature:
        return cls(int(d["id"]), d["kind"], tuple(d["left_px"]), tuple(d["right_px"]),
                   tuple(d["xyz_mm"]), float(d["radius_mm"]), float(d["safe_depth_mm"]))


@dataclass(frozen=True, eq=False)
class Branch:
    """A branch piece as a 3D cylinder: axis polyline (mm) and radius (mm).

    ``feature_ids`` are the ids of the features at its two ends (-1 where an end
    is not a feature, e.g. where the branch leaves the image). ``recovered`` marks a
    piece bridged across an occlusion (leaf, apple) rather than seen.
    """

    id: int
    feature_ids: tuple[int, int]
    polyline_mm: np.ndarray  # shape (N, 3)
    radius_mm: float
    recovered: bool = False

    def to_dict(self) -> dict:
        return {
            "id": self.id, "feature_ids": [int(i) for i in self.feature_ids],
            "polyline_mm": np.asarray(self.polyline_mm, float).round(3).tolist(),
            "radius_mm": float(self.radius_mm), "recovered": bool(self.recovered),
        }

    @classmethod
    def from_dict(cls, d: dict) -> Branch:
        poly = np.asarray(d["polyline_mm"], float).reshape(-1, 3)
        return cls(int(d["id"]), tuple(d["feature_ids"]), poly, float(d["radius_mm"]),
                   bool(d.get("recovered", False)))


@dataclass(frozen=True)
class WithheldFeature:
    """A tip or fork found but not reported: an independent check disagreed with its depth.

    ``left_px`` is in the original (distorted) left image; ``disparity_px`` is the matcher's
    rectified disparity, ``check_disparity_px`` the check's (``localize.featurecheck``: the
    branches' bark texture carried to the feature). ``reason``: ``"texture"`` (the texture's
    estimate is too far) or ``"pieces_agree"`` (two of the feature's pieces read it on one side;
    ``check_disparity_px`` is then the second of them).
    """

    kind: Literal["endpoint", "bifurcation"]
    left_px: tuple[float, float]
    disparity_px: float
    check_disparity_px: float
    reason: Literal["texture", "pieces_agree"] = "texture"

    def to_dict(self) -> dict:
        return {"kind": self.kind, "left_px": [float(v) for v in self.left_px],
                "disparity_px": float(self.disparity_px), "check_disparity_px": float(self.check_disparity_px),
                "reason": self.reason}

    @classmethod
    def from_dict(cls, d: dict) -> WithheldFeature:
        return cls(d["kind"], tuple(d["left_px"]), float(d["disparity_px"]), float(d["check_disparity_px"]),
                   d.get("reason", "texture"))


@dataclass(frozen=True, eq=False)
class LocalizationResult:
    """Everything the localizer found in one stereo pair."""

    features: tuple[Feature, ...] = ()
    branches: tuple[Branch, ...] = ()
    stamp_ns: int = 0
    timings_ms: dict = field(default_factory=dict)
    withheld: tuple[WithheldFeature, ...] = ()

    def to_dict(self) -> dict:
        return {
            "stamp_ns": int(self.stamp_ns),
            "features": [f.to_dict() for f in self.features],
            "branches": [b.to_dict() for b in self.branches],
            "withheld": [w.to_dict() for w in self.withheld],
            "timings_ms": {k: round(float(v), 3) for k, v in self.timings_ms.items()},
        }

    @classmethod
    def from_dict(cls, d: dict) -> LocalizationResult:
        return cls(
            tuple(Feature.from_dict(f) for f in d.get("features", [])),
            tuple(Branch.from_dict(b) for b in d.get("branches", [])),
            int(d.get("stamp_ns", 0)),
            dict(d.get("timings_ms", {})),
            tuple(WithheldFeature.from_dict(w) for w in d.get("withheld", [])),
        )
