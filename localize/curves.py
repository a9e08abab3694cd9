"""Smooth curves along a branch in disparity space: u(v) or v(u), and d along it.

A straight 3D line is a straight line in (u, v, d) space (the rectified projection is a
homography of 3D space), so a low-degree polynomial of the row fits a branch piece
well; extrapolation beyond the fitted span is linear (for forks and tips).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.linalg import _umath_linalg

from appliance.localize import kernels_fit


class cached:
    """``functools.cached_property`` without its per-class lock (Python 3.11 takes an RLock on every
    first computation: ~2 us, ~120 times per pair): computed once per instance, then read from the
    instance's ``__dict__`` (a non-data descriptor, so the stored value wins). Not thread-safe in the
    sense that two threads may both compute it the first time (the same value)."""

    def __init__(self, func):
        self.func = func
        self.name = func.__name__
        self.__doc__ = func.__doc__

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        value = obj.__dict__[self.name] = self.func(obj)
        return value


@dataclass(frozen=True, eq=False)
class Poly:
    """A polynomial of a scaled parameter: ``p(t) = polyval(coef, (t - t0) / ts)`` (well conditioned)."""

    coef: np.ndarray
    t0: float = 0.0
    ts: float = 1.0

    def __call__(self, t) -> np.ndarray:
        t = np.asarray(t, float)
        if t.shape == (1,):                 # one point: the same sums in Python floats (a tenth of the time)
            return np.array([self.at(float(t[0]))])
        x = t - self.t0
        x /= self.ts
        c = self._coef_list
        if len(c) == 1:
            return np.full(x.shape, c[0], float)
        y = x * c[0]                    # Horner in place (np.polyval's checks cost more than the sum here)
        y += c[1]
        for ci in c[2:]:
            y *= x
            y += ci
        return y

    def at(self, t: float) -> float:
        """``p(t)`` of one parameter."""
        x = (t - self.t0) / self.ts
        c = self._coef_list
        if len(c) == 1:
            return c[0]
        y = x * c[0] + c[1]
        for ci in c[2:]:
            y = y * x + ci
        return y

    @cached
    def _coef_list(self) -> list[float]:
        return self.coef.tolist()

    def deriv(self) -> Poly:
        return self._deriv

    @cached
    def _deriv(self) -> Poly:
        if len(self.coef) <= 1:
            return Poly(np.zeros(1), self.t0, self.ts)
        n = len(self.coef) - 1             # (np.polyder's product, without its checks)
        return Poly(self.coef[:-1] * np.arange(n, 0, -1) / self.ts, self.t0, self.ts)

    @classmethod
    def constant(cls, value: float) -> Poly:
        return cls(np.array([float(value)]))

    @classmethod
    def fit(cls, t: np.ndarray, y: np.ndarray, degree: int) -> Poly:
        """Least squares (``degree`` lowered to what the samples support)."""
        t, y = np.asarray(t, float), np.asarray(y, float)
        n = len(t)
        increasing = False
        if degree > 0 and n:
            increasing = bool((t[1:] > t[:-1]).all())
            if not increasing:                                     # count distinct values
                st = np.sort(t)
                degree = int(min(degree, np.count_nonzero(st[1:] != st[:-1])))
        degree = int(max(min(degree, n - 1), 0))
        t0 = float(t.sum()) / n if n else 0.0
        t_lo, t_hi = (float(t[0]), float(t[-1])) if increasing else (float(t.min()), float(t.max())) if n else (0.0, 0.0)
        ts = max(t_hi - t0, t0 - t_lo, 1.0) if n else 1.0
        x = (t - t0) / ts
        return cls(_lstsq_poly(x, y, degree), t0, ts)


@dataclass(frozen=True, eq=False)
class Spliced:
    """:class:`Poly` ``base`` on ``[lo, hi]``, continued by the polynomials ``below`` (t < lo) and
    ``above`` (t > hi) where given (a piece carried on past an occluder keeps its own fit)."""

    base: Poly
    lo: float
    hi: float
    below: Poly | None = None
    above: Poly | None = None

    def __call__(self, t) -> np.ndarray:
        t = np.asarray(t, float)
        if t.shape == (1,):
            return np.array([self.at(float(t[0]))])
        out = np.asarray(self.base(t), float)
        for part, sel in ((self.below, t < self.lo), (self.above, t > self.hi)):
            if part is not None and sel.any():
                out = np.where(sel, part(t), out)
        return out

    def at(self, t: float) -> float:
        part = self.below if t < self.lo else self.above if t > self.hi else None
        return (part or self.base).at(t)

    def deriv(self) -> Spliced:
        return self._deriv

    @cached
    def _deriv(self) -> Spliced:            # (made once: read at every extrapolation)
        return Spliced(self.base.deriv(), self.lo, self.hi, self.below and self.below.deriv(),
                       self.above and self.above.deriv())


def _solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.linalg.solve(a, b)`` (the same LAPACK gufunc, the same values bit for bit) without its
    wrapper's checks and error-state context (~3 of its ~8 us, ~50 calls per pair); a singular
    system (non-finite result: never with the distinct parameters the fits ask for) goes through
    ``np.linalg.solve``, which raises as before (after the gufunc's RuntimeWarning)."""
    x = _umath_linalg.solve1(a, b) if b.ndim == a.ndim - 1 else _umath_linalg.solve(a, b)
    if not np.isfinite(x).all():
        return np.linalg.solve(a, b)
    return x


