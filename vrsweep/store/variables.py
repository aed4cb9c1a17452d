"""Names, units and meanings of what a sweep stores per grid point (the HDF5 contract).

Units: the paper's model is dimensionless, so x, v, t and the parameters carry units "1";
what each quantity *is* (an amplitude of x, a gain |Q|/c, a count per slow period) is said
in its long_name, so that a gain is never mistaken for an amplitude (ERRATA 6).
"""

import numpy as np

from vrsweep.results import FLAG_MEANINGS, FLAG_VALUES, MOTION_MEANINGS, Motion


def point_variables(integration):
    """(name, dtype, extra_dims, attrs) for every per-point variable, in storage order."""
    strobe = (("strobe", integration.strobe_periods),)
    return [
        ("R", np.float64, (), {"units": "1", "long_name": ("gain |Q|/c at the slow frequency omega (eq3.3): over the last "
                                                           "whole cycles where periodic, a weighted Birkhoff average "
                                                           "where quasi-periodic")}),
        ("Qs", np.float64, (), {"units": "1", "long_name": "sine Fourier component of x at omega (eq3.1)"}),
        ("Qc", np.float64, (), {"units": "1", "long_name": "cosine Fourier component of x at omega (eq3.2)"}),
        ("Q_amplitude", np.float64, (), {
            "units": "1",
            "long_name": "amplitude |Q| = sqrt(Qs^2 + Qc^2) of x at omega (same units as x; compare with A_theory)"}),
        ("R_err", np.float64, (), {
            "units": "1",
            "long_name": ("95% half-width of R: jackknife over 10 batches of whole periods (cycles) of the "
                          "measurement window (vrsweep.analysis.diagnostics); where the motion is quasi-periodic, "
                          "the largest distance of R from the weighted average of half or three quarters of the "
                          "window (vrsweep.analysis.motion)")}),
        ("impacts_per_period", np.float64, (), {
            "units": "1", "long_name": "mean number of impacts per slow period 2 pi/omega (measurement window)"}),
        ("status", np.int8, (), {
            "long_name": "how the point's integration ended",
            "flag_values": np.array(FLAG_VALUES, dtype=np.int8), "flag_meanings": FLAG_MEANINGS}),
        ("period", np.int64, (), {
            "units": "1",
            "long_name": ("period of the stroboscopic samples in slow periods, to period_tolerance (0: none up to "
                          "max_period: chaotic, quasi-periodic, longer, or not yet converged)")}),
        ("motion", np.int8, (), {
            "long_name": ("kind of motion: periodic, quasi-periodic (weighted averages converge), chaotic, "
                          "not settled; none where the point failed (vrsweep.analysis.motion)"),
            "flag_values": np.array([int(kind) for kind in Motion], dtype=np.int8), "flag_meanings": MOTION_MEANINGS}),
        ("impacts_per_cycle", np.int64, (), {
            "units": "1", "long_name": "impacts in one cycle of the detected period (-1: no period)"}),
        ("strobe_x", np.float64, strobe, {
            "units": "1", "long_name": "stroboscopic x at t = nT over the last slow periods (T = 2 pi/omega)"}),
        ("strobe_v", np.float64, strobe, {
            "units": "1", "long_name": "stroboscopic velocity at t = nT over the last slow periods"}),
        ("x_min", np.float64, (), {"units": "1", "long_name": "smallest x over the measurement window"}),
        ("x_max", np.float64, (), {"units": "1", "long_name": "largest x over the measurement window"}),
        *IMPACT_VARIABLES,
        ("x_final", np.float64, (), {"units": "1", "long_name": "x at the end of the run"}),
        ("v_final", np.float64, (), {"units": "1", "long_name": "velocity at the end of the run"}),
        ("n_steps", np.int64, (), {"units": "1", "long_name": "Dormand-Prince step attempts"}),
        ("n_rhs", np.int64, (), {"units": "1", "long_name": "right-hand-side evaluations"}),
    ] + (LYAPUNOV_VARIABLES if integration.lyapunov else [])


def written_model_words(variables, model):
    """``point_variables``' list with the long names of a written model (numerics.written): its
    response's frequency and scale and its period T, not the paper's omega and c."""
    words = {
        "R": (f"gain |Q|/|{model.response_scale}| at the response frequency {model.response_frequency}: over the "
              "last whole cycles where periodic, a weighted Birkhoff average where quasi-periodic"),
        "Qs": f"sine Fourier component of x at {model.response_frequency}",
        "Qc": f"cosine Fourier component of x at {model.response_frequency}",
        "Q_amplitude": f"amplitude |Q| = sqrt(Qs^2 + Qc^2) of x at {model.response_frequency} (same units as x)",
        "impacts_per_period": f"mean number of impacts per period T = {model.period} (measurement window)",
        "period": ("period of the stroboscopic samples in periods T, to period_tolerance (0: none up to "
                   "max_period: chaotic, quasi-periodic, longer, or not yet converged)"),
        "strobe_x": f"stroboscopic x at t = nT over the last periods (T = {model.period})",
        "strobe_v": "stroboscopic velocity at t = nT over the last periods",
    }
    return [(name, dtype, extra, dict(attrs, long_name=words[name]) if name in words else attrs)
            for name, dtype, extra, attrs in variables]


# The measurement window's impacts (vrsweep.analysis.diagnostics.impact_observables); NaN where it had
# none. Speeds are |v| into the barrier before the impact law (eq2.2).
IMPACT_VARIABLES = [
    ("impact_speed_min", np.float64, (), {
        "units": "1", "long_name": ("slowest impact speed |v-| over the measurement window (before eq2.2; falls to "
                                    "zero like a square root at a grazing line)")}),
    ("impact_speed_max", np.float64, (), {
        "units": "1", "long_name": "fastest impact speed |v-| over the measurement window (before eq2.2)"}),
    ("impact_speed_mean", np.float64, (), {
        "units": "1", "long_name": "mean impact speed |v-| over the measurement window's impacts (before eq2.2)"}),
    ("impact_phase", np.float64, (), {
        "units": "rad", "long_name": ("circular mean of the impacts' phase omega t mod 2 pi at the response "
                                      "frequency omega, in [0, 2 pi)")}),
    ("impact_phase_spread", np.float64, (), {
        "units": "rad", "long_name": ("circular standard deviation of the impacts' phase omega t "
                                      "(0: every impact at one phase)")}),
    ("stuck_fraction", np.float64, (), {
        "units": "1", "long_name": ("fraction of the measurement window's time the mass stuck: at rest on a barrier, or "
                                    "sliding on a surface v = c (a written model's friction)")}),
]


# With integration.lyapunov (vrsweep.numerics.tangent). Time t is dimensionless, so a rate is too.
LYAPUNOV_VARIABLES = [
    ("lyapunov", np.float64, (), {
        "units": "1",
        "long_name": ("largest Lyapunov exponent per unit time over the measurement window (tangent vector "
                      "through impacts by the saltation matrix; -inf: the mass stuck on the barrier)")}),
    ("lyapunov_err", np.float64, (), {
        "units": "1",
        "long_name": "95% half-width of lyapunov from 10 batches of whole periods (vrsweep.analysis.diagnostics)"}),
]
