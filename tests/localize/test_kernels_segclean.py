"""The segment stage's component clean-up kernels (localize/kernels_segclean.py, speedseg) against the numpy /
OpenCV code they replace (kept here as the reference: the start's ``drop_small`` and ``_bark_chroma``)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from appliance.commands.common import effective_config
from appliance.localize import kernels_segment
from appliance.localize.segment import _K3, _disc_offsets, _near_chroma, drop_small, sample_nearest, segment_mask
from appliance.localize.skeleton import block_mean

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"


def _bark_chroma_ref(bgr, cover, small_blocks, factor, sampled=False):
    full = cv2.compare(cover, 255, cv2.CMP_EQ)
    full.reshape(-1)[small_blocks] = 0
    inner = cv2.erode(full, _K3, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    use = inner if cv2.countNonZero(inner) else full
    if not cv2.countNonZero(use):
        return None
    first = bgr if sampled else sample_nearest(bgr, factor)
    hs, ws = min(first.shape[0], use.shape[0]), min(first.shape[1], use.shape[1])
    c = np.array(cv2.mean(first[:hs, :ws], mask=np.ascontiguousarray(use[:hs, :ws]))[:3])
    n = float(np.linalg.norm(c))
    return c / n if n > 0 else None


def drop_small_ref(mask, min_area_px, factor=4, keep_radius_px=0.0, bgr=None, keep_chroma_deg=0.0, small_bgr=None):
    """The replaced code (d94870a's ``segment.drop_small``)."""
    h, w = mask.shape
    hs, ws = -(-h // factor), -(-w // factor)
    if (hs * factor, ws * factor) != (h, w):
        pad = cv2.copyMakeBorder(mask, 0, hs * factor - h, 0, ws * factor - w, cv2.BORDER_CONSTANT, value=0)
        bpad = None if bgr is None else cv2.copyMakeBorder(bgr, 0, hs * factor - h, 0, ws * factor - w,
                                                           cv2.BORDER_CONSTANT, value=0)
        out = drop_small_ref(pad, min_area_px, factor, keep_radius_px, bpad, keep_chroma_deg)
        return mask if out is pad else out[:h, :w]
    cover = block_mean(mask, factor)
    n, labels = cv2.connectedComponents(cover, connectivity=8, ltype=cv2.CV_32S)
    if n <= 1:
        return mask
    idx = np.flatnonzero(cover != 0)
    lab = labels.reshape(-1).take(idx)
    area = np.bincount(lab, weights=np.rint(cover.reshape(-1).take(idx) * (factor * factor / 255.0)), minlength=n)
    small = area < min_area_px
    small[0] = False
    if not small.any():
        return mask
    if keep_radius_px > 0:
        sel = small[lab] & (area[lab] >= np.pi * keep_radius_px ** 2)
        if sel.any():
            ids, comp = np.unique(lab[sel], return_inverse=True)
            gy, gx = np.divmod(idx[sel], ws)
            dy, dx = _disc_offsets(float(keep_radius_px))
            comp = comp.astype(np.int64)
            if bgr is None or keep_chroma_deg <= 0:
                keep = kernels_segment.blocks_hold_disc(mask, gy, gx, comp, len(ids), factor, dy, dx)
            else:
                count, sums = kernels_segment.blocks_disc_colour(mask, bgr, gy, gx, comp, len(ids), factor, dy, dx)
                keep = count > 0
                if keep.any():
                    chi = _bark_chroma_ref(bgr if small_bgr is None else small_bgr, cover, idx[small[lab]], factor,
                                           sampled=small_bgr is not None)
                    keep &= _near_chroma(sums, chi, keep_chroma_deg)
            small[ids[keep]] = False
            if not small.any():
                return mask
    out = mask.copy()
    gy, gx = np.divmod(idx[small[lab]], ws)
    out.reshape(hs, factor, ws, factor)[gy, :, gx, :] = 0
    return out


def _blobs(rng, h, w, share):
    """A random 0/255 mask of blobs of many sizes (specks to limbs), and a BGR image of bark-like colours
    (two chromaticities, so the colour test keeps some wide pieces and drops others)."""
    f = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), float(rng.uniform(1.0, 6.0)))
    m = np.where(f > np.quantile(f, 1 - share), 255, 0).astype(np.uint8)
    img = np.empty((h, w, 3), np.uint8)
    img[:] = (40, 60, 90)
    img[: h // 2, : w // 2] = (40, 75, 90)
    img += rng.integers(0, 3, (h, w, 3), dtype=np.uint8)
    return m, img


@pytest.mark.parametrize("h, w", [(240, 320), (96, 128), (101, 77), (37, 19), (8, 12)])
def test_drop_small_random_masks(h, w):
    rng = np.random.default_rng(h * 1000 + w)
    for trial in range(12):
        m, img = _blobs(rng, h, w, float(rng.uniform(0.02, 0.4)))
        for kw in (dict(), dict(keep_radius_px=3.5), dict(keep_radius_px=3.5, bgr=img, keep_chroma_deg=3.0),
                   dict(keep_radius_px=2.0, bgr=img, keep_chroma_deg=10.0)):
            area = float(rng.choice([30, 100, 400, 1500]))
            want = drop_small_ref(m, area, **kw)
            got = drop_small(m, area, **kw)
            np.testing.assert_array_equal(got, want)                      # atol 0 (px values)
            assert (got is m) == (want is m)
            if h % 4 == 0 and w % 4 == 0 and "bgr" in kw:                # the sample passed, in place
                small = sample_nearest(img, 4)
                want = drop_small_ref(m, area, small_bgr=small, **kw)
                out = m.copy()
                got = drop_small(out, area, small_bgr=small, out=out, **kw)
                np.testing.assert_array_equal(got, want)
                np.testing.assert_array_equal(out, want)


def test_drop_small_constructed():
    """Pieces at the image's edges and corners, one touching the large component diagonally only, a wide
    piece of the bark's colour, a whole-block limb (the whole blocks' inner part)."""
    m = np.zeros((120, 160), np.uint8)
    img = np.full((120, 160, 3), (60, 110, 70), np.uint8)
    m[40:80, :80] = 255                                          # a limb from the left edge (whole blocks)
    m[0:3, 0:3] = 255                                            # a speck in a corner
    m[117:, 150:] = 255                                          # ... and the opposite one
    m[80:84, 80:84] = 255                                        # touches the limb diagonally (blocks)
    cv2.circle(m, (30, 15), 7, 255, -1)                          # a wide piece, ~150 px
    cv2.circle(m, (130, 15), 7, 255, -1)                         # ... another, of another colour
    img[m > 0] = (40, 60, 90)
    img[5:25, 120:140][m[5:25, 120:140] > 0] = (40, 80, 90)
    for kw in (dict(), dict(keep_radius_px=3.5), dict(keep_radius_px=3.5, bgr=img, keep_chroma_deg=3.0)):
        want, got = drop_small_ref(m, 400, **kw), drop_small(m, 400, **kw)
        np.testing.assert_array_equal(got, want)
    got = drop_small(m, 400, keep_radius_px=3.5, bgr=img, keep_chroma_deg=3.0)
    assert got[15, 30] == 255 and got[15, 130] == 0 and got[1, 1] == 0 and got[82, 82] == 255


@pytest.mark.parametrize("n", ["00", "03"])
def test_segment_mask_fixtures_against_the_start(n):
    """The whole stage on fixture images (03: grass, the whole image tested) with the reference clean-up."""
    import appliance.localize.segment as seg

    cfg = effective_config(None).localize.segment
    img = cv2.imread(str(FIXTURES / f"left_{n}.png"))
    got = segment_mask(img, cfg)
    real = seg.drop_small
    seg.drop_small = lambda m, *a, out=None, **k: drop_small_ref(m, *a, **k)
    try:
        want = segment_mask(img, cfg)
    finally:
        seg.drop_small = real
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("h, w", [(240, 320), (101, 77), (3, 40), (37, 5)])
def test_morphology_kernels_over_one_whole_image_tile(h, w):
    """The whole image tested (grass): ``segment_mask`` runs the tiles' kernels over one tile of the image's
    size; a raw mask anywhere (specks, holes, the image's edges) gives OpenCV's opening + closing and
    gradient, atol 0."""
    rng = np.random.default_rng(h + 7 * w)
    one = np.ones((1, 1), np.uint8)
    cross = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3))
    for dense in (0.1, 0.5, 0.9):
        raw = np.where(rng.random((h, w)) < dense, 255, 0).astype(np.uint8)
        want = cv2.morphologyEx(cv2.morphologyEx(raw, cv2.MORPH_OPEN, cross), cv2.MORPH_CLOSE, cross)
        grad = cv2.morphologyEx(want, cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8))
        for tile_px in (h, max(h, w)):             # (segment_mask passes the height)
            got = kernels_segment.open_close_tiles(raw, one, tile_px, np.zeros_like(raw))
            np.testing.assert_array_equal(got, want)
            np.testing.assert_array_equal(kernels_segment.gradient_tiles(want, one, tile_px, raw.copy()), grad)