def _lstsq_poly(x: np.ndarray, y: np.ndarray, degree: int) -> np.ndarray:
    """Least-squares coefficients (highest power first) of a polynomial in ``x`` (scaled to
    [-1, 1], distinct values > ``degree``) by the normal equations: a (degree + 1)^2 system of
    power sums, well conditioned on [-1, 1] for degree <= 3."""
    if degree == 0:
        return np.array([float(y.sum()) / len(y)]) if len(y) else np.zeros(1)
    if degree == 1:                     # a line in closed form
        n, sx, sy = len(x), float(x.sum()), float(y.sum())
        sxx, sxy = float(x @ x), float(x @ y)
        det = n * sxx - sx * sx
        return np.array([(n * sxy - sx * sy) / det, (sxx * sy - sx * sxy) / det])
    a = np.empty((len(x), degree + 1))          # np.vander(x, degree + 1): the same products, in order
    a[:, degree] = 1.0
    a[:, degree - 1] = x
    for k in range(degree - 2, -1, -1):
        np.multiply(a[:, k + 1], x, out=a[:, k])
    return _solve(a.T @ a, a.T @ y)


def linspace(lo: float, hi: float, n: int) -> np.ndarray:
    """``np.linspace(lo, hi, n)`` of two scalars: the same values bit for bit (numpy's own steps: an
    arange scaled in place by (hi - lo) / (n - 1), lo added, the last set to hi), without its
    argument handling (~2 against ~7 us; ~65 calls per pair)."""
    if n < 2:
        return np.linspace(lo, hi, n)
    lo, hi = float(lo), float(hi)
    delta = hi - lo
    div = n - 1
    step = delta / div
    y = np.arange(0, n, dtype=np.float64)
    if step == 0:                       # (numpy's handling of denormal steps)
        y /= div
        y *= delta
    else:
        y *= step
    y += lo
    y[-1] = hi
    return y


def angle_deg(pts: np.ndarray) -> float:
    """Angle of a point set's (N, 2) (x, y) main direction from the rows, degrees (0..90)."""
    c = pts - pts.sum(0) / len(pts)             # (the mean, bit for bit, without np.mean's checks)
    sxx, syy, sxy = float(c[:, 0] @ c[:, 0]), float(c[:, 1] @ c[:, 1]), float(c[:, 0] @ c[:, 1])
    return abs(float(np.degrees(0.5 * np.arctan2(2 * sxy, sxx - syy))))


