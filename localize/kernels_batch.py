"""Compiled loops over many small searches in one call (fourteenth pass, speed20; docs/localize-numba.md).

A Python loop calling a kernel per patch pays numba's dispatch (typing ~14 arguments: ~8-10 us) each time,
more than the patch's own work. :func:`ncc_search_each` runs :func:`kernels_ncc.ncc_search` for every patch
with its own window in one call: each patch's search is the same code on the same inputs, so the same
values.
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT
from appliance.localize.kernels_ncc import ncc_search


@numba.njit(**_JIT)
def ncc_search_each(lbox, rbox, uv, hh, hw, lo, hi, h, w, by0, lx0, rx0, d_out, score):
    """:func:`kernels_ncc.ncc_search` of each patch ``i`` alone over its own disparities ``lo[i]``..``hi[i]``
    (int64 (N,)): ``uv`` (N, 2) int64 centres, ``hh`` (N,) int64 half heights, the boxes ``lbox`` / ``rbox``
    (uint8, read at rows from ``by0``, columns from ``lx0`` / ``rx0``) and the image size ``h`` x ``w`` as
    there; patch ``i``'s disparity and score written into ``d_out[i]`` and ``score[i]`` (N,) float64 where
    it finds one (as the calls one by one: ``ncc_search(..., uv[i:i + 1], hh[i:i + 1], hw, lo[i], hi[i],
    ..., d_out[i:i + 1], score[i:i + 1])``)."""
    for i in range(len(uv)):
        ncc_search(lbox, rbox, uv[i:i + 1], hh[i:i + 1], hw, lo[i], hi[i], h, w, by0, lx0, rx0,
                   d_out[i:i + 1], score[i:i + 1])


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    img, i, f = np.zeros((8, 16), np.uint8), np.ones(1, np.int64), np.zeros(1)
    ncc_search_each(img, img, np.zeros((1, 2), np.int64), i, 1, 0 * i, 2 * i, 8, 16, 0, 0, 0, f.copy(), f.copy())
