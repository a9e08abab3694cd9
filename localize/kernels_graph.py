"""Compiled kernels of the pixel grid and the skeleton's graph: rectify's tiles, the skeleton's thinning, the
graph's pixel work, prune, recover and the result's medians (docs/localize-numba.md).

Whole functions of the stages around the match stage (rectify, skeleton, prune, recover, the result's
assembly) and the lazy grey reads, each giving the values of the numpy / OpenCV code it replaces bit for
bit (the references are in tests/localize/test_kernels_graph.py):

- rectify: :func:`needed_tiles` (the sparse remap's tiles, one scan of the mask by 8-pixel words),
  :func:`source_box` (a lazy read's source box), :func:`project_distorted` (``cv2.projectPoints``' model,
  for :meth:`Rectifier.to_original`);
- skeleton: :func:`coarse_mask` (the fast skeleton's 4x smaller mask straight from the rectified
  coverage), :func:`thin` (Zhang-Suen and the corner removal), :func:`corners` (the corner removal alone),
  both on :func:`zhang_suen_flat` and :func:`remove_corners_flat` (the thinning passes over the listed
  pixels of a flat padded image);
- graph and prune: :func:`graph_arrays` (:func:`graph.build_graph`'s arrays around
  :func:`graph_core`: the junction and segment labels by union-find, :func:`_components`),
  :func:`spur_mask` (:func:`prune.spur_ids`' test);
- recover: :func:`end_fit` (the ends' principal axes), :func:`bridge_pairs` (the candidate pairs of
  ends), :func:`line_pixels` (the bridges' pixels);
- the result: :func:`group_medians` (each piece's median depth).

Word scans (:func:`needed_tiles`, :func:`graph_arrays`, :func:`thin`, :func:`corners`) read a uint8 image
by ``np.uint64`` words and skip the zero ones: callers pass the image with its rows padded to a multiple
of 8 px and its word view.
"""

from __future__ import annotations

import numba
import numpy as np

from appliance.localize.kernels import _JIT
from appliance.localize.kernels_stats import _sorted


