"""Single-pixel, 8-connected skeletons of branch masks.

``thinning`` is the paper's morphological thinning (Zhang-Suen, the same result as
cv2.ximgproc.thinning, computed at the pixels that can still change only) at full
resolution. ``fast`` thins a mask ``downscale`` times smaller (thinning time grows with the
branch thickness, so a 4x smaller mask thins ~40x faster); the skeleton then carries
only the topology and approximate centre lines, which the dense matcher refines at full
resolution from the image edges.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np
from appliance.localize import kernels_graph

# neighbour k of pixel (y, x) is at (y + DY[k], x + DX[k]): N, NE, E, SE, S, SW, W, NW
DY = np.array([-1, -1, 0, 1, 1, 1, 0, -1])
DX = np.array([0, 1, 1, 1, 0, -1, -1, -1])
_LITTLE_ENDIAN = sys.byteorder == "little"
_GATHER_BITS, _TOP_BYTE = np.uint64(0x0102040810204080), np.uint64(56)


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A skeleton image and its scale.

    Attributes
    ----------
    image : ndarray, shape (H/scale, W/scale), uint8 0/1
    mask : ndarray, shape (H/scale, W/scale), uint8 0/255
        The mask that was thinned.
    scale : int
        Full-resolution pixels per skeleton pixel; a skeleton pixel (x, y) is at
        ``(x + 0.5) * scale - 0.5`` in the full image.
    """

    image: np.ndarray
    scale: int = 1
    mask: np.ndarray | None = None


def neighbour_code(img01: np.ndarray) -> np.ndarray:
    """8-bit code of each pixel's 8 neighbours (bit k = neighbour k set), uint8."""
    kernel = np.zeros((3, 3), np.float32)
    kernel[1 + DY, 1 + DX] = 2.0 ** np.arange(8)
    code = cv2.filter2D(img01.astype(np.uint8), cv2.CV_32F, kernel, borderType=cv2.BORDER_CONSTANT)
    return code.astype(np.uint8)


def binary(img: np.ndarray, on: int = 1) -> np.ndarray:
    """``on`` where ``img`` is non-zero, else 0, uint8 (one OpenCV pass for uint8 images)."""
    img = np.asarray(img)
    if img.dtype == bool:
        img = img.view(np.uint8)
    if img.dtype == np.uint8 and img.ndim == 2:
        return cv2.threshold(img, 0, on, cv2.THRESH_BINARY)[1]
    return (img > 0).astype(np.uint8) * np.uint8(on)


def pixels(img: np.ndarray) -> np.ndarray:
    """(row, col) of the non-zero pixels of a 2D uint8 image in row-major order, shape (N, 2) int64."""
    pts = cv2.findNonZero(img)
    return np.zeros((0, 2), np.int64) if pts is None else pts.reshape(-1, 2)[:, ::-1].astype(np.int64)


