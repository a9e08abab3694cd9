"""Branch pixels: the embedded colour recogniser, and checks of external masks.

An external segmenter is any callable ``(bgr image) -> bool mask`` of the same size;
its masks are passed to :meth:`Localizer.localize` as ``mask_left``/``mask_right``.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache
from types import SimpleNamespace

import cv2
import numpy as np
from appliance.config.schema import SegmentConfig
from appliance.localize import kernels_front, kernels_segclean, kernels_segment
from appliance.localize.errors import LocalizeError
from appliance.localize.skeleton import binary, block_mean

Segmenter = Callable[[np.ndarray], np.ndarray]
_K3 = np.ones((3, 3), np.uint8)
_ONE_TILE = np.ones((1, 1), np.uint8)   # bark_lookup_rows' tiles: the whole image
FULL_SHARE = 0.6               # bark_mask: above this share of tiles to test, the whole image (rows whole)
_MIN_SIN2 = 0.05 ** 2          # unmix_edges: background and bark chromaticities at least ~3 deg apart


def _kernel(size_px: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size_px, size_px))


def _mirrored(cfg: SegmentConfig) -> bool:
    """Whether the bark test reads the image as RGB (hues mirrored, h -> 120 - h mod 180): the hue
    range wraps through red and holds 120 (every range of :func:`_boxes` then maps to one interval)."""
    return cfg.hue_min > cfg.hue_max and cfg.hue_min >= 120 >= cfg.hue_max


def _boxes(cfg: SegmentConfig, mirrored: bool) -> list[tuple[tuple[int, int, int], tuple[int, int, int]]]:
    """``cv2.inRange`` bounds (lo, hi) of bark's colour boxes, in the HSV reading given by ``mirrored``
    (:func:`_mirrored`); a colour in any box is bark:

    - brown: hue in [hue_min, hue_max] (wrapping past 180 when hue_min > hue_max), saturation <= saturation_max,
      value in [value_min, value_max];
    - olive: hue from hue_min on to ``olive_hue_max`` (past hue_max: greener), saturation <= olive_saturation_max
      (0: no olive box), value in [value_min, min(value_max, pale_value_max)] (pale green-grey brighter than
      that is hazy foliage).

    The grey test is not a box of HSV: see :func:`_grey`.
    """
    v0 = cfg.value_min
    out = []

    def hue_box(h0: int, h1: int, s_max: int, v1: int) -> None:
        if mirrored:
            out.append(((120 - h1, 0, v0), (300 - h0, s_max, v1)))
        elif h0 <= h1:
            out.append(((h0, 0, v0), (h1, s_max, v1)))
        else:
            out.extend((((h0, 0, v0), (180, s_max, v1)), ((0, 0, v0), (h1, s_max, v1))))

    hue_box(cfg.hue_min, cfg.hue_max, cfg.saturation_max, cfg.value_max)
    if cfg.olive_saturation_max > 0 and cfg.olive_hue_max > cfg.hue_max:
        hue_box(cfg.hue_min, cfg.olive_hue_max, cfg.olive_saturation_max, min(cfg.value_max, cfg.pale_value_max))
    return out


def _grey(bgr: np.ndarray, cfg: SegmentConfig) -> np.ndarray | None:
    """Grey bark, uint8 0/255 (H, W): chroma (max - min of B, G, R) at most ``grey_chroma_max`` and value
    in [value_min, min(value_max, pale_value_max)], any hue (None with ``grey_chroma_max`` 0). A near-grey's
    hue is noise, and so is a dark one's saturation (chroma / value): sensor noise of a few levels in dark
    grey bark (value ~30) gives saturations up to ~80, its chroma stays small. Pale grey-green brighter than
    ``pale_value_max`` is hazy foliage (tree.avi), not bark."""
    if cfg.grey_chroma_max <= 0:
        return None
    c0, c1, c2 = cv2.split(bgr)
    v = cv2.max(cv2.max(c0, c1), c2)                                        # HSV's value
    chroma = cv2.subtract(v, cv2.min(cv2.min(c0, c1), c2))
    return cv2.bitwise_and(cv2.inRange(chroma, 0, cfg.grey_chroma_max),
                           cv2.inRange(v, cfg.value_min, min(cfg.value_max, cfg.pale_value_max)))


def _in_boxes(hsv: np.ndarray, boxes: list, dst: np.ndarray | None = None,
              extra: np.ndarray | None = None) -> np.ndarray:
    """Union of ``cv2.inRange`` over ``boxes`` (:func:`_boxes`) and the mask ``extra``, uint8 0/255 (H, W),
    into ``dst`` when given."""
    m = cv2.inRange(hsv, *boxes[0], dst=dst)        # three channels at once: no split, ~2x faster
    for lo, hi in boxes[1:]:
        cv2.bitwise_or(m, cv2.inRange(hsv, lo, hi), dst=m)
    if extra is not None:
        cv2.bitwise_or(m, extra, dst=m)
    return m


def hsv_bark(hsv: np.ndarray, cfg: SegmentConfig, bgr: np.ndarray | None = None) -> np.ndarray:
    """Raw bark mask from colour thresholds of an HSV image (OpenCV scale, read as BGR), uint8 0/255,
    shape (H, W): the colour in one of :func:`_boxes`' (brown, olive), or (with the BGR image ``bgr``)
    grey (:func:`_grey`)."""
    return _in_boxes(hsv, _boxes(cfg, False), extra=None if bgr is None else _grey(bgr, cfg))


def bark_hsv(bgr: np.ndarray, cfg: SegmentConfig) -> tuple[np.ndarray, np.ndarray]:
    """HSV image (H, W, 3) and raw bark mask (uint8 0/255, (H, W)) of a BGR image.

    A hue range wrapping through red (``hue_min`` >= 120 >= ``hue_max``) is tested on the hues
    of the image read as RGB: red and blue swapped mirror every hue h to 120 - h (mod 180),
    so the range becomes [120 - hue_max, 300 - hue_min], one ``inRange`` instead of two and an
    OR (0.6 ms less per 1280x960 image); the olive range likewise. Saturation and value are the
    same either way; exactly grey pixels (saturation 0, hue 0 in both readings) are bark by the
    grey test alone (:func:`_grey`; with ``grey_chroma_max`` 0: never).
    """
    mirrored = _mirrored(cfg)
    hsv = cv2.cvtColor(bgr, cv2.COLOR_RGB2HSV if mirrored else cv2.COLOR_BGR2HSV)
    return hsv, _in_boxes(hsv, _boxes(cfg, mirrored), extra=_grey(bgr, cfg))


def _hsv_threshold(bgr: np.ndarray, cfg: SegmentConfig, dst: np.ndarray | None = None) -> np.ndarray:
    """:func:`bark_hsv`'s raw bark mask alone (uint8 0/255), into ``dst`` when given."""
    mirrored = _mirrored(cfg)
    hsv = cv2.cvtColor(bgr, cv2.COLOR_RGB2HSV if mirrored else cv2.COLOR_BGR2HSV)
    return _in_boxes(hsv, _boxes(cfg, mirrored), dst=dst, extra=_grey(bgr, cfg))


