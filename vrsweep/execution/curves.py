"""A bifurcation point of a branch file followed in a second parameter: the curve both ways.

The algorithm is analysis/curves.py; the file it makes is store/curve_file.py.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from vrsweep.analysis import curves
from vrsweep.config.domains import domain_test, outside_domain
from vrsweep.errors import UsageError
from vrsweep.execution.sweep import integration_settings
from vrsweep.numerics.settings import CONTINUATION_DEFAULTS
from vrsweep.store.branch_file import UNLOCATED


# The branch file's grazing orbit and the barrier-free orbit Newton finds from it are the same orbit
# when they agree to this (relative): the branch locates a graze to location_tolerance (1e-6) in the
# parameter, where the state moves by the square root of that at worst (1e-3).
GRAZE_MATCH = 1e-2


@dataclass
class CurveRequest:
    """What ``continue BRANCH.h5 --point K --along NAME`` asks for, read from the branch file."""
    config: object          # the branch's Config (its resolved YAML)
    kind: str               # fold, period_doubling or grazing
    names: tuple            # (branch parameter, along)
    values: np.ndarray      # (2,) where the point lies
    state: np.ndarray       # (2,) its x, v
    periods: int
    ranges: tuple           # ((low1, high1), (low2, high2))


# The settings a curve may change on a branch file (overrides ``continuation.KEY=VALUE``): the
# continuation section's numerics; parameter, from, to and switch are the branch's own.
CURVE_SETTINGS = tuple(f"continuation.{key}" for key in CONTINUATION_DEFAULTS)


def read_request(path, point, along, to=None, within=None, overrides=()):
    """The CurveRequest of bifurcation row ``point`` of branch file ``path`` moved along ``along``.

    to: (low, high) of ``along`` (default: the config's sweep axis of that name); within: (low,
    high) of the branch's parameter (default: the branch's continuation.to); overrides:
    ``continuation.KEY=VALUE`` settings (CURVE_SETTINGS) over the branch's section: the step
    (max_step, initial_step, min_step) and max_points of the curve, checked as a config's are."""
    from vrsweep.config import parse_config
    from vrsweep.store.reading import open_results

    with open_results(path) as ds:
        if ds.attrs.get("vrsweep_file") != "branch":
            raise UsageError.naming("{path} is not a branch file: follow a bifurcation point of the output of "
                                    "vrsweep continue CONFIG.yaml", path=str(path))
        count = ds.sizes.get("bifurcation", 0)
        if not 0 <= point < count:
            raise UsageError.naming("{point} = {index} is not a bifurcation of {path}: it has {count} (0 to "
                                    "{last}); vrsweep info {path} lists them", {"point": "point"}, index=point,
                                    path=str(path), count=count, last=count - 1)
        kind = str(ds["bifurcation_kind"].values[point])
        branch = int(ds["bifurcation_branch"].values[point])
        periods = int(ds["branch_periods"].values[branch])
        value = float(ds["bifurcation_parameter"].values[point])
        state = np.array([float(ds["bifurcation_x"].values[point]), float(ds["bifurcation_v"].values[point])])
        config = parse_config(ds.attrs["config"], f"{path} (its config)", line_numbers=False)
        first = str(ds.attrs["parameter"])
    if not np.all(np.isfinite([value, *state])):
        raise UsageError.naming("{point} = {index} has no finite {name}, x and v in {path}: there is no point to "
                                "start the curve from", {"point": "point"}, index=point, name=first, path=str(path))
    if kind == UNLOCATED + "grazing":
        raise UsageError.naming("{point} = {index} is a change of the impact count whose graze could not be "
                                "located (unlocated_grazing): it has no grazing orbit to start a curve from",
                                {"point": "point"}, index=point)
    if kind.startswith(UNLOCATED):
        raise UsageError.naming("{point} = {index} is a {kind} point: it was not located, so there is no "
                                "bifurcating orbit to start a curve from", {"point": "point"}, index=point, kind=kind)
    if kind not in curves.KINDS:
        raise UsageError.naming("{point} = {index} is a {kind} point: only fold, period_doubling and grazing "
                                "points can be followed in two parameters", {"point": "point"}, index=point,
                                kind=kind)
    config = _with_settings(config, overrides)
    names = (first, along)
    curves.check_pair(config.parameters, config.model, names, config.continuation.max_period)
    section = config.continuation
    within = (section.low, section.high) if within is None else tuple(within)
    if to is None:
        axis = next((a for a in config.axes if a.name == along), None)
        if axis is None:
            raise UsageError.naming("no range for {along_name}: give one with {to}, e.g. {to} 3.5 4.5",
                                    {"to": "to"}, along_name=along)
        to = (float(np.min(axis.values)), float(np.max(axis.values)))
    second = float(config.parameters[along])
    for key, name, (low, high), now in (("within", first, within, value), ("to", along, tuple(to), second)):
        # The placeholder is the argument's own name (to, within), which a command words as its flag.
        if not low < high:
            raise UsageError.naming("{" + key + "} {low} {high}: the range of {name} is empty (give LOW HIGH, "
                                    "LOW < HIGH)", name=name, low=f"{low:g}", high=f"{high:g}")
        if not low <= now <= high:
            raise UsageError.naming("the point's {name} = {now} lies outside its range [{low}, {high}] ({" + key + "})",
                                    name=name, now=f"{now:.8g}", low=f"{low:g}", high=f"{high:g}")
    # The stored config holds the point's own values of both parameters, not the branch's start.
    config = dataclasses.replace(config, parameters={**config.parameters, first: value})
    # A branch file written before branches kept to the model's domain may hold points outside.
    outside = outside_domain(config.model, config.parameters)
    if outside is not None:
        raise UsageError.naming("{point} = {index} lies outside the model's domain ({reason}): there is no curve "
                                "to follow from it", {"point": "point"}, index=point, reason=outside)
    return CurveRequest(config, kind, names, np.array([value, second]), state, periods, (within, tuple(to)))


