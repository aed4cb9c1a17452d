"""The paper's analysis (eq2.10-eq2.28, eq3.4), as corrected in docs/errata.md.

Reading order follows the paper:

1. the effective slow system (eq2.10) and its coefficients wt2 (eq2.11, signed: ERRATA 5) and
   K (eq2.12); the resonance condition wt2 = omega^2 gives g_res (eq3.4);
2. the slow flow of the multiple-scales analysis, eq2.24 *as re-derived* (ERRATA 1: the paper
   swaps sin(theta) and cos(theta)); the paper's printed form is kept behind ``literal=True`` for
   reproducing its Fig. 6 only;
3. its fixed points, i.e. the frequency response (eq2.27 with the missing K restored, ERRATA 2),
   solved the clean way round (ERRATA 3): for each g, compute wt2 and K, then
   F^2 = Gamma^2 R^2 (K - R^2/4)^2 + R^2 (3 Lambda R^2/4 - sigma)^2 is a cubic in R^2 whose
   positive roots are the response branches (one or three: hysteresis); stability from the
   eigenvalues of the slow-flow Jacobian;
4. the slow flow integrated in time from (R0, theta0) (eq2.20-eq2.22, ERRATA 9) and the
   reconstruction X(t) ~ R cos(omega t + theta) (eq2.21), optionally with the third harmonics of
   eq2.26.

No epsilon anywhere (ERRATA 4). Every epsilon of eq2.15 multiplies a parameter, and only the
products matter:

    eps*Gamma = gamma/omega,  eps*Lambda = alpha/omega^2,  eps*F = c/omega^2,
    eps*sigma = 1 - wt2/omega^2                                              (eq2.13, eq2.14)

and d/dtau = D0 + eps D1 with tau = omega t, so "dR/dtau" below is eps * dR/dtau1 of the paper,
written with those products. Rates (e.g. Jacobian eigenvalues) are per unit of tau = omega t.

Amplitudes here are amplitudes of the slow motion X, in the units of x. The numerical R of eq3.3
is a gain |Q|/c: divide by c before comparing with it (ERRATA 6).

The first-order theory does not see the barrier: the effective system's impact law (eq2.5) enters
only through the paper's choice of initial values (eq2.20). Where an amplitude exceeds Delta the
motion would hit the barrier and the analytic amplitude is indicative only.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping

import numpy as np

from vrsweep.numerics.model import effective_damping_level, effective_stiffness

THEORY_NOTE = (
    "analytic side: first-order multiple scales on the effective system eq2.10, following the "
    "corrected derivation (ERRATA 1-3): slow flow eq2.24 with sin/cos as re-derived, fixed points "
    "as the positive roots of a cubic in R^2, stability from the slow-flow Jacobian"
)
AMPLITUDE_NOTE = "A is the amplitude of the slow motion X (eq2.21), not the gain |Q|/c; the gain is A/c (ERRATA 6)"
BARRIER_NOTE = "the first-order theory ignores the barrier: where A > Delta the motion impacts and A is indicative only"


def _get(params: Mapping, name: str) -> np.ndarray:
    return np.asarray(params[name], dtype=np.float64)


# --------------------------------------------------------------------------------------------
# 1. Effective system and resonance condition
# --------------------------------------------------------------------------------------------


def effective_frequency_squared(params: Mapping) -> np.ndarray:
    """wt2 = 3 alpha g^2 / (2 Omega^4) - omega0^2, signed.   # eq2.11 (squared; ERRATA 5)

    Negative below g = Omega^2 omega0 sqrt(2/(3 alpha)): the effective linear stiffness is
    negative there (the double well survives), so the square root of eq2.11 is never taken.
    """
    return effective_stiffness(_get(params, "alpha"), _get(params, "omega0"),
                               _get(params, "g"), _get(params, "Omega"))


def damping_level(params: Mapping) -> np.ndarray:
    """K = 1 - g^2 / (2 Omega^4), the level of the effective Van der Pol damping.   # eq2.12"""
    return effective_damping_level(_get(params, "g"), _get(params, "Omega"))


def g_res(alpha, omega0, omega, Omega):
    """g_res = Omega^2 sqrt(2 (omega^2 + omega0^2) / (3 alpha)).   # eq3.4

    The g at which wt2 = omega^2 (eq2.11), i.e. zero detuning sigma. With the paper's parameters
    it is 21.065 at Omega = 4 and 32.914 at Omega = 5 (ERRATA 7): proportional to Omega^2 and to
    alpha^(-1/2), not to Omega and 1/alpha as the paper's text says.

    alpha <= 0 has no resonance (wt2 never reaches omega^2): inf for alpha = 0, NaN below.
    """
    alpha, omega0, omega, Omega = (np.asarray(v, dtype=np.float64) for v in (alpha, omega0, omega, Omega))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.square(Omega) * np.sqrt(2.0 * (np.square(omega) + np.square(omega0)) / (3.0 * alpha))


