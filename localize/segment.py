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

Segmenter = Callable[[np.ndarray], np.ndarray]


def _kernel(size_px: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size_px, size_px))


def hsv_bark(bgr: np.ndarray, cfg: SegmentConfig, occluder: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Raw bark and occluder masks from colour thresholds, uint8 0/255, shape (H, W).

    Bark: hue in [hue_min, hue_max] (wrapping past 180 when hue_min > hue_max),
    saturation <= saturation_max, value in [value_min, value_max]. Occluder (leaf,
    apple): saturation above saturation_max and value above value_min.
    """
    hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
    lo_s, hi_s = 0, cfg.saturation_max
    if cfg.hue_min <= cfg.hue_max:
        bark = cv2.inRange(hsv, (cfg.hue_min, lo_s, cfg.value_min), (cfg.hue_max, hi_s, cfg.value_max))
    else:
        bark = cv2.inRange(hsv, (cfg.hue_min, lo_s, cfg.value_min), (180, hi_s, cfg.value_max))
        bark |= cv2.inRange(hsv, (0, lo_s, cfg.value_min), (cfg.hue_max, hi_s, cfg.value_max))
    occ = cv2.inRange(hsv, (0, min(cfg.saturation_max + 1, 255), cfg.value_min), (180, 255, 255)) if occluder else None
    return bark, occ


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
    small pixel), ten times faster than at full size; areas are counted at full size.
    """
    h, w = mask.shape
    cover = cv2.resize(mask, (w // factor, h // factor), interpolation=cv2.INTER_AREA)
    n, labels = cv2.connectedComponents((cover > 0).astype(np.uint8), connectivity=8, ltype=cv2.CV_32S)
    if n <= 1:
        return mask
    area = np.bincount(labels.ravel(), weights=cover.ravel() / 255.0 * factor * factor, minlength=n)
    keep = (area >= min_area_px).astype(np.uint8) * 255
    keep[0] = 0
    keep_big = cv2.resize(keep[labels], (w, h), interpolation=cv2.INTER_NEAREST)
    return cv2.bitwise_and(mask, keep_big)


def segment_color(bgr: np.ndarray, cfg: SegmentConfig, occluder: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """The embedded recogniser: (branch mask, occluder mask or None), uint8 0/255, shape (H, W)."""
    bark, occ = hsv_bark(bgr, cfg, occluder)
    return clean_mask(bark, cfg), occ


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
    m = (m > 0).astype(np.uint8) * 255
    if not m.any():
        raise LocalizeError(f"{what}: mask is empty (no branch pixel)")
    return m
