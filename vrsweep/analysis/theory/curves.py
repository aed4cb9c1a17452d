"""Curves of the theory in a parameter plane: the fold (two fixed points of the slow flow eq2.24
merge: the cubic's discriminant) and the Hopf curve (the small fixed point changes stability: a
Neimark-Sacker curve of the orbits), found as zeros along one parameter for each value of the
other. Part of ``vrsweep.analysis.theory``; drawn over maps by plot/curves.py."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from vrsweep.analysis.theory.response import fixed_point_cubic, fixed_point_phase
from vrsweep.analysis.theory.slowflow import _get, damping_level, g_res, slow_flow_jacobian


# --------------------------------------------------------------------------------------------
# 3b. Bifurcations of the slow flow in a parameter plane: folds and Hopf points
# --------------------------------------------------------------------------------------------

THEORY_PLANE_PARAMETERS = ("gamma", "alpha", "c", "omega0", "omega", "g", "Omega")
FOLD_SAMPLES = 2001
BISECTION_STEPS = 80  # halves a bracket 80 times: far below rounding for any bracket width


def fold_discriminant(params: Mapping) -> np.ndarray:
    """Discriminant of the fixed-point cubic in u = R^2, divided by a3^4 (that of the monic cubic).

    # eq2.27 (ERRATA 2, 3): the cubic of ``fixed_point_cubic``

        D = 18 a3 a2 a1 a0 - 4 a2^3 a0 + a2^2 a1^2 - 4 a3 a1^3 - 27 a3^2 a0^2

    D > 0: three distinct real roots (three fixed points: hysteresis); D < 0: one; D = 0: two roots
    merge, a saddle-node (fold) of the slow flow. With F > 0 every real root is positive
    (``fixed_point_cubic``), so every zero of D is a fold of fixed points with R > 0. Broadcasts
    over the parameter arrays; shape: their broadcast shape.
    """
    a3, a2, a1, a0 = fixed_point_cubic(params)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        b2, b1, b0 = a2 / a3, a1 / a3, a0 / a3  # monic: the sign is D's, the scale a3-free
        return 18.0 * b2 * b1 * b0 - 4.0 * b2**3 * b0 + b2**2 * b1**2 - 4.0 * b1**3 - 27.0 * b0**2


def fold_amplitude(params: Mapping) -> np.ndarray:
    """R at the double root of the fixed-point cubic, where ``fold_discriminant`` vanishes.

    For a cubic with a double root u2 and a simple root u1, the closed form
    u2 = (9 a3 a0 - a2 a1) / (2 (a2^2 - 3 a3 a1)) (from the remainder of p divided by p'). NaN
    where it is not positive; meaningless away from D = 0 (and 0/0 at a cusp, a triple root).
    """
    a3, a2, a1, a0 = fixed_point_cubic(params)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = (9.0 * a3 * a0 - a2 * a1) / (2.0 * (a2 * a2 - 3.0 * a3 * a1))
        return np.where(u > 0.0, np.sqrt(np.where(u > 0.0, u, 0.0)), np.nan)


def hopf_function(params: Mapping) -> np.ndarray:
    """The fixed-point cubic at u = 2K: zero where a fixed point has R^2 = 2K.

    At a fixed point of the corrected slow flow (eq2.24, ERRATA 1) the Jacobian's trace is
    Gamma (K - R^2/2) (see ``analytic_peak``): it vanishes on R^2 = 2K, which needs K > 0. Where
    the Jacobian's determinant is positive there, the fixed point changes stability with a complex
    pair crossing the imaginary axis: a Hopf point of the slow flow, a Neimark-Sacker (torus)
    bifurcation of the periodic orbit it stands for. Divided by a3 like ``fold_discriminant``.
    """
    a3, a2, a1, a0 = fixed_point_cubic(params)
    u = 2.0 * damping_level(params)
    with np.errstate(divide="ignore", invalid="ignore"):
        return ((u + a2 / a3) * u + a1 / a3) * u + a0 / a3


@dataclasses.dataclass(frozen=True)
class ParameterCurve:
    """A curve of the analytic theory in a parameter plane, as values of ``over`` per value of ``along``.

    along, over: parameter names; values: shape (n,), the values of ``along``; at: shape (n, k),
    the values of ``over`` where the curve crosses the line ``along = values[i]``, ascending,
    NaN-padded (all NaN where it does not cross within the searched range); R: shape (n, k), the
    amplitude of X (eq2.21) of the fixed point at that bifurcation (not the gain; ERRATA 6).
    kind: "fold" or "hopf".
    """

    kind: str
    along: str
    over: str
    values: np.ndarray
    at: np.ndarray
    R: np.ndarray


def _check_plane(along, over):
    for role, name in (("along", along), ("over", over)):
        if name not in THEORY_PLANE_PARAMETERS:
            raise ValueError(f"{role}={name!r}: the first-order theory depends on "
                             f"{', '.join(THEORY_PLANE_PARAMETERS)} only (not on Delta or e)")
    if along == over:
        raise ValueError(f"along and over name the same parameter, {along!r}: a plane needs two")


def _zeros_along(function, params, along, values, over, within, samples):
    """Zeros in ``over`` of function(params) per value of ``along``: shape (n, k), NaN-padded.

    Sign changes on ``samples`` points of ``within``, each refined by bisection to rounding. Two
    zeros closer together than the sample spacing (next to a cusp) cancel and are missed; a zero
    where the function touches 0 without changing sign is missed too.
    """
    values = np.asarray(values, dtype=np.float64).ravel()
    low, high = (float(v) for v in within)
    if not (math.isfinite(low) and math.isfinite(high) and low < high):
        raise ValueError(f"within={within!r}: needs two finite numbers, the first the smaller")
    grid = np.linspace(low, high, int(samples))

    def evaluate(along_values, over_values):
        p = {name: _get(params, name) for name in THEORY_PLANE_PARAMETERS if name not in (along, over)}
        p[along], p[over] = along_values, over_values
        return function(p)

    sampled = evaluate(values[:, None], grid[None, :])  # (n, samples)
    sign = np.sign(sampled)
    rows, columns = np.nonzero(sign[:, :-1] * sign[:, 1:] < 0.0)
    exact_rows, exact_columns = np.nonzero(sampled == 0.0)  # a sample right on a zero
    left, right = grid[columns].copy(), grid[columns + 1].copy()
    left_sign = sign[rows, columns]
    for _ in range(BISECTION_STEPS):  # all brackets at once
        middle = 0.5 * (left + right)
        middle_sign = np.sign(evaluate(values[rows], middle))
        same = middle_sign == left_sign
        left, right = np.where(same, middle, left), np.where(same, right, middle)
    found_rows = np.concatenate([rows, exact_rows])
    found = np.concatenate([0.5 * (left + right), grid[exact_columns]])
    width = max(1, int(np.bincount(found_rows, minlength=values.size).max())) if found.size else 1
    at = np.full((values.size, width), np.nan)
    for i in range(values.size):
        mine = np.sort(found[found_rows == i])
        at[i, :mine.size] = mine
    return values, at


def _default_range(params, along, values, over, within):
    if within is not None:
        return within
    if over != "g":
        raise ValueError(f"within=(low, high): the range of {over} to search (a default exists for g only)")
    p = {name: _get(params, name) for name in ("alpha", "omega0", "omega", "Omega")}
    if along in p:
        p[along] = np.asarray(values, dtype=np.float64)
    resonance = np.asarray(g_res(p["alpha"], p["omega0"], p["omega"], p["Omega"]))
    if not np.all(np.isfinite(resonance)):
        raise ValueError("within=(low, high): g_res is undefined here (alpha <= 0), so no default range of g")
    return (0.0, 3.0 * float(resonance.max()))


def fold_curve(params: Mapping, along: str = "Omega", values=None, over: str = "g", within=None,
               samples: int = FOLD_SAMPLES) -> ParameterCurve:
    """The fold (saddle-node) curve of the slow flow in the (over, along) plane, e.g. (g, Omega).

    # eq2.24 (corrected, ERRATA 1), eq2.27 as a cubic in R^2 (ERRATA 2, 3)

    Where two fixed points merge: the discriminant of the fixed-point cubic vanishes
    (``fold_discriminant``). For each value of ``along`` (default: params[along]), the values of
    ``over`` in ``within`` (default for g: 0 to 3 g_res) where it does, found on ``samples``
    points and refined by bisection to rounding; see ``_zeros_along`` for what can be missed.
    ParameterCurve.at has shape (len(values), k), NaN where there is no fold. The fold does not
    depend on the barrier (Delta, e): the theory ignores it.
    """
    _check_plane(along, over)
    values = np.atleast_1d(np.asarray(params[along] if values is None else values, dtype=np.float64))
    within = _default_range(params, along, values, over, within)
    values, at = _zeros_along(fold_discriminant, params, along, values, over, within, samples)
    R = _at_curve(fold_amplitude, params, along, values, over, at)
    return ParameterCurve("fold", along, over, values, at, R)


def hopf_curve(params: Mapping, along: str = "Omega", values=None, over: str = "g", within=None,
               samples: int = FOLD_SAMPLES) -> ParameterCurve:
    """The Hopf curve of the slow flow (a Neimark-Sacker curve of the orbits) in the (over, along) plane.

    # eq2.24 (corrected, ERRATA 1): trace of the Jacobian Gamma (K - R^2/2) = 0 at a fixed point

    Zeros of ``hopf_function`` (a fixed point with R^2 = 2K) where K > 0 and the Jacobian's
    determinant is positive (a complex pair on the imaginary axis, not a neutral saddle).
    Arguments and result as ``fold_curve``; R = sqrt(2K).
    """
    _check_plane(along, over)
    values = np.atleast_1d(np.asarray(params[along] if values is None else values, dtype=np.float64))
    within = _default_range(params, along, values, over, within)
    values, at = _zeros_along(hopf_function, params, along, values, over, within, samples)
    p = _plane_parameters(params, along, values[:, None], over, at)
    K = damping_level(p)
    with np.errstate(invalid="ignore"):
        R = np.sqrt(np.where(K > 0.0, 2.0 * K, np.nan))
        J = slow_flow_jacobian(R, fixed_point_phase(R, p), p)
        determinant = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
        keep = np.isfinite(R) & (determinant > 0.0)
    at, R = np.where(keep, at, np.nan), np.where(keep, R, np.nan)
    order = np.argsort(at, axis=1)  # NaN last
    return ParameterCurve("hopf", along, over, values, np.take_along_axis(at, order, 1),
                          np.take_along_axis(R, order, 1))


def _plane_parameters(params, along, along_values, over, over_values):
    p = {name: _get(params, name) for name in THEORY_PLANE_PARAMETERS if name not in (along, over)}
    p[along], p[over] = along_values, over_values
    return p


def _at_curve(function, params, along, values, over, at):
    return function(_plane_parameters(params, along, values[:, None], over, at))