def bark_lut(cfg: SegmentConfig) -> np.ndarray:
    """:func:`bark_hsv`'s test of every 8-bit colour, bit-packed: bit ``k & 7`` of byte ``k >> 3`` is
    that of BGR colour ``k = b << 16 | g << 8 | r``; (2^21,) uint8 (2 MB), read-only. Taken by OpenCV's
    own conversion and thresholds (:func:`_hsv_threshold`) of all 2^24 colours, so a look-up is their
    value exactly; ~90 ms (the brown box alone: ~45), once per process and set of thresholds (the
    localizer's, when it is built)."""
    return _bark_lut(*(getattr(cfg, k) for k in _LUT_KEYS))


def bark_lut_rows(cfg: SegmentConfig) -> tuple[np.ndarray, np.ndarray]:
    """:func:`bark_lut`'s table in two levels (:func:`kernels_front.bark_lookup_rows`): ``index``
    (2^16,) uint16, per ``b << 8 | g`` its row of ``rows`` ((R * 32,) uint8, the R distinct 32-byte
    rows of the table over ``r``: ~3000 with the default thresholds, ~0.2 MB in all against 2 MB);
    both read-only, the same test of every colour (tested on all 2^24)."""
    return _bark_lut_rows(*(getattr(cfg, k) for k in _LUT_KEYS))


