"""R's error due to the integration, estimated for every run: a sample of its points again at a
1000x tighter tolerance (issue 34).

R_err measures how R varies over the measurement window; it knows nothing of the solver. At a
loose rtol R can be off by orders of magnitude more than R_err says (docs/accuracy.md). So when a
run finishes, the periodic ones among the first points of the grid's shuffled order (whole lines:
a hysteresis line's points depend on each other) are run again at rtol and atol times TIGHTER, and

    R_solver_err = max over the sample's periodic points of 2 |R - R_tight| / |R|

is stored as a root attribute: a relative error bound for R at every point of the file. The factor
2 covers R_tight's own error, which the benchmarks put at well under |R - R_tight| for a 1000x
tighter tolerance (rk45: 1000^(5/6) times smaller; dop853 likewise). Only points periodic in the
run count: a chaotic point's R changes with any change of the steps, and R_err already says it is
not converged (the tight run may find another period: then the difference is the run's error all
the same). Where the sample holds no periodic point, its quasi-periodic points (analysis/motion.py)
count instead, as on a map of the original model at an Omega/omega that is no small ratio: their
R converges too, and the difference then also holds the two runs' averaging errors (each within
its R_err), so the bound can only be wider. A periodic point whose tight run settles on no period
is left out (estimate: a transient, not the solver). So is a point whose |Q| (the tight run's)
lies below the run's rtol times the motion's size max(|x_min|, |x_max|): a component the run's
tolerance does not resolve, zero within its accuracy (a response frequency the orbit holds only
through the solver's errors, as 2w of a symmetric orbit: 1e-12 to 6e-11 of F at rtol 1e-9); its
two runs' R are two such errors, and their relative difference, about 1, is no relative error of
any R the run resolves (a Duffing oscillator's R at 2w, 1e-12 at its
symmetric orbits, put R_solver_err at 0.60 and every point of the file beyond trust). With none
left there is no R_solver_err, and R_solver_err_points is 0: nothing was estimated.

On a GPU the tight run starts as soon as the sample's points are done (start, execution/job.py's
SolverErrorSample), beside the rest of the grid; its points, and so the estimate, are the same.

The first points are the grid's, not a shard's: each shard reruns those it holds, and the merge's
largest bound is the whole run's, bit for bit. Cost: SAMPLE_FRACTION of the points (at least
SAMPLE_MIN, at most SAMPLE_POINTS), the periodic ones only, each about 2.5 to 4 times a point's
cost (rk45 takes 1000^(1/5) = 4x the steps; dop853 1000^(1/8) = 2.4x): a few per cent of a
large run.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

TIGHTER = 1e-3
SMALLEST_RTOL = 1e-14        # config/schema.py's lower bound of rtol: a tighter one means nothing
SAMPLE_FRACTION = 0.02
SAMPLE_POINTS = 32
SAMPLE_MIN = 4
SAFETY = 2.0
NOISE_FLOOR = 1.0            # |Q| below this times rtol times max|x|: zero within the run's accuracy


def tight_integration(integration):
    """The run's integration settings at TIGHTER times its tolerances (rtol no tighter than 1e-14)."""
    rtol = max(integration.rtol * TIGHTER, SMALLEST_RTOL)
    return dataclasses.replace(integration, rtol=rtol, atol=integration.atol * (rtol / integration.rtol))


def candidate_lines(grid):
    """The grid's first lines in its shuffled order, SAMPLE_FRACTION of its points (at least
    SAMPLE_MIN, at most SAMPLE_POINTS): the same lines for a whole run and for its shards, so that
    merged shards carry the whole run's estimate."""
    from vrsweep.config.grid import shuffled_lines

    lines = shuffled_lines(grid, 0, 1)
    n_points = max(SAMPLE_MIN, min(SAMPLE_POINTS, math.ceil(SAMPLE_FRACTION * grid.n_points)))
    return lines[:max(1, math.ceil(n_points / lines.shape[1]))]


def sample_lines(grid, done, periodic):
    """The lines to rerun: of candidate_lines, those this file holds done (``done``: False outside a
    shard's own points) and periodic throughout."""
    first = candidate_lines(grid)
    return first[np.all(done[first] & periodic[first], axis=1)]


