"""Exact ground truth of a rendered scene, and its files (``stem.json`` + ``stem.npz``).

All 3D quantities are in the left camera's unrectified optical frame (X right, Y down, Z forward, mm);
pixels are of the distorted images with pixel centres at integer coordinates.

``stem.json``: ``{"seed", "rig": {K1, D1, K2, D2, R, T, width_px, height_px}, "branches": [{"axis_mm",
"radius_mm", "parent", "parent_vertex"}], "features": [{"kind", "xyz_mm", "left_px", "right_px",
"visible_left", "visible_right", "branch", "parent", "radius_mm"}]}``.
``stem.npz``: ``depth_left_mm`` (H, W) float32, NaN off visible branches; ``mask_left``, ``mask_right``
(H, W) bool.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from appliance.errors import ApplianceError
from appliance.synth.rig import Rig


class TruthError(ApplianceError):
    """A truth file is missing or malformed."""


@dataclass(frozen=True, eq=False)
class TrueBranch:
    """One branch: a tapered tube around an axis polyline.

    Attributes
    ----------
    axis_mm : ndarray, shape (N, 3)
        Axis vertices from the base to the tip.
    radius_mm : ndarray, shape (N,)
        Radius at each vertex (linear in between).
    parent : int
        Index of the branch it grows from, -1 for a root (which starts outside the view).
    parent_vertex : int
        Index of the parent's vertex where this branch starts (``axis_mm[0]`` equals it); -1 for a root.
    """

    axis_mm: np.ndarray
    radius_mm: np.ndarray
    parent: int = -1
    parent_vertex: int = -1

    @property
    def length_mm(self) -> float:
        return float(np.linalg.norm(np.diff(self.axis_mm, axis=0), axis=1).sum())


@dataclass(frozen=True, eq=False)
class TrueFeatures:
    """The scene's features (struct of arrays, M rows).

    Attributes
    ----------
    kind : ndarray (M,) of str
        "endpoint" (a branch tip: the end of its axis) or "bifurcation" (a fork: where a child's axis leaves
        its parent's axis).
    xyz_mm : ndarray (M, 3)
        The 3D point on the axis.
    left_px, right_px : ndarray (M, 2)
        Its projection through each distorted camera (``cv2.projectPoints``).
    visible_left, visible_right : ndarray (M,) bool
        Inside the image and not hidden by a leaf, an apple or another branch.
    branch : ndarray (M,) int
        The branch whose tip it is, or the child branch of a fork.
    parent : ndarray (M,) int
        The parent branch of a fork; -1 for tips.
    radius_mm : ndarray (M,)
        Radius of ``branch`` at the point.
    """

    kind: np.ndarray
    xyz_mm: np.ndarray
    left_px: np.ndarray
    right_px: np.ndarray
    visible_left: np.ndarray
    visible_right: np.ndarray
    branch: np.ndarray
    parent: np.ndarray
    radius_mm: np.ndarray

    def __len__(self) -> int:
        return len(self.kind)

    def subset(self, keep: np.ndarray) -> TrueFeatures:
        """The rows selected by a boolean mask or index array."""
        return TrueFeatures(*(getattr(self, f)[keep] for f in _FEATURE_FIELDS))


_FEATURE_FIELDS = ("kind", "xyz_mm", "left_px", "right_px", "visible_left", "visible_right", "branch",
                   "parent", "radius_mm")


@dataclass(frozen=True, eq=False)
class SceneTruth:
    """Everything known about a rendered scene.

    Attributes
    ----------
    rig : Rig
    branches : list of TrueBranch
    features : TrueFeatures
    depth_left_mm : ndarray (H, W) float32
        Z of the visible branch surface at each left pixel (mean over its covered supersamples); NaN elsewhere.
    mask_left, mask_right : ndarray (H, W) bool
        Pixels at least half covered by a visible branch (pixels hidden by leaves/apples are not in it).
    seed : int
    cover_left, cover_right : ndarray (H, W) float32 or None
        Share 0-1 of each pixel's supersamples on a visible branch: the exact soft masks (their 0.5
        level is ``mask_*``); None in truth files written before they were kept.
    """

    rig: Rig
    branches: list
    features: TrueFeatures
    depth_left_mm: np.ndarray
    mask_left: np.ndarray
    mask_right: np.ndarray
    seed: int = 0
    cover_left: np.ndarray | None = None
    cover_right: np.ndarray | None = None

    def exact_masks(self, *, soft: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """The exact branch masks (left, right): the binary masks (the accuracy benchmark's "exact masks"), or
        with ``soft`` the renderer's coverage of each pixel (float 0-1) where the truth holds it."""
        if soft and self.cover_left is not None and self.cover_right is not None:
            return self.cover_left, self.cover_right
        return self.mask_left, self.mask_right


def _rig_dict(rig: Rig) -> dict:
    return {k: np.asarray(getattr(rig, k), float).tolist() for k in ("K1", "D1", "K2", "D2", "R", "T")} | {
        "width_px": rig.width_px, "height_px": rig.height_px}


def _rig_from_dict(d: dict) -> Rig:
    a = {k: np.asarray(d[k], np.float64) for k in ("K1", "D1", "K2", "D2", "R", "T")}
    return Rig(a["K1"].reshape(3, 3), a["D1"].ravel(), a["K2"].reshape(3, 3), a["D2"].ravel(),
               a["R"].reshape(3, 3), a["T"].reshape(3), int(d["width_px"]), int(d["height_px"]))


def truth_to_dict(truth: SceneTruth) -> dict:
    """The JSON part of the truth (everything but the per-pixel arrays)."""
    f = truth.features
    return {
        "seed": int(truth.seed),
        "rig": _rig_dict(truth.rig),
        "branches": [{"axis_mm": np.round(b.axis_mm, 4).tolist(), "radius_mm": np.round(b.radius_mm, 4).tolist(),
                      "parent": int(b.parent), "parent_vertex": int(b.parent_vertex)} for b in truth.branches],
        "features": [{"kind": str(f.kind[i]), "xyz_mm": f.xyz_mm[i].round(4).tolist(),
                      "left_px": f.left_px[i].round(4).tolist(), "right_px": f.right_px[i].round(4).tolist(),
                      "visible_left": bool(f.visible_left[i]), "visible_right": bool(f.visible_right[i]),
                      "branch": int(f.branch[i]), "parent": int(f.parent[i]),
                      "radius_mm": round(float(f.radius_mm[i]), 4)} for i in range(len(f))],
    }


def save_truth(truth: SceneTruth, stem: str | Path) -> tuple[Path, Path]:
    """Write ``stem.json`` and ``stem.npz``; returns both paths."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    json_path, npz_path = stem.with_name(stem.name + ".json"), stem.with_name(stem.name + ".npz")
    json_path.write_text(json.dumps(truth_to_dict(truth), indent=1) + "\n")
    cover = {f"cover_{side}": np.rint(255.0 * c).astype(np.uint8)
             for side, c in (("left", truth.cover_left), ("right", truth.cover_right)) if c is not None}
    np.savez_compressed(npz_path, depth_left_mm=truth.depth_left_mm.astype(np.float32),
                        mask_left=truth.mask_left, mask_right=truth.mask_right, **cover)
    return json_path, npz_path


def load_truth(json_path: str | Path) -> SceneTruth:
    """Read ``stem.json`` and the ``stem.npz`` next to it.

    Raises
    ------
    TruthError
        A file is missing or a key is absent.
    """
    json_path = Path(json_path)
    npz_path = json_path.with_suffix(".npz")
    for p in (json_path, npz_path):
        if not p.is_file():
            raise TruthError(f"{p}: truth file not found")
    try:
        d = json.loads(json_path.read_text())
        branches = [TrueBranch(np.asarray(b["axis_mm"], float).reshape(-1, 3), np.asarray(b["radius_mm"], float),
                               int(b["parent"]), int(b["parent_vertex"])) for b in d["branches"]]
        fs = d["features"]
        features = TrueFeatures(
            np.array([f["kind"] for f in fs], dtype="<U11"),
            np.array([f["xyz_mm"] for f in fs], float).reshape(-1, 3),
            np.array([f["left_px"] for f in fs], float).reshape(-1, 2),
            np.array([f["right_px"] for f in fs], float).reshape(-1, 2),
            np.array([f["visible_left"] for f in fs], bool),
            np.array([f["visible_right"] for f in fs], bool),
            np.array([f["branch"] for f in fs], int),
            np.array([f["parent"] for f in fs], int),
            np.array([f["radius_mm"] for f in fs], float),
        )
        rig = _rig_from_dict(d["rig"])
    except (KeyError, TypeError, ValueError) as e:
        raise TruthError(f"{json_path}: malformed truth ({e})") from None
    with np.load(npz_path) as z:
        try:
            cover = [z[k].astype(np.float32) / 255.0 if k in z else None for k in ("cover_left", "cover_right")]
            return SceneTruth(rig, branches, features, z["depth_left_mm"], z["mask_left"].astype(bool),
                              z["mask_right"].astype(bool), int(d.get("seed", 0)), *cover)
        except KeyError as e:
            raise TruthError(f"{npz_path}: array {e} missing") from None
