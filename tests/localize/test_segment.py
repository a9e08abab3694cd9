"""Colour recogniser clean-up: small components go, branches stay."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from appliance.localize.segment import drop_small


@pytest.mark.parametrize("size", [(240, 320), (243, 317)])     # blocks aligned with the image, and not
def test_drop_small_removes_specks_and_keeps_branches(size):
    h, w = size
    m = np.zeros(size, np.uint8)
    cv2.line(m, (10, 10), (w - 20, h - 30), 255, 5)             # a branch: ~1500 px
    cv2.circle(m, (w - 40, 30), 6, 255, -1)                    # a speck: ~110 px
    m[h - 2:, :3] = 255                                        # a speck in the corner
    out = drop_small(m, 400)
    assert out[30, w - 40] == 0 and not out[h - 2:, :3].any()
    branch = m.copy()
    branch[:60, w - 60:] = 0
    branch[h - 2:, :3] = 0
    assert np.array_equal(out, branch)                         # the branch is untouched, pixel for pixel
    assert drop_small(m, 5) is m                               # nothing to drop: the mask itself


def test_colour_recogniser_finds_bark_and_tells_leaves_at_points():
    from appliance.config import load_config
    from appliance.localize.segment import occluder_at, segment_color

    cfg = load_config().localize.segment
    img = np.full((120, 160, 3), (235, 206, 135), np.uint8)     # sky (BGR)
    cv2.rectangle(img, (70, 0), (90, 119), (40, 60, 90), -1)     # brown-grey bark, a vertical branch
    cv2.circle(img, (30, 60), 15, (40, 170, 60), -1)             # a green leaf
    mask, _ = segment_color(img, cfg)
    assert mask[:, 72:88].all() and not mask[:, :65].any() and not mask[:, 95:].any()
    pts = np.array([[30, 60], [80, 60], [150, 10], [-5, 60], [30, 200]])
    assert occluder_at(img, pts, cfg).tolist() == [True, False, False, False, False]


def test_reddish_grey_bark_is_bark_but_a_red_apple_is_not():
    """Bark with a little more blue than green (hue ~178, past the wrap) is still bark; a red
    apple of the same hue is far more saturated."""
    from appliance.config import load_config
    from appliance.localize.segment import segment_color

    cfg = load_config().localize.segment
    img = np.full((120, 160, 3), (235, 206, 135), np.uint8)     # sky (BGR)
    cv2.rectangle(img, (70, 0), (90, 119), (80, 76, 125), -1)    # reddish grey bark, B > G
    cv2.circle(img, (30, 60), 15, (30, 30, 180), -1)             # a red apple
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    assert hsv[60, 80, 0] > 170 and hsv[60, 30, 0] < 5          # hues on both sides of the wrap
    mask, _ = segment_color(img, cfg)
    assert mask[:, 72:88].all() and not mask[:, :65].any()


def test_mirrored_hue_range_equals_the_wrapped_one():
    """A range wrapping through red tested on RGB2HSV hues (one inRange each for the brown and the
    olive range) picks the same pixels as two on BGR2HSV hues, but for hue rounding at the bounds."""
    from dataclasses import replace

    from appliance.config import load_config
    from appliance.localize.segment import bark_hsv, hsv_bark

    cfg = replace(load_config().localize.segment, hue_min=170, hue_max=30)
    img = np.random.default_rng(1).integers(0, 256, (400, 500, 3), dtype=np.uint8)
    hsv, fast = bark_hsv(img, cfg)
    ref = hsv_bark(cv2.cvtColor(img, cv2.COLOR_BGR2HSV), cfg, img)
    assert np.array_equal(hsv[..., 1:], cv2.cvtColor(img, cv2.COLOR_BGR2HSV)[..., 1:])   # S, V as before
    assert cv2.countNonZero(ref) > 2000
    assert cv2.countNonZero(fast ^ ref) <= 5e-3 * cv2.countNonZero(ref)


def _branch_scene(bark_bgr, back_bgr, x0=60.3, x1=71.7, h=80, w=140, ss=8):
    """A vertical branch spanning x0..x1 (px, sub-pixel) over a plain background, rendered with
    ``ss`` supersamples per pixel (exact area mixing); its true coverage per pixel."""
    xs = (np.arange(w * ss) + 0.5) / ss
    inside = ((xs >= x0) & (xs <= x1)).astype(float).reshape(w, ss).mean(1)
    cover = np.tile(inside, (h, 1))
    img = cover[..., None] * np.array(bark_bgr, float) + (1 - cover[..., None]) * np.array(back_bgr, float)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8), cover


@pytest.mark.parametrize("back", [(235, 206, 135), (40, 120, 60), (60, 160, 140)])   # sky, foliage, grass
@pytest.mark.parametrize("bark", [(50, 62, 78), (25, 30, 38)])                        # lit, shaded bark
def test_unmix_edges_gives_outline_pixels_their_bark_share(back, bark):
    from appliance.localize.segment import unmix_edges

    img, cover = _branch_scene(bark, back)
    hard = np.where(cover == 1, 255, 0).astype(np.uint8)      # a recogniser's mask: the pure pixels only
    assert (cover[0] % 1 > 0.2).sum() == 2                     # ... and a mixed pixel at each side
    soft = unmix_edges(img, hard, 20)
    assert np.abs(soft[8:-8].astype(float) / 255 - cover[8:-8]).max() < 0.06     # coverage within 6 %
    assert np.array_equal(soft[8:-8] > 127, cover[8:-8] >= 0.5)                  # thresholded: the exact mask
    assert np.array_equal(soft[:, :58], hard[:, :58]) and np.array_equal(soft[:, 75:], hard[:, 75:])


def test_unmix_edges_keeps_pixels_it_cannot_tell():
    """A background of the bark's own chromaticity (dark soil) gives no share: the mask stays."""
    from appliance.localize.segment import unmix_edges

    img, _ = _branch_scene((50, 62, 78), (100, 124, 156))     # the same hue, twice as bright
    hard = np.zeros(img.shape[:2], np.uint8)
    hard[:, 61:71] = 255
    assert np.array_equal(unmix_edges(img, hard, 20), hard)
    assert np.array_equal(unmix_edges(img, np.zeros_like(hard), 20), np.zeros_like(hard))


