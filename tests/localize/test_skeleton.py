"""The sparse Zhang-Suen thinning is OpenCV's, pixel for pixel."""

from __future__ import annotations

import cv2
import numpy as np
from appliance.localize.graph import ENDPOINT, build_graph
from appliance.localize.skeleton import (
    Skeleton,
    SparseImage,
    block_mean,
    neighbour_code,
    remove_corners,
    skeletonize,
    zhang_suen,
)

from tests.localize.shapes import y_shape


def _blobs(seed: int, shape=(90, 120)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    m = (cv2.GaussianBlur(rng.random(shape), (0, 0), 3) > 0.5).astype(np.uint8) * 255
    m[0, rng.integers(0, shape[1], 30)] = 255           # foreground on the image border stays
    m[:, -1] = 255 * (rng.random(shape[0]) > 0.3)
    return m


def test_zhang_suen_is_opencv_thinning():
    masks = [y_shape(), np.full((20, 30), 255, np.uint8), np.zeros((10, 10), np.uint8)]
    masks += [_blobs(seed) for seed in range(20)]
    for m in masks:
        want = cv2.ximgproc.thinning(m, thinningType=cv2.ximgproc.THINNING_ZHANGSUEN) > 0
        got = zhang_suen(m)
        assert got.dtype == np.uint8 and got.shape == m.shape
        assert np.array_equal(got > 0, want)


def test_remove_corners_keeps_paths_connected_and_thin():
    skel = skeletonize(y_shape(), "thinning")
    thin = zhang_suen(y_shape())
    assert np.array_equal(skel.image, remove_corners(thin))
    assert skel.image.sum() < thin.sum()                              # staircase corners went
    n, _ = cv2.connectedComponents(skel.image, connectivity=8)
    assert n - 1 == 1


def test_a_one_pixel_bump_on_a_turn_goes_and_makes_no_junction():
    # Zhang-Suen leaves such a pixel on the outside of a turn (seen on real photographs): its two
    # neighbours touch each other, so it is redundant; kept, it made them a false junction
    img = np.zeros((10, 9), np.uint8)
    path = [(1, 2), (2, 3), (3, 4), (4, 5), (5, 5), (6, 5), (7, 5), (8, 5)]
    for y, x in path + [(4, 6)]:
        img[y, x] = 1
    out = remove_corners(img)
    assert out[4, 6] == 0 and all(out[y, x] for y, x in path)
    g = build_graph(Skeleton(out, 1, img))
    assert list(g.node_kind) == [ENDPOINT, ENDPOINT] and len(g.seg_yx) == 1


def test_fast_skeleton_block_mean_thresholds_as_one_area_resize():
    # every 4 x 4 block of a 0/255 mask (2^16 of them): the mean by halvings passes the fast
    # skeleton's threshold exactly where OpenCV's one-step 4x area resize does
    codes = np.arange(1 << 16)
    bits = ((codes[:, None] >> np.arange(16)) & 1).astype(np.uint8) * 255
    img = bits.reshape(256, 256, 4, 4).transpose(0, 2, 1, 3).reshape(1024, 1024)
    one = cv2.resize(img, (256, 256), interpolation=cv2.INTER_AREA)
    halved = block_mean(img, 4)
    assert np.array_equal(cv2.threshold(one, 76, 255, cv2.THRESH_BINARY)[1],
                          cv2.threshold(halved, 76, 255, cv2.THRESH_BINARY)[1])
    assert np.array_equal(one > 0, halved > 0)               # any pixel set: non-zero either way
    m = _blobs(3, (96, 128))
    small = cv2.threshold(cv2.resize(m, (32, 24), interpolation=cv2.INTER_AREA), 76, 255, cv2.THRESH_BINARY)[1]
    assert np.array_equal(skeletonize(m, "fast", 4).mask, small)


def test_sparse_codes_are_the_neighbour_codes():
    # a random image (all 256 codes occur), set pixels 1 or 2 (zhang_suen marks border pixels 2)
    rng = np.random.default_rng(7)
    for on in (1, 2):
        img = (rng.random((60, 80)) < 0.45).astype(np.uint8)
        sp = SparseImage.from_image(img)
        sp.flat[sp.flat > 0] = on
        yx = np.argwhere(np.ones_like(img))
        assert np.array_equal(sp.codes(sp.index(yx[:, 0], yx[:, 1])), neighbour_code(img)[yx[:, 0], yx[:, 1]])
    assert sp.codes(np.zeros(0, np.int64)).shape == (0,)