def problem_of(request):
    config = request.config
    parameters = dict(config.parameters, **dict(zip(request.names, request.values)))
    return curves.CurveProblem(parameters, config.model, request.names, integration_settings(config.integration),
                               config.integration.method, config.continuation.options(),
                               domain=domain_test(config.model, parameters), range_fraction=curves.RANGE_FRACTION)


def _with_settings(config, overrides):
    """The branch's config with the curve's settings (CURVE_SETTINGS) over its continuation section;
    the section's own rule (min_step <= initial_step <= max_step) holds for them too."""
    from vrsweep.config import with_overrides
    from vrsweep.execution.continuation import check_steps

    for setting in overrides:
        name = str(setting).partition("=")[0].strip()
        if name not in CURVE_SETTINGS:
            raise UsageError.naming("{set} {setting}: a branch file takes the settings of its curves only: "
                                    "{allowed}", {"set": "set"}, setting=str(setting),
                                    allowed=", ".join(CURVE_SETTINGS))
    if not overrides:
        return config
    config = with_overrides(config, overrides)
    section = config.continuation
    given = {str(setting).partition("=")[0].strip() for setting in overrides}
    if "continuation.initial_step" not in given:
        # --set continuation.max_step=0.001 alone: the first step is the nearest allowed to the branch's.
        start = min(max(section.initial_step, section.min_step), section.max_step)
        section = dataclasses.replace(section, initial_step=start)
        config = dataclasses.replace(config, continuation=section)
    check_steps(section)
    return config


def run_curve(request, progress=None):
    """The curve through the request's point both ways. Returns ([Curve], [SpecialPoint]). A start
    that does not converge raises UsageError saying why (there is nothing to follow). progress(point):
    called after each point; a KeyboardInterrupt it raises stops the curve there, keeping it."""
    problem = problem_of(request)
    start, failure = curves.start_point(problem, request.kind, request.state, request.values, request.periods)
    if failure is not None:
        raise UsageError.naming("the {kind} point did not converge as a point of the {kind} curve at {where}: "
                                "{reason}", kind=request.kind.replace("_", " "),
                                where=", ".join(f"{n} = {v:.8g}" for n, v in zip(request.names, request.values)),
                                reason=failure[1] + (
                                    "; only the graze of a non-impacting orbit is followed, not an impact reaching "
                                    "zero speed" if request.kind == "grazing" else ""))
    if request.kind == "grazing" and np.max(np.abs(start.state - request.state)) > GRAZE_MATCH * max(
            1.0, float(np.max(np.abs(request.state)))):
        raise UsageError.naming(
            "the grazing point at {where} is not the graze of a non-impacting orbit (the barrier-free orbit "
            "there is another one): the graze of an impacting orbit, whose slowest impact reaches zero speed, "
            "is not followed in two parameters", where=", ".join(f"{n} = {v:.8g}" for n, v in
                                                                  zip(request.names, request.values)))
    curve, specials = curves.continue_curve(problem, request.kind, start, request.ranges,
                                            request.config.continuation.max_points, progress)
    return [curve], specials
