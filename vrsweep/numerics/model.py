"""The oscillator family, its parameters, and the original -> effective mapping.

Both models of the paper are one family (docs/design.md):

    x'' + gamma (x^2 - mu) x' + stiffness x + alpha x^3 = c cos(omega t) + g cos(Omega t),   x < Delta
    x'(+) = -e x'(-)  at x = Delta                                                            # eq2.2

original  (eq2.1):  mu = 1, stiffness = -omega0^2, fast forcing g cos(Omega t)
effective (eq2.10): mu = K (eq2.12), stiffness = wt2 (eq2.11, signed: ERRATA 5), no fast forcing

The kernel sees only the coefficient vector built here, so it knows nothing of which model runs.
"""

import numpy as np

from vrsweep.numerics.coefficients import (
    ABOVE, HARMONIC, MAX_STEP, N_BARRIERS, N_HEADER, PERIOD, POSITION, RESPONSE_FREQUENCY, RESPONSE_SCALE, RESTITUTION,
    SCAN_STEP, SIDE, STICK_SCAN_FRACTION, barrier_slot,
)

PARAMETER_NAMES = ("gamma", "alpha", "c", "omega0", "omega", "Delta", "e", "g", "Omega")

# The paper's values (Fig. 1; Omega = 4).
DEFAULT_PARAMETERS = {
    "gamma": 0.22, "alpha": 0.1, "c": 0.04, "omega0": 0.1, "omega": 0.5,
    "Delta": 1.0, "e": 0.95, "g": 0.0, "Omega": 4.0,
}

PARAMETER_UNITS = {name: "1" for name in PARAMETER_NAMES}  # the paper's model is dimensionless
PARAMETER_LONG_NAMES = {
    "gamma": "Van der Pol damping coefficient gamma",
    "alpha": "cubic stiffness alpha",
    "c": "slow forcing amplitude c",
    "omega0": "linear stiffness frequency omega0",
    "omega": "slow forcing frequency omega",
    "Delta": "barrier position Delta",
    "e": "coefficient of restitution e",
    "g": "fast forcing amplitude g",
    "Omega": "fast forcing frequency Omega",
}
PARAMETER_SYMBOLS = {
    "gamma": r"$\gamma$", "alpha": r"$\alpha$", "c": r"$c$", "omega0": r"$\omega_0$",
    "omega": r"$\omega$", "Delta": r"$\Delta$", "e": r"$e$", "g": r"$g$", "Omega": r"$\Omega$",
}

# The initial state x(0), x'(0) may be swept too (the paper's x0, v0): each grid point then starts
# from its own state instead of the config's `initial` (basins of attraction, docs/design.md).
INITIAL_STATE_AXES = ("x0", "v0")
INITIAL_STATE_KEYS = {"x0": "x", "v0": "v"}  # axis -> key of the config's `initial` section
INITIAL_STATE_UNITS = {"x0": "1", "v0": "1"}
INITIAL_STATE_LONG_NAMES = {"x0": "initial position x(0)", "v0": "initial velocity x'(0)"}
INITIAL_STATE_SYMBOLS = {"x0": r"$x(0)$", "v0": r"$\dot{x}(0)$"}

# Everything a sweep axis can be: a parameter or an initial-state component.
AXIS_UNITS = {**PARAMETER_UNITS, **INITIAL_STATE_UNITS}
AXIS_LONG_NAMES = {**PARAMETER_LONG_NAMES, **INITIAL_STATE_LONG_NAMES}


def axis_long_name(name: str, written: bool = False) -> str:
    """A file's words for an axis or parameter. A written model's parameter is its own, whatever
    its name: its `omega` or `c` is not the paper's slow forcing (a written damping `c` was stored
    as 'slow forcing amplitude c')."""
    if written and name not in INITIAL_STATE_LONG_NAMES:
        return f"model parameter {name}"
    return AXIS_LONG_NAMES.get(name, f"model parameter {name}")

MODELS = ("original", "effective")

# Layout of the kernel's coefficient vector: the header every model fills (coefficients.py),
# then this family's block, read only by its right-hand sides (rhs.py, tangent.py, impact.py).
GAMMA, MU, STIFFNESS, ALPHA, C, OMEGA, G, BIG_OMEGA, DELTA, E = range(N_HEADER, N_HEADER + 10)
N_COEFFICIENTS = N_HEADER + 10

