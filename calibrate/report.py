"""Pictures of a calibration's quality: per-view errors, corner coverage, a rectification check."""

from __future__ import annotations

import os

import cv2
import numpy as np

from appliance.calibrate.model import StereoCalibration

_LEFT, _RIGHT = (200, 120, 30), (40, 130, 240)   # BGR: blue-ish left, orange right
_FONT = cv2.FONT_HERSHEY_SIMPLEX


def error_chart(keys: list[str], view_rms_px: np.ndarray, height_px: int = 420) -> np.ndarray:
    """Bar chart of each view's RMS reprojection error, left and right (like MATLAB's).

    Parameters
    ----------
    keys : list of str
        View names, one per row of ``view_rms_px``.
    view_rms_px : ndarray, shape (n, 2)
        RMS error per view in the left and right image, px.

    Returns
    -------
    ndarray, shape (height_px, W, 3), uint8 BGR
    """
    n = len(keys)
    keys = _short(keys)
    bar, gap, x0, y0, top = 14, 12, 70, height_px - 110, 40
    width = x0 + n * (2 * bar + gap) + 40
    img = np.full((height_px, max(width, 620), 3), 255, np.uint8)
    step = _nice_step(float(view_rms_px.max()) / 5 or 0.1)
    vmax = step * (np.floor(view_rms_px.max() / step) + 1)
    scale = (y0 - top) / vmax
    for t in np.arange(0, vmax + step / 2, step):           # y axis with grid
        y = int(round(y0 - t * scale))
        cv2.line(img, (x0, y), (img.shape[1] - 20, y), (225, 225, 225), 1)
        cv2.putText(img, f"{t:.2f}", (8, y + 4), _FONT, 0.4, (60, 60, 60), 1, cv2.LINE_AA)
    for i, key in enumerate(keys):
        x = x0 + gap // 2 + i * (2 * bar + gap)
        for j, colour in enumerate((_LEFT, _RIGHT)):
            h = int(round(view_rms_px[i, j] * scale))
            cv2.rectangle(img, (x + j * bar, y0 - h), (x + (j + 1) * bar - 2, y0), colour, -1)
        cv2.putText(img, key[:8], (x - 2, y0 + 16 + 14 * (i % 2)), _FONT, 0.35, (40, 40, 40), 1,
                    cv2.LINE_AA)
    mean = float(np.sqrt(np.mean(view_rms_px ** 2)))
    y = int(round(y0 - mean * scale))
    for xs in range(x0, img.shape[1] - 20, 12):             # dashed overall RMS line
        cv2.line(img, (xs, y), (min(xs + 6, img.shape[1] - 20), y), (0, 0, 200), 1)
    cv2.line(img, (x0, top - 10), (x0, y0), (0, 0, 0), 1)
    cv2.line(img, (x0, y0), (img.shape[1] - 20, y0), (0, 0, 0), 1)
    cv2.putText(img, "RMS reprojection error per view (px)", (x0, 22), _FONT, 0.55, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(img, f"- - overall {mean:.3f} px", (x0 + 330, 22), _FONT, 0.5, (0, 0, 200), 1, cv2.LINE_AA)
    ly = height_px - 30
    for k, (name, colour) in enumerate((("left camera", _LEFT), ("right camera", _RIGHT))):
        lx = x0 + k * 150
        cv2.rectangle(img, (lx, ly - 10), (lx + 14, ly), colour, -1)
        cv2.putText(img, name, (lx + 20, ly), _FONT, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(img, "view (pair name)", (img.shape[1] // 2 - 50, height_px - 50), _FONT, 0.4, (60, 60, 60), 1,
                cv2.LINE_AA)
    return img


def _nice_step(raw: float) -> float:
    """The 1, 2 or 5 x 10^k at or above ``raw``."""
    mag = 10 ** np.floor(np.log10(raw))
    return float(next(m * mag for m in (1, 2, 5, 10) if m * mag >= raw))


def _short(keys: list[str]) -> list[str]:
    """The left names without their common prefix and suffix (``left01.jpg/right01.jpg`` -> ``01``)."""
    keys = [k.split("/")[0] for k in keys]
    if len(keys) < 2:
        return keys
    head = len(os.path.commonprefix(keys))
    tail = len(os.path.commonprefix([k[::-1] for k in keys]))
    short = [k[head:len(k) - tail] for k in keys]
    return short if all(short) else keys


def coverage_map(image_size: tuple[int, int], corners_px: list[np.ndarray], cell_px: int = 32) -> np.ndarray:
    """Heat map of where detected corners fall in one camera's image.

    Parameters
    ----------
    image_size : (int, int)
        (width, height), px.
    corners_px : list of ndarray, shape (N, 2)
        Corners of each view, px.
    cell_px : int
        Side of a counting cell, px.

    Returns
    -------
    ndarray, shape (height, width, 3), uint8 BGR
        JET colours from no corners (dark blue) to the most, with the corners as dots.
    """
    w, h = image_size
    pts = np.concatenate(corners_px)
    bins = (int(np.ceil(h / cell_px)), int(np.ceil(w / cell_px)))
    counts, _, _ = np.histogram2d(pts[:, 1], pts[:, 0], bins=bins, range=[[0, bins[0] * cell_px],
                                                                           [0, bins[1] * cell_px]])
    norm = (255 * counts / max(counts.max(), 1)).astype(np.uint8)
    heat = cv2.resize(norm, (bins[1] * cell_px, bins[0] * cell_px), interpolation=cv2.INTER_NEAREST)[:h, :w]
    img = cv2.applyColorMap(heat, cv2.COLORMAP_JET)
    img[heat == 0] = (60, 20, 20)
    ipts = np.round(pts).astype(int)
    ok = (ipts[:, 0] >= 0) & (ipts[:, 0] < w) & (ipts[:, 1] >= 0) & (ipts[:, 1] < h)
    img[ipts[ok, 1], ipts[ok, 0]] = 255
    covered = float((counts > 0).mean())
    cv2.putText(img, f"{len(corners_px)} views, {covered:.0%} of {cell_px}px cells hold corners", (10, 25),
                _FONT, 0.6, (255, 255, 255), 2, cv2.LINE_AA)
    return img


def coverage_pair(image_size, left_px: list[np.ndarray], right_px: list[np.ndarray]) -> np.ndarray:
    """Left and right coverage maps side by side, with a 4 px white gap."""
    gap = np.full((image_size[1], 4, 3), 255, np.uint8)
    return np.hstack([coverage_map(image_size, left_px), gap, coverage_map(image_size, right_px)])


def rectified_check(calib: StereoCalibration, left: np.ndarray, right: np.ndarray, step_px: int = 40) -> np.ndarray:
    """The pair rectified side by side with horizontal lines: matching points must lie on one line.

    Parameters
    ----------
    calib : StereoCalibration
    left, right : ndarray, shape (H, W[, 3]), uint8
    step_px : int
        Spacing of the lines, px.
    """
    size = calib.image_size
    out = []
    for img, K, D, R, P in ((left, calib.K1, calib.D1, calib.R1, calib.P1),
                            (right, calib.K2, calib.D2, calib.R2, calib.P2)):
        mx, my = cv2.initUndistortRectifyMap(K, D, R, P, size, cv2.CV_16SC2)
        rect = cv2.remap(img, mx, my, cv2.INTER_LINEAR)
        out.append(cv2.cvtColor(rect, cv2.COLOR_GRAY2BGR) if rect.ndim == 2 else rect)
    both = np.hstack(out)
    for k, y in enumerate(range(step_px // 2, size[1], step_px)):
        cv2.line(both, (0, y), (both.shape[1] - 1, y), (0, 255, 0) if k % 2 == 0 else (0, 0, 255), 1)
    cv2.line(both, (size[0], 0), (size[0], size[1] - 1), (255, 255, 255), 2)
    cv2.putText(both, f"rectified: f {calib.f_px:.1f} px, baseline {calib.baseline_mm:.2f} mm, "
                f"epipolar RMS {calib.epipolar_rms_px:.3f} px", (10, 25), _FONT, 0.6, (0, 255, 255), 2, cv2.LINE_AA)
    return both
