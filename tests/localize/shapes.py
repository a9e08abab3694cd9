"""Small constructed masks and a synthetic rectified rig for the localize tests."""

from __future__ import annotations

import cv2
import numpy as np
from appliance.calibrate.model import StereoCalibration


def y_shape(size: int = 200) -> np.ndarray:
    """A thick stem with two arms: one fork, three tips (uint8 0/255)."""
    m = np.zeros((size, size), np.uint8)
    cv2.line(m, (100, 190), (100, 100), 255, 9)
    cv2.line(m, (100, 100), (40, 20), 255, 7)
    cv2.line(m, (100, 100), (160, 20), 255, 7)
    return m


def ideal_rig(width: int = 640, height: int = 480, f_px: float = 700.0, baseline_mm: float = 120.0):
    """A distortion-free, already rectified rig: rectification is the identity."""
    K = np.array([[f_px, 0, (width - 1) / 2], [0, f_px, (height - 1) / 2], [0, 0, 1]])
    return StereoCalibration.from_pose((width, height), K, np.zeros(5), K, np.zeros(5), np.eye(3),
                                       [-baseline_mm, 0.0, 0.0])


def branch_pair(calib: StereoCalibration, depth_mm: float, radius_px: float = 6.0,
                top=(300.0, 60.0), bottom=(260.0, 420.0), background: int = 40):
    """A rendered straight 'branch' at constant depth in both views, supersampled (anti-aliased edges).

    Returns (left BGR, right BGR, left mask, right mask, disparity px).
    """
    d = calib.f_px * calib.baseline_mm / depth_mm
    w, h = calib.image_size
    ss = 4
    out = []
    for shift in (0.0, d):
        big = np.full((h * ss, w * ss), background, np.uint8)
        p = tuple(int(round((c - (shift if k == 0 else 0) + 0.5) * ss - 0.5)) for k, c in enumerate(top))
        q = tuple(int(round((c - (shift if k == 0 else 0) + 0.5) * ss - 0.5)) for k, c in enumerate(bottom))
        cv2.line(big, p, q, 200, int(round(2 * radius_px * ss)))
        grey = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
        out.append(grey)
    imgs = [cv2.cvtColor(g, cv2.COLOR_GRAY2BGR) for g in out]
    masks = [((g.astype(int) - background) > (200 - background) / 2).astype(np.uint8) * 255 for g in out]
    return imgs[0], imgs[1], masks[0], masks[1], d


def y_pair(calib: StereoCalibration, depth_mm: float, angle_deg: float, parent_radius_px: float = 10.0,
           child_radius_px: float = 6.0, fork=(320.0, 300.0), background: int = 40,
           child_depth_mm: float | None = None):
    """A drawn vertical parent with a thinner child leaving it at ``angle_deg`` (upwards, to the
    right) from the point ``fork`` on its axis, at constant depth in both views, supersampled.
    ``child_depth_mm`` puts the child at another depth (then it only crosses the parent).

    Returns (left BGR, right BGR, left mask, right mask, fork (x, y) left px, disparity px).
    """
    d = calib.f_px * calib.baseline_mm / depth_mm
    d_child = calib.f_px * calib.baseline_mm / (child_depth_mm or depth_mm)
    w, h = calib.image_size
    ss = 4
    fork = np.asarray(fork, float)
    a = np.radians(angle_deg)
    child_end = fork + 180.0 * np.array([np.sin(a), -np.cos(a)])
    imgs, masks = [], []
    for shift, shift_child in ((0.0, 0.0), (d, d_child)):
        def px(p, dx):
            return (int(round((p[0] - dx + 0.5) * ss - 0.5)), int(round((p[1] + 0.5) * ss - 0.5)))
        big = np.full((h * ss, w * ss), background, np.uint8)
        cv2.line(big, px((fork[0], 40.0), shift), px((fork[0], h - 20.0), shift), 200,
                 int(round(2 * parent_radius_px * ss)))
        cv2.line(big, px(fork, shift_child), px(child_end, shift_child), 200, int(round(2 * child_radius_px * ss)))
        cv2.circle(big, px(child_end, shift_child), int(round(child_radius_px * ss)), 200, -1)
        grey = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
        imgs.append(cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR))
        masks.append(((grey.astype(int) - background) > (200 - background) / 2).astype(np.uint8) * 255)
    return imgs[0], imgs[1], masks[0], masks[1], fork, d


def end_placer(left: np.ndarray, right: np.ndarray, valid_right: np.ndarray | None = None, block: bool = False):
    """An ``EndPlacer`` over the soft masks ``left`` / ``right`` (uint8 0-255, no grey texture, rectified,
    working range 100-300 px; ``valid_right``: where the right view sees the scene; ``block``: the masks
    carry the skeleton's block mask, as the localizer's): (placer, every segment's index, the left mask's
    transposed runs)."""
    from appliance.config import load_config
    from appliance.localize.edges import find_runs
    from appliance.localize.ends import EndPlacer
    from appliance.localize.graph import build_graph
    from appliance.localize.matching import StereoMasks
    from appliance.localize.radius import ridge_radius_map
    from appliance.localize.skeleton import skeletonize

    grey = np.zeros(left.shape, np.uint8)
    bl = cv2.threshold(left, 127, 255, cv2.THRESH_BINARY)[1]
    skel = skeletonize(bl, "fast", 4)
    sm = StereoMasks(left, right, grey, grey, ridge_radius_map(bl), (100.0, 300.0), 1450.0, valid_right=valid_right,
                     left_block=skel.mask if block else None)
    graph = build_graph(skel)
    return EndPlacer(graph, sm, {}, load_config().localize.match), list(range(len(graph.seg_yx))), \
        find_runs(left.T, soft=True)
