"""Horizontal runs of a mask with sub-pixel boundaries (vectorised).

A run is a maximal stretch of branch pixels along a row. With a soft mask (a binary mask
remapped with linear interpolation, so its boundary pixels carry the coverage), each boundary
is placed where the coverage crosses one half between the pixel outside and the pixel inside:
the rectified outline to a small fraction of a pixel.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from appliance.localize import kernels_colruns, kernels_runs
from appliance.localize.curves import cached


def _frozen(a: np.ndarray) -> np.ndarray:
    """``a`` made read-only (cached arrays are shared by every caller)."""
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Runs:
    """All runs of one mask, sorted by row then column.

    Attributes
    ----------
    width : int
        Image width, px (runs are keyed by ``row * width + x``).
    row : ndarray (R,) int
    x0, x1 : ndarray (R,) int
        First and last pixel of the run.
    left_px, right_px : ndarray (R,) float
        Sub-pixel boundaries (``x0 - 0.5`` and ``x1 + 0.5`` before refinement).
    """

    width: int
    row: np.ndarray
    x0: np.ndarray
    x1: np.ndarray
    left_px: np.ndarray
    right_px: np.ndarray

    @cached
    def centre_px(self) -> np.ndarray:
        return _frozen(0.5 * (self.left_px + self.right_px))

    @cached
    def span_px(self) -> np.ndarray:
        return _frozen(self.right_px - self.left_px)

    @cached
    def bounds_px(self) -> np.ndarray:
        """(2, R) ``left_px`` and ``right_px`` stacked (for the kernels)."""
        return _frozen(np.stack([self.left_px, self.right_px]))

    @cached
    def _start_keys(self) -> np.ndarray:
        return _frozen(self.row * self.width + self.x0)

    @cached
    def _find_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Start keys, rows and last pixels with a sentinel run first (no query's: the smallest
        key, row and last pixel), so that :meth:`find`'s "last run starting at or before" always exists."""
        lowest = np.iinfo(np.int64).min
        return tuple(_frozen(np.concatenate([[lowest], a]).astype(np.int64))
                     for a in (self._start_keys, self.row, self.x1))

    @cached
    def _centre_keys(self) -> np.ndarray:
        return _frozen(self.row * self.width + self.centre_px)

    def find(self, row: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Index of the run containing pixel (row, round(x)) for each query, -1 if none
        (compiled: :func:`kernels_runs.runs_find`)."""
        keys, rows, x1 = self._find_tables          # (a sentinel first: the same runs, two steps less)
        row, x = _queries(row, x)
        return kernels_runs.runs_find(keys, rows, x1, self.width, row, x[0])

    def between(self, row: np.ndarray, lo_px: np.ndarray, hi_px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Runs of ``row`` whose centre lies in [lo_px, hi_px], for each query.

        Returns
        -------
        query, run : ndarray (K,) int
            Pairs (query index, run index), all candidates of all queries.
        """
        row, (lo, hi) = _queries(row, lo_px, hi_px)
        return kernels_runs.runs_between(self._centre_keys, row, self.width, lo, hi)


def _queries(row, *cols) -> tuple[np.ndarray, list[np.ndarray]]:
    """Query rows as contiguous int64 (Q,) and columns as contiguous float64 (Q,) (broadcast where
    their shapes differ), as the kernels take them."""
    row = np.ascontiguousarray(row, np.int64)
    cols = [np.ascontiguousarray(c, float) for c in cols]
    if any(c.shape != row.shape for c in cols):
        row, *cols = (np.ascontiguousarray(a) for a in np.broadcast_arrays(row, *cols))
    return row, cols


def _soft_crossing(flat: np.ndarray, row_start: np.ndarray, outside: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """Where the soft mask (``flat``: its pixels row-major, rows starting at ``row_start``) crosses
    half way between an outside and an inside pixel of a row (coverage in float32)."""
    a = flat[row_start + outside].astype(np.float32)
    b = flat[row_start + inside].astype(np.float32)
    frac = np.minimum(np.maximum((127.5 - a) / np.maximum(b - a, 1.0), 0.0), 1.0)
    return outside + frac * (inside - outside)


def _run_bounds(mask: np.ndarray, above: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row, first and last column (int64, row-major order) of the runs of ``mask > above`` (uint8, C-contiguous).

    The mask is thresholded straight into a zero-padded buffer; the changes between
    neighbouring columns (an xor of the flat buffer with itself shifted by one) are found
    8 bytes at a time (the few non-zero 64-bit words, then their non-zero bytes): a
    fraction of a full-size ``cv2.findNonZero``.
    """
    h, w = mask.shape
    wp = w + 2
    n = h * wp
    m = np.zeros(n, np.uint8)
    cv2.threshold(mask, above, 1, cv2.THRESH_BINARY, dst=m.reshape(h, wp)[:, 1:-1])
    change = np.empty((n + 7) // 8 * 8, np.uint8)        # change[i]: padded flat pixels i and i + 1 differ
    np.bitwise_xor(m[1:], m[:-1], out=change[:n - 1])
    change[n - 1:] = 0
    words = change.view(np.uint64)
    wi = np.flatnonzero(words != 0)
    bi = np.flatnonzero(words[wi].view(np.uint8) != 0)
    row, col = np.divmod(wi[bi >> 3] * 8 + (bi & 7), wp)    # start, end, start, end, ... (row-major)
    return row[0::2].astype(np.int64), col[0::2].astype(np.int64), col[1::2].astype(np.int64) - 1


def find_runs(mask: np.ndarray, soft: bool = False) -> Runs:
    """Runs of ``mask`` (H, W).

    Parameters
    ----------
    mask : ndarray (H, W)
        Branch mask; with ``soft`` a uint8 coverage 0-255 (e.g. a binary mask remapped with
        linear interpolation): branch where >= 128, and each boundary is placed where the
        coverage crosses 127.5 between its outside and inside pixel; otherwise branch where
        non-zero and boundaries half a pixel outside the run. A transposed view of a C-contiguous
        uint8 mask (the runs along its columns) is read in place, row by row
        (:func:`kernels_colruns.mask_col_runs`: the same runs; fourteenth pass); other views are
        copied (OpenCV's transpose where it applies).
    """
    mask = np.asarray(mask)
    w = mask.shape[1]
    if (mask.dtype == np.uint8 and mask.ndim == 2 and mask.size and not mask.flags.c_contiguous
            and mask.T.flags.c_contiguous and mask.shape[0] % 8 == 0 and mask.T.ctypes.data % 8 == 0):
        flat = mask.T.reshape(-1)       # a transposed view: its runs read down the columns in place (compiled)
        return Runs(w, *kernels_colruns.mask_col_runs(flat, flat.view(np.uint64), w, mask.shape[0],
                                                      127 if soft else 0, bool(soft)))
    if mask.dtype == np.uint8 and not mask.flags.c_contiguous:     # e.g. a transposed view
        mask = cv2.transpose(mask.T) if mask.T.flags.c_contiguous else np.ascontiguousarray(mask)
    if mask.dtype == np.uint8 and mask.size and mask.size % 8 == 0 and mask.ctypes.data % 8 == 0:
        flat = mask.reshape(-1)         # compiled: the same runs and boundaries, bit for bit
        return Runs(w, *kernels_runs.mask_runs(flat, flat.view(np.uint64), w, 127 if soft else 0, bool(soft)))
    if mask.dtype == np.uint8:
        sr, x0, x1 = _run_bounds(mask, 127 if soft else 0)
    else:
        sr, x0, x1 = _run_bounds(((mask >= 128) if soft else (mask > 0)).view(np.uint8), 0)
    left, right = x0 - 0.5, x1 + 0.5
    if soft and len(sr):
        flat, start = mask.reshape(-1), sr * w
        left = np.where(x0 > 0, _soft_crossing(flat, start, np.maximum(x0 - 1, 0), x0), left)
        right = np.where(x1 < w - 1, _soft_crossing(flat, start, np.minimum(x1 + 1, w - 1), x1), right)
    return Runs(w, sr, x0, x1, left, right)