def sample_is_final(first, done, owned=None):
    """Whether every candidate line (``first``: candidate_lines) this file will hold (``owned``: a
    shard's points, None for all) is done: then the sample, and so the estimate, is what the run's
    end would choose, and its tight run can start while the rest of the grid computes (a GPU's
    run, execution/job.py)."""
    held = np.ones(first.shape, dtype=bool) if owned is None else owned[first]
    return bool(np.all(done[first] | ~held))


@dataclasses.dataclass
class Sample:
    """The tight run of the sample, started (start): its settings' rtol, and where it has lines,
    the runner, its chunk in flight or done, and the points the run counted as converged."""
    rtol: float
    run_rtol: float = None
    runner: object = None
    chunk: object = None
    converged: np.ndarray = None


def estimate(config, grid, done, stored):
    """The root attributes R_solver_err (relative; absent if not estimated), R_solver_err_points (the
    periodic points it was measured on) and R_solver_err_rtol (the tight rtol).

    stored: the run's {"R", "period", "status", "motion"} over the whole grid (flat)."""
    return finish(start(config, grid, done, stored), stored)


def start(config, grid, done, stored):
    """The sample's tight run, started (a Sample): on the CPU it runs here, to the end; on a GPU it
    is launched and left running (finish waits), so that a run can start it once its sample is
    final (sample_is_final) and let the card compute it beside the rest of the grid."""
    from vrsweep.execution.sweep import LineRunner
    from vrsweep.results import Motion, Status

    tight = tight_integration(config.integration)
    ok = stored["status"] == Status.OK
    converged = ok & (stored["period"] > 0)
    lines = sample_lines(grid, done, converged)
    if not len(lines):
        converged = ok & (stored["motion"] == Motion.QUASI_PERIODIC)
        lines = sample_lines(grid, done, converged)
    if not len(lines):
        return Sample(tight.rtol, config.integration.rtol)
    runner = LineRunner(dataclasses.replace(config, integration=tight))
    return Sample(tight.rtol, config.integration.rtol, runner, runner.start(lines), converged)


def finish(sample, stored):
    """start's attributes (see estimate), once its tight run is done. stored: as start's; the
    sample's points are the same in both (written once, never again)."""
    from vrsweep.results import Status

    # R_solver_err itself only where it was measured (an attribute of NaN would make equal files
    # compare unequal): its absence with R_solver_err_points = 0 says "not estimated".
    attributes = {"R_solver_err_points": np.int64(0), "R_solver_err_rtol": sample.rtol}
    if sample.chunk is None:
        return attributes
    converged = sample.converged
    flat, values = sample.runner.finish(sample.chunk)
    r, r_tight = stored["R"][flat], values["R"]
    # Converged in the run (sample_lines chose such points); whatever the tight run found: a period
    # that changes with the tolerance is itself the run's error (rk45 at rtol 1e-4 made a period-6
    # orbit of Omega = 5, g = 45 another orbit, R 11 % off).
    # A periodic point whose tight run found no period at all did not settle there: a chaotic
    # transient that one run's window caught on an orbit and the other's did not (measured: the
    # original model at g = 22, Omega = 60/11, period 11 at rtol 1e-9, still chaotic at 1e-12,
    # R 3.01 against 3.42). That difference is the transient's, which no tolerance removes
    # (docs/trust.md, "What R_err cannot see"), not the solver's; counted, one such point would
    # put every point of a map beyond trust.
    unsettled = (stored["period"][flat] > 0) & (values["period"] == 0)
    # A component at the solver's rounding (module doc): its relative difference is noise's.
    size = np.maximum(np.abs(values["x_min"]), np.abs(values["x_max"]))
    resolved = values["Q_amplitude"] > NOISE_FLOOR * sample.run_rtol * size
    same = ((stored["status"][flat] == Status.OK) & (values["status"] == Status.OK) & converged[flat]
            & ~unsettled & resolved & np.isfinite(r) & (r != 0) & np.isfinite(r_tight))
    if same.any():
        attributes["R_solver_err"] = float(SAFETY * np.max(np.abs(r[same] - r_tight[same]) / np.abs(r[same])))
        attributes["R_solver_err_points"] = np.int64(same.sum())
    return attributes