# --------------------------------------------------------------------------------------------
# 2. Slow flow
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class SlowFlowCoefficients:
    """The epsilon-products of eq2.15 in physical parameters (ERRATA 4); arrays broadcast together.

    Each field is the product with epsilon: ``Gamma`` is eps*Gamma = gamma/omega, and so on.
    """

    Gamma: np.ndarray   # eps*Gamma  = gamma / omega                  (eq2.13)
    Lambda: np.ndarray  # eps*Lambda = alpha / omega^2                (eq2.13)
    F: np.ndarray       # eps*F      = c / omega^2                    (eq2.13, ERRATA 4)
    sigma: np.ndarray   # eps*sigma  = 1 - wt2 / omega^2, the detuning (eq2.14)
    K: np.ndarray       # damping level                               (eq2.12)


def slow_flow_coefficients(params: Mapping) -> SlowFlowCoefficients:
    """eps*Gamma, eps*Lambda, eps*F, eps*sigma and K from physical parameters (eq2.13, eq2.14; ERRATA 4)."""
    omega = _get(params, "omega")
    return SlowFlowCoefficients(
        Gamma=_get(params, "gamma") / omega,
        Lambda=_get(params, "alpha") / np.square(omega),
        F=_get(params, "c") / np.square(omega),
        sigma=1.0 - effective_frequency_squared(params) / np.square(omega),
        K=damping_level(params),
    )


def slow_flow(R, theta, params: Mapping, literal: bool = False):
    """(dR/dtau, dtheta/dtau) of the slow flow, tau = omega t.   # eq2.24 (corrected, ERRATA 1)

    Corrected (default), from the secular terms of eq2.23:

        dR/dtau     = -Gamma R^3/8 + Gamma K R/2 - (F/2) sin(theta)
        R dtheta/dtau = 3 Lambda R^3/8 - sigma R/2 - (F/2) cos(theta)

    with Gamma, Lambda, F, sigma the epsilon-products (ERRATA 4).

    ``literal=True`` gives the paper's printed eq2.24, with sin and cos swapped -- for reproducing
    the paper's Fig. 6 only. It has the same fixed-point amplitudes but other phases, transients
    and stability.

    The polar form is singular at R = 0 (the phase is undefined there), as in the paper.
    """
    R = np.asarray(R, dtype=np.float64)
    theta = np.asarray(theta, dtype=np.float64)
    return _slow_flow_rates(R, theta, slow_flow_coefficients(params), literal)


def _slow_flow_rates(R, theta, co: SlowFlowCoefficients, literal: bool):
    """``slow_flow`` with the coefficients already computed."""
    sin_term, cos_term = np.sin(theta), np.cos(theta)
    if literal:
        sin_term, cos_term = cos_term, sin_term  # the paper's eq2.24 as printed
    R_cubed = R * R * R
    dR = -co.Gamma * R_cubed / 8.0 + co.Gamma * co.K * R / 2.0 - 0.5 * co.F * sin_term
    dtheta = (3.0 * co.Lambda * R_cubed / 8.0 - co.sigma * R / 2.0 - 0.5 * co.F * cos_term) / R
    return dR, dtheta


def slow_flow_jacobian(R, theta, params: Mapping, literal: bool = False) -> np.ndarray:
    """Jacobian d(dR/dtau, dtheta/dtau)/d(R, theta) of ``slow_flow``, shape (..., 2, 2).   # eq2.24 (ERRATA 1)

    Analytic; tests check it against finite differences.
    """
    co = slow_flow_coefficients(params)
    R = np.asarray(R, dtype=np.float64)
    theta = np.asarray(theta, dtype=np.float64)
    sin_term, cos_term = np.sin(theta), np.cos(theta)
    # Forcing terms: -F/2 s(theta) in dR/dtau and -F/(2R) c(theta) in dtheta/dtau, with
    # (s, c) = (sin, cos) in the corrected flow and (cos, sin) in the literal one.
    if literal:
        dtheta_forcing, dR_forcing_slope, dtheta_forcing_slope = sin_term, -sin_term, cos_term
    else:
        dtheta_forcing, dR_forcing_slope, dtheta_forcing_slope = cos_term, cos_term, -sin_term
    shape = np.broadcast_shapes(R.shape, theta.shape, *(np.shape(v) for v in dataclasses.astuple(co)))
    J = np.empty(shape + (2, 2))
    J[..., 0, 0] = -3.0 * co.Gamma * R**2 / 8.0 + co.Gamma * co.K / 2.0
    J[..., 0, 1] = -0.5 * co.F * dR_forcing_slope
    J[..., 1, 0] = 3.0 * co.Lambda * R / 4.0 + 0.5 * co.F * dtheta_forcing / R**2
    J[..., 1, 1] = -0.5 * co.F * dtheta_forcing_slope / R
    return J


# --------------------------------------------------------------------------------------------
# 3. Fixed points: the frequency response as a cubic in R^2
# --------------------------------------------------------------------------------------------