def angle_deg_groups(pts: np.ndarray, g: np.ndarray, n_groups: int) -> np.ndarray:
    """:func:`angle_deg` of every group of points at once (``pts`` (N, 2) (x, y), group ids ``g`` (N,),
    every group non-empty): (G,) degrees; the sums in another order (equal up to rounding)."""
    n = np.bincount(g, minlength=n_groups)
    c = pts - np.column_stack([np.bincount(g, pts[:, 0], n_groups), np.bincount(g, pts[:, 1], n_groups)])[g] / n[g, None]
    sxx = np.bincount(g, c[:, 0] * c[:, 0], n_groups)
    syy = np.bincount(g, c[:, 1] * c[:, 1], n_groups)
    sxy = np.bincount(g, c[:, 0] * c[:, 1], n_groups)
    return np.abs(np.degrees(0.5 * np.arctan2(2 * sxy, sxx - syy)))


def median(a: np.ndarray) -> float:
    """``np.median`` of a 1-D float array (the same value, bit for bit) at a fraction
    of its cost (~1.5 against ~10 us on a few hundred values): ``np.partition`` at the middle."""
    n = len(a)
    if n == 0:
        return np.nan                   # as np.median (without its warning)
    k = n // 2
    p = np.array(a, copy=True)         # (np.partition's own steps: a copy partitioned in place)
    if n % 2:
        p.partition(k)
        return p[k]
    p.partition((k - 1, k))
    return (p[k - 1] + p[k]) / 2


def percentile(a: np.ndarray, q: float) -> float:
    """``np.percentile(a, q)`` of a 1-D float array with its default (linear) method: the same value,
    bit for bit (the same virtual index, partition and interpolation; checked for ``q / 100`` a binary
    fraction, as 25, 50, 75: numpy's rounding of others may differ by an ulp), at a tenth of its cost
    (~2 against ~20 us)."""
    n = len(a)
    if n == 0:
        return float(np.percentile(a, q))                # (its error)
    quant = q / 100
    vi = n * quant + (1 + quant * (1 - 1 - 1)) - 1       # numpy's virtual index (alpha = beta = 1)
    lo = min(max(int(np.floor(vi)), 0), n - 1)
    hi = min(lo + 1, n - 1)
    gamma = vi - np.floor(vi)
    p = np.partition(a, (lo, hi)) if hi != lo else np.partition(a, lo)
    x, y = float(p[lo]), float(p[hi])
    diff = y - x
    return y - diff * (1 - gamma) if gamma >= 0.5 else x + diff * gamma


def robust_fit(t: np.ndarray, y: np.ndarray, degree: int, rounds: int = 3, k_mad: float = 3.5) -> tuple[Poly, np.ndarray]:
    """Least-squares polynomial with iterative rejection of residuals beyond ``k_mad`` MADs
    (:func:`robust_fit_groups` of one group: :meth:`Poly.fit`'s fits up to rounding).

    Returns
    -------
    (Poly, inliers bool (N,))
    """
    t = np.ascontiguousarray(t, float)
    coef, t0, ts, deg, keep = kernels_fit.robust_fit_groups(
        t, np.ascontiguousarray(y, float), np.array([0, len(t)]), np.array([degree], np.int64),
        np.array([rounds], np.int64), float(k_mad))
    return Poly(coef[0, 3 - int(deg[0]):], float(t0[0]), float(ts[0])), keep


def degree_for(n_samples: int, span_px: float) -> int:
    """Poly degree for a branch piece: 1 when short, up to 3 when long."""
    if n_samples < 12 or span_px < 40:
        return 1
    return 2 if span_px < 160 else 3


_NO_SLOPES = np.zeros(2)


def _one(t) -> float | None:
    """``t`` as a Python float when it is one value (a float, or a one-element 1-D array), else None."""
    if isinstance(t, float):
        return float(t)
    if type(t) is np.ndarray and t.shape == (1,):
        return float(t[0])
    return None


