"""Closed-form linear impact oscillator: an exact reference for impact sequences.

With gamma = 0 and alpha = 0 the paper's oscillator (eq2.1) is linear between impacts,

    x'' + k x = c cos(omega t) + g cos(Omega t),        x < Delta,
    x'(+) = -e x'(-)   at x = Delta                      # eq2.2

so between impacts x(t) is known in closed form: a homogeneous part (cos/sin for k > 0,
cosh/sinh for k < 0, a straight line for k = 0) plus the particular solutions
c cos(omega t)/(k - omega^2) and g cos(Omega t)/(k - Omega^2). The only numerical step left is
locating each impact, a scalar root of a known smooth function, which brentq does to ~1e-15.
That makes the impact times and velocities accurate to ~1e-12 over a few tens of impacts, so a
1e-8 comparison against an ODE solver (scipy in tests/reference.py, the numba kernel) tests the
solver and not the reference.

Time is always kept as an offset tau = t - t_i from the last impact so that the homogeneous part
is evaluated at small arguments (cosh/sinh of a large argument would lose digits to cancellation
between the homogeneous and particular parts).
"""

import math

import numpy as np
from scipy.optimize import brentq

# Two linear cases with many well-separated impacts and no sticking or grazing (checked by
# tests/test_reference.py against SciPy, and for separation by test_closed_form_cases_separated).
#
# 1. Slow forcing only: k = 0.04 (natural frequency 0.2, below the forcing frequency 0.5),
#    c = 0.3, omega = 0.5, barrier at Delta = 0.5, e = 0.8. The particular oscillation
#    (amplitude c/|k - omega^2| = 1.43) carries the mass well past the barrier every slow period, so
#    impacts come roughly once per slow period: over 25 impacts they are >= 11 time units apart and
#    every rebound is faster than 0.4.
# 2. Slow and fast forcing: k = 1, c = 0.3, omega = 0.5, g = 2, Omega = 4, Delta = 0.5, e = 0.95.
#    The fast term (amplitude g/|k - Omega^2| = 0.13) makes the approach curves wiggle, which
#    exercises root location on a non-trivial function; over 30 impacts they are >= 3.2 apart and
#    every rebound is faster than 1.4.
#
# Negative stiffness (the paper's k = -omega0^2) makes no good long case: without the cubic term
# the potential -|k| x^2/2 has no well below the barrier, and every start tried (c up to 2, fast
# forcing, e = 1) escapes to x -> -inf after a few impacts. test_reference.py checks the cosh/sinh
# branch over a finite horizon instead.
CLOSED_FORM_CASES = [
    dict(k=0.04, c=0.3, omega=0.5, g=0.0, Omega=4.0, Delta=0.5, e=0.8,
         x0=0.0, v0=0.5, n_impacts=25),
    dict(k=1.0, c=0.3, omega=0.5, g=2.0, Omega=4.0, Delta=0.5, e=0.95,
         x0=0.0, v0=1.0, n_impacts=30),
]

# Grid points per shortest time scale when scanning for the next crossing. Between two grid
# points x(t) then has at most one local extremum, which the scan locates exactly, so a graze
# (x touching Delta between grid points) cannot be missed.
_POINTS_PER_SCALE = 64