def fixed_point_cubic(params: Mapping):
    """Coefficients (a3, a2, a1, a0) of the fixed-point condition as a cubic in u = R^2.   # ERRATA 2, 3

    At a fixed point of eq2.24 (corrected), F sin(theta) = Gamma R (K - R^2/4) and
    F cos(theta) = R (3 Lambda R^2/4 - sigma); squaring and adding (the literal form gives the same,
    with sin and cos swapped):

        F^2 = Gamma^2 u (K - u/4)^2 + u (3 Lambda u/4 - sigma)^2
        0   = (Gamma^2 + 9 Lambda^2)/16 u^3 - (Gamma^2 K + 3 Lambda sigma)/2 u^2
              + (Gamma^2 K^2 + sigma^2) u - F^2

    This is eq2.27 solved for R at given sigma (i.e. given g through eq2.11, eq2.14) instead of the
    other way round. For u < 0 the right-hand side is below -F^2, so every real root is positive
    when F > 0.
    """
    co = slow_flow_coefficients(params)
    a3 = (np.square(co.Gamma) + 9.0 * np.square(co.Lambda)) / 16.0
    a2 = -(np.square(co.Gamma) * co.K + 3.0 * co.Lambda * co.sigma) / 2.0
    a1 = np.square(co.Gamma * co.K) + np.square(co.sigma)
    a0 = -np.square(co.F)
    return np.broadcast_arrays(a3, a2, a1, a0)


def _cubic_value_and_slope(u, a3, a2, a1, a0):
    return ((a3 * u + a2) * u + a1) * u + a0, (3.0 * a3 * u + 2.0 * a2) * u + a1


def _positive_real_roots(a3, a2, a1, a0) -> np.ndarray:
    """Positive real roots u of a3 u^3 + a2 u^2 + a1 u + a0, shape (..., 3), ascending, NaN-padded.

    Vectorised: eigenvalues of the companion matrices (np.roots does the same one polynomial at a
    time), then one Newton step on each real root where it reduces the residual. A root counts as
    real when its imaginary part is below 1e-7 of its size: near a fold (saddle-node) the two
    merging roots come out of the eigensolver as a pair with imaginary parts of order
    sqrt(machine epsilon), and the cubic vanishes there to rounding.
    """
    a3, a2, a1, a0 = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (a3, a2, a1, a0)))
    shape = a3.shape
    a3, a2, a1, a0 = (a.ravel() for a in (a3, a2, a1, a0))
    roots = np.full((a3.size, 3), np.nan, dtype=np.complex128)

    finite = np.isfinite(a3) & np.isfinite(a2) & np.isfinite(a1) & np.isfinite(a0)  # NaN in, NaN out
    cubic = finite & (a3 > 0.0)
    if np.any(cubic):
        companion = np.zeros((int(cubic.sum()), 3, 3))
        companion[:, 0, 0] = -a2[cubic] / a3[cubic]
        companion[:, 0, 1] = -a1[cubic] / a3[cubic]
        companion[:, 0, 2] = -a0[cubic] / a3[cubic]
        companion[:, 1, 0] = 1.0
        companion[:, 2, 1] = 1.0
        roots[cubic] = np.linalg.eigvals(companion)
    # gamma = alpha = 0 (a3 = a2 = 0): the linear case u sigma^2 = F^2, one root.
    linear = finite & (a3 == 0.0) & (a2 == 0.0) & (a1 > 0.0)
    roots[linear, 0] = -a0[linear] / a1[linear]

    size = np.abs(roots)
    is_real = np.isfinite(size) & (np.abs(roots.imag) <= 1e-7 * np.maximum(size, 1e-300))
    u = np.where(is_real, roots.real, np.nan)

    # One Newton step, kept only where it helps (it can overshoot next to a fold).
    coefficients = (a3[:, None], a2[:, None], a1[:, None], a0[:, None])
    value, slope = _cubic_value_and_slope(u, *coefficients)
    with np.errstate(divide="ignore", invalid="ignore"):
        polished = u - value / slope
    polished_value, _ = _cubic_value_and_slope(polished, *coefficients)
    better = np.isfinite(polished) & (np.abs(polished_value) < np.abs(value))
    u = np.where(better, polished, u)

    # Keep positive roots. With F = 0 (no slow forcing, a0 = 0) u = 0 is a root: R = 0 is no
    # response amplitude, so drop it (the eigensolver returns it as +-rounding).
    zero_scale = np.where(a0 == 0.0, 1e-12 * np.where(np.isfinite(size), size, 0.0).max(axis=1), 0.0)
    u = np.where(u > zero_scale[:, None], u, np.nan)
    return np.sort(u, axis=1).reshape(shape + (3,))  # NaN sorts last


def fixed_point_phase(R, params: Mapping, literal: bool = False):
    """theta at a fixed point of amplitude R.   # eq2.24 (corrected, ERRATA 1)

    Corrected: F sin(theta) = Gamma R (K - R^2/4), F cos(theta) = R (3 Lambda R^2/4 - sigma).
    Literal form: the same with sin and cos swapped.
    """
    co = slow_flow_coefficients(params)
    R = np.asarray(R, dtype=np.float64)
    F_sin = co.Gamma * R * (co.K - R**2 / 4.0)
    F_cos = R * (3.0 * co.Lambda * R**2 / 4.0 - co.sigma)
    if literal:
        F_sin, F_cos = F_cos, F_sin
    return np.arctan2(F_sin, F_cos)


