"""The original model's forcing rule for continuation, in plain Python (no numba): ``vrsweep
validate`` checks a continuation section with it without importing the numerics, and
analysis/continuation.py and analysis/curves.py apply the same rule before they integrate."""

from __future__ import annotations

import math

from vrsweep.errors import UsageError
from vrsweep.numerics.settings import CONTINUATION_DEFAULTS

# Omega/omega is p/q when it agrees with it to this (relative): a ratio typed as a decimal (8.6 =
# 43/5) is p/q to roundoff, one that is not (8.6001) is off by far more.
RATIO_TOLERANCE = 1e-12


def check_commensurate(parameters, model, moving, max_period=CONTINUATION_DEFAULTS["max_period"]):
    """The slow periods q after which the original model's fast forcing g cos(Omega t) repeats, 1
    when there is none (another model, or g = 0 throughout); UsageError when it never repeats
    within ``max_period`` slow periods, or when Omega or omega moves.

    Decided from the values continued (``moving``: the parameter, or the names of a curve's two):
    a continued g is a forcing whatever parameters.g says, so the same Omega/omega is accepted or
    refused alike. Omega/omega = p/q in lowest terms repeats after q slow periods, and every
    periodic orbit closes after a multiple of q (find_start asks for one)."""
    from fractions import Fraction

    moving = (moving,) if isinstance(moving, str) else tuple(moving)
    if model != "original" or ("g" not in moving and parameters.get("g", 0.0) == 0.0):
        return 1
    for name in moving:
        if name in ("Omega", "omega"):
            raise UsageError.naming(
                "{parameter} = {name} cannot be continued in the original model: its fast forcing repeats "
                "only where Omega/omega is a ratio of whole numbers, which a moving {name} leaves at once; "
                "continue {name} in the effective model (no fast force) instead",
                {"parameter": "continuation.parameter"}, name=name)
    ratio = parameters["Omega"] / parameters["omega"]
    # Omega = 1e308 over omega = 0.5 overflows to inf, which Fraction refuses (a traceback): no p/q.
    fraction = Fraction(ratio).limit_denominator(max(int(max_period), 1)) if math.isfinite(ratio) else None
    if fraction is None or not abs(ratio - fraction) <= RATIO_TOLERANCE * abs(ratio):
        raise UsageError.naming(
            "Omega/omega = {ratio} is not a ratio p/q of whole numbers with q at most {max_period} = {limit}: "
            "the original model's fast forcing then repeats after no orbit period continue looks for (it is "
            "quasi-periodic), so there is no periodic orbit to continue; choose {Omega} with Omega/omega = p/q "
            "(e.g. Omega = 4 with omega = 0.5: 8; Omega = 4.3: 43/5, orbits of multiples of 5 slow periods)",
            {"Omega": "parameters.Omega", "max_period": "continuation.max_period"}, ratio=f"{ratio:.10g}",
            limit=max_period)
    return fraction.denominator