class LinearOscillator:
    """x'' + k x = c cos(omega t) + g cos(Omega t), solved in closed form from a state (t0, x0, v0).

    Refuses exact resonance (k = omega^2 with c != 0, or k = Omega^2 with g != 0): the particular
    solution there is secular, t sin(omega t), which this reference does not need.
    """

    def __init__(self, k, c, omega, g, Omega):
        self.k, self.c, self.omega, self.g, self.Omega = map(float, (k, c, omega, g, Omega))
        # (amplitude of the particular cos term, its frequency) for each active forcing
        self.forcings = []
        for amp, freq in ((self.c, self.omega), (self.g, self.Omega)):
            if amp == 0.0:
                continue
            detuning = self.k - freq * freq
            if detuning == 0.0 or abs(detuning) < 1e-12 * max(abs(self.k), freq * freq):
                raise ValueError(
                    f"exact resonance k = {self.k} = frequency^2 = {freq * freq}: "
                    "the closed form's particular solution is secular there; choose another k")
            self.forcings.append((amp / detuning, freq))
        self.s = math.sqrt(abs(self.k))

    def particular(self, t):
        """(x_p(t), x_p'(t)): the bounded periodic particular solution."""
        t = np.asarray(t, dtype=float)
        xp = np.zeros_like(t)
        vp = np.zeros_like(t)
        for a, w in self.forcings:
            xp = xp + a * np.cos(w * t)
            vp = vp - a * w * np.sin(w * t)
        return xp, vp

    def homogeneous(self, a, b, tau):
        """(h, h') for h'' + k h = 0 with h(0) = a, h'(0) = b, at offset tau."""
        tau = np.asarray(tau, dtype=float)
        s = self.s
        if self.k > 0.0:
            cs, sn = np.cos(s * tau), np.sin(s * tau)
            return a * cs + (b / s) * sn, -a * s * sn + b * cs
        if self.k < 0.0:
            ch, sh = np.cosh(s * tau), np.sinh(s * tau)
            return a * ch + (b / s) * sh, a * s * sh + b * ch
        return a + b * tau, b + 0.0 * tau

    def state(self, t0, x0, v0, t):
        """(x(t), v(t)) of the solution through (t0, x0, v0), with no barrier."""
        xp0, vp0 = self.particular(t0)
        h, hd = self.homogeneous(x0 - xp0, v0 - vp0, np.asarray(t, dtype=float) - t0)
        xp, vp = self.particular(t)
        return h + xp, hd + vp

    def shortest_time_scale(self):
        """The shortest period among the natural one (or growth time 1/s) and the forcings."""
        scales = [2.0 * math.pi / w for _, w in self.forcings]
        if self.s > 0.0:
            scales.append(2.0 * math.pi / self.s if self.k > 0 else 1.0 / self.s)
        return min(scales) if scales else math.inf


def _root(fun, a, b):
    """brentq at ~machine precision, re-checking the bracket with the scalar function itself."""
    fa, fb = fun(a), fun(b)
    if fa == 0.0:
        return a
    if fb == 0.0:
        return b
    if (fa > 0) == (fb > 0):
        raise RuntimeError(f"no sign change on [{a!r}, {b!r}] ({fa:.3g}, {fb:.3g}): scan too coarse?")
    return brentq(fun, a, b, xtol=1e-15, rtol=4.0 * np.finfo(float).eps)


def _next_crossing(osc, t0, x0, v0, Delta, horizon, dt):
    """First t > t0 with x(t) = Delta reached from below, or None if none before t0 + horizon.

    The scan assumes (and the grid step dt is chosen so) that x has at most one local extremum
    per grid interval. Then an interval holds an up-crossing iff x ends it at or above Delta,
    or x has a local maximum inside it that reaches Delta (a graze the end points cannot see).

    A restart after an impact has x(t0) = Delta and v0 < 0: t0 itself is not a crossing, and a
    quick return within the first interval (down to a local minimum and back up) is located
    from that minimum, so a root finder never sees the spurious root at t0.
    """
    def f(t):
        return float(osc.state(t0, x0, v0, t)[0]) - Delta

    def vel(t):
        return float(osc.state(t0, x0, v0, t)[1])

    n = max(2, int(math.ceil(horizon / dt)))
    edges = t0 + dt * np.arange(n + 1)
    xs, vs = osc.state(t0, x0, v0, edges)
    fs = xs - Delta
    restart = v0 < 0.0 and x0 >= Delta
    if not restart and (x0 > Delta or (x0 == Delta and v0 >= 0.0)):
        raise ValueError(f"state at t = {t0} is not below the barrier (x = {x0}, v = {v0})")
    for i in range(n):
        a, b = edges[i], edges[i + 1]
        fa, fb, va, vb = fs[i], fs[i + 1], vs[i], vs[i + 1]
        if i == 0 and restart:
            if fb < 0.0:
                continue
            # Back at the barrier within one grid step: through a local minimum, then up.
            if not vb > 0.0:
                raise RuntimeError(f"scan step {dt} too coarse after the restart at t = {t0}")
            return _root(f, _root(vel, a, b), b)
        if fa < 0.0 <= fb:
            return _root(f, a, b)
        if va > 0.0 > vb:
            tm = _root(vel, a, b)
            if f(tm) >= 0.0:
                return _root(f, a, tm)
    return None