def _eigenvalues_2x2(J):
    """Eigenvalues of (..., 2, 2) matrices from trace and determinant, shape (..., 2), complex."""
    trace = J[..., 0, 0] + J[..., 1, 1]
    det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    root = np.sqrt((trace**2 / 4.0 - det).astype(np.complex128))
    return np.stack([trace / 2.0 - root, trace / 2.0 + root], axis=-1)


@dataclasses.dataclass(frozen=True)
class FixedPoints:
    """Fixed points of the slow flow at one parameter set, ascending in R.

    R: amplitudes of X (not gains; ERRATA 6); theta: phases; stable: both eigenvalues have negative
    real part; eigenvalues: shape (n, 2), complex, per unit tau = omega t.
    """

    R: np.ndarray
    theta: np.ndarray
    stable: np.ndarray
    eigenvalues: np.ndarray

    def __len__(self):
        return len(self.R)


def _solve_fixed_points(params: Mapping, literal: bool = False):
    """All fixed points for broadcast parameter arrays: R, theta, stable, eigenvalues.

    Shapes (..., 3), (..., 3), (..., 3), (..., 3, 2); NaN (stable False) where a root is absent.
    """
    u = _positive_real_roots(*fixed_point_cubic(params))
    R = np.sqrt(u)
    # Parameters gain a trailing axis for the root index.
    per_root = {name: _get(params, name)[..., None] for name in ("gamma", "alpha", "c", "omega0", "omega", "g", "Omega")}
    theta = fixed_point_phase(R, per_root, literal)
    with np.errstate(invalid="ignore", divide="ignore"):
        eigenvalues = _eigenvalues_2x2(slow_flow_jacobian(R, theta, per_root, literal))
    stable = np.all(eigenvalues.real < 0.0, axis=-1) & np.isfinite(R)
    return R, theta, stable, eigenvalues


def fixed_points(params: Mapping, literal: bool = False) -> FixedPoints:
    """All fixed points (R > 0, theta) of the slow flow at one parameter set, with stability.

    # eq2.24 (corrected, ERRATA 1), eq2.27 (ERRATA 2) solved as a cubic in R^2 (ERRATA 3)

    params: mapping with scalar gamma, alpha, c, omega0, omega, g, Omega. One root or three
    (hysteresis; two can merge at a fold). ``literal=True`` uses the paper's printed eq2.24: same
    R, other theta and stability.
    """
    R, theta, stable, eigenvalues = _solve_fixed_points(params, literal)
    if R.shape != (3,):
        raise ValueError("fixed_points takes one parameter set (scalars); use response_branches or analytic_columns for grids")
    present = np.isfinite(R)
    return FixedPoints(R=R[present], theta=theta[present], stable=stable[present], eigenvalues=eigenvalues[present])


@dataclasses.dataclass(frozen=True)
class ResponseBranches:
    """The analytic response over a grid of g: up to three roots per g, ascending, NaN-padded.

    g: shape (n,); R, theta, stable: shape (n, 3). R is the amplitude of X (eq2.21), not the gain
    (ERRATA 6). Draw stable roots solid, unstable dashed; three roots at one g mean hysteresis.
    """

    g: np.ndarray
    R: np.ndarray
    theta: np.ndarray
    stable: np.ndarray


def response_branches(params: Mapping, g_values, literal: bool = False) -> ResponseBranches:
    """Fixed points of the slow flow for each g in g_values, other parameters from params.

    # eq2.24 (corrected, ERRATA 1), cubic in R^2 (ERRATA 2, 3), eq2.11, eq2.12 at each g
    """
    g = np.asarray(g_values, dtype=np.float64).ravel()
    at_each_g = {name: _get(params, name) for name in ("gamma", "alpha", "c", "omega0", "omega", "Omega")}
    at_each_g["g"] = g
    R, theta, stable, _ = _solve_fixed_points(at_each_g, literal)
    return ResponseBranches(g=g, R=R, theta=theta, stable=stable)


def _largest_stable(R, stable):
    """Largest stable amplitude over the last (root) axis; NaN where none is stable."""
    candidates = np.where(stable, R, -np.inf)
    best = candidates.max(axis=-1)
    return np.where(np.isfinite(best), best, np.nan)


