"""The head of every model's coefficient vector: what the kernel needs to know of any model.

A model's coefficient vector (one per grid point) starts with this header, filled in Python
from the point's parameters, and goes on with the model's own values, which only the model's
right-hand sides read (model.py's block for the paper's models; the parameters in declared
order for a written model, numerics/written.py):

    coefficients[PERIOD]               T, the stroboscopic period: sections, periods, R's window
    coefficients[MAX_STEP]             the largest step the controller may take (accuracy of R)
    coefficients[SCAN_STEP]            the step of the scan for the release of a stuck mass
    coefficients[RESPONSE_FREQUENCY]   w of R's Fourier component Q = (2/NT) int x e^{iwt} dt
    coefficients[RESPONSE_SCALE]       R = |Q| / scale, scale > 0 (eq3.3: c; a written model's |scale|)
    coefficients[N_BARRIERS]           0, 1 or 2 rigid stops
    coefficients[HARMONIC, HARMONIC + 1]   the frequencies whose cos and sin a dop853 step takes by
                                       rotating the phases of its start (rhs.py), 0 where unused
    coefficients[BARRIER + 3 b + POSITION, SIDE, RESTITUTION]    barrier b: where it is, SIDE
                                       +1 (above: the mass stays at x <= position) or -1 (below:
                                       x >= position), and its coefficient of restitution
    coefficients[N_HEADER:]            the model's own block

Plain Python, no numba: the config and execution layers fill it.
"""

import numpy as np

PERIOD, MAX_STEP, SCAN_STEP, RESPONSE_FREQUENCY, RESPONSE_SCALE, N_BARRIERS = range(6)
HARMONIC = 6
N_HARMONICS = 2
BARRIER = HARMONIC + N_HARMONICS
POSITION, SIDE, RESTITUTION = range(3)
BARRIER_VALUES = 3
MAX_BARRIERS = 2
N_HEADER = BARRIER + BARRIER_VALUES * MAX_BARRIERS

ABOVE = 1.0
BELOW = -1.0

# SCAN_STEP is this share of the model's shortest forcing period (the release of a stuck mass is a
# sign change of the force at the barrier, which no scan step this short steps over).
STICK_SCAN_FRACTION = 1.0 / 64.0


def shortest_period(coefficients):
    """The model's shortest forcing period (from SCAN_STEP: exact, a power of two)."""
    return coefficients[..., SCAN_STEP] / STICK_SCAN_FRACTION


def barrier_position(coefficients, barrier=0):
    return coefficients[..., BARRIER + BARRIER_VALUES * barrier + POSITION]


def grazing_barrier(coefficients):
    """Where continuation looks for grazes (analysis/grazing.py measures the orbit's highest smooth
    maximum against it): the first barrier above the mass, or +inf when a model has none above (its
    branches then end where an impact appears or disappears at a barrier below)."""
    coefficients = np.asarray(coefficients, dtype=np.float64)
    for barrier in range(int(coefficients[N_BARRIERS])):
        if coefficients[BARRIER + BARRIER_VALUES * barrier + SIDE] > 0.0:
            return float(coefficients[BARRIER + BARRIER_VALUES * barrier + POSITION])
    return np.inf


def grazing_scale(coefficients):
    """The length on which grazing tests measure a smooth maximum's gap to grazing_barrier's
    Delta and an impact's squared speed: max(1, |Delta|), and 1 where no barrier is above. (With
    |inf| as the scale every impact was "slow": a model whose only stop is below was next to a
    graze at every orbit, so its branches ended as grazes at folds and at the section.)"""
    barrier = grazing_barrier(coefficients)
    return max(1.0, abs(barrier)) if np.isfinite(barrier) else 1.0


def barrier_slot(barrier, value):
    """The index of one value (POSITION, SIDE, RESTITUTION) of barrier ``barrier``."""
    return BARRIER + BARRIER_VALUES * barrier + value


def free_of_barriers(coefficients):
    """A copy without the barriers' effect: each moved to infinity on its side, so the kernel
    never impacts (the barrier-free map of grazing.py)."""
    free = np.array(coefficients, dtype=np.float64)
    for barrier in range(MAX_BARRIERS):
        side = free[..., barrier_slot(barrier, SIDE)]
        free[..., barrier_slot(barrier, POSITION)] = np.where(side < 0.0, -np.inf, np.inf)
    return free


def only_barrier(coefficients, kept):
    """A copy with barrier ``kept`` alone in effect (the others moved to infinity on their side):
    the map with one stop's impacts only, at a graze of two stops at once (analysis/grazing.py)."""
    only = free_of_barriers(coefficients)
    slot = barrier_slot(kept, POSITION)
    only[..., slot] = np.asarray(coefficients, dtype=np.float64)[..., slot]
    return only