def test_unmix_edges_on_a_ragged_size_and_in_place():
    """Sizes not a multiple of the block: the whole blocks are unmixed, the last rows and columns kept;
    ``out=mask`` writes into the mask itself."""
    from appliance.localize.segment import unmix_edges

    img, cover = _branch_scene((50, 62, 78), (235, 206, 135), h=83, w=141)
    hard = np.where(cover == 1, 255, 0).astype(np.uint8)
    soft = unmix_edges(img, hard, 20)
    assert np.array_equal(soft[:80] > 127, cover[:80] >= 0.5)
    assert np.array_equal(soft[80:], hard[80:])                 # 83 = 4 * 20 + 3: the last 3 rows kept
    same = hard.copy()
    assert unmix_edges(img, same, 20, out=same) is same and np.array_equal(same, soft)


def test_unmix_edges_band_reaches_an_outline_smeared_over_two_pixels():
    """Colour smeared over 3 px across the outline (as JPEG's half-size chroma does): the band of
    2 px reaches every mixed pixel, the band of 1 px leaves the outermost ones as they were."""
    from appliance.localize.segment import unmix_edges

    img, cover = _branch_scene((50, 62, 78), (40, 120, 60), x0=61.0, x1=75.0)
    img = cv2.blur(img, (3, 1), borderType=cv2.BORDER_REPLICATE)
    cover = cv2.blur(cover, (3, 1), borderType=cv2.BORDER_REPLICATE)
    hard = np.where(cover > 0.99, 255, 0).astype(np.uint8)
    err = [np.abs(unmix_edges(img, hard, 20, band).astype(float) / 255 - cover)[8:-8].max() for band in (1, 2)]
    assert (cover[0] % 1 > 0.2).sum() == 4                     # two mixed pixels at each side
    assert err[0] > 0.25 and err[1] < 0.06