def analytic_columns(grid_parameters: Mapping) -> dict:
    """The analytic side of a sweep, for storing beside the numerical grid.

    grid_parameters: parameter name -> array broadcast to the grid shape (``Config.grid_parameters()``).
    Returns name -> (array, dims_suffix, attrs), where dims_suffix names the dimensions the array
    has beyond the grid's:

    - ``A_theory`` (grid + ("root",)): amplitudes of X at the fixed points of the corrected slow
      flow (eq2.24, ERRATA 1; cubic in R^2, ERRATA 2, 3), ascending, NaN where absent;
    - ``A_theory_stable`` (grid + ("root",)), int8: 1 where that root is a stable fixed point;
    - ``A_theory_max_stable`` (grid): the largest stable amplitude, NaN where none is stable;
    - ``g_res`` (grid): eq3.4 (depends on alpha, omega0, omega, Omega only; the caller may reduce
      it to the Omega axis).

    Vectorised over the whole grid (companion-matrix eigenvalues): ~0.3 s for 10^5 points.
    """
    R, _, stable, _ = _solve_fixed_points(grid_parameters)
    amplitude_attrs = {"units": "1", "comment": (
        "first-order multiple-scales analysis of the effective system eq2.10; positive roots of the "
        "fixed-point cubic in R^2 (ERRATA 2, 3) of the corrected slow flow eq2.24 (ERRATA 1), "
        "ascending along 'root', NaN where absent; ignores the barrier (indicative only where > Delta); "
        "compare with |Q|, or with the gain R = |Q|/c after dividing by c")}
    return {
        "A_theory": (R, ("root",), {
            **amplitude_attrs,
            "long_name": "analytic amplitude of the slow motion X (eq2.21), not the gain |Q|/c; ERRATA 6",
        }),
        "A_theory_stable": (stable.astype(np.int8), ("root",), {
            "units": "1",
            "long_name": "stability of each analytic root of A_theory (1: stable fixed point of the corrected slow flow eq2.24)",
            "flag_values": np.array([0, 1], dtype=np.int8),
            "flag_meanings": "unstable_or_absent stable",
        }),
        "A_theory_max_stable": (_largest_stable(R, stable), (), {
            **amplitude_attrs,
            "long_name": "largest stable analytic amplitude of the slow motion X (eq2.21), not the gain |Q|/c; ERRATA 6; NaN if none",
        }),
        "g_res": (np.broadcast_to(g_res(grid_parameters["alpha"], grid_parameters["omega0"],
                                        grid_parameters["omega"], grid_parameters["Omega"]), R.shape[:-1]).copy(), (), {
            "units": "1",
            "long_name": "fast forcing amplitude at vibrational resonance g_res (eq3.4), where wt2 = omega^2",
        }),
    }


@dataclasses.dataclass(frozen=True)
class AnalyticPeak:
    """Largest stable analytic amplitude over a grid of g, per Omega (arrays shaped like Omega).

    g: where it is reached; amplitude: of X (eq2.21); gain: amplitude / c, the paper's R of eq3.3
    (ERRATA 6). NaN where no g of the grid has a stable root.
    """

    Omega: np.ndarray
    g: np.ndarray
    amplitude: np.ndarray
    gain: np.ndarray


def analytic_peak(params: Mapping, g_values) -> AnalyticPeak:
    """Where over g_values the largest stable amplitude is, for each Omega in params["Omega"].

    # eq2.24 (corrected, ERRATA 1), cubic in R^2 (ERRATA 2, 3)

    params["Omega"] may be a scalar or an array (other parameters scalars or broadcastable with it);
    the peak is only as fine as the g grid. Note that the largest stable amplitude need not sit at
    g_res: while K > 0 small amplitudes are self-excited (trace of the Jacobian = Gamma (K - R^2/2)),
    and with the paper's parameters the largest stable root is the Van der Pol-like branch at g = 0.
    """
    g = np.asarray(g_values, dtype=np.float64).ravel()
    Omega = _get(params, "Omega")
    over_grid = {name: _get(params, name)[..., None] for name in ("gamma", "alpha", "c", "omega0", "omega", "Omega")}
    over_grid["g"] = g
    R, _, stable, _ = _solve_fixed_points(over_grid)
    best = _largest_stable(R, stable)  # (..., len(g))
    any_stable = np.any(np.isfinite(best), axis=-1)
    index = np.argmax(np.where(np.isfinite(best), best, -np.inf), axis=-1)
    amplitude = np.where(any_stable, np.take_along_axis(best, index[..., None], axis=-1)[..., 0], np.nan)
    peak_g = np.where(any_stable, g[index], np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):  # c = 0: no gain to speak of
        gain = np.asarray(amplitude / _get(params, "c"))
    return AnalyticPeak(Omega=np.broadcast_to(Omega, amplitude.shape).copy(), g=peak_g,
                        amplitude=amplitude, gain=gain)


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


# --------------------------------------------------------------------------------------------
# 4. The slow flow in time, and back to X(t)
# --------------------------------------------------------------------------------------------

DEFAULT_SLOW_STEP = 0.05
"""Largest RK4 step in tau = omega t. The slow flow's rates are of order |eps*sigma|, eps*Gamma |K|,
eps*Lambda R^2 and eps*F/R, all O(1) or below for the paper's parameters, so h = 0.05 keeps the
RK4 error (~ (h rate)^4 per unit tau) far below what plots resolve. Pass max_step for extreme
parameters; tests check the 4th-order convergence."""