@dataclass(frozen=True, eq=False)
class BranchCurve:
    """A branch piece in the rectified left image with its disparity.

    ``t`` is the parameter (row v for steep pieces, column u for flat ones); the other
    image coordinate is ``s(t)``; the disparity ``d(t)``; the radius is ``radius_px``
    (median along the piece).
    """

    segment: int
    by_row: bool
    t_range: tuple[float, float]
    s_poly: Poly
    d_poly: Poly
    radius_px: float
    n_samples: int
    d_end_slopes: tuple[float, float] | None = None
    right_runs: np.ndarray | None = None

    def _at(self, poly: Poly, t1: float, slopes=None) -> float:
        """:meth:`_eval` of one parameter, in Python floats."""
        lo, hi = self.t_range
        tc1 = min(max(t1, lo), hi)
        if tc1 == t1:
            return poly.at(tc1)
        slope = poly.deriv().at(tc1) if slopes is None else slopes[0] if t1 < lo else slopes[1]
        return poly.at(tc1) + slope * (t1 - tc1)

    def _eval(self, poly: Poly, t, slopes=None) -> np.ndarray:
        """``poly`` inside the span, beyond it along ``slopes`` (the curve's own at the span's ends by default)."""
        t1 = _one(t)
        if t1 is not None:                  # one point: the same sums in Python floats
            return np.array([self._at(poly, t1, slopes)])
        t = np.asarray(t, float)
        if t.ndim == 0:                     # (np.atleast_1d's reshape, without its wrapper)
            t = t.reshape(1)
        lo, hi = self.t_range
        if t.shape == (1,):
            return np.array([self._at(poly, float(t[0]), slopes)])
        if not t.size:
            return poly(t)
        if type(poly) is Poly:              # compiled: the same sums as below
            return kernels_fit.eval_clamped(poly.coef, poly._deriv.coef, float(poly.t0), float(poly.ts),
                                        float(lo), float(hi), _NO_SLOPES if slopes is None else np.asarray(slopes, float),
                                        slopes is None, np.ascontiguousarray(t))
        mn, mx = t.min(), t.max()
        if mn >= lo and mx <= hi:           # no extrapolation (NaN: the general path)
            return poly(t)
        # all beyond one end (a walk out of the span): that end's value and slope, as below per point
        if mn >= hi:
            return poly.at(hi) + (poly.deriv().at(hi) if slopes is None else slopes[1]) * (t - hi)
        if mx <= lo:                        # (at lo itself: the same value, poly(lo) + slope * 0)
            return poly.at(lo) + (poly.deriv().at(lo) if slopes is None else slopes[0]) * (t - lo)
        tc = np.minimum(np.maximum(t, lo), hi)
        if slopes is None:
            slopes = (poly.deriv().at(lo), poly.deriv().at(hi))
        return poly(tc) + np.where(t < lo, slopes[0], slopes[1]) * (t - tc)

    def s_at(self, t) -> np.ndarray:
        return self._eval(self.s_poly, t)

    def d_at(self, t) -> np.ndarray:
        """Disparity; beyond the fitted span along the straight line fitted to the last samples."""
        return self._eval(self.d_poly, t, self.d_end_slopes)

    def uv_at(self, t) -> np.ndarray:
        """(N, 2) rectified left (u, v) at parameters ``t``."""
        t1 = _one(t)
        if t1 is not None:
            s = self._at(self.s_poly, t1)
            return np.array([[s, t1]] if self.by_row else [[t1, s]])
        t = np.asarray(t, float).reshape(-1)
        out = np.empty((len(t), 2))
        out[:, 0 if self.by_row else 1] = self.s_at(t)
        out[:, 1 if self.by_row else 0] = t
        return out

    def t_of(self, uv) -> np.ndarray:
        """Parameter of points (N, 2) (their v when by row, else their u)."""
        uv = np.asarray(uv, float).reshape(-1, 2)
        return uv[:, 1] if self.by_row else uv[:, 0]

    def uvd(self, step_px: float = 4.0) -> np.ndarray:
        """Samples (N, 3) of (u, v, d) along the fitted span every ``step_px`` of t."""
        lo, hi = self.t_range
        t = linspace(lo, hi, max(2, int(np.ceil((hi - lo) / step_px)) + 1))
        out = np.empty((len(t), 3))
        out[:, 1 if self.by_row else 0] = t
        if np.isfinite(t).all():            # inside the span: the polynomials themselves (as _eval)
            out[:, 0 if self.by_row else 1] = self.s_poly(t)
            out[:, 2] = self.d_poly(t)
        else:
            out[:, 0 if self.by_row else 1] = self.s_at(t)
            out[:, 2] = self.d_at(t)
        return out


