"""The rows a steep fork side is read from (``forkdisp.side_disparity_near``), fork by fork, against the truth.

    python benchmarks/side_rows.py [--extra 56 | --seeds A-B] [--masks true|colour|both] [--band 750-1250]
                                   --pickle OUT [--set MODULE.NAME=VALUE ...]

``band_tail.py``'s trace (the improved localizer on cached scenes, ``ForkPlacing.fork`` traced), and for every
steep side read from its crossings the rows it was read from, recomputed by :func:`side_rows` (the steps of
``kernels_forks.side_near`` in numpy): each row's offset from the fork (px), both views' crossing edges (px),
the disparity of the crossing's middle, whether the checks kept it (``grown``: a crossing the child widens,
``forkdisp.SIDE_GROWN_*``) and whether the robust line kept it; the child's direction in the image. Writes the
band's matched features (``band_tail``'s records, forks with ``sides[k]['rows']``) to ``--pickle``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import pickle
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import band_tail  # noqa: E402

from appliance.localize import forkdisp, forkends  # noqa: E402


def side_rows(c, runs_l, runs_r, t_fork, f_px=None, cx_px=None, offset_px=0.0, span_rows=forkdisp.SIDE_SPAN_ROWS,
              tol_d_px=2.5, width_tol_px=1.2, k_mad=3.5, grow=True):
    """The rows of ``side_disparity_near``'s read (same arguments): dict of arrays ``x`` (row - t_fork),
    ``d`` (the crossings' middles' disparity), ``l_lo``, ``l_hi``, ``r_lo``, ``r_hi`` (edges, px), ``w_end``
    (the span's left width), ``ratio``, ``kept`` (both views' checks), ``line`` (the robust line's rows), ``grown``
    (the crotch's widened rows, ``forkdisp.SIDE_GROWN_*``: counted with ``grow`` only)."""
    lo, hi = c.t_range
    end, sg = (lo, 1.0) if t_fork < lo else (hi, -1.0)
    n_gap = int(abs(t_fork - end))
    s_end, slope_s, d_end, slope_d, ratio = forkdisp._carried(c, end)
    if forkdisp.SIDE_WIDTH_PERSPECTIVE and f_px is not None and cx_px is not None:
        ratio *= forkdisp.perspective_width_ratio(s_end, d_end, f_px, cx_px, offset_px)
    i = np.arange(n_gap + span_rows + 1)
    rows = (i - n_gap) * sg + end
    dt = rows - end
    u, dc = s_end + slope_s * dt, d_end + slope_d * dt
    ri = rows.astype(np.int64)
    il = runs_l.find(ri, u)
    ref = [runs_l.span_px[il[k]] for k in range(n_gap, min(n_gap + 20, len(i))) if il[k] >= 0]
    w_end = float(np.median(ref)) if ref else np.nan
    ilc = np.maximum(il, 0)
    wl, cl = runs_l.span_px[ilc], runs_l.centre_px[ilc]
    ex = wl - w_end
    plain = np.abs(ex) <= 0.1 * w_end + 1.5
    grown = ~plain & (ex > 0) & (ex <= forkdisp.SIDE_GROWN_FRAC * w_end + forkdisp.SIDE_GROWN_PX) \
        & (np.abs(rows - t_fork) <= forkdisp.SIDE_GROWN_MAX_W * w_end) & grow
    ok_l = (il >= 0) & (plain | grown) & (np.abs(cl - u) <= 0.15 * w_end + 1.5 + np.where(grown, 0.5 * ex, 0.0))
    ir = runs_r.find(ri, cl - dc)
    irc = np.maximum(ir, 0)
    wr, cr = runs_r.span_px[irc], runs_r.centre_px[irc]
    dd = cl - cr
    ok = ok_l & (ir >= 0) & (np.abs(dd - dc) <= tol_d_px) \
        & (np.abs(wr - ratio * wl) <= np.where(grown, forkdisp.SIDE_GROWN_TOL_PX, width_tol_px))
    x = rows - t_fork
    line = ok.copy()
    if ok.sum() >= 2:
        a, b = np.polyfit(x[ok], dd[ok], 1)
        res = dd - (a * x + b)
        mad = 1.4826 * np.median(np.abs(res[ok] - np.median(res[ok])))
        line = ok & (np.abs(res) <= k_mad * (mad + 1e-3) + 0.05)
    return dict(x=x, d=dd, l_lo=runs_l.left_px[ilc], l_hi=runs_l.right_px[ilc], r_lo=runs_r.left_px[irc],
                r_hi=runs_r.right_px[irc], u=u, d_carried=dc, w_end=w_end, ratio=ratio, kept=ok, line=line, grown=grown,
                found_l=il >= 0, found_r=ir >= 0)


def child_direction(b, loc: dict) -> np.ndarray | None:
    """The traced fork's child's direction from the fork (unit, image px), towards the end of the child's curve
    further from it; None where the child has no curve (``b`` the placer, ``loc`` ``ForkPlacing.fork``'s locals)."""
    child, xy = loc.get("child"), np.asarray(loc["xy"], float)
    if child not in b.curves:
        return None
    uv = b.curves[child].uv_at(np.asarray(b.curves[child].t_range, float))
    far = uv[int(np.argmax(np.hypot(*(uv - xy).T)))]
    return (far - xy) / max(float(np.hypot(*(far - xy))), 1e-9)


def band_tail_argv(a) -> list[str]:
    """``band_tail.py``'s command line for this script's arguments (``--band --masks --seeds/--extra --set``),
    every matched fork traced (``--over 99``); the caller adds ``--pickle``."""
    argv = ["band_tail.py", "--band", a.band, "--masks", a.masks, "--over", "99"]
    argv += ["--seeds", f"{a.seeds[0]}-{a.seeds[-1]}"] if a.seeds else ["--extra", str(a.extra)]
    for kv in a.set:
        argv += ["--set", kv]
    return argv


def tracer_parser(description: str, pickle_required: bool = False) -> argparse.ArgumentParser:
    """The fork-side tracers' common options (this script's, ``side_edges.py``'s, ``side_curve.py``'s):
    ``--extra/--seeds --masks --band --set --pickle``, as :func:`band_tail_argv` passes them on."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--extra", type=int, default=56)
    ap.add_argument("--seeds", metavar="A-B", type=band_tail._seed_range)
    ap.add_argument("--masks", choices=["true", "colour", "both"], default="both")
    ap.add_argument("--band", default="750-1250")
    ap.add_argument("--set", action="append", default=[], metavar="MODULE.NAME=VALUE")
    ap.add_argument("--pickle", type=Path, required=pickle_required)
    return ap


def trace_sides(on_read, on_fork) -> None:
    """Hook the fork-side tracers (this script's, ``side_edges.py``'s, ``side_curve.py``'s) into the localizer
    and ``band_tail``'s trace: ``on_read(v, c, runs_l, runs_r, t_fork, kw)`` is called with every side read
    ``forkdisp.side_disparity_near`` returns (its arguments too) and gives what to keep of it (None: nothing);
    ``on_fork(b, loc, f, kept)`` is called, after ``band_tail`` recorded a traced fork ``f`` that has a place,
    with ``kept`` the list of (side record, what ``on_read`` kept of that side's read, or None)."""
    store = {}
    orig = forkends.side_disparity_near

    def near(c, runs_l, runs_r, t_fork, **kw):
        v = orig(c, runs_l, runs_r, t_fork, **kw)
        if v is not None:
            keep = on_read(v, c, runs_l, runs_r, t_fork, kw)
            if keep is not None:
                store[id(v)] = (v, keep)
        return v
    forkends.side_disparity_near = near
    fork_return = band_tail.Trace._fork_return

    def _fork_return(self, b, node, loc, lines):
        fork_return(self, b, node, loc, lines)
        f = self.forks.get(node)
        if f is None or "xy" not in loc:
            return
        sn = loc.get("side_near") or {}
        kept = []
        for s in f["sides"]:
            v = sn.get(s["seg"])
            hit = store.get(id(v)) if v is not None else None
            kept.append((s, hit[1] if hit is not None and hit[0] is v else None))
        on_fork(b, loc, f, kept)
        store.clear()
    band_tail.Trace._fork_return = _fork_return


def traced_sides(recs, key: str):
    """Every traced fork side in ``band_tail``'s records ``recs`` that holds ``key``: (record, the side's
    ``key``, the fork's true disparity px)."""
    for r in recs:
        if r["kind"] != "bifurcation" or not r["fork"]:
            continue
        d_true = r["d"] - r["derr"]
        for s in r["fork"]["sides"]:
            if s.get(key) is not None:
                yield r, s[key], d_true


def forks_with_truth(recs, truth_paths: dict, keep):
    """Every traced fork with a place in ``band_tail``'s records ``recs`` that has sides for which ``keep(side)``
    holds, with its scene's truth (loaded once a scene: the records come scene by scene): (record, fork, those
    sides, truth)."""
    from appliance.synth.truth import load_truth
    cache = {}
    for r in recs:
        f = r["fork"]
        if r["kind"] != "bifurcation" or not f or "xy" not in f:
            continue
        sides = [s for s in f["sides"] if keep(s)]
        if not sides:
            continue
        if r["scene"] not in cache:
            cache.clear()
            cache[r["scene"]] = load_truth(truth_paths[r["scene"]])
        yield r, f, sides, cache[r["scene"]]


def band_tail_records(argv: list[str]) -> list[dict]:
    """``band_tail.main()`` run quietly with ``argv`` (no ``--pickle``): its records, as it would pickle them."""
    recs = []
    orig_dumps = pickle.dumps

    def grab(obj, *k, **kw):
        recs.extend(obj)
        return orig_dumps(obj, *k, **kw)
    pickle.dumps = grab
    sys.argv = argv + ["--pickle", "/dev/null"]
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            band_tail.main()
    finally:
        pickle.dumps = orig_dumps
    return recs


def main() -> int:
    ap = tracer_parser(__doc__.splitlines()[0], pickle_required=True)
    a = ap.parse_args()

    def on_read(v, c, runs_l, runs_r, t_fork, kw):
        # (as side_disparity_near: the crotch's widened rows where the plain read stops short)
        rows = side_rows(c, runs_l, runs_r, t_fork, grow=False, **kw)
        if np.abs(rows['x'][rows['line']]).min() > forkdisp.SIDE_GROWN_SHORT_PX:
            grown = side_rows(c, runs_l, runs_r, t_fork, **kw)
            if grown['line'].sum() >= max(12, rows['line'].sum() + forkdisp.SIDE_GROWN_MIN_ROWS):
                rows = grown
        return rows

    def on_fork(b, loc, f, kept):
        for s, rows in kept:
            if rows is not None:
                s["rows"] = rows
        cdir = child_direction(b, loc)
        if cdir is not None:
            f["child_dir"] = cdir
        f["xy"] = np.asarray(loc["xy"], float).copy()
    trace_sides(on_read, on_fork)
    sys.argv = band_tail_argv(a) + ["--pickle", str(a.pickle)]
    return band_tail.main()


if __name__ == "__main__":
    raise SystemExit(main())