@lru_cache(maxsize=4)
def _bark_lut_rows(*values: int) -> tuple[np.ndarray, np.ndarray]:
    table = _bark_lut(*values).reshape(1 << 16, 32)
    words = table.view(np.uint64)                              # (2^16, 4): each row's 32 bytes as 4 words
    order = np.lexsort(words.T)                                # (~10 ms; np.unique(axis=0) took ~1 s: a
    ordered = words[order]                                     #  sort of 32-byte void items)
    first = np.ones(1 << 16, bool)
    first[1:] = (ordered[1:] != ordered[:-1]).any(axis=1)
    index = np.empty(1 << 16, np.uint16)                       # (2^16 rows at most: uint16 holds every row number)
    index[order] = np.cumsum(first) - 1
    rows = np.ascontiguousarray(table[order[first]]).reshape(-1)
    index.setflags(write=False)
    rows.setflags(write=False)
    return index, rows


_LUT_KEYS = ("hue_min", "hue_max", "saturation_max", "value_min", "value_max", "olive_hue_max",
             "olive_saturation_max", "grey_chroma_max", "pale_value_max")      # (the thresholds _hsv_threshold reads)


@lru_cache(maxsize=4)
def _bark_lut(*values: int) -> np.ndarray:
    cfg = SimpleNamespace(**dict(zip(_LUT_KEYS, values)))
    lut = np.zeros(1 << 21, np.uint8)
    g, r = np.meshgrid(np.arange(256, dtype=np.uint8), np.arange(256, dtype=np.uint8), indexing="ij")
    img = np.dstack([np.zeros_like(g), g, r])                  # (256 g, 256 r) BGR: colours b << 16 + g << 8 + r
    for b in range(256):
        img[:, :, 0] = b
        lut[b << 13:(b + 1) << 13] = np.packbits(_hsv_threshold(img, cfg).reshape(-1) != 0, bitorder="little")
    lut.setflags(write=False)
    return lut


def sample_nearest(img: np.ndarray, factor: int) -> np.ndarray:
    """Every ``factor``-th pixel of every ``factor``-th row (the whole blocks' first pixels: a
    nearest-neighbour resize), shape (H // factor, W // factor[, C])."""
    h, w = img.shape[:2]
    hs, ws = h // factor, w // factor
    if img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3 and img.flags.c_contiguous and hs and ws:
        return kernels_front.sample_every(img, factor, np.empty((hs, ws, 3), np.uint8))   # (compiled: the same copy)
    return cv2.resize(img[:hs * factor, :ws * factor], (ws, hs), interpolation=cv2.INTER_NEAREST)


def bark_mask(bgr: np.ndarray, cfg: SegmentConfig, sample: int = 4, tile_px: int = 16,
              small: np.ndarray | None = None) -> np.ndarray:
    """:func:`bark_hsv`'s raw bark mask (uint8 0/255, (H, W)), converted and thresholded only near bark.

    Every ``sample``-th pixel of every ``sample``-th row is tested first (a nearest-neighbour copy:
    1/16 of the work); the full-resolution test then runs only in the ``tile_px`` square tiles
    holding a sampled bark pixel and their 8 neighbour tiles (the rest stays 0): the pixels tested
    get exactly :func:`bark_hsv`'s values. Bark the sample misses over a tile and all its neighbours
    is lost: specks (which the clean-up drops anyway), and a strip at most 3 px wide running exactly
    along the rows (or columns) between two sampled ones for 3 tiles or more, or along the image's
    bottom (right) edge below (right of) the last sampled row (column), which the clean-up keeps if
    its area reaches ``min_area_px`` (a strip 3 px wide and ~130 px long). The fixture scenes and the
    28 rendered ones give the same cleaned mask as :func:`bark_hsv` (tested). The sample and the tiles' pixels are
    tested in one compiled pass by :func:`bark_lut`'s table (:func:`bark_lut_rows`, :func:`kernels_front.bark_lookup_rows`, one
    run of pixels per image row and run of tiles), so small tiles cost no calls: 16 px tiles cover
    ~21 % of fixture 00's image (32 px: 35 %), ~0.2 ms against ~1.6 ms per 1280x960 image for
    OpenCV's conversion and thresholds of the whole image. Where most tiles are flagged (a
    background speckled with bark-coloured pixels: fixture 03's grass) the whole image is looked up
    (~0.75 ms).

    ``small``: the sample, :func:`sample_nearest` (``bgr``, ``sample``), when already taken.
    """
    return _bark_tiles(bgr, cfg, sample, tile_px, small)[0]


