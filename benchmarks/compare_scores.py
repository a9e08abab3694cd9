"""Two runs of ``localize_accuracy.py --json`` side by side: what a change moved.

    python benchmarks/compare_scores.py BEFORE.json AFTER.json [--tol-mm 0.3] [--method "improved, colour masks"]

For each method both files hold (default: the improved variant with exact and with colour masks), one line per run:
p95 and largest |dZ| (mm), p95 of the four 250 mm bands, recall, precision, forks and tips found of those seen in
both views (false ones in brackets); then every true feature whose |dZ| moved by more than ``--tol-mm`` or that was
found in one run only. A feature is named by its index in its scene's truth, its kind and its true depth (the JSON's
rows carry no scene name; the depth tells scenes apart). Both files must come from the same scenes.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

BANDS_MM = [(500, 750), (750, 1000), (1000, 1250), (1250, 1500)]
METHODS = ["improved, true masks", "improved, colour masks"]


def figures(score: dict) -> str:
    """One line of a pooled score (``Score.to_dict``): p95, max, bands, recall, precision, forks, tips."""
    rows = score["rows"]
    found = [r for r in rows if r["truth_index"] >= 0 and r["result_id"] >= 0 and r["dz_mm"] is not None]
    dz = np.abs([r["dz_mm"] for r in found])
    z = np.array([r["z_true_mm"] for r in found])
    bands = [f"{np.percentile(dz[(z >= lo) & (z < hi)], 95):.2f}" if ((z >= lo) & (z < hi)).any() else "-"
             for lo, hi in BANDS_MM]
    counts = []
    for kind in ("bifurcation", "endpoint"):
        true = [r for r in rows if r["truth_index"] >= 0 and r["kind"] == kind]
        false = sum(r["truth_index"] < 0 and r["kind"] == kind for r in rows)
        counts.append(f"{sum(r['result_id'] >= 0 for r in true)}/{len(true)} ({false})")
    p95, mx = (f"{np.percentile(dz, 95):.2f}", f"{dz.max():.2f}") if len(dz) else ("-", "-")
    return (f"p95 {p95:>5}  max {mx:>6}  bands {' / '.join(bands):<26}  recall {score['recall']:.3f}  "
            f"precision {score['precision']:.3f}  forks {counts[0]:<12}  tips {counts[1]}")


def true_rows(score: dict) -> dict:
    """{(true index, kind, true Z rounded to 0.01 mm): signed dZ (mm), None where not found}."""
    return {(r["truth_index"], r["kind"], round(r["z_true_mm"], 2)): (r["dz_mm"] if r["result_id"] >= 0 else None)
            for r in score["rows"] if r["truth_index"] >= 0}


def moved(before: dict, after: dict, tol_mm: float) -> list[str]:
    """Lines for the true features found in one run only or whose |dZ| changed by more than ``tol_mm``."""
    a, b = true_rows(before), true_rows(after)
    out = []
    for key in sorted(a.keys() | b.keys(), key=lambda k: (k[2], k[0])):
        x, y = a.get(key), b.get(key)
        if (x is None) != (y is None) or (x is not None and abs(abs(y) - abs(x)) > tol_mm):
            fmt = [("missed" if v is None else f"{v:+.2f} mm") for v in (x, y)]
            out.append(f"  T{key[0]} {key[1]} at Z {key[2]:.0f} mm: {fmt[0]} -> {fmt[1]}")
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--tol-mm", type=float, default=0.3, help="list features whose |dZ| moved by more (default 0.3)")
    ap.add_argument("--method", action="append", help=f"a method of the JSON (default: {' and '.join(METHODS)})")
    a = ap.parse_args()
    runs = []
    for path in (a.before, a.after):
        try:
            runs.append(json.loads(path.read_text()))
        except (OSError, ValueError) as e:
            raise SystemExit(f"{path}: not a localize_accuracy.py --json file ({e})") from None
    for method in a.method or METHODS:
        if method not in runs[0] or method not in runs[1]:
            raise SystemExit(f"{method!r}: not in both files (they hold {sorted(runs[0])})")
        before, after = runs[0][method], runs[1][method]
        print(f"== {method}")
        print(f"before  {figures(before)}")
        print(f"after   {figures(after)}")
        print("\n".join(moved(before, after, a.tol_mm)) or f"  no feature moved by over {a.tol_mm} mm")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
