"""The slow flow of the paper's analysis (eq2.10-eq2.24, eq3.4, eq2.20-eq2.22, ERRATA 1, 5, 9):
the effective slow system's coefficients wt2 (eq2.11, signed) and K (eq2.12), the resonance g_res
(eq3.4), the slow flow eq2.24 as re-derived (``literal=True``: the paper's printed form, for its
Fig. 6 only) and its Jacobian; the slow flow integrated in time and the reconstruction
X(t) ~ R cos(omega t + theta) (eq2.21, optionally with the third harmonics of eq2.26).
Part of ``vrsweep.analysis.theory`` (its docstring: the reading order and the conventions)."""

from __future__ import annotations

import dataclasses
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


def fast_force(params: Mapping) -> np.ndarray:
    """Where the effective system (eq2.10-eq2.12), and with it the resonance wt2 = omega^2 (eq3.4),
    means anything: Omega > omega. It is the original system averaged over the fast force's period
    2 pi/Omega at a fixed slow time; where that force is no faster than the slow one (Omega <=
    omega) there is nothing fast to average over, and g_res is a root of a formula, not a
    resonance of the motion."""
    return _get(params, "Omega") > _get(params, "omega")


def g_res(alpha, omega0, omega, Omega):
    """g_res = Omega^2 sqrt(2 (omega^2 + omega0^2) / (3 alpha)).   # eq3.4

    The g at which wt2 = omega^2 (eq2.11), i.e. zero detuning sigma. With the paper's parameters
    it is 21.065 at Omega = 4 and 32.914 at Omega = 5 (ERRATA 7): proportional to Omega^2 and to
    alpha^(-1/2), not to Omega and 1/alpha as the paper's text says.

    alpha <= 0 has no resonance (wt2 never reaches omega^2): inf for alpha = 0, NaN below. The
    formula holds for any Omega; the resonance exists only where Omega > omega (``fast_force``).
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
