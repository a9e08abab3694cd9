"""How the feature check (localize/featurecheck.py) separates correct features from gross ones.

    python benchmarks/feature_check.py [--extra N | --seeds A-B] [--masks true|colour|both] [--threshold PX]
                                       [--agree PX]

Runs the improved localizer on the scenes of ``localize_accuracy.py`` (fixtures plus ``--extra`` rendered
seeds 100.., or ``--seeds A-B`` alone) with the check measuring but withholding nothing, scores each
reported feature against the truth and prints: the distribution of |texture - feature| (px) on correct
features (|dZ| < 3 mm) with a verdict (p50/p95/p99/max, the figures ``max_diff_px`` is chosen from), the
correct, gross (|dZ| > 5 mm) and false features withheld at several thresholds, the same for the pieces'
agreement (``FeatureCheck.agree_px``, forks: two pieces' own texture estimates on one side) and for both
rules at the defaults, every gross feature with its check, every correct one beyond ``--threshold`` or
``--agree``, and the check's time per pair. (Gross here: |dZ| > 5 mm; the forks of issue 5 on seeds 356-387
are 3.5-12 mm off: ``--gross 3.5``.)
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from localize_accuracy import REPO, _seed_range, scenes  # noqa: E402

from appliance.calibrate.model import load_calibration  # noqa: E402
from appliance.config import load_config  # noqa: E402
from appliance.localize import Localizer, featurecheck  # noqa: E402
from appliance.synth.evaluate import score_result  # noqa: E402
from appliance.synth.truth import load_truth  # noqa: E402

THRESHOLDS_PX = (0.6, 0.8, 1.0, 1.2, 1.5, 1.6, 2.0)
AGREE_THRESHOLDS_PX = (0.6, 0.7, 0.8, 0.9, 1.0, 1.2)


class _Measuring(Localizer):
    """The localizer keeping the last pair's feature checks (``Matching.stats["feature_check"]``, one per
    reported feature, in the result's order: nothing is withheld at an infinite threshold)."""

    def _assemble(self, m, stamp_ns, withheld=()):
        self.checks = m.stats.get("feature_check", [])
        return super()._assemble(m, stamp_ns, withheld)


def measure(scene_list: list, masks: list[str]) -> tuple[list[tuple], list[float]]:
    """(scene, masks, kind, truth index (-1: false), dZ mm, texture - feature px (NaN: no verdict),
    patches, the pieces' agreement px (NaN: fewer than two pieces)) of every reported feature, and the
    check's time (ms) of every pair. Nothing is withheld (every threshold infinite)."""
    cfg = load_config().localize
    cfg = replace(cfg, feature_check=replace(cfg.feature_check, enabled=True, max_diff_px=float("inf")))
    featurecheck.AGREE_PX = float("inf")            # (read by check_features at each call)
    featurecheck.TURN_PX = float("inf")
    loc = _Measuring(load_calibration(REPO / "fixtures" / "rig.yaml"), cfg, "improved")
    rows, times = [], []
    for name, lp, rp, tp in scene_list:
        left, right, truth = cv2.imread(str(lp)), cv2.imread(str(rp)), load_truth(tp)
        for mode in masks:
            kw = dict(mask_left=truth.mask_left, mask_right=truth.mask_right) if mode == "true" else {}
            loc.checks = []
            res = loc.localize(left, right, **kw)
            if len(loc.checks) != len(res.features):         # (a pair without branches: nothing checked)
                continue
            times.append(res.timings_ms.get("check", 0.0))
            by_id = {r.result_id: r for r in score_result(res, truth, name=name).rows if r.result_id >= 0}
            for f, k in zip(res.features, loc.checks):
                r = by_id.get(f.id)
                hit = r is not None and r.truth_index >= 0
                rows.append((name, mode, f.kind, r.truth_index if hit else -1, r.dz_mm if hit else np.nan,
                             k.diff_px, k.n_patches, k.agree_px))
        print(f"{name}: done", flush=True)
    return rows, times


