"""Pictures of a result like the paper's figures: numbered '+' at matched features in both
images side by side, branch axes coloured by depth."""

from __future__ import annotations

import cv2
import numpy as np
from appliance.calibrate.model import StereoCalibration
from appliance.localize.result import LocalizationResult


def depth_colour(z_mm: np.ndarray, range_mm: tuple[float, float]) -> np.ndarray:
    """BGR colours (N, 3) uint8 of depths: near red ... far blue (turbo colormap)."""
    near, far = range_mm
    t = np.clip((np.asarray(z_mm, float) - near) / (far - near), 0, 1)
    lut = cv2.applyColorMap(np.arange(256, dtype=np.uint8)[:, None], cv2.COLORMAP_TURBO)[:, 0]
    return lut[(255 * (1 - t)).astype(int)]


def _project(xyz: np.ndarray, calib: StereoCalibration, side: int) -> np.ndarray:
    if side == 0:
        rvec, tvec, K, D = np.zeros(3), np.zeros(3), calib.K1, calib.D1
    else:
        rvec, tvec, K, D = cv2.Rodrigues(calib.R)[0], calib.T.reshape(3), calib.K2, calib.D2
    px, _ = cv2.projectPoints(np.asarray(xyz, float).reshape(-1, 1, 3), rvec, tvec, K, D)
    return px.reshape(-1, 2)


def draw_overlay(left: np.ndarray, right: np.ndarray, result: LocalizationResult, calib: StereoCalibration,
                 range_mm: tuple[float, float] = (500.0, 1500.0), legend: bool = True) -> np.ndarray:
    """Left and right images side by side with the result drawn on both.

    Branch axes are drawn as lines coloured by depth (``range_mm``: near red, far blue;
    dashed-looking thin lines for recovered pieces), features as numbered '+' (yellow:
    endpoint, magenta: fork) at their ``left_px``/``right_px``, withheld features as a grey 'x'
    in the left image.

    Returns
    -------
    ndarray (H, 2W, 3) uint8 BGR
    """
    imgs = [cv2.cvtColor(im, cv2.COLOR_GRAY2BGR) if im.ndim == 2 else im.copy() for im in (left, right)]
    h, w = imgs[0].shape[:2]
    scale = max(1, round(w / 640))
    for side, img in enumerate(imgs):
        for b in result.branches:
            poly = np.asarray(b.polyline_mm, float)
            if len(poly) < 2:
                continue
            px = _project(poly, calib, side)
            cols = depth_colour(poly[:, 2], range_mm)
            thick = 1 if b.recovered else 2 * scale
            for k in range(len(px) - 1):
                p, q = (tuple(int(round(c)) for c in pt) for pt in (px[k], px[k + 1]))
                cv2.line(img, p, q, tuple(int(c) for c in cols[k]), thick, cv2.LINE_AA)
        for f in result.features:
            u, v = f.left_px if side == 0 else f.right_px
            colour = (0, 255, 255) if f.kind == "endpoint" else (255, 0, 255)
            c = (int(round(u)), int(round(v)))
            cv2.drawMarker(img, c, colour, cv2.MARKER_CROSS, 12 * scale, 2 * scale)
            cv2.putText(img, str(f.id), (c[0] + 5 * scale, c[1] - 5 * scale), cv2.FONT_HERSHEY_SIMPLEX,
                        0.5 * scale, colour, scale, cv2.LINE_AA)
    for wf in result.withheld:                          # found, but its depth failed a check
        c = tuple(int(round(x)) for x in wf.left_px)
        cv2.drawMarker(imgs[0], c, (160, 160, 160), cv2.MARKER_TILTED_CROSS, 12 * scale, 2 * scale)
    out = np.hstack(imgs)
    if legend:
        bar_w, bar_h = 256, 12 * scale
        bar = np.repeat(depth_colour(np.linspace(range_mm[0], range_mm[1], bar_w), range_mm)[None], bar_h, 0)
        y0 = h - bar_h - 20 * scale
        out[y0:y0 + bar_h, 10:10 + bar_w] = bar
        for z, x in ((range_mm[0], 10), (range_mm[1], 10 + bar_w - 40 * scale)):
            cv2.putText(out, f"{z:.0f} mm", (x, y0 - 4 * scale), cv2.FONT_HERSHEY_SIMPLEX, 0.45 * scale,
                        (255, 255, 255), scale, cv2.LINE_AA)
    return out
