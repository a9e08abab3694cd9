"""Compiled search of the block mask for the places a short isolated stub may lie (stubtips.py, stop 22;
docs/localize-stubfast22.md).

:func:`stub_seeds` replaces the steps after the whole left mask's labelling (a bincount over its 1.2 M labels,
the taken components, the candidates' pixels; 2-5 ms a pair with the labelling) by one pass over the labels of
the fast skeleton's block mask (16x fewer pixels): it drops the components holding a matched piece's or a
placed feature's point and lists the cells of the others where a stub's widest disc can lie; :mod:`stubtips`
labels the full mask in a crop around those alone.
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT


@numba.njit(**_JIT)
def _grown(a, n):
    """``a`` (rows, k) with room for at least ``n`` rows (the first rows kept; doubled when full)."""
    if n <= len(a):
        return a
    b = np.empty((max(n, 2 * len(a)), a.shape[1]), a.dtype)
    b[: len(a)] = a
    return b


@numba.njit(**_JIT)
def stub_seeds(labels, n, mask, scale, taken, min_cell_px):
    """The block mask's components free of taken points, and their cells dense enough for a stub.

    Parameters
    ----------
    labels : ndarray (H / scale, W / scale) int32
        The block mask's 8-connected components (``cv2.connectedComponents``: 0 = background, 1 ... n - 1);
        a cell is ``scale`` x ``scale`` pixels of ``mask``.
    n : int
        Number of labels (background included).
    mask : ndarray (H, W) uint8
        The left coverage (branch where >= 128).
    scale : int
        Pixels per cell.
    taken : ndarray (N, 2) float64
        Points (x, y) px of matched pieces and placed features. Rounded half to even (``np.rint``); one on a
        branch pixel of ``mask`` in a labelled cell makes that cell's component taken.
    min_cell_px : int
        A cell is listed when at least this many of its pixels are branch.

    Returns
    -------
    boxes : ndarray (K, 4) int64
        Each free component holding a listed cell: its cells' box (row0, col0, row1, col1), inclusive, in the
        order of the labels.
    cells : ndarray (M, 3) int64
        The listed cells: (component's row in ``boxes``, row, col), in raster order within each component.
    """
    bh, bw = labels.shape
    h, w = mask.shape
    free = np.ones(n, np.uint8)
    free[0] = 0
    for i in range(len(taken)):
        fx, fy = taken[i, 0], taken[i, 1]
        if not (np.isfinite(fx) and np.isfinite(fy)):
            continue
        x, y = np.int64(np.rint(fx)), np.int64(np.rint(fy))
        if 0 <= x < w and 0 <= y < h and mask[y, x] >= 128:
            cy, cx = y // scale, x // scale
            if cy < bh and cx < bw:
                free[labels[cy, cx]] = 0
    box = np.empty((n, 4), np.int64)
    box[:, 0], box[:, 1] = bh, bw
    box[:, 2], box[:, 3] = -1, -1
    for y in range(bh):
        row = labels[y]
        for x in range(bw):
            k = row[x]
            if k and free[k]:
                if box[k, 0] > y:
                    box[k, 0] = y
                if box[k, 1] > x:
                    box[k, 1] = x
                box[k, 2] = y
                if box[k, 3] < x:
                    box[k, 3] = x
    boxes = np.empty((8, 4), np.int64)
    cells = np.empty((8, 3), np.int64)
    nb, nc = 0, 0
    for k in range(1, n):
        if not free[k]:
            continue
        first = nc
        for y in range(box[k, 0], box[k, 2] + 1):
            for x in range(box[k, 1], box[k, 3] + 1):
                if labels[y, x] != k:
                    continue
                c = 0
                for py in range(y * scale, y * scale + scale):
                    for px in range(x * scale, x * scale + scale):
                        if mask[py, px] >= 128:
                            c += 1
                if c >= min_cell_px:
                    cells = _grown(cells, nc + 1)
                    cells[nc, 0], cells[nc, 1], cells[nc, 2] = nb, y, x
                    nc += 1
        if nc > first:
            boxes = _grown(boxes, nb + 1)
            boxes[nb, 0], boxes[nb, 1], boxes[nb, 2], boxes[nb, 3] = box[k, 0], box[k, 1], box[k, 2], box[k, 3]
            nb += 1
    return boxes[:nb].copy(), cells[:nc].copy()


@numba.njit(**_JIT)
def _fill(mask, seen, oy, ox, sy, sx, mark, stack):
    """Mark ``mark`` in ``seen`` (a window of ``mask`` whose first pixel is (``oy``, ``ox``)) the 8-connected
    branch pixels (>= 128) of the window reached from (``sy``, ``sx``) (image coordinates, a branch pixel).

    Returns (area, row0, col0, row1, col1, edge): the pixels marked, their box (image coordinates,
    inclusive) and whether they reach an edge of the window that is not the image's (the component may run
    on beyond it). ``stack`` holds at least the window's pixel count (int64).
    """
    h, w = mask.shape
    wh, ww = seen.shape
    seen[sy - oy, sx - ox] = mark
    stack[0] = (sy - oy) * ww + (sx - ox)
    head, tail = 0, 1
    r0, c0, r1, c1 = sy, sx, sy, sx
    edge = False
    while head < tail:
        i = stack[head]
        head += 1
        wy, wx = i // ww, i % ww
        y, x = wy + oy, wx + ox
        r0, r1, c0, c1 = min(r0, y), max(r1, y), min(c0, x), max(c1, x)
        if (wy == 0 and y > 0) or (wx == 0 and x > 0) or (wy == wh - 1 and y < h - 1) or (wx == ww - 1 and x < w - 1):
            edge = True
        for yy in range(max(wy - 1, 0), min(wy + 2, wh)):
            for xx in range(max(wx - 1, 0), min(wx + 2, ww)):
                if seen[yy, xx] == 0 and mask[yy + oy, xx + ox] >= 128:
                    seen[yy, xx] = mark
                    stack[tail] = yy * ww + xx
                    tail += 1
    return tail, r0, c0, r1, c1, edge


@numba.njit(**_JIT)
def stub_pixels(labels, n, mask, scale, taken, min_cell_px, min_area, max_area):
    """The left mask's components where a short isolated stub may lie, found from the block mask's labels.

    The block mask's components free of taken points (as :func:`stub_seeds`) and their cells holding at
    least ``min_cell_px`` branch pixels are read; the full mask's 8-connected components holding that many
    pixels of one such cell are filled in a window one cell beyond the block component's box (grown while
    a component reaches its edge), and kept when they hold ``min_area`` ... ``max_area`` pixels, do not touch
    the image's border and hold no taken point (rounded half to even, as ``np.rint``).

    Parameters
    ----------
    labels, n, mask, scale, taken, min_cell_px
        As :func:`stub_seeds`.
    min_area, max_area : int
        The components' size, px.

    Returns
    -------
    pixels : ndarray (P, 2) int64
        (row, col) of each component's pixels in raster order, the components one after another.
    starts : ndarray (K + 1,) int64
        Component ``k``'s pixels are ``pixels[starts[k]:starts[k + 1]]``; the components in no set order
        (their first pixels' raster order: ``pixels[starts[:-1]]``), each once.
    """
    boxes, cells = stub_seeds(labels, n, mask, scale, taken, min_cell_px)
    h, w = mask.shape
    pixels = np.empty((64, 2), np.int64)
    starts = np.zeros(max(len(boxes) * 4, 4) + 1, np.int64)
    keys = np.empty(max(len(boxes) * 4, 4), np.int64)
    nk, npix = 0, 0
    j = 0
    for b in range(len(boxes)):
        oy, ox = max((boxes[b, 0] - 1) * scale, 0), max((boxes[b, 1] - 1) * scale, 0)
        ey, ex = min((boxes[b, 2] + 2) * scale, h), min((boxes[b, 3] + 2) * scale, w)
        seen = np.zeros((ey - oy, ex - ox), np.int32)
        stack = np.empty((ey - oy) * (ex - ox), np.int64)
        info = np.zeros((8, 8), np.int64)          # per mark: area, r0, c0, r1, c1, edge, seed row, seed col
        qual = np.zeros(8, np.uint8)
        marks = 0
        ids = np.empty(scale * scale, np.int32)
        while j < len(cells) and cells[j, 0] == b:
            cy, cx = cells[j, 1], cells[j, 2]
            j += 1
            m = 0
            for py in range(cy * scale, cy * scale + scale):
                for px in range(cx * scale, cx * scale + scale):
                    if mask[py, px] < 128:
                        continue
                    if seen[py - oy, px - ox] == 0:
                        marks += 1
                        info = _grown(info, marks + 1)
                        if marks + 1 > len(qual):
                            q2 = np.zeros(2 * len(qual), np.uint8)
                            q2[: len(qual)] = qual
                            qual = q2
                        a, r0, c0, r1, c1, edge = _fill(mask, seen, oy, ox, py, px, marks, stack)
                        info[marks, 0], info[marks, 1], info[marks, 2], info[marks, 3] = a, r0, c0, r1
                        info[marks, 4], info[marks, 5], info[marks, 6], info[marks, 7] = c1, edge, py, px
                    ids[m] = seen[py - oy, px - ox]
                    m += 1
            for i in range(m):                          # (more than half a cell: one mark at most)
                c = 0
                for i2 in range(m):
                    if ids[i2] == ids[i]:
                        c += 1
                if c >= min_cell_px:
                    qual[ids[i]] = 1
                    break
        for mk in range(1, marks + 1):
            if not qual[mk]:
                continue
            area, r0, c0, r1, c1 = info[mk, 0], info[mk, 1], info[mk, 2], info[mk, 3], info[mk, 4]
            edge = info[mk, 5] != 0
            win, wy0, wx0, mark = seen, oy, ox, mk
            while edge and area <= max_area and r0 > 0 and c0 > 0 and r1 < h - 1 and c1 < w - 1:
                # it runs on beyond the window: a window twice as large around it
                gy, gx = win.shape[0], win.shape[1]
                wy0, wx0 = max(r0 - gy, 0), max(c0 - gx, 0)
                wy1, wx1 = min(r1 + 1 + gy, h), min(c1 + 1 + gx, w)
                win = np.zeros((wy1 - wy0, wx1 - wx0), np.int32)
                big = np.empty((wy1 - wy0) * (wx1 - wx0), np.int64)
                mark = 1
                area, r0, c0, r1, c1, edge = _fill(mask, win, wy0, wx0, info[mk, 6], info[mk, 7], 1, big)
            if area < min_area or area > max_area or r0 == 0 or c0 == 0 or r1 == h - 1 or c1 == w - 1:
                continue
            key = -1
            for y in range(r0, r1 + 1):
                for x in range(c0, c1 + 1):
                    if win[y - wy0, x - wx0] == mark:
                        key = y * w + x
                        break
                if key >= 0:
                    break
            dup = False
            for i in range(nk):
                if keys[i] == key:
                    dup = True
            if dup:
                continue
            hold = False
            for i in range(len(taken)):
                fx, fy = taken[i, 0], taken[i, 1]
                if not (np.isfinite(fx) and np.isfinite(fy)):
                    continue
                x, y = np.int64(np.rint(fx)), np.int64(np.rint(fy))
                if r0 <= y <= r1 and c0 <= x <= c1 and win[y - wy0, x - wx0] == mark:
                    hold = True
                    break
            if hold:
                continue
            pixels = _grown(pixels, npix + area)
            for y in range(r0, r1 + 1):
                for x in range(c0, c1 + 1):
                    if win[y - wy0, x - wx0] == mark:
                        pixels[npix, 0], pixels[npix, 1] = y, x
                        npix += 1
            if nk + 1 >= len(starts):
                s2 = np.zeros(2 * len(starts), np.int64)
                s2[: len(starts)] = starts
                starts = s2
                k2 = np.empty(2 * len(keys), np.int64)
                k2[: len(keys)] = keys
                keys = k2
            keys[nk] = key
            nk += 1
            starts[nk] = npix
    return pixels[:npix].copy(), starts[: nk + 1].copy()


@numba.njit(**_JIT)
def walk_end(mask, sx, sy, ox, oy, reach, step):
    """``stubtips._walk_end``'s walk: samples ``t = 0, step, ...`` below ``reach`` (``np.arange``'s) along the
    line from (``sx``, ``sy``) in direction (``ox``, ``oy``), each rounded half to even onto ``mask`` (branch
    where >= 128). Returns (ok, x, y): the point half a step past the last sample inside, where the line first
    leaves the branch inside the image; ok False when the first sample is not on the branch, the line leaves
    the image first or does not leave the branch within ``reach``. The same floating-point operations as the
    numpy steps, so the same values."""
    h, w = mask.shape
    n = int(np.ceil(reach / step))
    for i in range(max(n, 0)):
        t = 0.0 + i * step
        x, y = np.rint(sx + t * ox), np.rint(sy + t * oy)
        inside = 0 <= x < w and 0 <= y < h
        if inside and mask[int(y), int(x)] >= 128:
            continue
        if i == 0 or not inside:
            return False, 0.0, 0.0
        c = (0.0 + (i - 1) * step) + 0.5 * step
        return True, sx + c * ox, sy + c * oy
    return False, 0.0, 0.0


def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    labels, mask = np.zeros((2, 4), np.int32), np.zeros((8, 16), np.uint8)
    labels[0, 1] = 1
    mask[:4, 4:8] = 255
    for taken in (np.zeros((0, 2)), np.full((1, 2), 5.0)):
        stub_seeds(labels, 2, mask, 4, taken, 13)
        stub_pixels(labels, 2, mask, 4, taken, 13, 10, 900)
    walk_end(mask, 5.0, 2.0, 1.0, 0.0, 8.0, 0.25)