def closed_form_impacts(k, c, omega, g, Omega, Delta, e, x0, v0, n_impacts,
                        t0=0.0, horizon=None, min_rebound=1e-9):
    """The first n_impacts impacts of the linear impact oscillator started at (t0, x0, v0).

    Returns (impact_times, v_before, v_after) as float arrays: impact times t_i, the analytic
    velocity x'(t_i-) just before each impact and x'(t_i+) = -e x'(t_i-) just after (eq2.2).
    Each flight is the exact solution from the previous rebound state (t_i, Delta, v_after_i).

    horizon: how long to search for the next impact before giving up (RuntimeError); default
    200 shortest time scales. A rebound slower than min_rebound is chatter (impacts accumulating
    at a point) and raises RuntimeError, as the reference is only meant for non-sticking motion.
    """
    osc = LinearOscillator(k, c, omega, g, Omega)
    scale = osc.shortest_time_scale()
    if not math.isfinite(scale):
        scale = 1.0
    dt = scale / _POINTS_PER_SCALE
    if horizon is None:
        horizon = 200.0 * scale
    times, before, after = [], [], []
    t, x, v = float(t0), float(x0), float(v0)
    for _ in range(n_impacts):
        ti = _next_crossing(osc, t, x, v, Delta, horizon, dt)
        if ti is None:
            raise RuntimeError(f"no impact within {horizon} time units after t = {t}")
        vminus = float(osc.state(t, x, v, ti)[1])
        if vminus <= 0.0:
            # x only touched Delta (a graze): the impact law is degenerate there.
            raise RuntimeError(f"grazing contact at t = {ti} (x'(-) = {vminus:.3g})")
        vplus = -e * vminus
        if abs(vplus) < min_rebound:
            raise RuntimeError(f"chatter at t = {ti}: rebound speed {abs(vplus):.3g}")
        times.append(ti)
        before.append(vminus)
        after.append(vplus)
        t, x, v = ti, float(Delta), vplus
    return np.array(times), np.array(before), np.array(after)


def closed_form_state(k, c, omega, g, Omega, Delta, e, x0, v0, t, t0=0.0):
    """(x(t), v(t)) of the impacting linear oscillator at the sorted times t, for plotting/checks."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    osc = LinearOscillator(k, c, omega, g, Omega)
    xs, vs = np.empty_like(t), np.empty_like(t)
    scale = osc.shortest_time_scale()
    dt = (scale if math.isfinite(scale) else 1.0) / _POINTS_PER_SCALE
    ts, x, v, i = float(t0), float(x0), float(v0), 0
    while i < t.size:
        ti = _next_crossing(osc, ts, x, v, Delta, t[-1] - ts + dt, dt)
        end = np.inf if ti is None else ti
        j = i + int(np.searchsorted(t[i:], end, side="right"))
        xs[i:j], vs[i:j] = osc.state(ts, x, v, t[i:j])
        i = j
        if ti is not None:
            ts, x, v = ti, float(Delta), -e * float(osc.state(ts, x, v, ti)[1])
    return xs, vs


def linear_energy(k, x, v, alpha=0.0):
    """Mechanical energy v^2/2 + k x^2/2 + alpha x^4/4 (conserved when gamma = c = g = 0, e = 1)."""
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    return 0.5 * v * v + 0.5 * k * x * x + 0.25 * alpha * x ** 4
