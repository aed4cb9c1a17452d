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

The modules follow those seams: ``slowflow`` (1, 2 and 4), ``response`` (3, and a config's
predictions row by row, what ``vrsweep theory`` shows) and ``curves`` (the fold and Hopf curves
of the theory in a parameter plane). Every name is imported from here, as before the split:
``from vrsweep.analysis import theory; theory.fixed_points(...)``.

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

from vrsweep.analysis.theory.slowflow import (  # noqa: F401
    AMPLITUDE_NOTE, BARRIER_NOTE, DEFAULT_SLOW_STEP, SlowFlowCoefficients, THEORY_NOTE,
    damping_level, effective_frequency_squared, fast_force, g_res, initial_slow_state,
    integrate_slow_flow, reconstruct, slow_flow, slow_flow_cartesian, slow_flow_coefficients,
    slow_flow_jacobian,
)
from vrsweep.analysis.theory.response import (  # noqa: F401
    AnalyticPeak, DEFAULT_G_POINTS, FixedPoints, ResponseBranches, THEORY_PARAMETERS,
    analytic_columns, analytic_peak, fixed_point_cubic, fixed_point_phase, fixed_points,
    outside_theory, response_branches, theory_rows,
)
from vrsweep.analysis.theory.curves import (  # noqa: F401
    BISECTION_STEPS, FOLD_SAMPLES, ParameterCurve, THEORY_PLANE_PARAMETERS,
    fold_amplitude, fold_curve, fold_discriminant,
    hopf_curve, hopf_function,
)

__all__ = [
    "AMPLITUDE_NOTE", "BARRIER_NOTE", "DEFAULT_SLOW_STEP", "SlowFlowCoefficients", "THEORY_NOTE",
    "damping_level", "effective_frequency_squared", "fast_force", "g_res", "initial_slow_state", "integrate_slow_flow",
    "reconstruct", "slow_flow", "slow_flow_cartesian", "slow_flow_coefficients", "slow_flow_jacobian",
    "AnalyticPeak", "DEFAULT_G_POINTS", "FixedPoints", "ResponseBranches", "THEORY_PARAMETERS",
    "analytic_columns", "analytic_peak", "fixed_point_cubic", "fixed_point_phase", "fixed_points",
    "outside_theory", "response_branches", "theory_rows", "BISECTION_STEPS", "FOLD_SAMPLES", "ParameterCurve",
    "THEORY_PLANE_PARAMETERS", "fold_amplitude", "fold_curve", "fold_discriminant", "hopf_curve",
    "hopf_function",
]
