"""Compiled glue of the match stage, tenth pass (speedF; docs/localize-numba.md).

- :func:`to_full`: :meth:`graph.SkeletonGraph.to_full` of a C-contiguous (N, 2) int64 or float64 array:
  ``(yx[:, ::-1] + 0.5) * scale - 0.5`` element by element, the same float64 operations in the same order
  (no fused multiply-add: numba's default), so bit for bit. ~40 calls per pair, ~4 us of numpy each
  (four temporaries), ~1 us here.

Tests: tests/localize/test_kernels_speedF.py.
"""
from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT


@numba.njit(**_JIT)
def to_full(yx, scale):
    """Skeleton (row, col) -> full-resolution (x, y).

    Parameters
    ----------
    yx : ndarray (N, 2) int64 or float64, C-contiguous
        Skeleton pixels (row, col), in skeleton pixels.
    scale : float
        Full-resolution pixels per skeleton pixel.

    Returns
    -------
    ndarray (N, 2) float64
        (x, y) in full-resolution px: ``(col + 0.5) * scale - 0.5``, ``(row + 0.5) * scale - 0.5``.
    """
    n = yx.shape[0]
    out = np.empty((n, 2))
    for i in range(n):
        out[i, 0] = (float(yx[i, 1]) + 0.5) * scale - 0.5
        out[i, 1] = (float(yx[i, 0]) + 0.5) * scale - 0.5
    return out


def warm_up() -> None:
    """Compile (or load) the kernels here for the argument types the localizer passes."""
    for a in (np.zeros((2, 2), np.int64), np.zeros((2, 2))):
        to_full(a, 4.0)
        a.setflags(write=False)         # (a read-only array is another type: the graphs' shared ones)
        to_full(a, 4.0)