def integrate_slow_flow(params: Mapping, R0, theta0, tau_end, n_samples, literal: bool = False,
                        max_step: float = DEFAULT_SLOW_STEP):
    """Integrate the slow flow from (R0, theta0) at tau = 0 to tau_end.   # eq2.24 (corrected, ERRATA 1)

    Classical fixed-step RK4 in numpy, in the Cartesian coordinates u = R cos(theta),
    w = R sin(theta) of ``slow_flow_cartesian``: the polar form divides by R, so a start at rest
    (R0 = 0, e.g. x(0) = v(0) = 0) would give NaN from the first step, and a path passing close to
    the origin would lose accuracy. The step is the largest h <= max_step that divides the sample
    spacing tau_end/(n_samples - 1) evenly, so samples fall on steps (no interpolation). R0, theta0
    may be arrays (several starts at once). ``literal=True``: the paper's printed eq2.24, for
    reproducing its Fig. 6 only.

    Returns tau (n_samples,), R and theta (n_samples, *shape of R0). theta is continuous (not
    wrapped), starting at theta0; where R = 0 the phase is undefined and theta keeps its last value.
    """
    if n_samples < 2:
        raise ValueError("n_samples must be at least 2")
    if not tau_end > 0:
        raise ValueError("tau_end must be positive")
    if not max_step > 0:
        raise ValueError("max_step must be positive")
    spacing = tau_end / (n_samples - 1)
    steps_per_sample = max(1, math.ceil(spacing / max_step - 1e-9))
    h = spacing / steps_per_sample

    co = slow_flow_coefficients(params)
    if all(np.ndim(value) == 0 for value in dataclasses.astuple(co)):
        co = SlowFlowCoefficients(*(float(value) for value in dataclasses.astuple(co)))  # cheaper scalars

    def rates(u, w):
        return _cartesian_rates(u, w, co, literal)

    R = np.asarray(R0, dtype=np.float64).copy()
    theta = np.broadcast_to(np.asarray(theta0, dtype=np.float64), R.shape).copy()
    u, w = R * np.cos(theta), R * np.sin(theta)
    tau = np.linspace(0.0, tau_end, n_samples)
    R_out = np.empty((n_samples,) + R.shape)
    theta_out = np.empty((n_samples,) + R.shape)
    R_out[0], theta_out[0] = R, theta
    for sample in range(1, n_samples):
        for _ in range(steps_per_sample):
            k1u, k1w = rates(u, w)
            k2u, k2w = rates(u + 0.5 * h * k1u, w + 0.5 * h * k1w)
            k3u, k3w = rates(u + 0.5 * h * k2u, w + 0.5 * h * k2w)
            k4u, k4w = rates(u + h * k3u, w + h * k3w)
            u = u + h / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u)
            w = w + h / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w)
            # Follow theta step by step: a step turns the phase by far less than pi (except right
            # at the origin, where the phase means nothing), so the nearest branch is the path's.
            turn = np.arctan2(w, u) - theta
            theta = np.where((u != 0.0) | (w != 0.0), theta + (turn + np.pi) % (2.0 * np.pi) - np.pi, theta)
        R_out[sample], theta_out[sample] = np.hypot(u, w), theta
    return tau, R_out, theta_out


def slow_flow_cartesian(u, w, params: Mapping, literal: bool = False):
    """(du/dtau, dw/dtau) of the slow flow in u = R cos(theta), w = R sin(theta).   # eq2.24 (ERRATA 1)

    With X = R cos(tau + theta) = u cos(tau) - w sin(tau) (eq2.21), the corrected eq2.24 becomes

        du/dtau = a u - b w,    dw/dtau = a w + b u - F/2,
        a = Gamma (K/2 - R^2/8),  b = 3 Lambda R^2/8 - sigma/2,  R^2 = u^2 + w^2,

    smooth everywhere, the origin (rest) included. Same fixed points and trajectories as
    ``slow_flow`` wherever R > 0. The paper's printed form (``literal=True``, sin/cos swapped)
    has forcing -(F/2)(cos 2 theta, sin 2 theta), whose direction is undefined at R = 0: there it
    is taken at theta = 0.
    """
    co = slow_flow_coefficients(params)
    return _cartesian_rates(np.asarray(u, dtype=np.float64), np.asarray(w, dtype=np.float64), co, literal)


def _cartesian_rates(u, w, co: SlowFlowCoefficients, literal: bool):
    R_squared = u * u + w * w
    growth = co.Gamma * (0.5 * co.K - R_squared / 8.0)
    shift = 3.0 * co.Lambda * R_squared / 8.0 - 0.5 * co.sigma
    du = growth * u - shift * w
    dw = growth * w + shift * u
    if not literal:
        return du, dw - 0.5 * co.F
    safe = np.where(R_squared > 0.0, R_squared, 1.0)
    cos_2theta = np.where(R_squared > 0.0, (u * u - w * w) / safe, 1.0)
    sin_2theta = np.where(R_squared > 0.0, 2.0 * u * w / safe, 0.0)
    return du - 0.5 * co.F * cos_2theta, dw - 0.5 * co.F * sin_2theta


