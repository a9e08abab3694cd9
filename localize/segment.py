"""Branch pixels: the embedded colour recogniser, and checks of external masks.

An external segmenter is any callable ``(bgr image) -> bool mask`` of the same size;
its masks are passed to :meth:`Localizer.localize` as ``mask_left``/``mask_right``.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np
from appliance.config.schema import SegmentConfig
from appliance.localize.errors import LocalizeError
from appliance.localize.skeleton import binary, block_mean, pixels

Segmenter = Callable[[np.ndarray], np.ndarray]


def _kernel(size_px: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size_px, size_px))


def hsv_bark(hsv: np.ndarray, cfg: SegmentConfig) -> np.ndarray:
    """Raw bark mask from colour thresholds of an HSV image (OpenCV scale), uint8 0/255, shape (H, W).

    Bark: hue in [hue_min, hue_max] (wrapping past 180 when hue_min > hue_max),
    saturation <= saturation_max, value in [value_min, value_max].
    """
    lo, hi = (cfg.hue_min, 0, cfg.value_min), (cfg.hue_max, cfg.saturation_max, cfg.value_max)
    if cfg.hue_min <= cfg.hue_max:
        return cv2.inRange(hsv, lo, hi)       # three channels at once: no split, ~2x faster
    return cv2.inRange(hsv, lo, (180, *hi[1:])) | cv2.inRange(hsv, (0, *lo[1:]), hi)


def occluder_at(hsv: np.ndarray, xy_px: np.ndarray, cfg: SegmentConfig) -> np.ndarray:
    """Whether the pixels at ``xy_px`` (N, 2) (x, y; rounded) are a leaf or an apple: saturation
    above ``saturation_max`` and value at least ``value_min``; False outside the image. Tested at
    the few points recovery asks about rather than over the whole image."""
    h, w = hsv.shape[:2]
    p = np.rint(np.asarray(xy_px, float).reshape(-1, 2)).astype(int)
    ok = (p[:, 0] >= 0) & (p[:, 0] < w) & (p[:, 1] >= 0) & (p[:, 1] < h)
    px = hsv[p[ok, 1], p[ok, 0]].astype(int)
    out = np.zeros(len(p), bool)
    out[ok] = (px[:, 1] > cfg.saturation_max) & (px[:, 2] >= cfg.value_min)
    return out


def clean_mask(mask: np.ndarray, cfg: SegmentConfig) -> np.ndarray:
    """Opening, closing and removal of components smaller than ``min_area_px``; uint8 0/255."""
    m = mask
    if cfg.open_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, _kernel(cfg.open_px))
    if cfg.close_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, _kernel(cfg.close_px))
    if cfg.min_area_px > 0:
        m = drop_small(m, cfg.min_area_px)
    return m


def drop_small(mask: np.ndarray, min_area_px: float, factor: int = 4) -> np.ndarray:
    """Remove connected components smaller than ``min_area_px`` (uint8 0/255).

    Components are found on a ``factor`` times smaller copy (any branch pixel keeps a
    small pixel), ten times faster than at full size; areas are counted at full size
    (exact pixel counts of the blocks).
    Only the small components are cleared (``mask`` itself is returned when none is).
    """
    h, w = mask.shape
    hs, ws = -(-h // factor), -(-w // factor)
    if (hs * factor, ws * factor) != (h, w):                  # whole blocks only: pad, then crop
        pad = cv2.copyMakeBorder(mask, 0, hs * factor - h, 0, ws * factor - w, cv2.BORDER_CONSTANT, value=0)
        out = drop_small(pad, min_area_px, factor)
        return mask if out is pad else out[:h, :w]
    cover = block_mean(mask, factor)
    n, labels = cv2.connectedComponents(cover, connectivity=8, ltype=cv2.CV_32S)
    if n <= 1:
        return mask
    yx = pixels(cover)                                        # the few covered small pixels (row, col)
    lab = labels[yx[:, 0], yx[:, 1]]
    area = np.bincount(lab, weights=np.rint(cover[yx[:, 0], yx[:, 1]] * (factor * factor / 255.0)), minlength=n)
    small = area < min_area_px
    small[0] = False
    if not small.any():
        return mask
    out = mask.copy()
    gone = yx[small[lab]]
    out.reshape(hs, factor, ws, factor)[gone[:, 0], :, gone[:, 1], :] = 0
    return out


def segment_color(bgr: np.ndarray, cfg: SegmentConfig) -> tuple[np.ndarray, np.ndarray]:
    """The embedded recogniser: the branch mask, uint8 0/255 (H, W), and the HSV image it was
    taken from (H, W, 3) (for :func:`occluder_at`)."""
    hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
    return clean_mask(hsv_bark(hsv, cfg), cfg), hsv


def as_mask(mask: np.ndarray, shape: tuple[int, int], what: str) -> np.ndarray:
    """Validate an external mask: size, non-empty; returns uint8 0/255.

    Raises
    ------
    LocalizeError
        Wrong size, or no branch pixel at all.
    """
    m = np.asarray(mask)
    if m.ndim == 3:
        m = m.max(axis=2)
    if m.shape != tuple(shape):
        raise LocalizeError(f"{what}: mask is {m.shape[1]}x{m.shape[0]}, the image is {shape[1]}x{shape[0]}")
    m = binary(m, 255)
    if not cv2.countNonZero(m):
        raise LocalizeError(f"{what}: mask is empty (no branch pixel)")
    return m
