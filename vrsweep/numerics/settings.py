"""The kernel's settings vector: its layout, its names in the config, and their defaults.

Plain Python, no numba: the config schema takes its defaults of these settings from here
(config -> numerics, never back), and reading a config must not import numba (``vrsweep
validate`` starts in a fraction of a second; a Ctrl-C during numba's import was a traceback).
"""

# --- settings vector layout (float64), filled by execution.sweep.integration_settings ---
RTOL, ATOL, TRANSIENT_PERIODS, MEASURE_PERIODS, MAX_STEPS, MAX_IMPACTS_PER_PERIOD, \
    DIVERGENCE_BOUND, STICK_VELOCITY = range(8)
# Not config settings: a time window [TRANSPARENT_FROM, TRANSPARENT_TO) in which the barrier is
# transparent (no impact test, the motion passes it freely). analysis/grazing.py removes one
# impact of a periodic orbit this way and keeps the others. NaN, as settings_vector leaves them
# (every other caller): no window.
TRANSPARENT_FROM, TRANSPARENT_TO = 8, 9
N_SETTINGS = 10
# Their config names (the config's integration section), in index order, and their defaults:
# the config schema takes its defaults of these from here (config -> numerics, never back).
SETTING_DEFAULTS = {
    "rtol": 1e-9, "atol": 1e-11, "transient_periods": 100, "measure_periods": 100,
    "max_steps": 20_000_000, "max_impacts_per_period": 100_000, "divergence_bound": 1.0e6,
    "stick_velocity": 1.0e-7,
}
SETTING_NAMES = tuple(SETTING_DEFAULTS)
DEFAULT_METHOD = "rk45"  # the config schema's default of integration.method

# Defaults of the config's continuation section (analysis/continuation.py, docs/continuation.md):
# plain numbers here so that the config schema and the algorithm read the same ones.
CONTINUATION_DEFAULTS = {
    "max_points": 400, "initial_step": 0.05, "min_step": 1e-5, "max_step": 0.5, "newton_tolerance": 1e-8,
    "max_newton_iterations": 12, "max_period": 16, "location_tolerance": 1e-6,
}