# The largest step, as a share of a forcing period (kernel.py explains why steps are capped at all):
# with the fast forcing (g != 0) 1/8 of its period (1/6 left R 1.7e-3 off at g = 30, rtol 1e-4);
# without it (the effective model) 1/6 of the slow period (none left R 1.5e-5 off at g = 25).
FAST_STEP_FRACTION = 1.0 / 8.0
SLOW_STEP_FRACTION = 1.0 / 6.0


def effective_stiffness(alpha, omega0, g, Omega):
    """wt2 = 3 alpha g^2 / (2 Omega^4) - omega0^2, signed.  # eq2.11 (squared, ERRATA 5)"""
    with np.errstate(over="ignore"):  # g = 1e200: wt2 = inf, and the kernel reports non_finite
        return 1.5 * alpha * np.square(g) / np.power(Omega, 4) - np.square(omega0)


def effective_damping_level(g, Omega):
    """K = 1 - g^2 / (2 Omega^4).  # eq2.12"""
    with np.errstate(over="ignore"):
        return 1.0 - 0.5 * np.square(g) / np.power(Omega, 4)


def kernel_coefficients(parameters, model="original"):
    """Coefficient vectors for the kernel.

    parameters: mapping name -> scalar or array (broadcast together), or a structured table.
    Returns float64 array of shape broadcast_shape + (N_COEFFICIENTS,).
    """
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, not {model!r}")
    p = {name: np.asarray(parameters[name], dtype=np.float64) for name in PARAMETER_NAMES}
    shape = np.broadcast_shapes(*(v.shape for v in p.values()))
    out = np.empty(shape + (N_COEFFICIENTS,))
    out[..., GAMMA] = p["gamma"]
    out[..., ALPHA] = p["alpha"]
    out[..., C] = p["c"]
    out[..., OMEGA] = p["omega"]
    out[..., DELTA] = p["Delta"]
    out[..., E] = p["e"]
    out[..., BIG_OMEGA] = p["Omega"]
    if model == "original":
        out[..., MU] = 1.0  # eq2.1
        out[..., STIFFNESS] = -np.square(p["omega0"])
        out[..., G] = p["g"]
    else:
        out[..., MU] = effective_damping_level(p["g"], p["Omega"])  # eq2.12
        out[..., STIFFNESS] = effective_stiffness(p["alpha"], p["omega0"], p["g"], p["Omega"])  # eq2.11
        out[..., G] = 0.0  # eq2.10: the fast forcing has been averaged out
    fill_header(out)
    return out


def fill_header(out):
    """The kernel's header (coefficients.py) of the family's vectors: T = 2 pi / omega, R = |Q| / c
    at omega (eq3.3), one barrier above at Delta with restitution e (eq2.2)."""
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        slow_period = 2.0 * np.pi / out[..., OMEGA]
        fast = out[..., G] != 0.0
        # Without the fast forcing (the effective model) Omega may be anything: left out.
        fast_period = np.where(fast, 2.0 * np.pi / np.where(fast, out[..., BIG_OMEGA], 1.0), np.inf)
        out[..., PERIOD] = slow_period
        out[..., MAX_STEP] = np.where(fast, np.minimum(SLOW_STEP_FRACTION * slow_period,
                                                       FAST_STEP_FRACTION * 2.0 * np.pi / np.where(
                                                           fast, out[..., BIG_OMEGA], 1.0)),
                                      SLOW_STEP_FRACTION * slow_period)
        out[..., SCAN_STEP] = STICK_SCAN_FRACTION * np.minimum(slow_period, fast_period)
    out[..., RESPONSE_FREQUENCY] = out[..., OMEGA]
    out[..., RESPONSE_SCALE] = out[..., C]
    out[..., N_BARRIERS] = 1.0
    out[..., HARMONIC] = out[..., OMEGA]  # the forcing's phases, rotated by dop853 (rhs.py)
    out[..., HARMONIC + 1] = np.where(out[..., G] != 0.0, out[..., BIG_OMEGA], 0.0)
    out[..., barrier_slot(0, POSITION)] = out[..., DELTA]
    out[..., barrier_slot(0, SIDE)] = ABOVE
    out[..., barrier_slot(0, RESTITUTION)] = out[..., E]
    out[..., barrier_slot(1, POSITION)] = np.nan
    out[..., barrier_slot(1, SIDE)] = ABOVE
    out[..., barrier_slot(1, RESTITUTION)] = np.nan
