"""Procedural textures (periodic FFT noise): bark, and the backgrounds (sky, blurred foliage, grass)."""

from __future__ import annotations

import cv2
import numpy as np


def fft_noise(shape: tuple[int, int], rng: np.random.Generator, beta: float = 2.0,
              stretch: tuple[float, float] = (1.0, 1.0), cutoff: float = 0.0) -> np.ndarray:
    """Periodic ``1/f^beta`` noise, zero mean, unit standard deviation, float32 of ``shape`` (rows, cols).

    ``stretch`` scales the frequencies per axis (rows, cols): a larger value makes the pattern coarser
    (longer features) along that axis. Frequencies below ``cutoff`` (cycles per texel) are removed.
    """
    fy = np.fft.fftfreq(shape[0])[:, None] * stretch[0]
    fx = np.fft.rfftfreq(shape[1])[None, :] * stretch[1]
    f = np.hypot(fy, fx)
    amp = np.where(f > max(cutoff, 1e-6), 1.0 / np.maximum(f, 1e-6) ** (beta / 2), 0.0)
    spec = amp * (rng.normal(size=f.shape) + 1j * rng.normal(size=f.shape))
    n = np.fft.irfft2(spec, s=shape)
    return ((n - n.mean()) / (n.std() + 1e-12)).astype(np.float32)


def lookup(tex: np.ndarray, u: np.ndarray, v: np.ndarray, max_rows: int = 32000) -> np.ndarray:
    """Bilinear, wrapping lookup of ``tex`` (rows, cols[, C]) at texel coordinates ``u`` (col), ``v`` (row).

    ``u``, ``v`` : ndarray (N,). Returns (N,) or (N, C) float32. The points go to ``cv2.remap`` as rows
    of 1024, at most ``max_rows`` rows per call (remap's maps must stay under 32767 rows: more than
    ~33 M points, e.g. a render with 8 x 8 supersamples, are looked up in pieces; the same values).
    """
    n = np.size(u)
    width = 1024
    if n > max_rows * width:
        u, v, step = np.ravel(u), np.ravel(v), max_rows * width
        return np.concatenate([lookup(tex, u[i:i + step], v[i:i + step], max_rows) for i in range(0, n, step)])
    rows = max(1, -(-n // width))
    mx = np.zeros(rows * width, np.float32)
    my = np.zeros(rows * width, np.float32)
    mx[:n] = np.mod(np.ravel(u), tex.shape[1])        # remap's fixed-point maps need small coordinates
    my[:n] = np.mod(np.ravel(v), tex.shape[0])
    out = cv2.remap(tex, mx.reshape(rows, width), my.reshape(rows, width), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_WRAP)
    return out.reshape((rows * width,) + tex.shape[2:])[:n]


def bark_texture(rng: np.random.Generator, around: int = 256, along: int = 2048) -> np.ndarray:
    """Brightness factor (~0.5-1.3) of bark; rows go around the branch, columns along it (0.5 mm per column)."""
    ridges = fft_noise((around, along), rng, beta=2.6, stretch=(1.0, 6.0))
    fissure = np.clip((ridges + 0.9) / 0.6, 0, 1)             # dark cracks where ridges are low
    fine = fft_noise((around, along), rng, beta=1.2)
    spots = fft_noise((around, along), rng, beta=1.0) > 2.6     # lenticels
    tex = 0.55 + 0.55 * fissure + 0.08 * fine + 0.25 * spots
    return tex.astype(np.float32)


def background_texture(kind: str, rng: np.random.Generator, size: int = 1024) -> np.ndarray:
    """A BGR float32 (0..1) background of ``kind`` ("sky", "foliage", "grass", "mixed"), rows = up..down.

    The texture is mapped onto a plane far behind the tree (``texel_mm`` in :mod:`scene`).
    """
    big = fft_noise((size, size), rng, beta=2.8)
    mid = fft_noise((size, size), rng, beta=2.0)
    fine = fft_noise((size, size), rng, beta=1.0)
    rows = np.linspace(0, 1, size, dtype=np.float32)[:, None]

    def mix(a, b, w):
        return a[None, None, :] * (1 - w[..., None]) + b[None, None, :] * w[..., None]

    sky_blue, cloud = np.array([0.86, 0.66, 0.45]), np.array([0.93, 0.92, 0.90])
    sky = mix(sky_blue, cloud, np.clip(0.5 + 0.45 * big, 0, 1) * (0.6 + 0.4 * rows))
    leaf_dark, leaf_light = np.array([0.10, 0.22, 0.12]), np.array([0.25, 0.55, 0.42])
    blobs = np.clip(0.5 + 0.35 * mid + 0.15 * big, 0, 1)
    foliage = mix(leaf_dark, leaf_light, blobs)
    foliage = cv2.GaussianBlur(foliage.astype(np.float32), (0, 0), 3.0)
    grass_a, grass_b = np.array([0.15, 0.45, 0.40]), np.array([0.30, 0.62, 0.62])
    streaks = fft_noise((size, size), rng, beta=2.0, stretch=(6.0, 1.0))
    grass = mix(grass_a, grass_b, np.clip(0.5 + 0.3 * streaks + 0.1 * fine, 0, 1))
    if kind == "sky":
        out = sky
    elif kind == "foliage":
        out = foliage
    elif kind == "grass":
        out = grass
    elif kind == "mixed":
        horizon = 0.45 + 0.06 * fft_noise((1, size), rng, beta=4.0)
        w_sky = np.clip((horizon - rows) / 0.05, 0, 1)
        w_grass = np.clip((rows - 0.75 - 0.05 * mid) / 0.05, 0, 1)
        out = sky * w_sky[..., None] + foliage * (1 - w_sky[..., None])
        out = out * (1 - w_grass[..., None]) + grass * w_grass[..., None]
        gaps = np.clip((big - 1.3) / 0.3, 0, 1) * (1 - w_grass)          # sky seen through the canopy
        out = out * (1 - gaps[..., None]) + sky * gaps[..., None]
    else:
        raise ValueError(f"background kind must be sky, foliage, grass or mixed, not {kind!r}")
    return np.clip(out * (1 + 0.03 * fine[..., None]), 0, 1).astype(np.float32)
