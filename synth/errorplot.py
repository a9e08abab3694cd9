"""A picture of depth errors against true depth: one panel per method, each matched feature a dot.

    python -m appliance.synth.errorplot out/localize_accuracy.json out/accuracy_errors.png

reads the pooled scores ``benchmarks/localize_accuracy.py --json`` writes (or the benchmark draws it itself
with ``--plot``). Each panel plots dZ = reported Z - true Z (mm) against the true Z (mm) of every matched
feature: tips yellow, forks magenta. Dashed lines: the paper's +-6.2 mm (red) and issue 5's +-1.5 mm at
1000 mm (green). Errors past the panel's range are drawn as triangles on its edge and counted in its title.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from appliance.errors import ApplianceError

COLOURS = {"endpoint": (0, 190, 230), "bifurcation": (200, 0, 200)}
PAPER_MM = 6.2          # the paper's reported bound over 500-1500 mm
TARGET_MM = 1.5         # issue 5's bound at 1000 mm


@dataclass(frozen=True)
class Panel:
    """One method's matched features: true depth, signed depth error and kind, each (N,)."""

    title: str
    z_true_mm: np.ndarray
    dz_mm: np.ndarray
    kind: np.ndarray


def panels_from_scores(pooled: dict) -> list[Panel]:
    """One :class:`Panel` per method of a pooled benchmark JSON (``{method: Score.to_dict()}``)."""
    out = []
    for method, score in pooled.items():
        rows = [r for r in score["rows"] if r["truth_index"] >= 0 and r["result_id"] >= 0]
        out.append(Panel(method, np.array([r["z_true_mm"] for r in rows], float),
                         np.array([r["dz_mm"] for r in rows], float), np.array([r["kind"] for r in rows], str)))
    return out


def draw_panel(panel: Panel, size_px: tuple[int, int] = (560, 300), z_range_mm: tuple[float, float] = (500, 1500),
               dz_max_mm: float = 8.0) -> np.ndarray:
    """One panel, BGR (H, W, 3): dZ (mm, vertical, +-``dz_max_mm``) against true Z (mm, horizontal)."""
    w, h = size_px
    img = np.full((h, w, 3), 255, np.uint8)
    left, right, top, bottom = 46, 10, 26, 24
    z0, z1 = z_range_mm

    def to_px(z, dz):
        x = left + (np.asarray(z, float) - z0) / (z1 - z0) * (w - left - right)
        y = top + (dz_max_mm - np.asarray(dz, float)) / (2 * dz_max_mm) * (h - top - bottom)
        return x, y

    grey, font = (215, 215, 215), cv2.FONT_HERSHEY_SIMPLEX
    for z in np.arange(z0, z1 + 1, 250):
        x, _ = to_px(z, 0)
        cv2.line(img, (int(round(x)), top), (int(round(x)), h - bottom), grey, 1)
        cv2.putText(img, f"{z:.0f}", (int(x) - 14, h - 8), font, 0.38, (80, 80, 80), 1, cv2.LINE_AA)
    for dz in np.arange(-np.floor(dz_max_mm / 2) * 2, dz_max_mm + 0.1, 2):
        _, y = to_px(z0, dz)
        cv2.line(img, (left, int(round(y))), (w - right, int(round(y))), (120, 120, 120) if dz == 0 else grey, 1)
        cv2.putText(img, f"{dz:+.0f}", (6, int(y) + 4), font, 0.38, (80, 80, 80), 1, cv2.LINE_AA)
    for bound, colour, (za, zb) in ((PAPER_MM, (40, 40, 220), z_range_mm), (TARGET_MM, (40, 160, 40), (900, 1100))):
        for sign in (-1, 1):
            (xa, xb), (ya, _) = to_px([za, zb], [sign * bound] * 2)
            for xs in np.arange(xa, xb, 8):
                cv2.line(img, (int(xs), int(round(ya))), (int(min(xs + 4, xb)), int(round(ya))), colour, 1)
    z, dz = panel.z_true_mm, panel.dz_mm
    inside = np.abs(dz) <= dz_max_mm
    for kind in ("endpoint", "bifurcation"):        # forks last: they are fewer, drawn on top
        sel = panel.kind == kind
        x, y = to_px(z[sel & inside], dz[sel & inside])
        for xi, yi in zip(np.round(x).astype(int), np.round(y).astype(int)):
            cv2.circle(img, (xi, yi), 2, COLOURS[kind], -1, cv2.LINE_AA)
        x, _ = to_px(z[sel & ~inside], 0)
        for xi, above in zip(np.round(x).astype(int), dz[sel & ~inside] > 0):
            ye = top if above else h - bottom
            tip = np.array([[xi, ye], [xi - 4, ye + (7 if above else -7)], [xi + 4, ye + (7 if above else -7)]])
            cv2.fillConvexPoly(img, tip.astype(np.int32), COLOURS[kind], cv2.LINE_AA)
    p95 = float(np.percentile(np.abs(dz), 95)) if len(dz) else float("nan")
    title = f"{panel.title}: {len(dz)} features, p95 |dZ| {p95:.2f} mm, {int((~inside).sum())} past +-{dz_max_mm:g}"
    cv2.putText(img, title, (left, 17), font, 0.42, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.rectangle(img, (left, top), (w - right, h - bottom), (0, 0, 0), 1)
    return img


def draw_error_plot(panels: list[Panel], columns: int = 2, **kw) -> np.ndarray:
    """The panels in a grid of ``columns``, with a legend line below, BGR (H, W, 3)."""
    tiles = [draw_panel(p, **kw) for p in panels]
    if not tiles:
        raise ApplianceError("error plot: no method to draw")
    blank = np.full_like(tiles[0], 255)
    tiles += [blank] * (-len(tiles) % columns)
    grid = np.vstack([np.hstack(tiles[i:i + columns]) for i in range(0, len(tiles), columns)])
    legend = np.full((24, grid.shape[1], 3), 255, np.uint8)
    text = (f"x: true Z (mm); y: dZ = reported - true (mm). Dots: tips (yellow), forks (magenta). "
            f"Dashed: +-{PAPER_MM} mm (paper, red), +-{TARGET_MM} mm at 1000 mm (target, green)")
    cv2.putText(legend, text, (8, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (0, 0, 0), 1, cv2.LINE_AA)
    return np.vstack([grid, legend])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scores", type=Path, help="pooled scores JSON of benchmarks/localize_accuracy.py --json")
    ap.add_argument("out", type=Path, help="PNG (or JPEG) to write")
    ap.add_argument("--dz-max", type=float, default=8.0, metavar="MM", help="panels' vertical range, +-MM (default 8)")
    a = ap.parse_args(argv)
    try:
        try:
            pooled = json.loads(a.scores.read_text())
            panels = panels_from_scores(pooled)
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            raise ApplianceError(f"{a.scores}: not a pooled scores JSON of the accuracy benchmark ({exc})") from None
        img = draw_error_plot(panels, dz_max_mm=a.dz_max)
        a.out.parent.mkdir(parents=True, exist_ok=True)
        if not cv2.imwrite(str(a.out), img):
            raise ApplianceError(f"{a.out}: cannot write an image there")
    except ApplianceError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