def initial_slow_state(params: Mapping, rule: str = "paper", l: float = 1, x0=None, v0=None):
    """(R0, theta0) for integrating the slow flow.   # eq2.20-eq2.22 (ERRATA 9)

    rule="paper": the paper's start after an impact, C1 = Delta, C2 = Delta tan(pi l/omega)
    (eq2.20), R0 = sqrt(C1^2 + C2^2), theta0 = atan2(-C2, C1) (eq2.22). That is the paper's
    R0 = Delta sec(pi l/omega), theta0 = atan(-tan(pi l/omega)) wherever sec > 0, and keeps R0 > 0
    with X(0) = Delta otherwise. l is the number of slow periods between impacts. For Fig. 6
    (omega = 0.5, l = 1): R0 = Delta, theta0 = 0.

    rule="state": from the initial state (x0, v0) at t = 0, with X = R cos(tau + theta) and
    dX/dt = -omega R sin(tau + theta) (eq2.21): R0 = sqrt(x0^2 + (v0/omega)^2),
    theta0 = atan2(-v0/omega, x0). For Fig. 6's x(0) = 0.99, x'(0) = 0.5: R0 = 1.407, theta0 = -0.790.
    """
    if rule == "paper":
        Delta, omega = _get(params, "Delta"), _get(params, "omega")
        C1 = Delta
        C2 = Delta * np.tan(np.pi * l / omega)
        return np.hypot(C1, C2), np.arctan2(-C2, C1)
    if rule == "state":
        if x0 is None or v0 is None:
            raise ValueError("rule='state' needs x0 and v0")
        scaled_velocity = np.asarray(v0, dtype=np.float64) / _get(params, "omega")
        x0 = np.asarray(x0, dtype=np.float64)
        return np.hypot(x0, scaled_velocity), np.arctan2(-scaled_velocity, x0)
    raise ValueError(f"rule must be 'paper' or 'state', not {rule!r}")


def reconstruct(t, tau, R, theta, params: Mapping, correction: bool = False):
    """X(t) and dX/dt from the slow flow's samples (tau, R, theta).   # eq2.21 (+ eq2.26)

    First order (eq2.21): X = R cos(phi), dX/dt = -omega R sin(phi), phi = omega t + theta.

    correction=True adds the O(eps) terms. The particular part of X1 in eq2.26, multiplied by eps
    and written with the epsilon-products (ERRATA 4):

        eps X1 = -(gamma/omega) R^3/32 sin(3 phi) + (alpha/omega^2) R^3/32 cos(3 phi)

    X1's homogeneous part R1 cos(tau + theta1) needs the second order (the paper stops there) and
    is left out. The velocity is omega (D0 + eps D1)(X0 + eps X1) to O(eps):

        dX/dt = omega [ -R sin(phi) + dR/dtau cos(phi) - R dtheta/dtau sin(phi)
                        - 3 (gamma/omega) R^3/32 cos(3 phi) - 3 (alpha/omega^2) R^3/32 sin(3 phi) ]

    with dR/dtau, dtheta/dtau from the corrected slow flow (zero at a fixed point).

    R and theta are interpolated linearly at tau = omega t, so sample the slow flow at least as
    finely as its own variation (integrate_slow_flow's samples); t must lie within the samples.
    """
    omega = float(_get(params, "omega"))
    t = np.asarray(t, dtype=np.float64)
    tau = np.asarray(tau, dtype=np.float64)
    slow_time = omega * t
    span = tau[-1] - tau[0]
    if np.any(slow_time < tau[0] - 1e-9 * span) or np.any(slow_time > tau[-1] + 1e-9 * span):
        raise ValueError("omega t must lie within the slow-flow samples tau")
    R_t = np.interp(slow_time, tau, np.asarray(R, dtype=np.float64))
    theta_t = np.interp(slow_time, tau, np.asarray(theta, dtype=np.float64))
    phase = slow_time + theta_t
    x = R_t * np.cos(phase)
    dx_dtau = -R_t * np.sin(phase)
    if correction:
        co = slow_flow_coefficients(params)
        third = R_t**3 / 32.0
        x = x - co.Gamma * third * np.sin(3 * phase) + co.Lambda * third * np.cos(3 * phase)
        dR, dtheta = slow_flow(R_t, theta_t, params)
        dx_dtau = (dx_dtau + dR * np.cos(phase) - R_t * dtheta * np.sin(phase)
                   - 3.0 * co.Gamma * third * np.cos(3 * phase) - 3.0 * co.Lambda * third * np.sin(3 * phase))
    return x, omega * dx_dtau


# ---------------------------------------------------------------------------------------------
# A config's predictions, row by row (what `vrsweep theory` shows)
# ---------------------------------------------------------------------------------------------

# Parameters that enter the first-order theory besides g. Delta and e do not (the theory ignores
# the barrier), so sweeping them gives no extra rows.
THEORY_PARAMETERS = ("gamma", "alpha", "c", "omega0", "omega", "Omega")
DEFAULT_G_POINTS = 2001  # the default peak grid 0..2 g_res, steps of g_res/1000


def _finite_or_none(value):
    value = float(value)
    return value if math.isfinite(value) else None


def _stable_amplitudes(params):
    points = fixed_points(params)
    return [float(R) for R in points.R[points.stable]]