def test_segment_mask_tests_bark_only_near_bark_and_gives_the_same_mask():
    """The localizer's recogniser converts and thresholds only the tiles near sampled bark: on the
    fixture scenes the cleaned, unmixed mask is segment_color's pixel for pixel, and the raw mask
    only lacks pixels (never adds any) far from everything the clean-up keeps."""
    from pathlib import Path

    from appliance.config import load_config
    from appliance.localize.segment import bark_hsv, bark_mask, segment_color, segment_mask

    cfg = load_config().localize.segment
    root = Path(__file__).resolve().parents[2] / "fixtures" / "scenes"
    for name in ("left_00.png", "right_01.png", "left_02.png", "right_03.png"):
        img = cv2.imread(str(root / name))
        _, ref = bark_hsv(img, cfg)
        raw = bark_mask(img, cfg)
        assert cv2.countNonZero(raw & ~ref) == 0 and cv2.countNonZero(raw) > 0.99 * cv2.countNonZero(ref)
        assert np.array_equal(segment_mask(img, cfg), segment_color(img, cfg)[0])
    # bark nowhere near a sampled pixel: a 2 px wide line between the sampled rows is not tested
    img = np.full((128, 128, 3), (235, 206, 135), np.uint8)
    img[5:7, 10:120] = (40, 60, 90)
    assert not bark_mask(img, cfg).any() and bark_hsv(img, cfg)[1][5:7, 10:120].all()
    assert np.array_equal(bark_mask(img, cfg, sample=1), bark_hsv(img, cfg)[1])


def test_a_probability_mask_is_coverage_rounded_half_up_and_clipped():
    """as_mask's float path (in place, nan_to_num only when needed) is clip(nan_to_num(p) * 255 + 0.5,
    0, 255) as uint8, NaN and infinities included."""
    from appliance.localize.segment import as_mask

    rng = np.random.default_rng(4)
    for dtype in (np.float32, np.float64):
        p = rng.normal(0.5, 0.6, (60, 80)).astype(dtype)
        p.flat[:1000] = (np.arange(1000) / 999 * 1.2 - 0.1).astype(dtype)
        want = np.clip(p * 255.0 + 0.5, 0, 255).astype(np.uint8)
        assert np.array_equal(as_mask(p, p.shape, "m"), want)
        p.flat[rng.integers(0, p.size, 50)] = np.nan
        p.flat[1:3], p.flat[3:5] = np.inf, -np.inf
        with np.errstate(over="ignore"):
            want = np.clip(np.nan_to_num(p) * 255.0 + 0.5, 0, 255).astype(np.uint8)
        got = as_mask(p, p.shape, "m")
        assert np.array_equal(got, want) and got[0, 1] == 255 and got[0, 3] == 0


@pytest.mark.parametrize("size", [(240, 320), (243, 317)])
def test_drop_small_keeps_short_wide_twig_pieces_and_drops_thin_specks(size):
    h, w = size
    m = np.zeros(size, np.uint8)
    cv2.line(m, (40, 40), (56, 56), 255, 10)                   # a twig's piece beyond a leaf: r 5 px, ~330 px
    cv2.line(m, (160, 30), (220, 30), 255, 3)                  # a thin streak: ~320 px, 5 px wide
    cv2.circle(m, (100, 150), 3, 255, -1)                      # a speck: r 3 px
    m[h - 8:, w - 8:] = 255                                    # a wide piece in the padded corner block
    assert cv2.countNonZero(m[20:90, 20:90]) < 400
    out = drop_small(m, 400, keep_radius_px=3.5)
    twig = np.zeros_like(m)
    twig[20:90, 20:90] = m[20:90, 20:90]
    twig[h - 8:, w - 8:] = 255
    assert np.array_equal(out, twig)                           # the pieces kept whole, streak and speck gone
    assert not drop_small(m, 400)[20:90, 20:90].any()          # keep_radius_px 0: dropped as before
    assert not drop_small(m, 400, keep_radius_px=8.0)[20:90, 20:90].any()   # wider than the piece: dropped


