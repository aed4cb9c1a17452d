"""The fixed points of the slow flow, i.e. the frequency response (eq2.27 with the missing K
restored, ERRATA 2), solved the clean way round (ERRATA 3): a cubic in R^2 whose positive roots
are the response branches, stability from the slow flow's Jacobian; the analytic columns a sweep
file stores, the peak of the response over g, and a config's predictions row by row (what
``vrsweep theory`` shows). Part of ``vrsweep.analysis.theory``."""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping

import numpy as np

from vrsweep.analysis.theory.slowflow import (
    AMPLITUDE_NOTE, BARRIER_NOTE, THEORY_NOTE, _get, damping_level, effective_frequency_squared, fast_force, g_res,
    slow_flow_coefficients, slow_flow_jacobian,
)


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


def outside_theory(params: Mapping) -> str | None:
    """Why the first-order theory has no numbers at ``params`` (one line naming the parameters),
    None where it has. ``vrsweep theory --set Omega=1e-300`` printed wt2 and K as "nan..nan" and
    blamed a limit cycle ("no stable fixed point on the g grid"): Omega^4 underflowed to 0, and
    every number of the row was 0/0 or g^2/0.

    - Omega <= omega: the effective system (eq2.10) is the original one averaged over the fast
      force's period, and there is no fast force to average over (``fast_force``; the figures
      leave the theory out there too).
    - A term every number of a row goes through beyond a double's range (about 1.8e308, or
      below its smallest): Omega^4 (wt2 and K divide by it, eq2.11, eq2.12), g_res (eq3.4), the
      slow flow's coefficients gamma/omega, alpha/omega^2, c/omega^2 (eq2.13), and the cubic
      whose roots are the amplitudes at g_res and 2 g_res (the peak's default grid).

    A g of the config's own beyond the range (a g axis to 1e200) is not the theory's: that g's
    wt2 and K are inf (null in JSON), the other values are shown.
    """
    p = {name: float(params[name]) for name in ("gamma", "alpha", "c", "omega0", "omega", "Omega")}
    if not bool(fast_force(p)):
        return (f"Omega = {p['Omega']:g} is not above omega = {p['omega']:g}: the effective system (eq2.10) averages "
                "over the fast force, which must be faster than the slow one; the theory has nothing to say there")
    with np.errstate(all="ignore"):
        fourth = np.float64(p["Omega"]) ** 4
        if fourth == 0.0 or not np.isfinite(fourth):
            return (f"Omega^4, by which wt2 and K divide (eq2.11, eq2.12), is beyond a double's range at "
                    f"Omega = {p['Omega']:g}: the theory has no numbers there")
        resonance = float(g_res(p["alpha"], p["omega0"], p["omega"], p["Omega"]))
        if p["alpha"] > 0.0 and not math.isfinite(resonance):
            return (f"g_res = Omega^2 sqrt(2 (omega^2 + omega0^2) / (3 alpha)) (eq3.4) is beyond a double's range "
                    f"at Omega = {p['Omega']:g}, alpha = {p['alpha']:g}: the theory has no numbers there")
        co = slow_flow_coefficients(dict(p, g=0.0))
        if not all(np.isfinite(value) for value in (co.Gamma, co.Lambda, co.F)):
            return (f"the slow flow's coefficients gamma/omega, alpha/omega^2, c/omega^2 (eq2.13) are beyond a "
                    f"double's range at omega = {p['omega']:g}: the theory has no numbers there")
        if math.isfinite(resonance) and not all(np.all(np.isfinite(term)) for term in fixed_point_cubic(
                dict(p, g=np.array([resonance, 2.0 * resonance])))):
            return (f"the fixed points' cubic (eq2.27) at g_res = {resonance:.4g} (eq3.4) is beyond a double's range "
                    f"at Omega = {p['Omega']:g}, omega = {p['omega']:g}: the theory has no numbers there")
    return None


def _cubic_finite(params, g_values) -> np.ndarray:
    """Whether the fixed points' cubic (eq2.27) is within a double's range at each of ``g_values``."""
    g = np.atleast_1d(np.asarray(g_values, dtype=np.float64))
    with np.errstate(all="ignore"):
        coefficients = fixed_point_cubic(dict(params, g=g))
    return np.logical_and.reduce([np.isfinite(np.broadcast_to(c, g.shape)) for c in coefficients])


def _beyond_range(params, g_values, g=None):
    """A row's note where the cubic whose roots are the amplitudes is beyond a double's range at
    some of its g (a g of 1e200, or Omega and omega so small that g^2/(Omega^4 omega^2)
    overflows): no amplitude there, and no limit cycle to blame for it. None where it is not.
    ``g_values``: the peak's grid; ``g``: the config's g where it is not swept."""
    where = []
    if g is not None and not _cubic_finite(params, [g]).all():
        where.append(f"g = {float(g):g}")
    grid = np.atleast_1d(np.asarray(g_values, dtype=np.float64))
    finite = _cubic_finite(params, grid) if grid.size else np.ones(0, dtype=bool)
    if not finite.all():
        first = float(np.min(np.abs(grid[~finite])))
        where.append(f"{int((~finite).sum())} of the {grid.size} values of g the peak is searched over "
                     f"(from g = {first:g})")
    if not where:
        return None
    return (f"the fixed points' cubic (eq2.27) is beyond a double's range at Omega = {float(params['Omega']):g}, "
            f"omega = {float(params['omega']):g} and {' and at '.join(where)}: no amplitude there")


def _row_without_theory(config, params, row_axes, g_swept, g_values, reason):
    """A row of ``theory_rows`` where the theory has no numbers (``outside_theory``): every one
    of them None ('-' in the table), and the reason its note."""
    return {
        "Omega": params["Omega"],
        "parameters": {name: (None if name == "g" and g_swept else params[name]) for name in config.parameters},
        "swept": {name: params[name] for name in row_axes if name != "Omega"},
        "g_res": None, "g_swept": g_swept, "g": None if g_swept else params["g"],
        "g_range": [float(np.min(g_values)), float(np.max(g_values))],
        "wt2_at_g": None, "K_at_g": None, "wt2_range": [None, None], "K_range": [None, None], "K_at_g_res": None,
        "stable_amplitudes_at_g": None, "stable_amplitudes_at_g_res": [], "amplitude_at_g_res": None,
        "peak_search": None, "peak_g": None, "peak_amplitude": None, "peak_gain": None,
        "notes": [reason], "outside_theory": True,
    }


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
        reason = outside_theory(params)
        if reason is not None:
            rows.append(_row_without_theory(config, params, row_axes, g_swept,
                                            np.asarray(axes["g"] if g_swept else [params["g"]], dtype=np.float64),
                                            reason))
            continue
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
        beyond = _beyond_range(params, g_values if g_values is not None else [], None if g_swept else params["g"])
        if beyond is not None:
            notes.append(beyond)
        if g_values is not None and not math.isfinite(peak_A):
            # where the grid has no number at all, ``beyond`` says why: no limit cycle is to blame
            if _cubic_finite(params, g_values).any():
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
            "outside_theory": False,
        })
    if rows and all(row["outside_theory"] for row in rows):
        # Nothing to show: the one reason (of the first row) is the answer, not a table of '-'.
        from vrsweep.errors import UsageError

        raise UsageError.naming("{source}: {reason}", source=config.source_name, reason=rows[0]["notes"][0])
    return rows
