"""Compiled kernel of dense._two_view_patches (gross19b, docs/localize-gross19b.md): a flat piece's texture
patches whose shares on the branch differ between the two views (patchmask.py's numbers, without numpy's
per-call overhead on a few dozen patches)."""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT


@numba.njit(**_JIT)
def _inside(mask, cx, cy, hh, hw):
    """Pixels >= 128 of ``mask`` in the (2 hh + 1) x (2 hw + 1) box centred on the integer ``cx``, ``cy``
    (outside the image: outside)."""
    h, w = mask.shape
    n = 0
    for y in range(max(cy - hh, 0), min(cy + hh + 1, h)):
        for x in range(max(cx - hw, 0), min(cx + hw + 1, w)):
            if mask[y, x] >= 128:
                n += 1
    return n


@numba.njit(**_JIT)
def flat_share_dropped(left_mask, right_mask, u, v, d, hh, hw, max_diff, min_kept):
    """The patches (N,) bool to drop: ``u``, ``v``, ``d`` (N,) px the matched patches' centres and readings.
    The piece's Theil-Sen line through the readings (the median of the pairwise slopes, the median
    intercept: a few stray readings do not move it); each patch's share in the left mask at (u, v) and in the right mask at
    (u - line, v) (centres rounded half to even, as patchmask.inside_fraction); dropped where they differ by
    more than ``max_diff``, none when fewer than ``min_kept`` would stay."""
    n = len(u)
    out = np.zeros(n, np.bool_)
    if n == 0:
        return out
    m = 0
    sl = np.empty(n * (n - 1) // 2)
    for i in range(n):
        for j in range(i + 1, n):
            du = u[j] - u[i]
            if du != 0:
                sl[m] = (d[j] - d[i]) / du
                m += 1
    k = np.median(sl[:m]) if m > 0 else 0.0
    b = np.median(d - k * u)
    area = float((2 * hh + 1) * (2 * hw + 1))
    cy = np.rint(v)
    nbad = 0
    for i in range(n):
        line = b + k * u[i]
        fl = _inside(left_mask, int(np.rint(u[i])), int(cy[i]), hh, hw) / area
        fr = _inside(right_mask, int(np.rint(u[i] - line)), int(cy[i]), hh, hw) / area
        if abs(fl - fr) > max_diff:
            out[i] = True
            nbad += 1
    if nbad == 0 or n - nbad < min_kept:
        out[:] = False
    return out


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernel for the argument types dense.py passes."""
    m = np.zeros((4, 4), np.uint8)
    f = np.zeros(2)
    flat_share_dropped(m, m, f, f, f, 1, 1, 0.15, 3)
