"""One trajectory with everything the kernel can observe: dense samples, impacts, sticking.

Used by ``vrsweep simulate`` and by the tests; a sweep uses the kernel directly.
"""

from dataclasses import dataclass

import numpy as np

from vrsweep.numerics import kernel
from vrsweep.numerics.models import kernels_for
from vrsweep.results import Status

_SETTING_INDEX = {name: index for index, name in enumerate(kernel.SETTING_NAMES)}
# The kernel's settings a caller leaves out (the config schema's defaults are these too).
DEFAULT_SETTINGS = dict(kernel.SETTING_DEFAULTS)


def settings_vector(**settings):
    """The kernel's settings vector; unknown names are ignored (configs carry more keys)."""
    values = dict(DEFAULT_SETTINGS)
    values.update({k: v for k, v in settings.items() if k in _SETTING_INDEX})
    vector = np.full(kernel.N_SETTINGS, np.nan)  # the settings without a config name: unset
    for name, index in _SETTING_INDEX.items():
        vector[index] = values[name]
    return vector


@dataclass
class Trajectory:
    status: Status
    sample_times: np.ndarray     # (n_samples,)
    samples: np.ndarray          # (n_samples, 2): x, v
    impacts: np.ndarray          # (n_impacts, 3): t, v before, v after
    sticks: np.ndarray           # (n_sticks, 2): start, end
    period_records: np.ndarray   # (n_periods, N_RECORD), see kernel.REC_*
    summary: np.ndarray          # (N_SUMMARY,), see kernel.SUM_*

    @property
    def impacts_per_period(self):
        """Impacts in each slow period, transient included (Fig. impact_no); -1 for the periods a
        failed run did not reach (their records are NaN, which astype(int64) made -2**63)."""
        counts = self.period_records[:, kernel.REC_IMPACTS]
        return np.where(np.isfinite(counts), counts, -1.0).astype(np.int64)


def simulate(coefficients, initial_state, settings, sample_times=(), impact_capacity=4096,
             stick_capacity=1024, method="rk45", lyapunov=False, model="original"):
    """Integrate one point, keeping samples at ``sample_times`` and every impact and stick.

    ``method``: the integration method, a key of kernel.INTEGRATORS (rk45, dop853).
    ``model``: whose kernels (models.kernels_for): the paper's family (its vectors say which member
    it is, so the default serves both of its models) or a written model, whose vectors these are.
    ``lyapunov``: carry the tangent vectors too (tangent.py): the records then hold each period's
    REC_LOG_STRETCH and REC_LOG_AREA, the summary SUM_LYAPUNOV and SUM_LYAPUNOV_SUM.

    The logs grow and the run is repeated if they overflow: it is deterministic, so the
    second run is the same trajectory.
    """
    integrate = kernels_for(model).integrator(method, lyapunov)
    coefficients = np.ascontiguousarray(coefficients, dtype=np.float64)
    initial_state = np.ascontiguousarray(initial_state, dtype=np.float64)
    settings = np.ascontiguousarray(settings, dtype=np.float64)
    sample_times = np.ascontiguousarray(np.sort(np.asarray(sample_times, dtype=np.float64)))
    n_periods = int(settings[kernel.TRANSIENT_PERIODS] + settings[kernel.MEASURE_PERIODS])
    while True:
        records = np.full((n_periods, kernel.N_RECORD), np.nan)
        summary = np.full(kernel.N_SUMMARY, np.nan)
        samples = np.full((len(sample_times), 2), np.nan)
        # The kernel writes every row it counts and only those rows are returned: left unset, a
        # large log costs no page faults (np.full of bench_speed's 100 000 rows: 44 us a point).
        impacts = np.empty((impact_capacity, 3))
        sticks = np.empty((stick_capacity, 2))
        status = integrate(coefficients, initial_state, settings, records, summary,
                           sample_times, samples, impacts, sticks)
        n_impacts = int(summary[kernel.SUM_IMPACTS])
        n_sticks = int(summary[kernel.SUM_STICKS])
        if n_impacts <= impact_capacity and n_sticks <= stick_capacity:
            break
        impact_capacity = max(impact_capacity, 2 * n_impacts)
        stick_capacity = max(stick_capacity, 2 * n_sticks)
    return Trajectory(Status(int(status)), sample_times, samples, impacts[:n_impacts],
                      sticks[:n_sticks], records, summary)