@numba.njit(**_JIT)
def needed_tiles(words, cell_box, tile_box, out):
    """The output tiles of a sparse remap whose source cells hold a non-zero pixel, as runs along a tile row.

    Parameters
    ----------
    words : ndarray (H, W / 8) uint64
        The source image (uint8, width a multiple of 8) read as 8-pixel words: a cell is 8 x 8 px.
    cell_box : ndarray (T, 4) int64
        Each tile's source cells ``cy0, cy1, cx0, cx1`` (end exclusive; an empty range: nothing read).
    tile_box : ndarray (T, 4) int64
        Each tile ``y0, y1, x0, x1`` in the output (row-major tile order).
    out : ndarray (T, 4) int64
        Receives the runs ``y0, y1, x0, x1``: neighbouring needed tiles of one tile row joined.

    Returns
    -------
    int
        The number of runs written to ``out``.
    """
    h, wb = words.shape
    cells = np.zeros((-(-h // 8), wb), np.uint8)
    acc = np.zeros(wb, np.uint64)
    for y0 in range(0, h, 8):
        acc[:] = 0
        for y in range(y0, min(y0 + 8, h)):
            for c in range(wb):
                acc[c] |= words[y, c]
        for c in range(wb):
            cells[y0 // 8, c] = acc[c] != 0
    n = 0
    for t in range(len(tile_box)):
        cy0, cy1, cx0, cx1 = cell_box[t, 0], cell_box[t, 1], cell_box[t, 2], cell_box[t, 3]
        hit = False
        for cy in range(cy0, cy1):
            for cx in range(cx0, cx1):
                if cells[cy, cx]:
                    hit = True
                    break
            if hit:
                break
        if not hit:
            continue
        if n > 0 and out[n - 1, 0] == tile_box[t, 0] and out[n - 1, 3] == tile_box[t, 2]:
            out[n - 1, 3] = tile_box[t, 3]                  # (continues the run)
        else:
            out[n, 0], out[n, 1], out[n, 2], out[n, 3] = tile_box[t, 0], tile_box[t, 1], tile_box[t, 2], tile_box[t, 3]
            n += 1
    return n


@numba.njit(**_JIT)
def _by_label(lab, on, n):
    """Indices ``k`` (in order) of the ``on`` entries of ``lab`` (labels 1..n), grouped by label (a stable
    counting sort), and where each label's start (n + 1,): label ``g + 1`` at ``order[start[g]:start[g + 1]]``."""
    start = np.zeros(n + 1, np.int64)
    for k in range(len(lab)):
        if on[k]:
            start[lab[k]] += 1                  # (the count of label L at L, then summed up)
    for g in range(n):
        start[g + 1] += start[g]
    order = np.empty(start[n], np.int64)
    fill = start[:n].copy()
    for k in range(len(lab)):
        if on[k]:
            order[fill[lab[k] - 1]] = k
            fill[lab[k] - 1] += 1
    return order, start


@numba.njit(**_JIT)
def graph_arrays(image, words, w, count, scale):
    """:func:`graph.build_graph` of a skeleton image in one call: the arrays of its
    :class:`~appliance.localize.graph.SkeletonGraph` (the pixel work :func:`graph_core`'s).

    Parameters
    ----------
    image : ndarray (H, W8) uint8
        The skeleton, non-zero = set, its rows zero-padded to a multiple of 8 px.
    words : ndarray (H, W8 / 8) uint64
        ``image`` read as 8-pixel words (the scan skips zero words).
    w : int
        The skeleton's width W, px.
    count : ndarray (256,) uint8
        Set neighbours per neighbour code (:func:`skeleton.neighbour_tables`).
    scale : int
        Full-resolution px per skeleton px.

    Returns
    -------
    node_px : ndarray (P, 2) int64
        Node pixels (row, col): junctions by label (row-major within one), then the endpoints
        (row-major); node ``k``'s are ``node_px[node_start[k]:node_start[k + 1]]``.
    node_start : ndarray (K + 1,) int64
    node_yx : ndarray (K, 2) float64
        Node centroids (sums in row-major order, as ``np.bincount``'s, over the count).
    n_junctions : int
    seg_px : ndarray (Q, 2) int64
        Segment pixels (row, col) grouped by segment (row-major within one); segment ``s``'s are
        ``seg_px[seg_start[s]:seg_start[s + 1]]`` (the node-node segments after them have none).
    seg_start : ndarray (S + N + 1,) int64
    seg_nodes : ndarray (S + N, 2) int64
        Node at each end (-1: none); the N node-node contacts last.
    length_px : ndarray (S + N,) float64
        Full-resolution length: E/S steps 1, diagonal steps sqrt(2), added in E, SE, S, SW order,
        plus one step onto each end node; node-node contacts 1; times ``scale``.
    """
    h = image.shape[0]
    w2 = w + 2
    flat = np.zeros((h + 2) * w2, np.uint8)
    idx = _scan(image, words, w2, flat)
    m = len(idx)
    n, jlab, n_j, slab, n_s, sn, nn, steps = graph_core(flat, idx, w2, w, count)
    jorder, jstart = _by_label(jlab, n >= 3, n_j)
    n_e = 0
    for i in range(m):
        n_e += n[i] == 1
    k_nodes = n_j + n_e
    node_px = np.empty((len(jorder) + n_e, 2), np.int64)
    node_start = np.empty(k_nodes + 1, np.int64)
    node_yx = np.zeros((k_nodes, 2))
    node_start[:n_j + 1] = jstart
    c = len(jorder)
    for t in range(c):
        i = jorder[t]
        node_px[t, 0], node_px[t, 1] = idx[i] // w2 - 1, idx[i] % w2 - 1
    e = n_j
    for i in range(m):
        if n[i] == 1:
            node_px[c, 0], node_px[c, 1] = idx[i] // w2 - 1, idx[i] % w2 - 1
            c += 1
            e += 1
            node_start[e] = c
    for i in range(m):                                      # (centroid sums in row-major order)
        if n[i] >= 3:
            node_yx[jlab[i] - 1, 0] += np.float64(idx[i] // w2 - 1)
            node_yx[jlab[i] - 1, 1] += np.float64(idx[i] % w2 - 1)
    for g in range(n_j):
        size = np.float64(jstart[g + 1] - jstart[g])
        node_yx[g, 0] /= size
        node_yx[g, 1] /= size
    for g in range(n_j, k_nodes):
        node_yx[g, 0], node_yx[g, 1] = node_px[node_start[g], 0], node_px[node_start[g], 1]
    sorder, sstart = _by_label(slab, n == 2, n_s)
    seg_px = np.empty((len(sorder), 2), np.int64)
    for t in range(len(sorder)):
        i = sorder[t]
        seg_px[t, 0], seg_px[t, 1] = idx[i] // w2 - 1, idx[i] % w2 - 1
    n_n = len(nn)
    seg_start = np.empty(n_s + n_n + 1, np.int64)
    seg_start[:n_s + 1] = sstart
    seg_start[n_s + 1:] = sstart[n_s]
    seg_nodes = np.full((n_s + n_n, 2), -1, np.int64)
    filled = np.zeros(n_s, np.int64)
    for t in range(len(sn)):                                # (sorted by segment, then node)
        g = sn[t, 0] - 1
        if filled[g] < 2:
            seg_nodes[g, filled[g]] = sn[t, 1] - 1
            filled[g] += 1
    length = np.empty(n_s + n_n)
    root2 = np.sqrt(2.0)
    for g in range(n_s):
        v = 0.0
        v += 1.0 * steps[0, g + 1]
        v += root2 * steps[1, g + 1]
        v += 1.0 * steps[2, g + 1]
        v += root2 * steps[3, g + 1]
        length[g] = (v + filled[g]) * scale
    for t in range(n_n):
        seg_nodes[n_s + t, 0], seg_nodes[n_s + t, 1] = nn[t, 0] - 1, nn[t, 1] - 1
        length[n_s + t] = 1.0 * scale
    return node_px, node_start, node_yx, n_j, seg_px, seg_start, seg_nodes, length


@numba.njit(**_JIT)
def end_fit(seg_nodes, is_endpoint, node_yx, seg_px, seg_start, scale, reach_px):
    """:func:`recover.end_geometry`'s fit: each skeleton end's position and the principal axis of its
    segment's pixels within ``reach_px`` of it (numpy's sums, in the same order: bit for bit).

    Parameters
    ----------
    seg_nodes : ndarray (S, 2) int64
        Node at each end of each segment (-1: none).
    is_endpoint : ndarray (K,) bool
        Nodes that are endpoints.
    node_yx : ndarray (K, 2) float64
        Node positions (skeleton row, col).
    seg_px : ndarray (P, 2) int64
        All segments' pixels (row, col), segment after segment.
    seg_start : ndarray (S + 1,) int64
        Segment ``s``'s pixels are ``seg_px[seg_start[s]:seg_start[s + 1]]``.
    scale : float
        Full-resolution px per skeleton px.
    reach_px : float
        Full-resolution reach of the fit.

    Returns
    -------
    node, segment : ndarray (E,) int64
        The ends (segment by segment, its first end then its second).
    xy : ndarray (E, 2) float64
        Full-resolution positions (x, y).
    axis : ndarray (E, 2) float64
        Unit principal axis, pointing from the fitted pixels' centroid to the end.
    count : ndarray (E,) int64
        Pixels fitted (the fit counts with 2 or more).
    """
    n_seg = len(seg_nodes)
    n_end = 0
    for s in range(n_seg):
        for k in range(2):
            n_end += seg_nodes[s, k] >= 0 and is_endpoint[seg_nodes[s, k]]
    node = np.empty(n_end, np.int64)
    segment = np.empty(n_end, np.int64)
    xy = np.empty((n_end, 2))
    axis = np.zeros((n_end, 2))
    count = np.zeros(n_end, np.int64)
    e = 0
    for s in range(n_seg):
        for k in range(2):
            v = seg_nodes[s, k]
            if v < 0 or not is_endpoint[v]:
                continue
            node[e], segment[e] = v, s
            px = (node_yx[v, 1] + 0.5) * scale - 0.5
            py = (node_yx[v, 0] + 0.5) * scale - 0.5
            xy[e, 0], xy[e, 1] = px, py
            sx = sy = 0.0
            c = 0
            for i in range(seg_start[s], seg_start[s + 1]):
                x = (seg_px[i, 1] + 0.5) * scale - 0.5
                y = (seg_px[i, 0] + 0.5) * scale - 0.5
                if np.hypot(x - px, y - py) <= reach_px:
                    sx += x
                    sy += y
                    c += 1
            count[e] = c
            cx, cy = sx / max(c, 1), sy / max(c, 1)
            sxx = sxy = syy = 0.0
            for i in range(seg_start[s], seg_start[s + 1]):
                x = (seg_px[i, 1] + 0.5) * scale - 0.5
                y = (seg_px[i, 0] + 0.5) * scale - 0.5
                if np.hypot(x - px, y - py) <= reach_px:
                    dx, dy = x - cx, y - cy
                    sxx += dx * dx
                    sxy += dx * dy
                    syy += dy * dy
            big = (sxx + syy) / 2 + np.hypot((sxx - syy) / 2, sxy)      # the larger eigenvalue
            if sxx >= syy:
                ax, ay = big - syy, sxy
            else:
                ax, ay = sxy, big - sxx
            norm = max(np.hypot(ax, ay), 1e-300)
            ax, ay = ax / norm, ay / norm
            if ax * (px - cx) + ay * (py - cy) < 0:
                ax, ay = -ax, -ay
            axis[e, 0], axis[e, 1] = ax, ay
            e += 1
    return node, segment, xy, axis, count


@numba.njit(**_JIT)
def line_pixels(a_xy, b_xy, scale):
    """:func:`recover._bridge`'s skeleton pixels of straight lines: each line's ``np.linspace(0, 1, n)``
    points (``n`` = its longer skeleton extent, rounded up, + 1), rounded to pixels, distinct and sorted
    by (row, col), as ``np.unique(..., axis=0)`` gives them.

    Parameters
    ----------
    a_xy, b_xy : ndarray (L, 2) float64
        The lines' ends, full-resolution (x, y).
    scale : float
        Full-resolution px per skeleton px.

    Returns
    -------
    px : ndarray (N, 2) int64
        The pixels (row, col), line after line.
    start : ndarray (L + 1,) int64
        Line ``l``'s pixels are ``px[start[l]:start[l + 1]]``.
    """
    n_lines = len(a_xy)
    ns = np.empty(n_lines, np.int64)
    for i in range(n_lines):
        ax, ay = (a_xy[i, 0] + 0.5) / scale - 0.5, (a_xy[i, 1] + 0.5) / scale - 0.5
        bx, by = (b_xy[i, 0] + 0.5) / scale - 0.5, (b_xy[i, 1] + 0.5) / scale - 0.5
        ns[i] = np.int64(np.ceil(max(abs(bx - ax), abs(by - ay)))) + 1
    key = np.empty(ns.sum(), np.int64)
    start = np.zeros(n_lines + 1, np.int64)
    c = 0
    for i in range(n_lines):
        ax, ay = (a_xy[i, 0] + 0.5) / scale - 0.5, (a_xy[i, 1] + 0.5) / scale - 0.5
        bx, by = (b_xy[i, 0] + 0.5) / scale - 0.5, (b_xy[i, 1] + 0.5) / scale - 0.5
        n = ns[i]
        step = 1.0 / (n - 1) if n > 1 else 0.0
        c0 = c
        for k in range(n):
            t = 1.0 if k == n - 1 and n > 1 else k * step      # (np.linspace's: k * step, the last exactly 1)
            row = np.int64(np.rint(ay + t * (by - ay)))
            col = np.int64(np.rint(ax + t * (bx - ax)))
            v = (row << 32) + (col + (1 << 31))                   # (row, col) order
            j = c                                                 # (insertion sort: a few dozen points)
            while j > c0 and key[j - 1] > v:
                key[j] = key[j - 1]
                j -= 1
            if j > c0 and key[j - 1] == v:                        # (already there: undo the shift)
                for q in range(j, c):
                    key[q] = key[q + 1]
                continue
            key[j] = v
            c += 1
        start[i + 1] = c
    px = np.empty((c, 2), np.int64)
    for q in range(c):
        px[q, 0] = key[q] >> 32
        px[q, 1] = (key[q] & 0xFFFFFFFF) - (1 << 31)
    return px, start


_TOP_BITS = np.uint64(0x0101010101010101)      # bit 0 of each byte (after a shift by 7: each byte's top bit)
_LOW_HALF = np.uint64(0xFFFFFFFF)
_SUM_4 = np.uint64(0x01010101)                  # x * this: byte 3 is the sum of x's bytes 0-3


@numba.njit(**_JIT)
def coarse_mask(words, out):
    """The fast skeleton's 4x smaller mask of a coverage image: 255 where at least 5 of a 4 x 4 block's
    pixels are >= 128, else 0 (the same as the threshold at 128, the block mean by two halvings and the
    threshold at 77 of :func:`skeleton.skeletonize`: checked on all 2^16 blocks).

    Parameters
    ----------
    words : ndarray (H, W / 8) uint64
        The coverage image (uint8, H a multiple of 4, W of 8) read as 8-pixel words, little-endian (the
        first pixel in the lowest byte).
    out : ndarray (H / 4, W / 4) uint8
        Receives the mask.
    """
    h, nw = words.shape
    seven, half, three = np.uint64(7), np.uint64(32), np.uint64(24)
    byte = np.uint64(0xFF)
    for by in range(h // 4):
        for c in range(nw):
            s = np.uint64(0)
            for y in range(4 * by, 4 * by + 4):
                s += (words[y, c] >> seven) & _TOP_BITS       # (per byte: 0 or 1; summed, at most 4)
            lo = (((s & _LOW_HALF) * _SUM_4) >> three) & byte
            hi = (((s >> half) * _SUM_4) >> three) & byte
            out[by, 2 * c] = 255 if lo >= 5 else 0
            out[by, 2 * c + 1] = 255 if hi >= 5 else 0
    return out


@numba.njit(**_JIT)
def group_medians(values, start):
    """``np.median`` of each group of ``values`` (the same value, bit for bit: the middle value, or the
    mean ``(a + b) / 2`` of the two middle ones; NaN for an empty group; the values have no NaN).

    Parameters
    ----------
    values : ndarray (N,) float64
        The groups' values, group after group.
    start : ndarray (G + 1,) int64
        Group ``g`` is ``values[start[g]:start[g + 1]]``.

    Returns
    -------
    ndarray (G,) float64
    """
    out = np.empty(len(start) - 1)
    for g in range(len(out)):
        n = start[g + 1] - start[g]
        if n == 0:
            out[g] = np.nan
            continue
        p = _sorted(values[start[g]:start[g + 1]])
        k = n // 2
        out[g] = p[k] if n % 2 else (p[k - 1] + p[k]) / 2
    return out


@numba.njit(**_JIT)
def _scan(image, words, w2, flat):
    """The set pixels of ``image`` (H, W8) uint8 (``words``: its 8-pixel words, zero words skipped) as
    row-major flat indices into a zero-padded image of row length ``w2``; sets them to 1 in ``flat``."""
    h, nw = words.shape
    m = 0
    for y in range(h):
        for c in range(nw):
            if words[y, c] != 0:
                m += 8
    idx = np.empty(m, np.int64)
    m = 0
    for y in range(h):
        row = image[y]
        for c in range(nw):
            if words[y, c] != 0:
                for b in range(8):
                    if row[8 * c + b] != 0:
                        idx[m] = (y + 1) * w2 + 8 * c + b + 1
                        flat[idx[m]] = 1
                        m += 1
    return idx[:m]


@numba.njit(**_JIT)
def corners(image, words, corner, out):
    """:func:`skeleton.remove_corners` of a binary image in one call (:func:`remove_corners_flat` on
    the zero-padded flat image built here). ``image`` (H, W8) uint8, non-zero = set, rows padded to a
    multiple of 8 px; ``words`` its 8-pixel words; ``corner`` (256,) bool; ``out`` (H, W) uint8 receives
    the result, 0/1."""
    h, w = out.shape
    w2 = w + 2
    flat = np.zeros((h + 2) * w2, np.uint8)
    idx = _scan(image, words, w2, flat)
    remove_corners_flat(flat, idx, w2, corner)
    out[:] = 0
    for i in range(len(idx)):
        p = idx[i]
        if flat[p] != 0:
            out[p // w2 - 1, p % w2 - 1] = 1
    return out


@numba.njit(**_JIT)
def thin(image, words, off, tab0, tab1, corner, out):
    """:func:`skeleton.zhang_suen` then :func:`skeleton.remove_corners` of a binary image in one call: the
    zero-padded flat image, the pixels that may go (set, not on the image's border) and the outline to
    start from (set pixels with a zero 8-neighbour inside the image, as ``m - cv2.erode(m, 3 x 3)``)
    built here, then :func:`zhang_suen_flat` and :func:`remove_corners_flat` on it.

    Parameters
    ----------
    image : ndarray (H, W8) uint8
        The mask, non-zero = set, its rows padded with zeros to a multiple of 8 px.
    words : ndarray (H, W8 / 8) uint64
        ``image`` read as 8-pixel words (the scan skips zero words).
    off : ndarray (8,) int64
        Flat steps to the 8 neighbours (N, NE, E, SE, S, SW, W, NW) at row length W + 2.
    tab0, tab1 : ndarray (256,) bool
        :func:`skeleton.zhang_suen_tables`.
    corner : ndarray (256,) bool
        :func:`skeleton.neighbour_tables`' corner table.
    out : ndarray (H, W) uint8
        Receives the skeleton, 0/1.
    """
    h, w = out.shape
    w2 = w + 2
    flat = np.zeros((h + 2) * w2, np.uint8)
    idx = _scan(image, words, w2, flat)
    m = len(idx)
    live = flat.copy()
    for x in range(w):                                  # (pixels on the image's border stay)
        live[w2 + x + 1] = 0
        live[h * w2 + x + 1] = 0
    for y in range(h):
        live[(y + 1) * w2 + 1] = 0
        live[(y + 1) * w2 + w] = 0
    start = np.empty(m, np.int64)
    n = 0
    for i in range(m):
        p = idx[i]
        if live[p] == 0:
            continue
        for k in range(8):
            if flat[p + off[k]] == 0:                   # (a zero neighbour, inside the image)
                start[n] = p
                n += 1
                break
    zhang_suen_flat(flat, live, start[:n], off, tab0, tab1)
    n = 0
    for i in range(m):                                  # (thinning only deletes: the rest, row-major)
        if flat[idx[i]] != 0:
            idx[n] = idx[i]
            n += 1
    idx = idx[:n]
    remove_corners_flat(flat, idx, w2, corner)
    out[:] = 0
    for i in range(n):
        p = idx[i]
        if flat[p] != 0:
            out[p // w2 - 1, p % w2 - 1] = 1
    return out


@numba.njit(**_JIT)
def spur_mask(seg_nodes, node_kind, node_yx, seg_length_px, h, w, min_length_px, radius_factor, radius, r_scale,
              scale, keep_border):
    """:func:`prune.spur_ids`' test of every segment (see there), bit for bit.

    Parameters
    ----------
    seg_nodes : ndarray (S, 2) int64
    node_kind : ndarray (K,) int64
        ENDPOINT 1, JUNCTION 3 (others: neither).
    node_yx : ndarray (K, 2) float64
    seg_length_px : ndarray (S,) float64
    h, w : int
        The skeleton's shape.
    min_length_px, radius_factor : float
    radius : ndarray (Hr, Wr) float32
        The radius map (full-resolution px; not read when ``radius_factor`` is 0).
    r_scale : int
        Full-resolution px per radius map px.
    scale : int
        Full-resolution px per skeleton px.
    keep_border : bool

    Returns
    -------
    ndarray (S,) bool
        The spurs to remove.
    """
    n_seg = len(seg_nodes)
    spur = np.zeros(n_seg, np.bool_)
    junction = np.full(n_seg, -1, np.int64)
    end = np.full(n_seg, -1, np.int64)
    for s in range(n_seg):
        e0, e1 = seg_nodes[s, 0], seg_nodes[s, 1]
        k0 = node_kind[e0] if e0 >= 0 else 0
        k1 = node_kind[e1] if e1 >= 0 else 0
        if k0 == 1 and k1 == 3:
            spur[s], end[s], junction[s] = True, e0, e1
        elif k1 == 1 and k0 == 3:
            spur[s], end[s], junction[s] = True, e1, e0
    if keep_border:
        out = np.zeros(n_seg, np.bool_)
        n_out = np.zeros(len(node_kind), np.int64)
        for s in range(n_seg):
            if spur[s]:
                y, x = node_yx[end[s], 0], node_yx[end[s], 1]
                out[s] = min(y, x) <= 1 or y >= h - 2 or x >= w - 2
                if out[s]:
                    n_out[junction[s]] += 1
        for s in range(n_seg):
            if out[s] and n_out[junction[s]] == 1:
                spur[s] = False
    rh, rw = radius.shape
    for s in range(n_seg):
        if not spur[s]:
            continue
        limit = np.float64(min_length_px)
        if radius_factor > 0:
            j = junction[s]
            fx = (node_yx[j, 1] + 0.5) * scale - 0.5              # (graph.to_full, then radius_at)
            fy = (node_yx[j, 0] + 0.5) * scale - 0.5
            x = min(max(np.int64(np.rint((fx + 0.5) / r_scale - 0.5)), 0), rw - 1)
            y = min(max(np.int64(np.rint((fy + 0.5) / r_scale - 0.5)), 0), rh - 1)
            limit = max(limit, radius_factor * np.float64(radius[y, x]))
        spur[s] = seg_length_px[s] < limit
    return spur


@numba.njit(**_JIT)
def source_box(lo, hi, i0, i1, j0, j1):
    """The union of the source boxes of the tiles ``[i0:i1, j0:j1]`` of :meth:`Rectifier.source_grid`'s
    grids ``lo``, ``hi`` (rows, cols, 2) int64: ``(sy0, sy1, sx0, sx1)`` (empty: nothing seen)."""
    sy0, sx0 = lo[i0, j0, 0], lo[i0, j0, 1]
    sy1, sx1 = hi[i0, j0, 0], hi[i0, j0, 1]
    for i in range(i0, i1):
        for j in range(j0, j1):
            sy0, sx0 = min(sy0, lo[i, j, 0]), min(sx0, lo[i, j, 1])
            sy1, sx1 = max(sy1, hi[i, j, 0]), max(sx1, hi[i, j, 1])
    return sy0, sy1, sx0, sx1


@numba.njit(**_JIT)
def read_box(map1, y0, y1, x0, x1, h, w):
    """The source pixels a linear remap of the output rows ``y0:y1``, columns ``x0:x1`` reads through the
    fixed-point table ``map1`` (H, W, 2) int16 (``cv2.initUndistortRectifyMap``'s CV_16SC2: each output
    pixel's source column and row, rounded down; it reads those and the next ones): ``(sy0, sy1, sx0,
    sx1)``, end exclusive, clipped to the source image of ``h`` rows and ``w`` columns (empty: nothing of
    the image is read). Thirteenth pass (speedfront2): the exact box, instead of :func:`source_box`'s union
    of whole tiles' boxes (3-5x the pixels on the fixtures' reads)."""
    ax0, ay0 = np.int64(1 << 20), np.int64(1 << 20)
    ax1, ay1 = np.int64(-(1 << 20)), np.int64(-(1 << 20))
    for y in range(y0, y1):
        row = map1[y]
        for x in range(x0, x1):
            sx, sy = np.int64(row[x, 0]), np.int64(row[x, 1])
            ax0, ax1 = min(ax0, sx), max(ax1, sx)
            ay0, ay1 = min(ay0, sy), max(ay1, sy)
    return max(ay0, 0), min(ay1 + 2, h), max(ax0, 0), min(ax1 + 2, w)


@numba.njit(**_JIT)
def project_distorted(rays, K, k, out):
    """``cv2.projectPoints(rays, 0, 0, K, D)`` (no rotation, no translation, no tilt), bit for bit: OpenCV's
    distortion model in OpenCV's order of operations (the reciprocal of Z times X and Y, then the radial,
    tangential and thin-prism terms).

    Parameters
    ----------
    rays : ndarray (N, 3) float64
        Points (X, Y, Z) in the camera's frame.
    K : ndarray (3, 3) float64
        Camera matrix (fx, fy, cx, cy read; no skew).
    k : ndarray (12,) float64
        k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4 (zeros for those the calibration does not have).
    out : ndarray (N, 2) float64
        Receives the pixels (u, v).
    """
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    for i in range(len(rays)):
        X, Y, Z = rays[i, 0], rays[i, 1], rays[i, 2]
        z = 1.0 / Z if Z != 0 else 1.0
        x, y = X * z, Y * z
        r2 = x * x + y * y
        r4 = r2 * r2
        r6 = r4 * r2
        a1 = 2 * x * y
        a2 = r2 + 2 * x * x
        a3 = r2 + 2 * y * y
        cdist = 1 + k[0] * r2 + k[1] * r4 + k[4] * r6
        icdist2 = 1.0 / (1 + k[5] * r2 + k[6] * r4 + k[7] * r6)
        xd = x * cdist * icdist2 + k[2] * a1 + k[3] * a2 + k[8] * r2 + k[9] * r4
        yd = y * cdist * icdist2 + k[2] * a3 + k[3] * a1 + k[10] * r2 + k[11] * r4
        out[i, 0] = xd * fx + cx
        out[i, 1] = yd * fy + cy
    return out


@numba.njit(**_JIT)
def bridge_pairs(xy, axis, radius, segment, cos_max, max_gap_px, max_ratio):
    """:func:`recover.recover_collinear`'s candidate pairs of ends ``i < j`` (row-major, as ``np.nonzero`` of
    the upper triangle): each end points at the other within ``cos_max``, the gap is at most
    ``max_gap_px``, the radii (at least 0.5 px) differ by at most ``max_ratio``, other segments; the same
    arithmetic as the former numpy matrices (bit for bit).

    Parameters
    ----------
    xy, axis : ndarray (E, 2) float64
        Ends' positions (full-resolution px) and outward unit directions.
    radius : ndarray (E,) float64
    segment : ndarray (E,) int64
    cos_max, max_gap_px, max_ratio : float

    Returns
    -------
    i, j : ndarray (C,) int64
    cos_i, cos_j : ndarray (C,) float64
        How well end i points at j, and j at i.
    dist : ndarray (C,) float64
        The gap, px.
    """
    n = len(xy)
    cap = n * (n - 1) // 2
    ii, jj = np.empty(cap, np.int64), np.empty(cap, np.int64)
    ci, cj, dd = np.empty(cap), np.empty(cap), np.empty(cap)
    c = 0
    for i in range(n):
        ri = max(radius[i], 0.5)
        for j in range(i + 1, n):
            gx, gy = xy[j, 0] - xy[i, 0], xy[j, 1] - xy[i, 1]
            dist = np.hypot(gx, gy)
            ux, uy = gx / max(dist, 1e-9), gy / max(dist, 1e-9)
            cos_i = axis[i, 0] * ux + axis[i, 1] * uy
            cos_j = -(axis[j, 0] * ux + axis[j, 1] * uy)
            rj = max(radius[j], 0.5)
            ratio = max(ri, rj) / min(ri, rj)
            if (cos_i >= cos_max and cos_j >= cos_max and dist <= max_gap_px and ratio <= max_ratio
                    and segment[i] != segment[j]):
                ii[c], jj[c], ci[c], cj[c], dd[c] = i, j, cos_i, cos_j, dist
                c += 1
    return ii[:c], jj[:c], ci[:c], cj[:c], dd[:c]


@numba.njit(**_JIT)
def _code(flat, p, off):
    """Neighbour code of the padded flat pixel ``p``: bit k = neighbour k (``off[k]`` away) set."""
    c = 0
    for k in range(8):
        if flat[np.uint64(p + off[k])] != 0:        # (unsigned: numba drops its negative-index test)
            c |= 1 << k
    return c


@numba.njit(**_JIT)
def zhang_suen_flat(flat, live, start, off, tab0, tab1):
    """Zhang-Suen thinning in place on a zero-padded flat 0/1 image (``skeleton.zhang_suen``'s loop).

    ``live`` (uint8, same size; modified): the pixels that may still go; ``start``: the first
    sub-iteration's candidates (flat indices); ``off`` (8,): flat steps to the neighbours; ``tab0`` /
    ``tab1`` (256,) bool: the sub-iterations' deletion tables. Each sub-iteration decides on the image
    as the previous one left it, then deletes; later candidates are the live pixels next to a deletion
    in the last two sub-iterations; stops after two sub-iterations without a deletion. Returns the
    number of sub-iterations.
    """
    n = flat.size
    near = (np.empty(n, np.int64), np.empty(n, np.int64))
    n_near = np.zeros(2, np.int64)
    for k in range(len(start)):
        near[0][k] = start[k]
        near[1][k] = start[k]
    n_near[0] = n_near[1] = len(start)
    seen = np.full(n, -1, np.int64)
    cand = np.empty(n, np.int64)
    gone = np.empty(n, np.int64)
    i, quiet = 0, 0
    while quiet < 2:
        nc = 0
        if i == 0:
            for k in range(len(start)):
                cand[nc] = start[k]
                nc += 1
        else:
            for par in range(2):
                lst = near[par]
                for k in range(n_near[par]):
                    p = lst[k]
                    if live[p] != 0 and seen[p] != i:
                        seen[p] = i
                        cand[nc] = p
                        nc += 1
        tab = tab0 if (i & 1) == 0 else tab1
        ng = 0
        for k in range(nc):
            p = cand[k]
            if tab[_code(flat, p, off)]:
                gone[ng] = p
                ng += 1
        for k in range(ng):
            flat[gone[k]] = 0
            live[gone[k]] = 0
        lst = near[i & 1]
        m = 0
        for k in range(ng):
            for j in range(8):
                q = gone[k] + off[j]
                if live[q] != 0 and seen[q] != -2 - i:      # (each neighbour once per list)
                    seen[q] = -2 - i
                    lst[m] = q
                    m += 1
        n_near[i & 1] = m
        quiet = 0 if ng else quiet + 1
        i += 1
    return i


@numba.njit(**_JIT)
def remove_corners_flat(flat, idx, w2, corner):
    """``skeleton.remove_corners``' two passes in place on a zero-padded flat 0/1 image of row length
    ``w2``: the set pixels ``idx`` (row-major flat indices) of parity 0, then of parity 1, each pass
    deciding on the image as the previous pass left it (all its pixels first, then the deletions)."""
    off = np.array([-w2, -w2 + 1, 1, w2 + 1, w2, w2 - 1, -1, -w2 - 1], np.int64)
    gone = np.empty(len(idx), np.int64)
    for par in range(2):
        ng = 0
        for k in range(len(idx)):
            p = idx[k]
            if ((p // w2 + p % w2) & 1) == par and corner[_code(flat, p, off)]:
                gone[ng] = p
                ng += 1
        for k in range(ng):
            flat[gone[k]] = 0


@numba.njit(**_JIT)
def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@numba.njit(**_JIT)
def _components(idx, pos, on, w2, w):
    """8-connected components of the pixels ``idx[on]`` (``idx``: row-major flat indices into a
    zero-padded image of row length ``w2``): labels 1..n per pixel (0 where not ``on``) numbered as
    ``cv2.connectedComponents`` numbers them, by the first 2 x 2 block of each (blocks row-major; the
    block-based scan's order, checked on random images), and n. ``pos``: each flat pixel's index into
    ``idx``, -1 where none."""
    m = len(idx)
    parent = np.arange(m)
    for i in range(m):
        if not on[i]:
            continue
        p = idx[i]
        for q in (p - 1, p - w2 - 1, p - w2, p - w2 + 1):        # (neighbours scanned before p)
            j = pos[q]
            if j >= 0 and on[j]:
                a, b = _find(parent, i), _find(parent, j)
                if a != b:
                    parent[max(a, b)] = min(a, b)
    wb = (w + 1) // 2
    first = np.full(m, np.iinfo(np.int64).max)
    n_roots = 0
    for i in range(m):
        if on[i]:
            r = _find(parent, i)
            y, x = idx[i] // w2 - 1, idx[i] % w2 - 1
            first[r] = min(first[r], (y // 2) * wb + x // 2)
            n_roots += parent[i] == i
    key = np.empty(n_roots, np.int64)                          # (first block, root) in one sortable key
    c = 0
    for i in range(m):
        if on[i] and parent[i] == i:
            key[c] = first[i] * m + i
            c += 1
    key = _sorted(key)                                         # (not np.argsort: its compile time)
    rank = np.zeros(m, np.int64)
    for k in range(n_roots):
        rank[key[k] % m] = k + 1
    lab = np.zeros(m, np.int64)
    for i in range(m):
        if on[i]:
            lab[i] = rank[_find(parent, i)]
    return lab, n_roots


@numba.njit(**_JIT)
def _unique_pairs(a, b, n):
    """Distinct pairs (a[k], b[k]) of the first ``n``, sorted, as (K, 2) int64."""
    key = np.empty(n, np.int64)
    for k in range(n):
        key[k] = (a[k] << 32) | b[k]
    key = _sorted(key)
    out = np.empty((n, 2), np.int64)
    c = 0
    for k in range(n):
        if k == 0 or key[k] != key[k - 1]:
            out[c, 0], out[c, 1] = key[k] >> 32, key[k] & 0xFFFFFFFF
            c += 1
    return out[:c]


@numba.njit(**_JIT)
def graph_core(flat, idx, w2, w, count):
    """``graph.build_graph``'s pixel work on a zero-padded flat 0/1 skeleton (row length ``w2``, image
    width ``w``; ``idx`` its set pixels, row-major): each pixel's neighbour count (``count`` table), the
    junction (>= 3) and path (2) pixels' 8-connected component labels (as ``cv2.connectedComponents``
    numbers them), the segment-node contacts (segment, node) and node-node contacts (node, node),
    1-based, distinct and sorted, and per segment the steps to its E, SE, S, SW neighbours (4, S + 1).
    Node ids: junctions 1..J by label, then the endpoints (1 neighbour) in row-major order."""
    m = len(idx)
    off = np.array([-w2, -w2 + 1, 1, w2 + 1, w2, w2 - 1, -1, -w2 - 1], np.int64)
    pos = np.full(len(flat), -1, np.int32)
    for i in range(m):
        pos[idx[i]] = i
    n = np.empty(m, np.int64)
    for i in range(m):
        c = 0
        for k in range(8):
            if flat[idx[i] + off[k]] != 0:
                c |= 1 << k
        n[i] = count[c]
    jlab, n_j = _components(idx, pos, n >= 3, w2, w)
    slab, n_s = _components(idx, pos, n == 2, w2, w)
    node = jlab.copy()
    e = n_j
    for i in range(m):
        if n[i] == 1:
            e += 1
            node[i] = e
    ps, pn, c = np.empty(8 * m, np.int64), np.empty(8 * m, np.int64), 0
    steps = np.zeros((4, n_s + 1), np.int64)
    for i in range(m):
        if n[i] != 2:
            continue
        for k in range(8):
            j = pos[idx[i] + off[k]]
            if j >= 0:
                if node[j] > 0:
                    ps[c], pn[c] = slab[i], node[j]
                    c += 1
                if 2 <= k <= 5 and slab[j] == slab[i]:
                    steps[k - 2, slab[i]] += 1
    sn = _unique_pairs(ps, pn, c)
    a, b, c = np.empty(8 * m, np.int64), np.empty(8 * m, np.int64), 0
    for i in range(m):
        if node[i] == 0:
            continue
        for k in range(8):
            j = pos[idx[i] + off[k]]
            if j >= 0 and node[j] > 0 and node[j] != node[i]:
                a[c], b[c] = min(node[i], node[j]), max(node[i], node[j])
                c += 1
    return n, jlab, n_j, slab, n_s, sn, _unique_pairs(a, b, c), steps



def warm_up() -> None:
    """Compile (or load from the cache) this module's kernels for the argument types callers pass."""
    box = np.zeros((2, 4), np.int64)
    needed_tiles(np.zeros((8, 1), np.uint64), box, np.zeros((2, 5), np.int64)[:, :4], box.copy())  # (a slice of the tiles)
    i2 = np.zeros((1, 2), np.int64)
    end_fit(i2, np.zeros(1, bool), np.zeros((1, 2)), i2, np.zeros(2, np.int64), 4.0, 20.0)
    line_pixels(np.zeros((1, 2)), np.ones((1, 2)), 4.0)
    project_distorted(np.ones((1, 3)), np.eye(3), np.zeros(12), np.zeros((1, 2)))
    bridge_pairs(np.zeros((2, 2)), np.zeros((2, 2)), np.ones(2), np.arange(2), 0.9, 60.0, 2.0)
    grid = np.zeros((1, 1, 2), np.int64)
    source_box(grid, grid, 0, 1, 0, 1)
    read_box(np.zeros((1, 1, 2), np.int16), 0, 1, 0, 1, 1, 1)
    coarse_mask(np.zeros((4, 1), np.uint64), np.zeros((1, 2), np.uint8))
    group_medians(np.zeros(3), np.array([0, 1, 3], np.int64))
    spur_mask(np.zeros((1, 2), np.int64), np.ones(1, np.int64), np.zeros((1, 2)), np.zeros(1), 2, 2, 5.0, 1.5,
              np.zeros((2, 2), np.float32), 4, 4, True)
    tab = np.zeros(256, bool)
    corners(np.zeros((3, 8), np.uint8), np.zeros((3, 1), np.uint64), tab, np.zeros((3, 8), np.uint8))
    thin(np.zeros((3, 8), np.uint8), np.zeros((3, 1), np.uint64), np.array([-10, -9, 1, 11, 10, 9, -1, -11], np.int64),
         tab, tab, tab, np.zeros((3, 8), np.uint8))
    graph_arrays(np.zeros((2, 8), np.uint8), np.zeros((2, 1), np.uint64), 8, np.zeros(256, np.uint8), 4)
    img, tab, i = np.zeros(16, np.uint8), np.zeros(256, bool), np.arange(4, dtype=np.int64)
    off = np.array([-4, -3, 1, 5, 4, 3, -1, -5], np.int64)
    zhang_suen_flat(img, img.copy(), i[:0], off, tab, tab)
    remove_corners_flat(img, i[:0], 4, tab)
    graph_core(np.zeros(16, np.uint8), i[:0], 4, 2, np.zeros(256, np.uint8))
