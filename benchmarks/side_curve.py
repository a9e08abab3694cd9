"""The steep fork sides' reads carried to the fork by a line or by a curve, against the truth (issue 5).

    python benchmarks/side_curve.py [--extra 56 | --seeds A-B] [--masks true|colour|both] [--band 750-1250]
                                    [--pickle OUT] [--axis] [--set MODULE.NAME=VALUE ...]

``side_rows.py``'s trace (``band_tail.py``'s: the improved localizer on cached scenes; nothing of the localizer
changed), and for every steep side read from its crossings (``forkdisp.side_disparity_near``) its rows
(:func:`side_edges.read_rows`: the kernel's steps in numpy on the runs the read sees) and the side's value at the
fork carried from those rows in several ways (:func:`carries`):

- ``line``: the robust line through the rows (today's read);
- ``quad``: a second-degree fit through the same rows;
- ``poly``: the piece's own fit (``BranchCurve.d_poly``, its polynomial continued past the span, not its end
  slope) moved onto the rows by their mean offset from it;
- ``polyline``: a line through the rows' offsets from the piece's polynomial, plus the polynomial at the fork;
- ``bend``: the line through the rows less half the polynomial's second derivative at the span's end times the
  square of the row's distance from the fork (the piece's curvature in depth kept, its level and slope the rows').

Each against the fork's true disparity plus the silhouette bias (``centreaxis.centre_bias_px``), grouped by the
read's reach (nearest kept row within 2 px of the fork, 2-6 px, more than 6 px short). With ``--axis`` the same
carries through the TRUE parent axis on the read's own rows (the carry's model error alone: how far a line or a
curve through the parent's true depth on those rows misses it at the fork). ``--pickle`` keeps the sides (rows,
curve coefficients, truth) for other carries.
"""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import band_tail  # noqa: E402
import side_edges as se  # noqa: E402
import side_rows as sr  # noqa: E402

from appliance.localize import centreaxis  # noqa: E402

CARRIES = ("line", "quad", "poly", "polyline", "bend")


def _poly_free(coef, t0, ts, t):
    """A :class:`curves.Poly`'s polynomial (``coef`` highest first, on ``(t - t0) / ts``) at ``t``, continued past
    the span (no end slopes)."""
    return np.polyval(coef, (np.asarray(t, float) - t0) / ts)


def carries(x, d, t_fork, poly, end) -> dict:
    """The side's value at the fork (x = 0) from rows at ``x`` (row - t_fork) with disparities ``d``, carried each
    way of :data:`CARRIES`; ``poly`` (coef, t0, ts) the piece's d fit, ``end`` the span's end row."""
    out = {"line": float(np.polyfit(x, d, 1)[1])}
    out["quad"] = float(np.polyfit(x, d, 2)[2]) if len(x) >= 6 and np.ptp(x) >= 8 else out["line"]
    coef, t0, ts = poly
    p_rows = _poly_free(coef, t0, ts, x + t_fork)
    p_fork = float(_poly_free(coef, t0, ts, t_fork))
    out["poly"] = p_fork + float(np.mean(d - p_rows))
    out["polyline"] = p_fork + float(np.polyfit(x, d - p_rows, 1)[1])
    c2 = np.polyder(np.asarray(coef, float), 2)
    k = float(np.polyval(c2, (end - t0) / ts)) / ts ** 2 if len(coef) >= 3 else 0.0     # d'' (px / row^2)
    out["bend"] = float(np.polyfit(x, d - 0.5 * k * x ** 2, 1)[1])
    out["k"] = k
    return out