def end_slopes(t: np.ndarray, y: np.ndarray, reach: float = 60.0) -> tuple[float, float]:
    """Slopes dy/dt of straight lines fitted to the samples within ``reach`` of each end of t."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    lo, hi = float(t.min()), float(t.max())
    out = []
    for near in (t <= lo + reach, t >= hi - reach):
        tn = t[near]
        if len(tn) < 5 or float(tn.max()) - float(tn.min()) < 5:
            near = np.ones(len(t), bool)
            tn = t
        if float(tn.max()) > float(tn.min()):                  # least-squares slope
            dt = tn - float(tn.sum()) / len(tn)
            out.append(float(dt @ y[near]) / float(dt @ dt))
        else:
            out.append(0.0)
    return out[0], out[1]


def end_slopes_groups(t: np.ndarray, y: np.ndarray, g: np.ndarray, n_groups: int,
                      reach: float = 60.0) -> np.ndarray:
    """:func:`end_slopes` of every group at once (``g`` (N,) group ids, any order): (G, 2) slopes at
    each group's low and high end (the same rules; the sums in another order: equal up to rounding).
    Groups without samples get 0."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    g = np.asarray(g, np.intp)
    if len(t) and t.ndim == 1:          # compiled: the same steps, bit for bit
        return kernels_fit.end_slopes_groups(np.ascontiguousarray(t), np.ascontiguousarray(y), np.ascontiguousarray(g),
                                         int(n_groups), float(reach))
    return _end_slopes_groups_np(t, y, g, n_groups, reach)


def _end_slopes_groups_np(t: np.ndarray, y: np.ndarray, g: np.ndarray, n_groups: int, reach: float) -> np.ndarray:
    """:func:`end_slopes_groups` in numpy (the reference of :func:`kernels_fit.end_slopes_groups`)."""
    out = np.zeros((n_groups, 2))
    if not len(t):
        return out
    lo, hi = np.full(n_groups, np.inf), np.full(n_groups, -np.inf)
    np.minimum.at(lo, g, t)
    np.maximum.at(hi, g, t)
    for k, near in enumerate((t <= (lo + reach)[g], t >= (hi - reach)[g])):
        n = np.bincount(g, near, n_groups)
        t_lo, t_hi = np.full(n_groups, np.inf), np.full(n_groups, -np.inf)
        np.minimum.at(t_lo, g[near], t[near])
        np.maximum.at(t_hi, g[near], t[near])
        whole = (n < 5) | (t_hi - t_lo < 5)                # too few near the end: all the samples
        near = near | whole[g]
        n = np.bincount(g, near, n_groups)
        mean = np.bincount(g, np.where(near, t, 0.0), n_groups) / np.maximum(n, 1)
        dt = np.where(near, t - mean[g], 0.0)
        sxx = np.bincount(g, dt * dt, n_groups)
        sxy = np.bincount(g, dt * y, n_groups)
        out[:, k] = np.where(sxx > 0, sxy / np.where(sxx > 0, sxx, 1.0), 0.0)
    return out


