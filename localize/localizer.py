"""The localizer: a stereo pair in, branches and their tips and forks in 3D out.

Stages (each timed in ``LocalizationResult.timings_ms``): segment, rectify, skeleton,
prune, recover, radius, match, check (improved: each feature's disparity against its bark texture,
:mod:`featurecheck`), triangulate. ``variant="paper"`` runs the paper's choice
at every step (full-size thinning, 5 px spur pruning, Hough recovery, feature matching);
``"improved"`` runs what the configuration says (by default: fast skeleton, radius-aware
pruning, collinear recovery, dense centre-line matching).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import replace
from typing import Literal

import cv2
import numpy as np
from appliance.calibrate.model import StereoCalibration
from appliance.config.schema import LocalizeConfig
from appliance.localize import kernels, kernels_graph
from appliance.localize.curves import median
from appliance.localize.dense import match_dense
from appliance.localize.errors import LocalizeError
from appliance.localize.featurecheck import check_features
from appliance.localize.graph import SkeletonGraph
from appliance.localize.match import match_features
from appliance.localize.matching import Matching, StereoMasks
from appliance.localize.prune import prune
from appliance.localize.radius import RadiusMap, ridge_radius_map
from appliance.localize.recover import recover
from appliance.localize.rectify import LazyRectified, Rectifier
from appliance.localize.result import Branch, Feature, LocalizationResult, WithheldFeature
from appliance.localize.segment import as_mask, bark_lut_rows, occluder_at, segment_mask
from appliance.localize.skeleton import skeletonize
from appliance.localize.triangulate import disparity_range_px, triangulate

Variant = Literal["improved", "paper"]


def paper_config(cfg: LocalizeConfig) -> LocalizeConfig:
    """``cfg`` with the paper's choice at every step (segmentation settings kept)."""
    return replace(
        cfg,
        skeleton=replace(cfg.skeleton, method="thinning"),
        prune=replace(cfg.prune, min_length_px=5.0, radius_factor=0.0, keep_border_spurs=False),
        recover=replace(cfg.recover, method="hough"),
        match=replace(cfg.match, method="features", max_disparity_gradient=0.0),
        feature_check=replace(cfg.feature_check, enabled=False),
    )


class _Clock:
    def __init__(self):
        self.timings: dict[str, float] = {}
        self._t = time.perf_counter()

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self.timings[stage] = self.timings.get(stage, 0.0) + (now - self._t) * 1e3
        self._t = now


def plausible_part(uvd: np.ndarray, max_gradient: float) -> np.ndarray:
    """The longest part (in the image) of a piece's samples (N, 3) of rectified (u, v, d)
    along which the disparity changes by at most ``max_gradient`` px per px of the image
    (steps shorter than 1 px count as 1 px); ``uvd`` itself when no step exceeds it or
    ``max_gradient`` is 0.

    Along a branch inclined at angle a to the image plane, disparity changes by
    ``b / Z * tan(a)`` per image px (b baseline, Z depth): 0.5 at 1000 mm needs a branch
    pointing within ~14 deg of the camera's axis. A larger step is a bad fit or a join to
    another branch's depth.
    """
    if max_gradient <= 0 or len(uvd) < 2:
        return uvd
    step = np.diff(uvd, axis=0)
    ln = np.hypot(step[:, 0], step[:, 1])
    bad = np.abs(step[:, 2]) > max_gradient * np.maximum(ln, 1.0)
    if not bad.any():
        return uvd
    cuts = np.r_[0, np.flatnonzero(bad) + 1, len(uvd)]
    cum = np.r_[0.0, np.cumsum(ln)]
    best = max(itertools.pairwise(cuts), key=lambda ab: cum[ab[1] - 1] - cum[ab[0]])
    return uvd[best[0]:best[1]]