def test_colour_recogniser_keeps_a_twig_tip_beyond_a_leaf():
    from appliance.config import load_config
    from appliance.localize.segment import segment_color

    cfg = load_config().localize.segment
    img = np.full((160, 200, 3), (235, 206, 135), np.uint8)     # sky (BGR)
    cv2.line(img, (0, 80), (116, 80), (40, 60, 90), 11)          # a twig, r ~5.5 px ...
    cv2.circle(img, (95, 80), 14, (40, 170, 60), -1)             # ... cut by a leaf: 15 px of it beyond
    mask, _ = segment_color(img, cfg)
    assert (mask[77:84, 112:120] >= 128).all()                   # the piece beyond the leaf, with its end
    assert not (mask[:, 125:] >= 128).any() and not (mask[70:91, 85:105] >= 128).any()


def test_drop_small_keeps_wide_pieces_only_of_the_bark_chromaticity():
    m = np.zeros((200, 240), np.uint8)
    cv2.line(m, (10, 150), (230, 150), 255, 21)                 # a limb: the large component
    cv2.line(m, (40, 40), (56, 56), 255, 10)                   # a twig's piece, ~330 px
    img = np.full((200, 240, 3), (60, 110, 70), np.uint8)      # green-brown background (BGR)
    bark = (40, 60, 90)
    img[m > 0] = bark
    kept = drop_small(m, 400, keep_radius_px=3.5, bgr=img, keep_chroma_deg=3.0)
    assert np.array_equal(kept, m)                             # the piece has the limb's bark: kept
    shade = img.copy()
    shade[:100] //= 2                                          # in shadow: darker, same chromaticity
    assert np.array_equal(drop_small(m, 400, keep_radius_px=3.5, bgr=shade, keep_chroma_deg=3.0), m)
    olive = img.copy()
    olive[:100][m[:100] > 0] = (40, 75, 90)                    # a blob of another colour (~9 deg off)
    out = drop_small(m, 400, keep_radius_px=3.5, bgr=olive, keep_chroma_deg=3.0)
    assert not out[:100].any() and np.array_equal(out[100:], m[100:])
    assert np.array_equal(drop_small(m, 400, keep_radius_px=3.5, bgr=olive, keep_chroma_deg=0.0), m)
    alone = m.copy()
    alone[100:] = 0                                            # no large component: no bark to compare with
    assert not drop_small(alone, 400, keep_radius_px=3.5, bgr=img, keep_chroma_deg=3.0).any()


# backgrounds as the renderer's (two colours mixed by smooth noise; BGR) and bark from grey to brown to olive
_BACKS = {"sky": ((219, 168, 115), (237, 235, 230)), "foliage": ((25, 56, 31), (64, 140, 107)),
          "grass": ((38, 115, 102), (77, 158, 158))}
_BARKS = {"brown": (69, 84, 102), "grey": (40, 47, 45), "blue-grey": (50, 46, 43), "olive": (44, 66, 58)}


def _smooth(rng, h, w, sigma_px):
    t = cv2.GaussianBlur(rng.random((h, w)), (0, 0), sigma_px)
    return (t - t.min()) / (t.max() - t.min())


def _textured_branch(bark_bgr, back, seed=0, h=240, w=320, noise=2.0):
    """A slanted branch (radius ~9 px, anti-aliased) lit from one side, its bark textured (brightness x
    0.75-1.25), over a background of two colours mixed by smooth noise, with sensor noise; the image (H, W, 3)
    uint8 and the branch's coverage (H, W) 0-1."""
    rng = np.random.default_rng(seed)
    a, b = (np.array(c, float) for c in back)
    t = _smooth(rng, h, w, 10)[..., None]
    img = a * (1 - t) + b * t
    k = 4                                                      # supersamples per side
    big = np.zeros((h * k, w * k), np.uint8)
    cv2.line(big, (120 * k, -10), (200 * k, h * k + 10), 255, 18 * k)
    cover = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA).astype(float) / 255
    ys, xs = np.mgrid[0:h, 0:w]
    across = ((xs - 120) - (ys * 80 / h)) / 9.0                # -1..1 across the branch
    light = np.clip(0.95 + 0.3 * across, 0.6, 1.25)            # lit side right, shaded left
    tex = 0.75 + 0.5 * _smooth(rng, h, w, 1.5)
    bark = np.array(bark_bgr, float) * (light * tex)[..., None]
    img = cover[..., None] * bark + (1 - cover[..., None]) * img + rng.normal(0, noise, img.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8), cover