def main() -> int:
    ap = sr.tracer_parser(__doc__.splitlines()[0])
    ap.add_argument("--axis", action="store_true", help="also each carry through the true parent axis on the rows")
    a = ap.parse_args()

    def on_read(v, c, runs_l, runs_r, t_fork, kw):
        rows = se.read_rows(c, runs_l, runs_r, t_fork, **kw)
        k = rows["line"]
        lo, hi = c.t_range
        dp = getattr(c.d_poly, "base", c.d_poly)        # (a Spliced fit: the piece's own polynomial)
        return (dict(x=rows["x"][k], d=rows["d"][k], t_fork=float(t_fork), end=float(lo if t_fork < lo else hi),
                     poly=(np.asarray(dp.coef, float).copy(), float(dp.t0), float(dp.ts)),
                     t_range=(float(lo), float(hi)), d_kernel=float(v.d_px), nearest=float(v.nearest_px)),
                kw, float(v.d_px))

    def on_fork(b, loc, f, kept):
        xy = np.asarray(loc["xy"], float)
        f["xy"] = xy.copy()
        for s, keep in kept:
            c = b.curves[s["seg"]]
            s["t_range"], s["by_row"] = tuple(float(t) for t in c.t_range), bool(c.by_row)
            if keep is not None:
                st, kw, d_px = keep
                st["bias"] = centreaxis.centre_bias_px(d_px, float(xy[0]), s["radius_px"], kw["f_px"], kw["cx_px"],
                                                       kw.get("offset_px", 0.0))
                s["curve"] = st
    sr.trace_sides(on_read, on_fork)
    recs = sr.band_tail_records(sr.band_tail_argv(a))
    if a.axis:
        add_axis(recs, {name: tp for name, _, _, tp in band_tail.scene_list(a.extra, a.seeds)})
    if a.pickle:
        a.pickle.write_bytes(pickle.dumps(recs))
    report(recs, a.axis)
    return 0


def add_axis(recs, truth_paths: dict) -> None:
    """Each traced side's ``axis``: the true parent axis's disparity on its rows and at the fork's row
    (:func:`side_edges.true_axis_rdv`), NaN where the axis does not cross a row near the fork."""
    for r, f, sides, truth in sr.forks_with_truth(recs, truth_paths, lambda s: s.get("curve")):
        u, v, d, _ = se.true_axis_rdv(truth, int(truth.features.parent[r["t"]]))
        xf = np.asarray(f["xy"], float)
        near = np.hypot(u - xf[0], v - xf[1]) < 400

        def on_row(rv):
            cand = np.flatnonzero(near & (np.abs(v - rv) < 0.6))
            return d[cand[np.argmin(np.abs(v[cand] - rv))]] if len(cand) else np.nan
        for s in sides:
            st = s["curve"]
            st["axis"] = np.array([on_row(rv) for rv in xf[1] + st["x"]])
            st["axis_fork"] = float(on_row(xf[1]))


def side_table(recs) -> list[dict]:
    """The traced sides with their carries' errors (px, after the silhouette bias) and, where traced, the carries'
    errors through the true axis (``model``)."""
    out = []
    for r, st, d_true in sr.traced_sides(recs, "curve"):
        if len(st["x"]) < 12:
            continue
        cv = carries(st["x"], st["d"], st["t_fork"], st["poly"], st["end"])
        row = dict(masks=r["masks"], scene=r["scene"], t=r["t"], z=r["z"], dz=r["dz"], nearest=st["nearest"],
                   k=cv["k"], n=len(st["x"]), err={c: cv[c] - st["bias"] - d_true for c in CARRIES},
                   kernel=st["d_kernel"] - st["bias"] - d_true, rule=r["rule"])
        ax = st.get("axis")
        if ax is not None and np.isfinite(st["axis_fork"]) and np.isfinite(ax).sum() >= 12:
            ok = np.isfinite(ax)
            mv = carries(st["x"][ok], ax[ok], st["t_fork"], st["poly"], st["end"])
            row["model"] = {c: mv[c] - st["axis_fork"] for c in CARRIES}
        out.append(row)
    return out


def report(recs, axis: bool) -> None:
    """Prints the carries' errors by mask source and reach: sd, p95 abs and mean abs (px)."""
    rows = side_table(recs)
    groups = (("all", lambda s: True), ("< 2 px", lambda s: s["nearest"] < 2),
              ("2-6 px", lambda s: 2 <= s["nearest"] <= 6), ("> 6 px short", lambda s: s["nearest"] > 6))
    for key, title in (("err", "the read's error at the fork"), ("model", "through the true axis on the read's rows")):
        if key == "model" and not axis:
            continue
        print(f"\n{title}: sd / p95 abs (px)\n")
        print("| masks | reach | sides | " + " | ".join(CARRIES) + " |")
        print("|---|---|---|" + "---|" * len(CARRIES))
        for m in ("true", "colour"):
            for grp, sel in groups:
                ss = [s for s in rows if s["masks"] == m and sel(s) and key in s]
                if len(ss) < 2:
                    continue
                cells = []
                for c in CARRIES:
                    e = np.array([s[key][c] for s in ss])
                    cells.append(f"{e.std():.3f} / {np.percentile(np.abs(e), 95):.3f}")
                print(f"| {m} | {grp} | {len(ss)} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    raise SystemExit(main())