def longest_run(uvd: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """The longest run of consecutive samples (N, 3) where ``ok`` (N,) holds (``uvd`` itself
    when all do; no samples when none does)."""
    if ok.all():
        return uvd
    idx = np.flatnonzero(ok)
    if len(idx) == 0:
        return uvd[:0]
    cuts = np.flatnonzero(np.diff(idx) > 1)
    starts = np.r_[idx[0], idx[cuts + 1]]
    ends = np.r_[idx[cuts], idx[-1]]
    k = int(np.argmax(ends - starts))
    return uvd[starts[k]:ends[k] + 1]


def _whole_pieces(pieces: list, d_lo: float, d_hi: float, max_gradient: float) -> list[bool]:
    """Per piece (``uvd`` (N >= 2, 3) float64 each) whether :meth:`Localizer._assemble` keeps all of it:
    every disparity in [``d_lo``, ``d_hi``] (so > 0) and no step beyond ``max_gradient`` (the test of
    :func:`plausible_part`); all pieces' samples tested at once. False for a piece to check alone."""
    if not pieces:
        return []
    if any(p.uvd.dtype != np.float64 or p.uvd.ndim != 2 for p in pieces):
        return [False] * len(pieces)
    uvd = np.concatenate([p.uvd for p in pieces])
    ends = np.cumsum([len(p.uvd) for p in pieces])
    starts = np.concatenate(([0], ends[:-1]))         # (np.r_'s array, without its parsing)
    d = uvd[:, 2]
    fail = ~((d >= d_lo) & (d <= d_hi) & (d > 0))
    if max_gradient > 0:
        step = np.diff(uvd, axis=0)
        ln = np.hypot(step[:, 0], step[:, 1])
        bad = np.abs(step[:, 2]) > max_gradient * np.maximum(ln, 1.0)
        bad[ends[:-1] - 1] = False                      # (the steps from one piece to the next)
        fail[:-1] |= bad
    return (np.logical_or.reduceat(fail, starts) == 0).tolist()


class Localizer:
    """Branch localization for one calibrated rig.

    Parameters
    ----------
    calib : StereoCalibration
    cfg : LocalizeConfig
    variant : {"improved", "paper"}
    warm : bool
        Load the numba kernels (~1.5 s from numba's disk cache) and the colour tables now, so that the
        first pair does not wait for them. False for a localizer built only to check the settings (the run
        loop's, when localizer processes do the work): its first pair would load them.
    """

    def __init__(self, calib: StereoCalibration, cfg: LocalizeConfig, variant: Variant = "improved",
                 warm: bool = True):
        if variant not in ("improved", "paper"):
            raise ValueError(f"variant must be 'improved' or 'paper', got {variant!r}")
        self.calib = calib
        self.variant = variant
        self.cfg = paper_config(cfg) if variant == "paper" else cfg
        self.rectifier = Rectifier.from_calibration(calib)
        self.d_range_px = disparity_range_px(calib, self.cfg.working_range_mm)
        if warm:
            kernels.warm_up()               # (compiled or loaded now, not on the first frame)
            bark_lut_rows(self.cfg.segment)  # (the colour recogniser's tables, ~0.1 s once per process)

    # -- stages -------------------------------------------------------------------------------
    def _masks(self, left, right, mask_left, mask_right, clock):
        """Rectified branch coverage of both images (uint8 0-255), and the left image's
        occluder test for recovery (None for the paper's Hough recovery)."""
        seg = self.cfg.segment
        if mask_left is not None or mask_right is not None:
            if mask_left is None or mask_right is None:
                raise LocalizeError("masks: give both the left and the right mask, or neither")
            ml = as_mask(mask_left, left.shape[:2], "left mask")
            mr = as_mask(mask_right, right.shape[:2], "right mask")
        else:
            ml, mr = segment_mask(left, seg), segment_mask(right, seg)
        def occluded(xy_rect: np.ndarray) -> np.ndarray:
            # whoever made the masks, the colour image tells a leaf or an apple in a gap from open
            # sky (only the few pixels asked about are converted)
            return occluder_at(left, self.rectifier.to_original(xy_rect, 0), seg)
        clock.lap("segment")
        r = self.rectifier
        ml, mr = r.rectify(ml, 0, fast=True), r.rectify(mr, 1, fast=True)    # coverage 0-255, sub-pixel boundaries
        return ml, mr, occluded if self.cfg.recover.method == "collinear" else None

    def _graph(self, coverage: np.ndarray, occluder, clock) -> tuple[SkeletonGraph, RadiusMap, np.ndarray]:
        """Skeleton, radius map, pruning and recovery of one rectified mask (coverage, uint8 0-255:
        branch >= 128); the graph, the radius map and the mask the skeleton thinned (the block mask, 0/255,
        the graph's scale)."""
        c = self.cfg
        skel = skeletonize(coverage, c.skeleton.method, c.skeleton.downscale, level=127)
        clock.lap("skeleton")
        # (skel.mask: the thinned mask, 0/255; at scale 1 the coverage thresholded)
        radius = ridge_radius_map(skel.mask, 3, skel.scale) if skel.scale > 1 else ridge_radius_map(skel.mask)
        clock.lap("radius")
        _, graph = prune(skel, c.prune.min_length_px, c.prune.radius_factor, radius,
                         keep_border=c.prune.keep_border_spurs)
        clock.lap("prune")
        graph = recover(graph, c.recover, radius, occluder)
        clock.lap("recover")
        return graph, radius, skel.mask

    def localize(self, left: np.ndarray, right: np.ndarray, stamp_ns: int = 0,
                 mask_left: np.ndarray | None = None, mask_right: np.ndarray | None = None) -> LocalizationResult:
        """Localize the branches of one stereo pair.

        Parameters
        ----------
        left, right : ndarray (H, W, 3) uint8 BGR
            Original (distorted, unrectified) images of the calibration's size.
        stamp_ns : int
            Capture time, copied into the result.
        mask_left, mask_right : ndarray (H, W), optional
            Branch masks from an external segmenter (non-zero = branch; floating-point: a probability
            0-1 per pixel, kept soft for sub-pixel outlines), in the original
            images; the embedded colour recogniser runs when they are not given.

        Raises
        ------
        LocalizeError
            An image or mask of the wrong size, or an empty external mask.
        """
        r = self.rectifier
        r.check_size(left, "left image")
        r.check_size(right, "right image")
        clock = _Clock()
        ml, mr, occluder = self._masks(left, right, mask_left, mask_right, clock)
        withheld: list = []                              # (matched feature, its FeatureCheck)
        if cv2.minMaxLoc(ml)[1] <= 127 or cv2.minMaxLoc(mr)[1] <= 127:     # a view without branch pixels
            clock.lap("rectify")
            return LocalizationResult(stamp_ns=stamp_ns, timings_ms=clock.timings)
        clock.lap("rectify")
        c = self.cfg
        graph_l, radius_l, block_l = self._graph(ml, occluder, clock)
        if c.match.method == "features":                # (the right mask's graph: only this method's)
            graph_r, radius_r, _ = self._graph(mr, None, clock)
            matching = match_features(graph_l, graph_r, radius_l, radius_r, self.d_range_px, c.match)
        else:
            gl, gr = LazyRectified(r, left, 0), LazyRectified(r, right, 1)   # grey only where read
            clock.lap("rectify")
            sm = StereoMasks(ml, mr, gl, gr, radius_l, self.d_range_px, self.calib.f_px,
                             float(self.calib.P1[0, 2] - self.calib.P2[0, 2]), *r.valid,
                             cx_px=float(self.calib.P1[0, 2]), left_block=block_l,
                             baseline_mm=float(self.calib.baseline_mm))
            matching = match_dense(graph_l, sm, c.match)
            if c.feature_check.enabled and matching.features:   # (withheld features: not triangulated)
                clock.lap("match")
                checks = check_features(matching.features, matching.pieces, gl, gr, ml, self.d_range_px,
                                        sm.f_px, sm.offset_px, c.feature_check.max_diff_px)
                withheld = [(f, k) for f, k in zip(matching.features, checks) if k.withheld]
                matching = replace(matching, features=[f for f, k in zip(matching.features, checks) if not k.withheld],
                                   stats={**matching.stats, "feature_check": checks})
                clock.lap("check")
        clock.lap("match")
        result = self._assemble(matching, stamp_ns, withheld)
        clock.lap("triangulate")
        timings = dict(clock.timings)
        timings["total"] = sum(timings.values())
        return replace(result, timings_ms=timings)

    # -- output -------------------------------------------------------------------------------
    def _assemble(self, m: Matching, stamp_ns: int, withheld: list = ()) -> LocalizationResult:
        """Rectified (u, v, d) -> the result contract (left camera frame, original pixels).

        ``withheld``: (matched feature, its FeatureCheck) of features the check withheld.
        """
        calib, k = self.calib, self.cfg.safety_factor_k
        f = calib.f_px
        features, node_id = [], {}
        if m.features:
            uvd = np.array([[ft.u, ft.v, ft.d] for ft in m.features])
            xyz = triangulate(uvd[:, 0], uvd[:, 1], uvd[:, 2], calib)
            z_rect = calib.f_px * calib.baseline_mm / (uvd[:, 2] - (calib.P1[0, 2] - calib.P2[0, 2]))
            left_px = self.rectifier.to_original(uvd[:, :2], 0)
            right_px = self.rectifier.to_original(np.column_stack([uvd[:, 0] - uvd[:, 2], uvd[:, 1]]), 1)
            for i, ft in enumerate(m.features):
                radius_mm = float(ft.radius_px * z_rect[i] / f)
                node_id[ft.node] = i
                features.append(Feature(i, ft.kind, tuple(left_px[i]), tuple(right_px[i]), tuple(xyz[i]),
                                        radius_mm, float(xyz[i, 2] - k * radius_mm)))
        kept = []
        dmin, dmax = self.d_range_px
        pieces = [p for p in m.pieces if np.isfinite(p.radius_px) and len(p.uvd) >= 2]
        whole = _whole_pieces(pieces, 0.95 * dmin, 1.05 * dmax, self.cfg.match.max_disparity_gradient)
        for p, ok in zip(pieces, whole):
            if ok:                                      # (the usual case: all of it, checked at once)
                kept.append((p, p.uvd))
                continue
            if (p.uvd[:, 2] <= 0).any():
                continue
            # as the features: within the working range (5 %)
            uvd = longest_run(p.uvd, (p.uvd[:, 2] >= 0.95 * dmin) & (p.uvd[:, 2] <= 1.05 * dmax))
            uvd = plausible_part(uvd, self.cfg.match.max_disparity_gradient)
            if len(uvd) >= 2:
                kept.append((p, uvd))
        branches = []
        if kept:
            # all pieces triangulated at once (row by row the same values), then split
            uvd = np.vstack([u for _, u in kept])
            xyz, ends = triangulate(uvd[:, 0], uvd[:, 1], uvd[:, 2], calib), np.cumsum([len(u) for _, u in kept]).tolist()
            starts = [0] + ends[:-1]
            polys = [xyz[a:b] for a, b in zip(starts, ends)]      # (np.split's arrays)
            z = np.ascontiguousarray(xyz[:, 2])
            if np.isnan(z).any():
                z_med = [median(poly[:, 2]) for poly in polys]
            else:                                       # (np.median of each piece's Z, all at once)
                z_med = kernels_graph.group_medians(z, np.array(starts + ends[-1:], np.int64)).tolist()
            for (p, _), poly, zm in zip(kept, polys, z_med):
                radius_mm = float(p.radius_px * zm / f)
                ids = tuple(node_id.get(n, -1) for n in p.nodes)
                branches.append(Branch(len(branches), ids, poly, radius_mm, bool(p.recovered)))
        if withheld:
            at = self.rectifier.to_original(np.array([[ft.u, ft.v] for ft, _ in withheld]), 0)
            texture = [abs(k.diff_px) > self.cfg.feature_check.max_diff_px or k.turned for _, k in withheld]
            withheld = [WithheldFeature(ft.kind, tuple(at[i]), float(ft.d),
                                        float(k.d_check_px if t else ft.d + k.agree_px),
                                        "texture" if t else "pieces_agree")
                        for i, ((ft, k), t) in enumerate(zip(withheld, texture))]
        return LocalizationResult(tuple(features), tuple(branches), int(stamp_ns), withheld=tuple(withheld))
