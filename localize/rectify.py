"""Rectification of a stereo pair with maps computed once per calibration.

Rectified images have their epipolar lines on pixel rows: a 3D point seen at row ``v``
in the rectified left image is at the same row in the rectified right image.

Masks are mostly background: :meth:`Rectifier.rectify` remaps only the output tiles whose
source area holds a non-zero pixel (the others are zero in a full remap too), which gives the
same image as a full remap in about half the time.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from appliance.calibrate.model import StereoCalibration
from appliance.localize import kernels_graph
from appliance.localize.errors import LocalizeError
from appliance.localize.skeleton import block_mean

GREY_TILE_PX = (16, 64)     # LazyRectified's source boxes: per tile of this size (rows, cols)


@dataclass(frozen=True, eq=False)
class Rectifier:
    """Remap tables of both cameras and the point mappings between frames.

    Attributes
    ----------
    calib : StereoCalibration
    maps : tuple of two (map1, map2) pairs
        ``cv2.initUndistortRectifyMap`` tables (fixed point, CV_16SC2) of the left and
        right camera.
    valid : tuple of two ndarray (H, W) bool
        Rectified pixels that see the camera's image (2 px in from its outline).
    tiles : tuple of two ndarray (T, 8) int
        Output tiles ``y0, y1, x0, x1`` and the source box they read ``sy0, sy1, sx0, sx1``
        (end exclusive, clipped to the image; empty when the tile sees nothing), per camera.
    """

    calib: StereoCalibration
    maps: tuple

    valid: tuple = ()
    tiles: tuple = ()
    _sources: dict = field(default_factory=dict, repr=False)   # tile_sources() cache

    TILE_PX = (64, 16)      # output tile (rows, cols) of the sparse remap (tall and narrow: fewer calls, less area)
    BLOCK_PX = 8            # source pixels per cell of the "anything here" map
    SPARSE_MAX = 0.7        # remap in full when more than this share of the image is needed

    @classmethod
    def from_calibration(cls, calib: StereoCalibration) -> Rectifier:
        """Build the remap tables and the valid areas (the only expensive step; done once)."""
        size = tuple(int(s) for s in calib.image_size)
        maps = tuple(
            cv2.initUndistortRectifyMap(K, D, Rr, P, size, cv2.CV_16SC2)
            for K, D, Rr, P in ((calib.K1, calib.D1, calib.R1, calib.P1), (calib.K2, calib.D2, calib.R2, calib.P2))
        )
        ones = np.full(size[::-1], 255, np.uint8)
        valid = tuple(cv2.erode(cv2.remap(ones, m1, m2, cv2.INTER_NEAREST, borderValue=0), np.ones((5, 5), np.uint8),
                                borderType=cv2.BORDER_CONSTANT, borderValue=0) > 0
                      for m1, m2 in maps)
        tiles = tuple(_tile_sources(*cv2.convertMaps(m1, m2, cv2.CV_32FC1), cls.TILE_PX) for m1, m2 in maps)
        rect = cls(calib, maps, valid, tiles)
        for side in (0, 1):
            rect.float_maps(side)                        # the masks' remap tables
            rect._cell_boxes(side)                       # and their tiles' source cells
        return rect

    def tile_sources(self, side: int, tile_px: tuple[int, int]) -> np.ndarray:
        """:func:`_tile_sources` of one camera for tiles of ``tile_px`` (rows, cols), computed once."""
        key = (side, tuple(tile_px))
        if key not in self._sources:
            if tuple(tile_px) == self.TILE_PX and self.tiles:
                self._sources[key] = self.tiles[side]
            else:
                self._sources[key] = _tile_sources(*cv2.convertMaps(*self.maps[side], cv2.CV_32FC1), tile_px)
        return self._sources[key]

    def source_grid(self, side: int, tile_px: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`tile_sources` as two grids (rows, cols, 2) int: each tile's source box start (sy0, sx0)
        and end (sy1, sx1); a tile that sees nothing has start ``W + H`` and end -1 (a union of boxes by
        a min and a max). Computed once."""
        key = ("grid", side, tuple(tile_px))
        if key not in self._sources:
            t = self.tile_sources(side, tile_px)
            w, h = (int(s) for s in self.calib.image_size)
            shape = (-(-h // tile_px[0]), -(-w // tile_px[1]), 2)
            empty = ((t[:, 5] <= t[:, 4]) | (t[:, 7] <= t[:, 6]))[:, None]
            lo = np.where(empty, w + h, t[:, [4, 6]]).reshape(shape)
            hi = np.where(empty, -1, t[:, [5, 7]]).reshape(shape)
            self._sources[key] = (lo, hi)
        return self._sources[key]

    def check_size(self, image: np.ndarray, what: str) -> None:
        """Raise LocalizeError unless ``image`` has the calibration's size."""
        w, h = self.calib.image_size
        if image is None or image.ndim < 2 or image.shape[:2] != (h, w):
            got = "nothing" if image is None else f"{image.shape[1]}x{image.shape[0]}"
            raise LocalizeError(f"{what}: image is {got}, the calibration is for {w}x{h}")

    def float_maps(self, side: int) -> tuple[np.ndarray, np.ndarray]:
        """One camera's remap tables as two CV_32FC1 maps (the same positions as :attr:`maps`, to
        1/32 px), computed once."""
        key = ("float", side)
        if key not in self._sources:
            self._sources[key] = cv2.convertMaps(*self.maps[side], cv2.CV_32FC1)
        return self._sources[key]

    def rectify(self, image: np.ndarray, side: int, nearest: bool = False, fast: bool = False) -> np.ndarray:
        """Rectified copy of one camera's image.

        Parameters
        ----------
        image : ndarray, shape (H, W) or (H, W, C)
        side : int
            0 left camera, 1 right camera.
        nearest : bool
            Nearest-neighbour interpolation (for masks); linear otherwise.
        fast : bool
            Remap through float maps (:meth:`float_maps`): ~1.6x faster; OpenCV blends them in
            floating point, so a value half way between two levels may round to the even one (a
            level lower than the fixed-point remap on ~0.5 % of a random image's pixels). For masks.
        """
        m1, m2 = self.float_maps(side) if fast else self.maps[side]
        interp = cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR
        if image.dtype == np.uint8 and image.shape == m1.shape[:2] and self.tiles:
            need = self._needed_tiles(image, side)
            if ((need[:, 1] - need[:, 0]) * (need[:, 3] - need[:, 2])).sum() <= self.SPARSE_MAX * image.size:
                out = np.zeros(image.shape, np.uint8)
                for y0, y1, x0, x1 in need.tolist():
                    cv2.remap(image, m1[y0:y1, x0:x1], m2[y0:y1, x0:x1], interp, dst=out[y0:y1, x0:x1],
                              borderMode=cv2.BORDER_CONSTANT, borderValue=0)
                return out
        return cv2.remap(image, m1, m2, interp, borderMode=cv2.BORDER_CONSTANT, borderValue=0)

    def _needed_tiles(self, image: np.ndarray, side: int) -> np.ndarray:
        """Output areas (y0, y1, x0, x1), (N, 4): runs of the tiles of one tile row whose source box
        holds a non-zero pixel of ``image`` (tested by cells of ``BLOCK_PX`` px; compiled:
        :func:`kernels_graph.needed_tiles`, for images whose rows are whole 8-pixel words)."""
        b = self.BLOCK_PX
        h, w = image.shape
        t = self.tiles[side]
        if b == 8 and w % 8 == 0 and image.flags.c_contiguous:
            out = np.empty((len(t), 4), np.int64)
            n = kernels_graph.needed_tiles(image.view(np.uint64), self._cell_boxes(side), t[:, :4], out)
            return out[:n]
        hb, wb = -(-h // b), -(-w // b)
        any_px = cv2.threshold(image, 0, 255, cv2.THRESH_BINARY)[1]
        if (hb * b, wb * b) != (h, w):
            any_px = cv2.copyMakeBorder(any_px, 0, hb * b - h, 0, wb * b - w, cv2.BORDER_CONSTANT, value=0)
        # the block mean (by halvings): one 255 pixel of 64 still rounds to >= 4
        cells = cv2.integral(block_mean(any_px, b))
        by0, by1, bx0, bx1 = self._cell_boxes(side).T
        count = cells[by1, bx1] - cells[by0, bx1] - cells[by1, bx0] + cells[by0, bx0]
        need = t[count > 0, :4]
        if len(need) == 0:
            return need
        # neighbouring tiles of one tile row remapped by one call (fewer, wider calls)
        start = np.flatnonzero(np.concatenate([[True], (need[1:, 0] != need[:-1, 0]) | (need[1:, 2] != need[:-1, 3])]))
        end = np.concatenate([start[1:], [len(need)]]) - 1
        return np.column_stack([need[start, :3], need[end, 3]])

    def _cell_boxes(self, side: int) -> np.ndarray:
        """Each tile's source cells of ``BLOCK_PX`` px: ``cy0, cy1, cx0, cx1`` (T, 4) int64 (end exclusive,
        the source box rounded out to whole cells; empty for an empty box), computed once."""
        key = ("cells", side)
        if key not in self._sources:
            b, t = self.BLOCK_PX, self.tiles[side]
            by0, bx0 = t[:, 4] // b, t[:, 6] // b
            by1, bx1 = np.maximum(-(-t[:, 5] // b), by0), np.maximum(-(-t[:, 7] // b), bx0)
            self._sources[key] = np.ascontiguousarray(np.column_stack([by0, by1, bx0, bx1]), np.int64)
        return self._sources[key]

    def to_original(self, pts_px: np.ndarray, side: int) -> np.ndarray:
        """Rectified pixel positions -> pixel positions in the original (distorted) image.

        Parameters
        ----------
        pts_px : ndarray, shape (N, 2)
            (u, v) in the rectified image of ``side``.

        Returns
        -------
        ndarray, shape (N, 2), float64
        """
        pts = np.asarray(pts_px, np.float64).reshape(-1, 2)
        if len(pts) == 0:
            return np.zeros((0, 2))
        c = self.calib
        P, Rr, K, D = (c.P1, c.R1, c.K1, c.D1) if side == 0 else (c.P2, c.R2, c.K2, c.D2)
        rays = np.column_stack([(pts[:, 0] - P[0, 2]) / P[0, 0], (pts[:, 1] - P[1, 2]) / P[1, 1], np.ones(len(pts))])
        rays = rays @ Rr  # rows: R^T @ ray, back into the camera's unrectified frame
        k = self._distortion(side)
        if k is None:
            img, _ = cv2.projectPoints(rays.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)
            return img.reshape(-1, 2)
        return kernels_graph.project_distorted(rays, self._camera(side), k, np.empty((len(rays), 2)))

    def _distortion(self, side: int) -> np.ndarray | None:
        """One camera's distortion coefficients as the 12 of :func:`kernels_graph.project_distorted`
        (float64; None for a model it does not cover: the tilted sensor's 14, or a camera matrix with
        skew), computed once."""
        key = ("k12", side)
        if key not in self._sources:
            c = self.calib
            K, D = (c.K1, c.D1) if side == 0 else (c.K2, c.D2)
            d = np.asarray(D, np.float64).ravel()
            k = None
            if len(d) in (4, 5, 8, 12) and np.asarray(K)[0, 1] == 0:
                k = np.zeros(12)
                k[:len(d)] = d
            self._sources[key] = k
        return self._sources[key]

    def _camera(self, side: int) -> np.ndarray:
        """One camera's matrix K (3, 3) float64, C-contiguous, computed once."""
        key = ("K", side)
        if key not in self._sources:
            c = self.calib
            self._sources[key] = np.ascontiguousarray((c.K1 if side == 0 else c.K2), np.float64)
        return self._sources[key]


def _tile_sources(map_x: np.ndarray, map_y: np.ndarray, tile_px: tuple[int, int]) -> np.ndarray:
    """Output tiles of a remap and the source pixels each reads with linear interpolation.

    Returns
    -------
    ndarray (T, 8) int
        ``y0, y1, x0, x1, sy0, sy1, sx0, sx1`` (end exclusive; the source box clipped to the
        image, so it is empty when the tile sees nothing).
    """
    h, w = map_x.shape
    ys, xs = np.arange(0, h, tile_px[0]), np.arange(0, w, tile_px[1])

    def reduce(f, m):
        return f.reduceat(f.reduceat(m, ys, axis=0), xs, axis=1).ravel()

    finite_x = np.nan_to_num(map_x, nan=-1e6)
    finite_y = np.nan_to_num(map_y, nan=-1e6)
    # pixel floor(p) and floor(p) + 1 are read; a little margin for the 1/32 px rounding
    sx0 = np.floor(reduce(np.minimum, finite_x)) - 1
    sx1 = np.floor(reduce(np.maximum, finite_x)) + 3
    sy0 = np.floor(reduce(np.minimum, finite_y)) - 1
    sy1 = np.floor(reduce(np.maximum, finite_y)) + 3
    y0, x0 = (a.ravel() for a in np.meshgrid(ys, xs, indexing="ij"))
    y1, x1 = np.minimum(y0 + tile_px[0], h), np.minimum(x0 + tile_px[1], w)
    src = [np.clip(v, 0, lim) for v, lim in ((sy0, h), (sy1, h), (sx0, w), (sx1, w))]
    return np.column_stack([y0, y1, x0, x1, *src]).astype(np.int64)


class LazyRectified:
    """A rectified image computed where indexed (``img[y0:y1, x0:x1]``).

    The matcher reads the grey images only in small patches and strips; rectifying just the
    area read (one remap of exactly that rectangle) saves most of a full remap. A BGR ``image``
    is converted to grey only in the source area of the read (the box of the pixels the remap reads,
    :func:`kernels_graph.read_box` over the fixed-point table: thirteenth pass; before, the union of
    the source boxes of the ``tile_px`` tiles it covers, 3-5x the pixels): the same grey image as
    converting it all first, as the conversion and the remap are per pixel. Nothing is cached: a
    read costs about its area. (``tile_px``: kept for callers; no longer used.)
    """

    def __init__(self, rectifier: Rectifier, image: np.ndarray, side: int, tile_px: tuple[int, int] = GREY_TILE_PX):
        self.rectifier, self.image, self.side = rectifier, image, side
        self.th, self.tw = tile_px
        w, h = rectifier.calib.image_size
        self.shape = (h, w)
        self.dtype = image.dtype
        self._grey = None                                   # BGR input: grey where reads need it

    def __getitem__(self, index):
        ys, xs = index
        y0, y1, _ = ys.indices(self.shape[0])
        x0, x1, _ = xs.indices(self.shape[1])
        if y1 <= y0 or x1 <= x0:
            return np.zeros((max(y1 - y0, 0), max(x1 - x0, 0)), self.dtype)
        src = self.image
        if src.ndim == 3:
            sy0, sy1, sx0, sx1 = kernels_graph.read_box(self.rectifier.maps[self.side][0], y0, y1, x0, x1,
                                                         *src.shape[:2])      # (exactly the pixels read)
            if sy1 <= sy0 or sx1 <= sx0:                    # the area sees nothing of the image
                return np.zeros((y1 - y0, x1 - x0), np.uint8)
            if self._grey is None:
                self._grey = np.empty(src.shape[:2], np.uint8)
            cv2.cvtColor(src[sy0:sy1, sx0:sx1], cv2.COLOR_BGR2GRAY, dst=self._grey[sy0:sy1, sx0:sx1])
            src = self._grey
        m1, m2 = self.rectifier.maps[self.side]
        return cv2.remap(src, m1[y0:y1, x0:x1], m2[y0:y1, x0:x1], cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=0)


class ReadBox:
    """Reads of an image (ndarray or :class:`LazyRectified`) served from one read of a rectangle
    ``[y0:y1, x0:x1]`` (clipped to the image) where they lie inside it, from the image itself elsewhere:
    several reads of one neighbourhood (a flat piece's coarse and fine texture searches) cost one
    lazy remap. The values are the image's (a lazy read is per pixel: the same values whatever
    rectangle they come with). Reads inside the rectangle are read-only views of one array."""

    def __init__(self, image, y0: int, y1: int, x0: int, x1: int):
        h, w = image.shape
        self.image, self.shape, self.dtype = image, (h, w), image.dtype
        self.box = (max(y0, 0), min(y1, h), max(x0, 0), min(x1, w))
        y0, y1, x0, x1 = self.box
        self.data = None
        if y1 > y0 and x1 > x0:
            self.data = np.asarray(image[y0:y1, x0:x1])
            self.data.setflags(write=False)

    def __getitem__(self, index):
        ys, xs = index
        a0, a1, _ = ys.indices(self.shape[0])
        b0, b1, _ = xs.indices(self.shape[1])
        y0, y1, x0, x1 = self.box
        if self.data is not None and y0 <= a0 < a1 <= y1 and x0 <= b0 < b1 <= x1:
            return self.data[a0 - y0:a1 - y0, b0 - x0:b1 - x0]
        return self.image[ys, xs]