@pytest.mark.parametrize("back", sorted(_BACKS))
@pytest.mark.parametrize("bark", sorted(_BARKS))
def test_grey_brown_and_olive_bark_is_found_on_sky_foliage_and_grass(bark, back):
    """Real bark runs from grey to brown to olive-green-grey: with the default thresholds each is the
    branch over each background (the inside whole, nothing off it); grey bark's hue is noise (any hue,
    by its chroma), olive's is past the brown range (hue 30-45)."""
    from appliance.config import load_config
    from appliance.localize.segment import segment_color, segment_mask

    cfg = load_config().localize.segment
    img, cover = _textured_branch(_BARKS[bark], _BACKS[back])
    mask = segment_mask(img, cfg)
    inside = cv2.erode((cover >= 0.99).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    off = cv2.dilate((cover > 0).astype(np.uint8), np.ones((7, 7), np.uint8)) == 0
    assert (mask[inside] >= 128).mean() > (0.99 if bark in ("brown", "grey") else 0.95)   # (olive: hue ~41 +- noise,
    assert not (mask[off] >= 128).any()                     # blue-grey's lit side: chroma 11-13; holes in the texture)
    assert np.array_equal(mask, segment_color(img, cfg)[0])


def test_grey_and_olive_bark_need_their_thresholds():
    """Grey bark on sky and olive bark on grass were lost whole by the brown range alone (seeds 370, 165,
    199, 279); each of the two keys brings its own back, and 0 turns it off."""
    from dataclasses import replace

    from appliance.config import load_config
    from appliance.localize.segment import segment_mask

    cfg = load_config().localize.segment
    grey, area = _textured_branch((34, 40, 38), _BACKS["sky"])    # seed 370's bark: hue ~40, chroma ~6
    olive, _ = _textured_branch((40, 61, 54), _BACKS["grass"])    # seed 165's: hue ~40, saturation ~88
    n = area.sum()                                                # the branch's area, px

    def found(img, **keys):
        return (segment_mask(img, replace(cfg, **keys)) >= 128).sum() / n

    assert found(grey) > 0.95 and found(olive) > 0.85
    assert found(grey, olive_saturation_max=0, grey_chroma_max=0) == 0          # the brown range alone
    assert found(olive, olive_saturation_max=0, grey_chroma_max=0) == 0
    assert found(grey, olive_saturation_max=0) > 0.95                           # the grey test alone
    assert found(olive, grey_chroma_max=0) > 0.85 and found(olive, olive_saturation_max=0) < 0.1


def test_sky_leaves_apples_and_grass_are_not_bark():
    """No branch in the view: blue sky with clouds, leaves lit and in shadow, red and red-yellow apples,
    grass: the recogniser finds nothing (a leaf in deep shadow, BGR 22/35/27, is the nearest: chroma 13)."""
    from appliance.config import load_config
    from appliance.localize.segment import segment_color, segment_mask

    cfg = load_config().localize.segment
    rng = np.random.default_rng(3)
    h, w = 240, 320
    t = _smooth(rng, h, w, 10)[..., None]
    sky_a, sky_b = (np.array(c, float) for c in _BACKS["sky"])
    img = sky_a * (1 - t) + sky_b * t
    g_a, g_b = (np.array(c, float) for c in _BACKS["grass"])
    img[180:] = (g_a * (1 - t) + g_b * t)[180:]                    # grass below
    for (x, y), col in (((40, 40), (25, 56, 31)), ((100, 50), (64, 140, 107)), ((160, 40), (22, 35, 27)),
                        ((220, 60), (40, 170, 60))):                # leaves: dark, light, in shadow, bright
        cv2.ellipse(img, (x, y), (22, 10), 30, 0, 360, col, -1)
    cv2.circle(img, (80, 130), 28, (30, 30, 180), -1)               # a red apple
    cv2.circle(img, (200, 130), 28, (40, 110, 200), -1)             # a red-yellow one
    cv2.circle(img, (200, 130), 12, (30, 40, 150), -1)              # ... with a darker blush
    img = cv2.GaussianBlur(img, (0, 0), 0.7) + rng.normal(0, 2.0, img.shape)
    img = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    assert not (segment_mask(img, cfg) >= 128).any()
    assert not (segment_color(img, cfg)[0] >= 128).any()
