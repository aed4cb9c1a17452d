"""The stroboscopic map of p slow periods and its monodromy matrix: shooting for continuation.

An orbit of p slow periods T = 2 pi / omega is a fixed point of P^p, P the stroboscopic map
y = (x, v) at t = 0 mod T (docs/design.md, "Continuation of periodic orbits"). One call of the
kernel's *_monodromy variant (kernel.py) from y at t = 0 over p periods (no transient) gives
P^p(y), every period's tangent map (the saltation matrix of every impact in it), and the
orbit's measures of eq3.1-eq3.3 over exactly those p periods; the monodromy is the product of
the per-period maps, latest on the left.

Plain Python around one compiled kernel call, like trajectory.py.
"""

from dataclasses import dataclass

import numpy as np

from vrsweep.numerics import kernel
from vrsweep.numerics.models import kernels_for
from vrsweep.results import Status


@dataclass
class OrbitMap:
    """P^p at one state and one coefficient vector.

    status          the kernel's Status (OK, or why the integration stopped)
    end_state       (2,) x, v at t = pT
    monodromy       (2, 2) d y(pT) / d y(0): the product of period_maps, latest on the left
    period_maps     (p, 2, 2) each period's tangent map
    R, Q_amplitude  eq3.3 and |Q| over the p periods
    impacts         impacts in the p periods
    x_max           largest x over the p periods (Delta when it impacts)
    x_min           smallest x over the p periods (a barrier below's position when it impacts there)
    slowest_impact  smallest impact speed |x'(-)| over the p periods (inf without impacts)
    stuck_time      time held on the barrier in the p periods (sticking)
    impact_times    (impacts,) when each impact happened, t in [0, pT]
    impact_speeds   (impacts,) each impact's velocity x'(-)
    window_x_max    largest x inside the transparent window (-inf without one)
    free_x_max      largest smooth maximum of x (no impact there; -inf if none) and its time; a
                    sliding segment (x linear in t) counts with its higher end
    free_x_max_time
    """
    status: Status
    end_state: np.ndarray
    monodromy: np.ndarray
    period_maps: np.ndarray
    R: float
    Q_amplitude: float
    impacts: int
    x_max: float
    x_min: float
    slowest_impact: float
    stuck_time: float
    impact_times: np.ndarray
    impact_speeds: np.ndarray
    window_x_max: float
    free_x_max: float
    free_x_max_time: float


def periodic_map(coefficients, state, settings, periods, method="rk45", impact_capacity=1024, transparent=None,
                 model="original"):
    """P^periods from ``state`` (2,) at t = 0 with the kernel settings vector ``settings``.

    The settings' transient and measurement counts are replaced by 0 and ``periods``.
    transparent: (t_from, t_to) within [0, pT], a window in which the barrier is transparent (the
    map of the orbit without the impacts it would have there; grazing.py), or None.
    model: whose kernels (models.kernels_for), the model these coefficient vectors are of.
    The impact log is grown and the run repeated if it overflows (the run is deterministic).
    """
    integrate = kernels_for(model).monodromy(method)
    coefficients = np.ascontiguousarray(coefficients, dtype=np.float64)
    state = np.ascontiguousarray(state, dtype=np.float64)
    settings = np.array(settings, dtype=np.float64)
    settings[kernel.TRANSIENT_PERIODS] = 0
    settings[kernel.MEASURE_PERIODS] = periods
    if transparent is not None:
        settings[kernel.TRANSPARENT_FROM], settings[kernel.TRANSPARENT_TO] = transparent
    while True:
        records = np.full((periods, kernel.N_RECORD), np.nan)
        summary = np.full(kernel.N_SUMMARY, np.nan)
        impacts = np.full((impact_capacity, 3), np.nan)
        maps = np.full((periods, 4), np.nan)
        status = integrate(coefficients, state, settings, records, summary, np.empty(0),
                           np.empty((0, 2)), impacts, np.empty((0, 2)), maps)
        n_impacts = int(summary[kernel.SUM_IMPACTS])
        if n_impacts <= impact_capacity:
            break
        impact_capacity = 2 * n_impacts
    period_maps = maps.reshape(periods, 2, 2)
    monodromy = np.eye(2)
    for k in range(periods):
        monodromy = period_maps[k] @ monodromy
    # Speeds: an impact on a barrier below has x'(-) < 0, and the signed minimum was the fastest of
    # those, negative, which continuation read as an impact past stopping (a graze) at every step.
    slowest = float(np.min(np.abs(impacts[:n_impacts, 1]))) if n_impacts else np.inf
    return OrbitMap(
        status=Status(int(status)),
        end_state=np.array([summary[kernel.SUM_X_FINAL], summary[kernel.SUM_V_FINAL]]),
        monodromy=monodromy,
        period_maps=period_maps,
        R=float(summary[kernel.SUM_R]),
        Q_amplitude=float(summary[kernel.SUM_Q_AMPLITUDE]),
        impacts=n_impacts,
        x_max=float(np.max(records[:, kernel.REC_X_MAX])),
        x_min=float(np.min(records[:, kernel.REC_X_MIN])),
        slowest_impact=slowest,
        stuck_time=float(np.sum(records[:, kernel.REC_STUCK_TIME])),
        impact_times=impacts[:n_impacts, 0].copy(),
        impact_speeds=impacts[:n_impacts, 1].copy(),
        window_x_max=float(summary[kernel.SUM_WINDOW_X_MAX]),
        free_x_max=float(summary[kernel.SUM_FREE_X_MAX]),
        free_x_max_time=float(summary[kernel.SUM_FREE_X_MAX_TIME]),
    )