def report(rows: list, times: list, threshold: float, agree: float = 0.9, gross_mm: float = 5.0) -> str:
    """The figures of :func:`measure`'s rows and times as text."""
    dz = np.array([r[4] for r in rows], float)
    diff = np.array([r[5] for r in rows], float)
    agr = np.array([r[7] for r in rows], float)
    found = np.array([r[3] >= 0 for r in rows])
    ok, gross, false = found & (np.abs(dz) < 3), found & (np.abs(dz) > gross_mm), ~found
    v = np.isfinite(diff)
    out = [f"features {len(rows)}: correct {ok.sum()}, gross {gross.sum()}, false {false.sum()}; with a verdict: "
           f"correct {(ok & v).sum()}, gross {(gross & v).sum()}, false {(false & v).sum()}"]
    if (ok & v).any():
        p = np.percentile(np.abs(diff[ok & v]), [50, 95, 99, 100])
        out.append("correct |texture - feature| px: p50 %.3f  p95 %.3f  p99 %.3f  max %.3f" % tuple(p))
    for th in THRESHOLDS_PX:
        w = v & (np.abs(diff) > th)
        out.append(f"  withheld at {th:.1f} px: correct {(ok & w).sum()}, gross {(gross & w).sum()}/{gross.sum()}, "
                   f"false {(false & w).sum()}/{false.sum()}")
    va = np.isfinite(agr)
    if (ok & va).any():
        p = np.percentile(np.abs(agr[ok & va]), [50, 95, 99, 100])
        out.append(f"pieces' agreement, correct features with two pieces or more ({(ok & va).sum()}): "
                   "p50 %.3f  p95 %.3f  p99 %.3f  max %.3f" % tuple(p))
    for th in AGREE_THRESHOLDS_PX:
        w = va & (np.abs(agr) > th)
        out.append(f"  withheld by agreement at {th:.1f} px: correct {(ok & w).sum()}, gross {(gross & w).sum()}/"
                   f"{gross.sum()}, false {(false & w).sum()}/{false.sum()}")
    both = (v & (np.abs(diff) > threshold)) | (va & (np.abs(agr) > agree))
    out.append(f"withheld at {threshold} px or agreement {agree} px: correct {(ok & both).sum()}, gross "
               f"{(gross & both).sum()}/{gross.sum()}, false {(false & both).sum()}/{false.sum()}")
    for title, sel in (("gross features", gross), (f"correct features beyond {threshold} px or agreement {agree} px",
                                                    ok & both)):
        out.append(f"{title}:")
        for i in np.flatnonzero(sel):
            r = rows[i]
            out.append(f"  {r[0]:11s} {r[1]:6s} {r[2]:11s} T{r[3]:<3d} dZ {r[4]:+7.2f} mm  check {r[5]:+.2f} px "
                       f"({r[6]} patches)  agreement {r[7]:+.2f} px{'  withheld' if both[i] else ''}")
    out.append(f"check: median {np.median(times):.2f} ms, mean {np.mean(times):.2f} ms per pair ({len(times)} pairs)")
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--extra", type=int, default=56, help="rendered scenes after the fixtures (seeds 100..)")
    ap.add_argument("--seeds", metavar="A-B", type=_seed_range, help="these rendered seeds alone")
    ap.add_argument("--masks", choices=["true", "colour", "both"], default="both")
    ap.add_argument("--threshold", type=float, default=load_config().localize.feature_check.max_diff_px)
    ap.add_argument("--agree", type=float, default=featurecheck.AGREE_PX, help="the pieces' agreement, px")
    ap.add_argument("--gross", type=float, default=5.0, help="|dZ| (mm) over which a feature counts as gross")
    a = ap.parse_args()
    masks = ["true", "colour"] if a.masks == "both" else [a.masks]
    print(report(*measure(scenes(a.extra, a.seeds), masks), a.threshold, a.agree, a.gross))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
