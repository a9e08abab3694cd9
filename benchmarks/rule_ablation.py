"""What each of the localizer's rule switches does now: every switch turned over in turn, the scenes scored again.

    python benchmarks/rule_ablation.py [--extra 56] [--seeds A-B ...] [--masks true|colour|both]
                                       [--rules forkends.LONE_TAPER ...] [--json OUT]

The switches are the boolean module constants of ``localize/`` (``forkends.LONE_TAPER``, ``dense.STUB_TIPS``, ...:
each a rule that a round added for a case it measured, tested off and on in tests/localize). Over the scenes
(``localize_accuracy.py``'s: the fixtures plus ``--extra`` seeds 100.., and each ``--seeds A-B`` range; read from the
scene cache, rendered if missing), the improved localizer runs once as configured and once per switch with that
switch turned over (``--rules`` names some; default all). Per switch it prints what moved against the configured
run, feature by feature (a true feature's |dZ| changing by more than 0.05 mm; found -> missed and back; false
features gained and lost) and the pooled p95 / largest |dZ| (mm) both ways. A switch under which nothing moves on
many scenes is a rule that later rules have made redundant, or whose case is no longer there: a candidate for
removal. ``--json`` writes the figures.
"""

from __future__ import annotations

import argparse
import importlib
import json
import pkgutil
import sys
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from localize_accuracy import REPO, _seed_range, scenes  # noqa: E402

import appliance.localize  # noqa: E402
from appliance.calibrate.model import load_calibration  # noqa: E402
from appliance.config import load_config  # noqa: E402
from appliance.localize import Localizer  # noqa: E402
from appliance.synth.evaluate import feature_rows  # noqa: E402
from appliance.synth.truth import load_truth  # noqa: E402

MOVED_MM = 0.05      # a found feature whose |dZ| changes by more than this has moved


def switches() -> list[str]:
    """``module.NAME`` of every boolean upper-case module constant of ``appliance.localize``'s modules."""
    out = []
    for info in pkgutil.iter_modules(appliance.localize.__path__):
        if info.name.startswith("kernels"):
            continue
        mod = importlib.import_module(f"appliance.localize.{info.name}")
        out += [f"{info.name}.{k}" for k, v in vars(mod).items() if k.isupper() and not k.startswith("_") and isinstance(v, bool)]
    return sorted(out)


def run_all(loc: Localizer, pairs: list, modes: list[str]) -> dict:
    """{(scene, mode): {truth index: (found, |dZ| mm)}, plus the false features' count under key -1}."""
    out = {}
    for name, left, right, truth in pairs:
        for mode in modes:
            kw = dict(zip(("mask_left", "mask_right"), truth.exact_masks(soft=False))) if mode == "true" else {}
            rows, _ = feature_rows(loc.localize(left, right, **kw), truth)
            seen = {r.truth_index: (r.result_id >= 0, abs(r.dz_mm) if r.result_id >= 0 else np.nan)
                    for r in rows if r.truth_index >= 0}
            seen[-1] = sum(r.truth_index < 0 for r in rows)
            out[(name, mode)] = seen
    return out


def compare(base: dict, other: dict) -> dict:
    """What moved from ``base`` to ``other`` (both :func:`run_all`'s), and the pooled p95 / max |dZ| of each."""
    moved = lost = gained = false_more = false_fewer = 0
    scenes_moved = set()
    for key, b in base.items():
        o = other[key]
        n = sum(1 for t in b if t >= 0 and b[t][0] and o.get(t, (False,))[0] and abs(b[t][1] - o[t][1]) > MOVED_MM)
        lo = sum(1 for t in b if t >= 0 and b[t][0] and not o.get(t, (False,))[0])
        ga = sum(1 for t in o if t >= 0 and o[t][0] and not b.get(t, (False,))[0])
        df = o[-1] - b[-1]
        moved, lost, gained = moved + n, lost + lo, gained + ga
        false_more, false_fewer = false_more + max(df, 0), false_fewer + max(-df, 0)
        if n or lo or ga or df:
            scenes_moved.add(key)

    def pooled(run):
        dz = np.array([v[1] for s in run.values() for t, v in s.items() if t >= 0 and v[0]])
        return float(np.percentile(dz, 95)), float(dz.max())

    return dict(moved=moved, lost=lost, gained=gained, false_more=false_more, false_fewer=false_fewer,
                scenes=len(scenes_moved), base=pooled(base), off=pooled(other),
                where=sorted(f"{k[0]} {k[1]}" for k in scenes_moved)[:12])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--extra", type=int, default=0, help="the fixtures and this many rendered scenes (seeds 100..)")
    ap.add_argument("--seeds", metavar="A-B", type=_seed_range, action="append", default=[],
                    help="add the rendered scenes of seeds A..B (repeatable)")
    ap.add_argument("--masks", choices=["true", "colour", "both"], default="both")
    ap.add_argument("--rules", nargs="+", metavar="MODULE.NAME", help="only these switches (default: all)")
    ap.add_argument("--json", type=Path, help="write the figures here")
    a = ap.parse_args()
    names = a.rules or switches()
    listed = [] if a.seeds and not a.extra else scenes(a.extra)
    for r in a.seeds:
        listed += scenes(0, r)
    pairs = [(n, cv2.imread(str(lp)), cv2.imread(str(rp)), load_truth(tp)) for n, lp, rp, tp in listed]
    modes = ["true", "colour"] if a.masks == "both" else [a.masks]
    loc = Localizer(load_calibration(REPO / "fixtures" / "rig.yaml"), load_config().localize)
    t0 = time.perf_counter()
    base = run_all(loc, pairs, modes)
    print(f"{len(pairs)} scenes x {len(modes)} mask sources, configured run in {time.perf_counter() - t0:.0f} s",
          flush=True)
    print(f"{'switch (turned over)':<42}{'scenes':>7}{'moved':>6}{'lost':>5}{'gained':>7}{'false +/-':>10}"
          f"{'p95 on -> off':>16}{'max on -> off':>16}")
    out = {}
    for name in names:
        mod_name, attr = name.rsplit(".", 1)
        mod = importlib.import_module(f"appliance.localize.{mod_name}")
        value = getattr(mod, attr)
        setattr(mod, attr, not value)
        try:
            c = compare(base, run_all(loc, pairs, modes))
        finally:
            setattr(mod, attr, value)
        out[name] = dict(configured=value, **c)
        print(f"{name + ' -> ' + str(not value):<42}{c['scenes']:>7}{c['moved']:>6}{c['lost']:>5}{c['gained']:>7}"
              f"{'+%d/-%d' % (c['false_more'], c['false_fewer']):>10}"
              f"{'%.2f -> %.2f' % (c['base'][0], c['off'][0]):>16}{'%.1f -> %.1f' % (c['base'][1], c['off'][1]):>16}",
              flush=True)
    if a.json:
        a.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