def block_mean(mask: np.ndarray, factor: int) -> np.ndarray:
    """Mean of each ``factor`` x ``factor`` block (whole blocks), uint8, shape (H / factor, W / factor).

    A power-of-two factor is taken in halvings: OpenCV's 2x area resize is ~8x faster than
    one 4x (0.04 against 0.28 ms at 1280x960). Either way a block with any pixel set
    stays non-zero, and ``rint(mean * factor**2 / 255)`` is the exact count of set pixels.
    """
    h, w = mask.shape
    if factor & (factor - 1):
        return cv2.resize(mask, (w // factor, h // factor), interpolation=cv2.INTER_AREA)
    while factor > 1:
        h, w, factor = h // 2, w // 2, factor // 2
        mask = cv2.resize(mask, (w, h), interpolation=cv2.INTER_AREA)
    return mask


@dataclass(eq=False)
class SparseImage:
    """A binary image held as a zero-padded flat array, for work at a few pixels only.

    Attributes
    ----------
    flat : ndarray ((H + 2) * (W + 2),) uint8
        The image, 0/1, with a one-pixel border of zeros, raveled.
    shape : (int, int)
        (H, W) of the image.
    """

    flat: np.ndarray
    shape: tuple[int, int]

    @classmethod
    def from_image(cls, img: np.ndarray) -> SparseImage:
        """The image (H, W), non-zero = set, with its border of zeros."""
        pad = cv2.copyMakeBorder(binary(img), 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
        return cls(pad.reshape(-1), img.shape)

    def index(self, ys: np.ndarray, xs: np.ndarray) -> np.ndarray:
        """Flat indices of pixels (row, col), shape (N,) int64."""
        return (np.asarray(ys, np.int64) + 1) * (self.shape[1] + 2) + np.asarray(xs, np.int64) + 1

    def offsets(self) -> np.ndarray:
        """Flat index steps to neighbour k (N, NE, E, SE, S, SW, W, NW), shape (8,)."""
        return DY * (self.shape[1] + 2) + DX

    def codes(self, idx: np.ndarray) -> np.ndarray:
        """:func:`neighbour_code` at the flat indices ``idx``, shape (N,) uint8."""
        nb = self.flat[np.asarray(idx)[:, None] + self.offsets()] != 0
        if not _LITTLE_ENDIAN:
            return np.packbits(nb, axis=1, bitorder="little").reshape(-1)
        # the 8 neighbour bytes (0/1) of a pixel read as one uint64: a multiply moves byte k's bit to
        # bit 56 + k (no carries), the same code as np.packbits(bitorder="little") in half the time
        return ((nb.view(np.uint64)[:, 0] * _GATHER_BITS) >> _TOP_BYTE).astype(np.uint8)

    def image(self) -> np.ndarray:
        """The (H, W) uint8 0/1 image."""
        h, w = self.shape
        return self.flat.reshape(h + 2, w + 2)[1:-1, 1:-1].copy()


def _groups(pts: np.ndarray) -> int:
    """Number of 8-connected groups among a few pixel positions (N, 2)."""
    label = list(range(len(pts)))
    for a in range(len(pts)):
        for b in range(a + 1, len(pts)):
            if np.abs(pts[a] - pts[b]).max() <= 1:
                old, new = label[b], label[a]
                label = [new if x == old else x for x in label]
    return len(set(label))


@lru_cache(maxsize=1)
def neighbour_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lookup tables over the 256 neighbour codes.

    Returns
    -------
    count : (256,) uint8
        Number of set neighbours.
    components : (256,) uint8
        Number of 8-connected groups the set neighbours form (crossing number).
    corner : (256,) bool
        The pixel is redundant, so its removal keeps the skeleton connected: a staircase
        corner (one group, and two perpendicular 4-neighbours set with the pixel between them
        diagonal to nothing else), or a bump (exactly two neighbours, touching each other).
    """
    bits = (np.arange(256)[:, None] >> np.arange(8)) & 1
    count = bits.sum(1).astype(np.uint8)
    comps = np.zeros(256, np.uint8)
    corner = np.zeros(256, bool)
    pos = np.column_stack([DY, DX])
    for code in range(256):
        on = np.flatnonzero(bits[code])
        comps[code] = _groups(pos[on])
        four = [k for k in (0, 2, 4, 6) if bits[code, k]]
        perpendicular = any((b - a) % 8 in (2, 6) for a in four for b in four if a < b)
        # (or any pixel whose only two neighbours touch each other: a one-pixel bump on the outside
        # of a turn, which would make its two neighbours a false junction with a dangling segment)
        corner[code] = comps[code] == 1 and (count[code] >= 2 and perpendicular or count[code] == 2)
    return count, comps, corner


def remove_corners(skel01: np.ndarray) -> np.ndarray:
    """Remove redundant staircase corner and bump pixels (two passes by pixel parity); uint8 0/1.

    After this every pixel of a simple path has exactly two neighbours, so the paper's
    neighbour-count rules (1: endpoint, >= 3: bifurcation) hold. Each pass decides on the image
    as the previous pass left it (compiled: :func:`kernels_graph.remove_corners_flat`).
    """
    _, _, corner = neighbour_tables()
    image = _words_image(skel01)
    if image is None:
        img = SparseImage.from_image(skel01)
        idx = np.flatnonzero(img.flat.view(bool))             # (0/1 bytes) row-major, as pixels()
        kernels_graph.remove_corners_flat(img.flat, idx, img.shape[1] + 2, corner)
        return img.image()
    return kernels_graph.corners(image, image.view(np.uint64), corner, np.empty(skel01.shape, np.uint8))


def _words_image(mask: np.ndarray) -> np.ndarray | None:
    """A 2-D uint8 ``mask`` with rows of whole 8-pixel words (itself, or a zero-padded copy), for the
    word scans of :mod:`kernels_graph`; None for other masks."""
    mask = np.asarray(mask)
    if mask.dtype != np.uint8 or mask.ndim != 2:
        return None
    h, w = mask.shape
    if w % 8 or not mask.flags.c_contiguous:
        image = np.zeros((h, -(-w // 8) * 8), np.uint8)
        image[:, :w] = mask
        return image
    return mask


@lru_cache(maxsize=1)
def zhang_suen_tables() -> tuple[np.ndarray, np.ndarray]:
    """Deletion tables of Zhang-Suen's two sub-iterations over the 256 neighbour codes, (256,) bool.

    A pixel goes when its neighbours (P2..P9 = N, NE, ..., NW) form one run (A = 1), it
    has 2 to 6 of them (B), and P2*P4*P6 = P4*P6*P8 = 0 (first sub-iteration) or
    P2*P4*P8 = P2*P6*P8 = 0 (second).
    """
    bits = (np.arange(256)[:, None] >> np.arange(8)) & 1
    p2, _, p4, _, p6, _, p8, _ = bits.T
    runs = ((bits == 0) & (np.roll(bits, -1, axis=1) == 1)).sum(1)
    base = (runs == 1) & (bits.sum(1) >= 2) & (bits.sum(1) <= 6)
    return (base & (p2 * p4 * p6 == 0) & (p4 * p6 * p8 == 0),
            base & (p2 * p4 * p8 == 0) & (p2 * p6 * p8 == 0))


def zhang_suen(mask: np.ndarray) -> np.ndarray:
    """Zhang-Suen thinning, pixel for pixel the result of cv2.ximgproc.thinning (ZHANGSUEN).

    Each sub-iteration deletes, all at once, the pixels its table marks; pixels on the image
    border stay. A pixel's decision depends on its 3x3 neighbourhood only, so a pixel is
    examined again only when a neighbour went in the last two sub-iterations (and at first
    only where the neighbourhood is not full): the work follows the shrinking outline
    instead of passing over the whole image each time (~10x faster at full size).

    Parameters
    ----------
    mask : ndarray (H, W)
        Non-zero = foreground.

    Returns
    -------
    ndarray (H, W) uint8 0/1
    """
    tables = zhang_suen_tables()
    m = binary(mask)
    h, w = m.shape
    # ``flat``: the image 0/1 with a zero border (the neighbour codes); ``live``: the pixels that may
    # still go (foreground, not on the image border)
    flat = cv2.copyMakeBorder(m, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0).reshape(-1)
    live = flat.copy()
    pad = live.reshape(h + 2, w + 2)
    for edge in (pad[1], pad[h], pad[:, 1], pad[:, w]):
        edge[:] = 0                    # foreground on the image border is never deleted
    outline = cv2.copyMakeBorder(m - cv2.erode(m, np.ones((3, 3), np.uint8)), 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
    start = np.flatnonzero(outline.reshape(-1).view(bool))        # row-major, as pixels()
    start = start[live.take(start).view(bool)]
    kernels_graph.zhang_suen_flat(flat, live, start, (DY * (w + 2) + DX).astype(np.int64), *tables)
    return binary(flat.reshape(h + 2, w + 2)[1:-1, 1:-1])


def skeletonize(mask: np.ndarray, method: str = "thinning", downscale: int = 4, level: int = 0) -> Skeleton:
    """Skeleton of a branch mask.

    Parameters
    ----------
    mask : ndarray, shape (H, W)
        Non-zero (above ``level``) = branch.
    method : {"thinning", "fast"}
        ``thinning``: Zhang-Suen at full resolution (paper). ``fast``: the same on a mask
        ``downscale`` times smaller (a low pixel keeps branch if >= 30 % of it is branch,
        so thin twigs survive).
    downscale : int
        Factor of ``fast``.
    level : int
        Branch where ``mask > level`` (127: a rectified coverage image, 0-255, whose branch is >= 128).
        A uint8 coverage image at 127 with ``fast`` by 4 goes to :func:`kernels_graph.coarse_mask` (the
        threshold, the block mean and its threshold in one pass over the image).
    """
    h, w = mask.shape
    if level:
        if (method == "fast" and downscale == 4 and level == 127 and mask.dtype == np.uint8 and _LITTLE_ENDIAN
                and mask.flags.c_contiguous and h % 4 == 0 and w % 8 == 0):
            m = kernels_graph.coarse_mask(mask.view(np.uint64), np.empty((h // 4, w // 4), np.uint8))
            return Skeleton(thin(m), 4, m)
        mask = np.asarray(mask) > level
    m = binary(mask, 255)
    scale = 1
    if method == "fast" and downscale > 1:
        if downscale in (2, 4) and h % downscale == 0 and w % downscale == 0:
            # the block mean by halvings: the same pixels pass the threshold as of the one-step
            # mean (all 2^16 blocks of 4 x 4 checked in tests/localize/test_skeleton.py)
            small = block_mean(m, downscale)
        else:
            small = cv2.resize(m, (w // downscale, h // downscale), interpolation=cv2.INTER_AREA)
        m = cv2.threshold(small, 76, 255, cv2.THRESH_BINARY)[1]
        scale = downscale
    return Skeleton(thin(m), scale, m)


def thin(mask: np.ndarray) -> np.ndarray:
    """``remove_corners(zhang_suen(mask))`` (uint8 0/1, the shape of ``mask``), in one compiled call
    (:func:`kernels_graph.thin`) for a uint8 mask."""
    image = _words_image(mask)
    if image is None:
        return remove_corners(zhang_suen(mask))
    h, w = np.shape(mask)
    _, _, corner = neighbour_tables()
    return kernels_graph.thin(image, image.view(np.uint64), (DY * (w + 2) + DX).astype(np.int64), *zhang_suen_tables(),
                               corner, np.empty((h, w), np.uint8))