def _bark_tiles(bgr: np.ndarray, cfg: SegmentConfig, sample: int = 4, tile_px: int = 16,
                small: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`bark_mask`'s mask, and the ``tile_px`` square tiles tested (uint8 (TH, TW), non-zero: tested,
    the last tile row and column reaching the image's edges; the mask is zero outside them), None when
    the whole image was tested."""
    h, w = bgr.shape[:2]
    hs, ws = h // sample, w // sample
    if hs < 1 or ws < 1 or sample <= 1:
        return _hsv_threshold(bgr, cfg, dst=np.zeros((h, w), np.uint8)), None
    if small is None:
        small = sample_nearest(bgr, sample)
    index, rows = bark_lut_rows(cfg)                             # (bark_lut's table, ~0.2 MB)
    hit = np.zeros((hs, ws), np.uint8)                           # the sample's test, by the table too
    kernels_front.bark_lookup_rows(np.ascontiguousarray(small).reshape(-1), ws, index, rows, _ONE_TILE, max(hs, ws), hit.reshape(-1))
    b = max(1, tile_px // sample)                                # sampled pixels per tile side
    th, tw = -(-hs // b), -(-ws // b)
    if (th * b, tw * b) != (hs, ws):
        hit = cv2.copyMakeBorder(hit, 0, th * b - hs, 0, tw * b - ws, cv2.BORDER_CONSTANT, value=0)
    tiles = cv2.dilate(block_mean(hit, b) if b > 1 else hit, _K3, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    n_tiles = cv2.countNonZero(tiles)
    if n_tiles > FULL_SHARE * tiles.size:                       # bark-coloured nearly everywhere: all of it
        out = np.empty((h, w), np.uint8)                         # (every pixel written)
        kernels_front.bark_lookup_rows(np.ascontiguousarray(bgr).reshape(-1), w, index, rows, _ONE_TILE, tile_px, out.reshape(-1))
        return out, None
    out = np.zeros((h, w), np.uint8)
    if n_tiles == 0:
        return out, tiles
    kernels_front.bark_lookup_rows(np.ascontiguousarray(bgr).reshape(-1), w, index, rows, tiles, tile_px,
                              out.reshape(-1))                   # (compiled: no call per tile)
    return out, tiles


def occluder_at(bgr: np.ndarray, xy_px: np.ndarray, cfg: SegmentConfig) -> np.ndarray:
    """Whether the pixels at ``xy_px`` (N, 2) (x, y; rounded) of the BGR image are a leaf or an
    apple: saturation above ``saturation_max`` and value at least ``value_min``; False outside the
    image. Only the few pixels recovery asks about are converted to HSV."""
    h, w = bgr.shape[:2]
    p = np.rint(np.asarray(xy_px, float).reshape(-1, 2)).astype(int)
    ok = (p[:, 0] >= 0) & (p[:, 0] < w) & (p[:, 1] >= 0) & (p[:, 1] < h)
    px = bgr[p[ok, 1], p[ok, 0]]
    if len(px):
        px = cv2.cvtColor(px.reshape(1, -1, 3), cv2.COLOR_BGR2HSV).reshape(-1, 3).astype(int)
    out = np.zeros(len(p), bool)
    out[ok] = (px[:, 1] > cfg.saturation_max) & (px[:, 2] >= cfg.value_min)
    return out


def clean_mask(mask: np.ndarray, cfg: SegmentConfig, bgr: np.ndarray | None = None,
               small: np.ndarray | None = None, tiles: np.ndarray | None = None,
               tile_px: int = 16) -> np.ndarray:
    """Opening, closing and removal of components smaller than ``min_area_px`` unless they hold a disc
    of radius ``keep_radius_px`` and (with the BGR image ``bgr``) have the bark's chromaticity within
    ``keep_chroma_deg`` (:func:`drop_small`; ``small``: :func:`sample_nearest` (``bgr``, 4) when taken);
    uint8 0/255. ``tiles``: ``mask`` is zero outside these ``tile_px`` square tiles (:func:`_bark_tiles`):
    a 3 px opening and closing then run on them alone (:func:`kernels_segment.open_close_tiles`, the
    same values)."""
    if tiles is not None and cfg.open_px == 3 and cfg.close_px == 3 and mask.flags.c_contiguous:
        whole = tiles.size == 1 and tiles.reshape(-1)[0] != 0        # (one tile: every pixel written)
        m = kernels_segment.open_close_tiles(mask, tiles, tile_px, np.empty_like(mask) if whole else np.zeros_like(mask))
    else:
        m = _open_close(mask, cfg)
    if cfg.min_area_px > 0:
        m = drop_small(m, cfg.min_area_px, keep_radius_px=cfg.keep_radius_px, bgr=bgr,
                       keep_chroma_deg=cfg.keep_chroma_deg, small_bgr=small,
                       out=None if m is mask else m)              # (m: this function's own image)
    return m


def _open_close(mask: np.ndarray, cfg: SegmentConfig) -> np.ndarray:
    """:func:`clean_mask`'s opening (``open_px``) and closing (``close_px``) by OpenCV, uint8."""
    m = mask
    if cfg.open_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, _kernel(cfg.open_px))
    if cfg.close_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, _kernel(cfg.close_px))
    return m