def theory_rows(config) -> list[dict]:
    """The paper's predictions for a config, one dict per Omega (and per value of any other swept
    parameter that enters the theory): g_res (eq3.4), wt2 and K (eq2.11, eq2.12) at the config's g
    or over its g axis, and the analytic peak -- the largest stable amplitude of X over the g axis,
    or over DEFAULT_G_POINTS values of 0..2 g_res when g is not swept. ``vrsweep theory`` prints
    them (``--json``) or tabulates them. A written model has no such theory: UsageError."""
    if not isinstance(config.model, str):
        from vrsweep.errors import UsageError

        raise UsageError.naming("{source} writes its own model ({model}); the analytic theory (eq2.10-eq3.4) is "
                                "the paper's model's: run theory on a config with model: original or effective",
                                source=config.source_name, model=str(config.model))
    axes = {axis.name: axis.values for axis in config.axes}
    row_axes = [name for name in config.axis_names if name in THEORY_PARAMETERS]
    ignored_axes = [name for name in config.axis_names if name in ("Delta", "e")]
    g_swept = "g" in axes

    rows = []
    for row_values in itertools.product(*(axes[name] for name in row_axes)):
        params = dict(config.parameters)
        params.update({name: float(value) for name, value in zip(row_axes, row_values)})
        notes = [THEORY_NOTE, AMPLITUDE_NOTE]
        resonance_g = float(g_res(params["alpha"], params["omega0"], params["omega"], params["Omega"]))

        if g_swept:
            g_values = np.asarray(axes["g"], dtype=np.float64)
            search = {"source": "sweep axis g", "g_min": float(g_values.min()),
                      "g_max": float(g_values.max()), "num": int(g_values.size)}
        elif math.isfinite(resonance_g):
            g_values = np.linspace(0.0, 2.0 * resonance_g, DEFAULT_G_POINTS)
            search = {"source": "default grid 0..2 g_res", "g_min": 0.0, "g_max": float(g_values[-1]),
                      "num": DEFAULT_G_POINTS}
        else:
            g_values = None
            search = None
            notes.append("g_res is undefined (alpha <= 0: wt2 never reaches omega^2); sweep g to get a peak")

        at_g = dict(params)
        if g_swept:
            at_g["g"] = g_values
        wt2 = np.atleast_1d(effective_frequency_squared(at_g))
        K = np.atleast_1d(damping_level(at_g))

        if math.isfinite(resonance_g):
            at_resonance = dict(params, g=resonance_g)
            stable_at_resonance = _stable_amplitudes(at_resonance)
            K_at_resonance = float(damping_level(at_resonance))
        else:
            stable_at_resonance, K_at_resonance = [], math.nan

        if g_values is not None:
            peak = analytic_peak(params, g_values)
            peak_g, peak_A, peak_gain = float(peak.g), float(peak.amplitude), float(peak.gain)
        else:
            peak_g = peak_A = peak_gain = math.nan
        if g_values is not None and not math.isfinite(peak_A):
            notes.append("no stable fixed point on the g grid: the slow flow may settle on a limit cycle "
                         "(a modulated, quasi-periodic response) that the fixed points do not describe")
        elif g_values is not None and peak_g in (float(g_values.min()), float(g_values.max())):
            notes.append(f"the largest stable amplitude lies at the end g = {peak_g:g} of the g range: "
                         "no interior peak on the stable branch (while K > 0 small amplitudes are "
                         "self-excited and the stable branch is the large, Van der Pol-like one); "
                         "see A(g_res), amplitude_at_g_res in the JSON output")

        amplitudes = [peak_A, *stable_at_resonance]
        if not g_swept:
            stable_at_g = _stable_amplitudes(params)
            amplitudes += stable_at_g
        if any(A > params["Delta"] for A in amplitudes if math.isfinite(A)):
            notes.append(BARRIER_NOTE)
        if ignored_axes:
            notes.append(f"{' and '.join(ignored_axes)} (swept) {'does' if len(ignored_axes) == 1 else 'do'} "
                         "not enter the first-order theory")

        rows.append({
            "Omega": params["Omega"],
            "parameters": {name: (None if name == "g" and g_swept else params[name]) for name in config.parameters},
            "swept": {name: params[name] for name in row_axes if name != "Omega"},
            "g_res": _finite_or_none(resonance_g),
            "g_swept": g_swept,
            "g": None if g_swept else params["g"],
            "g_range": [float(np.min(at_g["g"])), float(np.max(at_g["g"]))],
            "wt2_at_g": None if g_swept else float(wt2[0]),
            "K_at_g": None if g_swept else float(K[0]),
            "wt2_range": [float(wt2.min()), float(wt2.max())],
            "K_range": [float(K.min()), float(K.max())],
            "K_at_g_res": _finite_or_none(K_at_resonance),
            "stable_amplitudes_at_g": None if g_swept else stable_at_g,
            "stable_amplitudes_at_g_res": stable_at_resonance,
            "amplitude_at_g_res": max(stable_at_resonance) if stable_at_resonance else None,
            "peak_search": search,
            "peak_g": _finite_or_none(peak_g),
            "peak_amplitude": _finite_or_none(peak_A),
            "peak_gain": _finite_or_none(peak_gain),
            "notes": notes,
        })
    return rows
