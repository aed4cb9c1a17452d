"""A config's continuation section run: the start orbit, the branch both ways, the bifurcations.

The algorithm is analysis/continuation.py; the file it makes is store/branch_file.py.
"""

from __future__ import annotations

import numpy as np

from vrsweep.errors import UsageError

# The section's keys as a refusal names them; "from_key", not "start": continue words its own
# --start flag for the argument "start", and the config key is meant here.
SECTION_WORDS = {"from_key": "continuation.from", "to": "continuation.to", "initial_step": "continuation.initial_step",
                 "min_step": "continuation.min_step", "max_step": "continuation.max_step"}


def check_steps(section):
    """Refuse (UsageError) steps a branch or a curve cannot take: min_step above max_step (said so:
    an initial_step the config never gave, set between them, was blamed for it), or an initial_step
    outside [min_step, max_step]."""
    if not section.min_step <= section.max_step:
        raise UsageError.naming("{min_step} = {low} is above {max_step} = {high}: the smallest step cannot exceed "
                                "the largest", SECTION_WORDS, low=f"{section.min_step:g}",
                                high=f"{section.max_step:g}")
    # A first step beyond max_step was taken whole, and the branch ended after it claiming
    # left_range; one below min_step ends the branch at its first failed correction.
    if not section.min_step <= section.initial_step <= section.max_step:
        raise UsageError.naming("{initial_step} = {value} must lie between {min_step} = {low} and {max_step} = "
                                "{high}", SECTION_WORDS, value=f"{section.initial_step:g}",
                                low=f"{section.min_step:g}", high=f"{section.max_step:g}")


def check_section(config):
    """Refuse (UsageError) a config whose continuation section ``continue`` cannot run, before
    anything is integrated: for ``continue`` and ``validate`` alike, without importing numba (the
    model's rule, commensurability, is plain Python: analysis/commensurate.py)."""
    section = config.continuation
    if section is None:
        raise UsageError.naming("{source} has no continuation section: add one, e.g. "
                                "continuation: {{parameter: g, from: 23.0, to: [21.0, 27.0]}}",
                                source=config.source_name)
    if not section.low <= section.start <= section.high:
        raise UsageError.naming("{from_key} = {value} lies outside {to} = [{low}, {high}]", SECTION_WORDS,
                                value=section.start, low=section.low, high=section.high)
    check_steps(section)
    from vrsweep.analysis.commensurate import check_commensurate  # plain Python: validate imports no numba

    check_commensurate(config.parameters, config.model, section.parameter, section.max_period)


def problem_of(config):
    """The ContinuationProblem of a config with a continuation section (check_section's refusals first)."""
    from vrsweep.analysis import continuation
    from vrsweep.config.domains import domain_test
    from vrsweep.execution.sweep import integration_settings

    check_section(config)
    section = config.continuation
    parameters = dict(config.parameters, **{section.parameter: section.start})
    # Every orbit inside the domain the config's own values must keep (config/domains.py): the
    # branch ends at its edge, and a start outside is refused.
    domain = domain_test(config.model, parameters)
    outside = domain({})
    if outside is not None:
        raise UsageError.naming("the start {from_key} = {value} lies outside the model's domain: {reason}",
                                SECTION_WORDS, value=f"{section.start:g}", reason=outside)
    return continuation.ContinuationProblem(parameters, config.model, section.parameter,
                                            integration_settings(config.integration), config.integration.method,
                                            section.options(), domain=domain)


def barrier_of(config) -> float:
    """The barrier a branch file measures distances to: Delta, or a written model's first barrier above
    (numerics.coefficients.grazing_barrier; +inf without one) at the config's parameters."""
    from vrsweep.numerics.coefficients import grazing_barrier
    from vrsweep.numerics.models import kernels_for

    return grazing_barrier(kernels_for(config.model).coefficients(config.parameters))


def start_state_from_sweep(path, at):
    """x, v at the end of the run of the grid point ``at`` ({axis: value}) of sweep file ``path``:
    the point's attractor (its x_final, v_final), where the first orbit is looked for."""
    from vrsweep.store.reading import axis_index, grid_axes, open_results

    with open_results(path) as ds:
        if ds.attrs.get("vrsweep_file") not in ("sweep", "shard"):
            raise UsageError.naming("{path} is not a sweep file: {start} takes the results of vrsweep run",
                                    path=str(path))
        selection = {}
        axes = grid_axes(ds)
        # Every sweep axis named: a point of a map is not a point of one of its axes (the first
        # value of an axis left out was taken silently). A hysteresis sweep's direction: its first.
        missing = [str(axis) for axis in axes if axis != "direction" and axis not in at]
        if missing:
            raise UsageError.naming("{path} sweeps {axes}: name its point on every axis, e.g. {at} {example}",
                                    path=str(path), axes=", ".join(str(a) for a in axes if a != "direction"),
                                    example=" ".join(f"{m}={float(ds[m].values[0]):g}" for m in missing))
        for name, value in at.items():
            if name not in axes:
                raise UsageError.naming("{path} has no axis {name}; its axes: {axes}", path=str(path), name=name,
                                        axes=", ".join(str(a) for a in axes))
            selection[name] = axis_index(name, np.asarray(ds[name].values, dtype=np.float64), value)
        point = ds[["x_final", "v_final"]].isel(selection)
        for dim in list(point.dims):  # e.g. direction of a hysteresis sweep: its first
            point = point.isel({dim: 0})
        return np.array([float(point["x_final"]), float(point["v_final"])])


def run_continuation(config, start_state=None, progress=None, switch=None, failures=None):
    """The branch through the orbit found at the section's ``from`` and, with ``switch`` (default:
    the section's ``switch``), the branches born on it: of 2p periods at its period doublings, the
    second branch through each branch point (analysis/switching.py). Returns (branches,
    bifurcations); branch 0 is the first.

    start_state: (2,) where the transient starts (default: the config's initial state).
    progress(orbit): called after each orbit; a KeyboardInterrupt it raises stops the continuation
    there, keeping what is followed (each branch's unreached ends: "interrupted").
    failures: a list that receives (parameter, kind, reason) for each period doubling ("period_doubling")
    or branch point ("branch_point") where no branch was found.
    """
    from vrsweep.analysis import continuation, switching

    problem = problem_of(config)
    section = config.continuation
    if start_state is None:
        start_state = np.array([config.initial["x"], config.initial["v"]])
    start = continuation.find_start(problem, start_state, section.start, config.integration.transient_periods,
                                    section.max_period)
    branch, bifurcations = continuation.continue_branch(problem, start, section.low, section.high,
                                                        section.max_points, progress)
    if not (section.switch if switch is None else switch) or continuation.interrupted(branch):
        return [branch], bifurcations
    branches, bifurcations, missed = switching.switch_all(problem, branch, bifurcations, section.low, section.high,
                                                      section.max_points, section.max_period, progress)
    if failures is not None:
        failures.extend(missed)
    return branches, bifurcations