def drop_small(mask: np.ndarray, min_area_px: float, factor: int = 4, keep_radius_px: float = 0.0,
               bgr: np.ndarray | None = None, keep_chroma_deg: float = 0.0,
               small_bgr: np.ndarray | None = None, out: np.ndarray | None = None) -> np.ndarray:
    """Remove connected components smaller than ``min_area_px`` (uint8 0/255), except those holding
    a disc of radius ``keep_radius_px`` (0: none kept) whose inside (the pixels at the discs' centres)
    has, in the BGR image ``bgr`` (H, W, 3), the chromaticity of the large components' bark within
    ``keep_chroma_deg`` (0 or no ``bgr``: not tested; no large component: none kept).

    Components are found on a ``factor`` times smaller copy (any branch pixel keeps a
    small pixel), ten times faster than at full size; areas are counted at full size
    (exact pixel counts of the blocks).
    A short piece of a twig (radius 4-8 px, 15-50 px long between a leaf and its tip: 100-400 px)
    is small but wide; specks of bark colour that survive the opening are not: on the 60 scenes'
    views no dropped component holding a disc of radius 3.5 px lay off the exact masks, 133 on
    them did (72 % of the branch pixels dropped). The disc is tested at full size on the small
    components' pixels only (:func:`kernels_segment.blocks_hold_disc`, with the colour
    :func:`kernels_segment.blocks_disc_colour`: ~0.1 ms per pair). The chromaticity (one plant's bark: the
    unmixing's model, :func:`unmix_edges`) keeps out wide blobs of out-of-focus background that
    pass the colour thresholds (real images: bokeh of brown foliage); the rendered scenes' twig
    pieces lie within 1.5 deg of it. ``small_bgr``: :func:`sample_nearest` (``bgr``, ``factor``) when
    already taken.
    Only the small components are cleared (``mask`` itself is returned when none is), in ``out``
    (may be ``mask`` itself; a copy of ``mask`` by default). The steps over the blocks are compiled
    (:mod:`kernels_segclean`: the components' areas, the chosen ones' blocks, the whole blocks' colour
    sums, the clearing).
    """
    h, w = mask.shape
    hs, ws = -(-h // factor), -(-w // factor)
    if (hs * factor, ws * factor) != (h, w):                  # whole blocks only: pad, then crop
        pad = cv2.copyMakeBorder(mask, 0, hs * factor - h, 0, ws * factor - w, cv2.BORDER_CONSTANT, value=0)
        bpad = None if bgr is None else cv2.copyMakeBorder(bgr, 0, hs * factor - h, 0, ws * factor - w,
                                                           cv2.BORDER_CONSTANT, value=0)
        res = drop_small(pad, min_area_px, factor, keep_radius_px, bpad, keep_chroma_deg)   # (small_bgr: ragged)
        if res is pad:
            return mask
        if out is None:
            return res[:h, :w]
        out[...] = res[:h, :w]
        return out
    cover = block_mean(mask, factor)
    n, labels = cv2.connectedComponents(cover, connectivity=8, ltype=cv2.CV_32S)
    if n <= 1:
        return mask
    idx = (cover != 0).ravel().nonzero()[0]                   # the few covered small pixels, row-major (np.flatnonzero's)
    cover, labels = cover.reshape(-1), labels.reshape(-1)
    area = kernels_segclean.component_areas(idx, labels, cover, _counts_of(factor), n)
    small = area < min_area_px
    small[0] = False
    if not small.any():
        return mask
    if keep_radius_px > 0:                                    # wide pieces (twigs) stay
        sel = small & (area >= np.pi * keep_radius_px ** 2)
        if sel.any():
            ids = sel.nonzero()[0]                            # (np.unique's numbering of their blocks)
            comp_of = np.full(n, -1, np.int64)
            comp_of[ids] = np.arange(len(ids))
            gy, gx, comp = kernels_segclean.component_blocks(idx, labels, comp_of, ws)
            dy, dx = _disc_offsets(float(keep_radius_px))
            if bgr is None or keep_chroma_deg <= 0:
                keep = kernels_segment.blocks_hold_disc(mask, gy, gx, comp, len(ids), factor, dy, dx)
            else:
                count, sums = kernels_segment.blocks_disc_colour(mask, bgr, gy, gx, comp, len(ids), factor, dy, dx)
                keep = count > 0
                if keep.any():
                    chi = _bark_chroma(bgr if small_bgr is None else small_bgr, cover, idx, labels, small, hs, ws,
                                       factor, sampled=small_bgr is not None)
                    keep &= _near_chroma(sums, chi, keep_chroma_deg)
            small[ids[keep]] = False
            if not small.any():
                return mask
    if out is None:
        out = mask.copy()
    elif out is not mask:
        out[...] = mask
    return kernels_segclean.clear_blocks(out, idx, labels, small, ws, factor)


@lru_cache(maxsize=4)
def _counts_of(factor: int) -> np.ndarray:
    """Per value of :func:`block_mean` (256,) float64 the pixel count it stands for,
    ``rint(value * factor^2 / 255)`` (read-only)."""
    out = np.rint(np.arange(256) * (factor * factor / 255.0))
    out.setflags(write=False)
    return out


def _bark_chroma(bgr: np.ndarray, cover: np.ndarray, idx: np.ndarray, labels: np.ndarray, small: np.ndarray,
                 hs: int, ws: int, factor: int, sampled: bool = False) -> np.ndarray | None:
    """Unit BGR vector (3,) of the large components' bark: the mean of the first pixels of their whole
    ``factor`` x ``factor`` blocks (``cover`` 255; the blocks of the components flagged in ``small`` left
    out) whose 8 neighbour blocks are whole too (the outline's mixed pixels left out; all whole blocks
    where none is); None without any. ``cover``, ``labels``: the (hs, ws) block image and its labels,
    flat; ``idx``: its non-zero blocks, row-major. ``sampled``: ``bgr`` is already :func:`sample_nearest`
    (image, ``factor``). (cv2.mean's value: the sums times 1 / n.)"""
    first = bgr if sampled else sample_nearest(bgr, factor)          # (read where inside both grids)
    n_in, s_in, n_all, s_all = kernels_segclean.whole_block_sums(idx, labels, cover, small, first, hs, ws)
    if not (n_in[0] or n_all[0]):
        return None
    n, s = (n_in[1], s_in) if n_in[0] else (n_all[1], s_all)
    if not n:
        return None
    c = s * (1.0 / n)
    norm = float(np.linalg.norm(c))
    return c / norm if norm > 0 else None


def _near_chroma(sums: np.ndarray, chi: np.ndarray | None, max_deg: float) -> np.ndarray:
    """Whether each colour sum (N, 3) is within ``max_deg`` of the unit vector ``chi`` (all False
    without one)."""
    if chi is None:
        return np.zeros(len(sums), bool)
    n = np.linalg.norm(sums, axis=1)
    return sums @ chi >= np.cos(np.radians(max_deg)) * np.maximum(n, 1e-9)


@lru_cache(maxsize=8)
def _disc_offsets(radius_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (dy, dx) (M,) int64 of the pixels nearer than ``radius_px`` to a pixel (itself excluded),
    nearest first (an unset one is then found early), read-only."""
    r = int(np.ceil(radius_px))
    dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
    d2 = (dy * dy + dx * dx).ravel()
    keep = (d2 > 0) & (d2 < radius_px ** 2)
    order = np.argsort(d2[keep], kind="stable")
    out = dy.ravel()[keep][order].astype(np.int64), dx.ravel()[keep][order].astype(np.int64)
    for a in out:
        a.setflags(write=False)
    return out


def unmix_edges(bgr: np.ndarray, mask: np.ndarray, window_px: int, band_px: int = 1, factor: int = 4,
                out: np.ndarray | None = None, scratch: np.ndarray | None = None,
                small: np.ndarray | None = None, tiles: np.ndarray | None = None,
                tile_px: int = 16) -> np.ndarray:
    """Soft branch coverage at the mask's outline: each pixel of the outline (morphological
    gradient over (2 ``band_px`` + 1)^2: the pixels up to ``band_px`` inside and outside the mask's
    edge) gets the share of bark in its colour, 0-255; the rest of ``mask`` (uint8 0/255, (H, W))
    is kept. ``band_px`` 2 suits JPEG images, whose colour is smeared over 2 px (4:2:0).

    An outline pixel's colour is taken as a mix ``p = beta * c_o + k * chi``: ``c_o`` the mean
    colour of the background near it (pixels of a ``factor`` times smaller nearest-neighbour
    copy more than one small pixel off the mask, over ``window_px``: sky, foliage and leaves
    are smooth at that scale), ``chi`` the bark's chromaticity (unit BGR vector of the mean
    colour inside the mask: shading scales bark colour, it does not change its chromaticity),
    ``k`` free (the bark's brightness at that edge: lit or shaded side). The least-squares
    ``beta`` is the background's share, coverage = 1 - beta = 1 - p . v with one vector ``v``
    per ``factor`` x ``factor`` block. Pixels with no background sample in their window, or whose
    background has nearly the bark's chromaticity (less than ~3 deg apart), keep their value,
    as do those of the last ``H % factor`` rows and ``W % factor`` columns. Thresholded at 0.5
    this is the exact masks' pixel-coverage rule; the soft values give the rectified coverage
    sub-pixel outlines. ~0.5 ms per 1280x960 image alone, ~1.2 ms cache-cold (outline pixels
    found per block; the blocks' unmixing and their pixels in one compiled pass,
    :func:`kernels_segment.unmix_blocks`).

    ``out`` (may be ``mask`` itself) receives the result, a copy of ``mask`` by default;
    ``scratch``, a uint8 (H, W) array that may be overwritten (not ``mask``), holds the outline.
    Both save allocating a full-size image. ``small``: :func:`sample_nearest` (``bgr``, ``factor``)
    when already taken. ``tiles``: ``mask`` is zero farther than 1 px from these ``tile_px`` square
    tiles (:func:`clean_mask` of :func:`_bark_tiles`' mask): the outline (``band_px`` 1) is then
    found on them alone (:func:`kernels_segment.gradient_tiles`, the same values), and ``scratch``
    must be zero off them (:func:`_bark_tiles`' mask is).
    """
    h, w = mask.shape
    hs, ws = h // factor, w // factor
    if tiles is not None and band_px == 1 and mask.flags.c_contiguous:
        ring = kernels_segment.gradient_tiles(mask, tiles, tile_px, np.zeros_like(mask) if scratch is None else scratch)
    else:
        ring = cv2.morphologyEx(mask, cv2.MORPH_GRADIENT, np.ones((2 * band_px + 1,) * 2, np.uint8), dst=scratch)
    # the blocks holding outline pixels, row-major (y * ws + x)
    bi = (block_mean(ring[:hs * factor, :ws * factor], factor) != 0).ravel().nonzero()[0] if hs and ws else np.zeros(0, np.intp)
    if out is None:
        out = mask.copy()
    elif out is not mask:
        out[...] = mask
    if len(bi) == 0:
        return out
    if small is None:
        small = sample_nearest(bgr, factor)
    ms = cv2.resize(mask[:hs * factor, :ws * factor], (ws, hs), interpolation=cv2.INTER_NEAREST)
    chi = np.array(cv2.mean(small, mask=cv2.erode(ms, _K3))[:3], np.float32)
    if not chi.any():                                            # only thin twigs: their whole mask
        chi = np.array(cv2.mean(small, mask=ms)[:3], np.float32)
    chi /= max(float(np.linalg.norm(chi)), 1e-6)
    away = cv2.bitwise_not(cv2.dilate(ms, _K3))                 # sure background, 255
    win = (max(1, round(window_px / factor)),) * 2
    n_o = cv2.boxFilter(away, cv2.CV_32F, win, normalize=False)
    s_o = cv2.boxFilter(cv2.bitwise_and(small, small, mask=away), cv2.CV_32F, win, normalize=False)
    # per block the background's mean colour and the unmixing vector, then each outline pixel's 1 - p . v
    # (compiled: numpy's float32 steps, the same values)
    kernels_segment.unmix_blocks(bgr, ring, bi, n_o, s_o, chi, _MIN_SIN2, factor, out)
    return out


def segment_color(bgr: np.ndarray, cfg: SegmentConfig) -> tuple[np.ndarray, np.ndarray]:
    """The embedded recogniser: the branch mask, uint8 (H, W) (0/255; with ``edge_window_px`` > 0
    soft coverage 0-255 along the outline, see :func:`unmix_edges`), and the HSV image it was
    taken from (H, W, 3). The reference for :func:`segment_mask`, which gives the same mask faster."""
    hsv, raw = bark_hsv(bgr, cfg)
    mask = clean_mask(raw, cfg, bgr)
    if cfg.edge_window_px > 0:
        mask = unmix_edges(bgr, mask, cfg.edge_window_px, cfg.edge_band_px, out=mask,
                           scratch=None if raw is mask else raw)
    return mask, hsv


def segment_mask(bgr: np.ndarray, cfg: SegmentConfig) -> np.ndarray:
    """:func:`segment_color`'s mask without the HSV image, the bark test run only near bark
    (:func:`bark_mask`): what the localizer uses (its occluder test converts the few pixels it
    asks about, :func:`occluder_at`). The clean-up's morphology runs on the tested tiles
    (:mod:`kernels_segment`); where the whole image was tested (grass) on one tile of the image's size,
    the same values as OpenCV's whole-image calls, ~0.1 ms per image faster."""
    small = sample_nearest(bgr, 4) if min(bgr.shape[:2]) >= 4 else None    # (shared by both)
    raw, tiles = _bark_tiles(bgr, cfg, small=small)
    tile_px = 16
    if tiles is None:           # the whole image tested: one tile (the kernels' passes over all of it, ~0.1 ms per
        tiles, tile_px = _ONE_TILE, bgr.shape[0]     # image less than OpenCV's morphology; a single tile reaches the
                                                     # right and bottom edges: its size sets only the buffers' rows)
    mask = clean_mask(raw, cfg, bgr, small, tiles, tile_px)
    if cfg.edge_window_px > 0:
        mask = unmix_edges(bgr, mask, cfg.edge_window_px, cfg.edge_band_px, out=mask,
                           scratch=None if raw is mask else raw, small=small,
                           tiles=None if raw is mask else tiles, tile_px=tile_px)
    return mask


def as_mask(mask: np.ndarray, shape: tuple[int, int], what: str) -> np.ndarray:
    """Validate an external mask: size, non-empty; returns uint8 coverage 0-255.

    A floating-point mask is a probability (or coverage) of branch per pixel, 0-1: kept soft
    (0-255; branch where >= 0.5), so its outline places edges to a fraction of a pixel as the
    colour recogniser's soft outlines do. Any other mask is binary: non-zero = branch (255).

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
    if np.issubdtype(m.dtype, np.floating):
        # clip(nan_to_num(m) * 255 + 0.5, 0, 255) as uint8, in place; nan_to_num (~3 ms per 1280x960
        # image) only when something is not finite (it is the identity otherwise)
        with np.errstate(over="ignore"):                   # (an infinity: the largest float, x 255)
            v = (m if np.isfinite(m).all() else np.nan_to_num(m)) * 255.0
        v += 0.5
        m = np.clip(v, 0, 255, out=v).astype(np.uint8)
        if not cv2.countNonZero(cv2.threshold(m, 127, 255, cv2.THRESH_BINARY)[1]):
            raise LocalizeError(f"{what}: mask is empty (no pixel of probability 0.5 or more)")
        return m
    m = binary(m, 255)
    if not cv2.countNonZero(m):
        raise LocalizeError(f"{what}: mask is empty (no branch pixel)")
    return m