@dataclass(frozen=True, eq=False)
class GroupPolys:
    """Polynomials of several groups of samples at once (one per branch piece), as :class:`Poly`.

    ``coef`` (G, 4) holds each group's coefficients highest power first, padded with leading
    zeros to degree 3 (Horner over the padding gives the same sums as over the unpadded
    coefficients); ``t0``, ``ts`` (G,) the parameter scaling; ``degree`` (G,) int.
    """

    coef: np.ndarray
    t0: np.ndarray
    ts: np.ndarray
    degree: np.ndarray

    def __call__(self, g: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Values at parameters ``t`` (N,) of samples of groups ``g`` (N,)."""
        x = (np.asarray(t, float) - self.t0.take(g)) / self.ts.take(g)
        c0, c1, c2, c3 = self._coef_rows    # (a gather per coefficient, from contiguous rows: the same values)
        y = x * c0.take(g) + c1.take(g)
        y = y * x + c2.take(g)
        return y * x + c3.take(g)

    @cached
    def _coef_rows(self) -> np.ndarray:
        return np.ascontiguousarray(self.coef.T)

    def deriv(self) -> GroupPolys:
        d = np.zeros_like(self.coef)
        d[:, 1:] = self.coef[:, :3] * np.array([3.0, 2.0, 1.0]) / self.ts[:, None]
        return GroupPolys(d, self.t0, self.ts, np.maximum(self.degree - 1, 0))

    def poly(self, k: int) -> Poly:
        """Group ``k``'s :class:`Poly`."""
        return Poly(self.coef[k, 3 - int(self.degree[k]):].copy(), float(self.t0[k]), float(self.ts[k]))

    @classmethod
    def of(cls, polys: list[Poly]) -> GroupPolys:
        coef = np.zeros((len(polys), 4))
        for k, p in enumerate(polys):
            coef[k, 4 - len(p.coef):] = p.coef
        return cls(coef, np.array([float(p.t0) for p in polys]), np.array([float(p.ts) for p in polys]),
                   np.array([len(p.coef) - 1 for p in polys]))


def fit_groups(t: np.ndarray, y: np.ndarray, g: np.ndarray, n_groups: int, degree: np.ndarray,
               increasing: bool | None = None) -> GroupPolys:
    """:meth:`Poly.fit` of every group at once (``g`` (N,) non-decreasing group ids; ``degree`` (G,)).

    Compiled (:func:`kernels_fit.fit_groups`): per group the normal equations from its power sums
    (those of ``np.add.reduceat``, bit for bit), solved by elimination: the same least squares as
    :meth:`Poly.fit` up to rounding (~1e-16). Groups without samples get a constant 0.
    ``increasing`` is accepted for the callers' sake (each group is tested as it is fitted).
    """
    coef, t0, ts, deg = kernels_fit.fit_groups(np.ascontiguousarray(t, float), np.ascontiguousarray(y, float), _bounds(g, n_groups),
                                           np.ascontiguousarray(degree, np.int64))
    return GroupPolys(coef, t0, ts, deg)


def _bounds(g: np.ndarray, n_groups: int) -> np.ndarray:
    """Each group's first sample and, last, the number of samples (``g`` non-decreasing): (G + 1,)."""
    return np.searchsorted(g, np.arange(n_groups + 1))


def robust_fit_groups(t: np.ndarray, y: np.ndarray, g: np.ndarray, n_groups: int, degree: np.ndarray,
                      rounds: int | np.ndarray = 3, k_mad: float = 3.5) -> tuple[GroupPolys, np.ndarray]:
    """:func:`robust_fit` of every group at once (``g`` (N,) non-decreasing; ``degree`` (G,) int;
    ``rounds`` one for all or (G,) per group: each group's values are those of fitting it alone).
    Compiled (:func:`kernels_fit.robust_fit_groups`).

    Returns
    -------
    (GroupPolys, inliers bool (N,))
    """
    coef, t0, ts, deg, keep = kernels_fit.robust_fit_groups(
        np.ascontiguousarray(t, float), np.ascontiguousarray(y, float), _bounds(g, n_groups),
        np.ascontiguousarray(degree, np.int64), np.array(np.broadcast_to(np.asarray(rounds, np.int64), (n_groups,))),
        float(k_mad))
    return GroupPolys(coef, t0, ts, deg), keep
