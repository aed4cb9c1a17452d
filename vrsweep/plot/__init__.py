"""Figures from vrsweep files: every function returns a matplotlib Figure (no pyplot, no display).

Sweep results (``vrsweep run``)
    ``response``     R = |Q|/c (or the amplitude |Q|) against one swept parameter, one curve per
                     value of the other axes, with the analytic branches of the corrected theory
                     (stable solid, unstable dashed) in the same units and the resonance g_res
                     (eq3.4) marked. Fig. 1 and Fig. 2 of the paper.
    ``map``          a heat map over two swept parameters with the resonance curve drawn over it.
    ``var``          any stored variable (impact_speed_min, x_max, period...): mapped over two axes,
                     drawn against one (``variable_figure``).
    ``impacts``      mean impacts per slow period against the axis (or as a map).
    ``status``       how each point's integration ended.
    ``bifurcation``  the stroboscopic x(nT) against the swept parameter, every sample a dot.
    ``lyapunov``     the largest Lyapunov exponent against the swept parameter, with the zero line;
                     ``bifurcation+lyapunov`` draws it under the bifurcation diagram, one x axis.
Curves files (``vrsweep continue`` on a branch file), after a map
    ``vrsweep plot MAP.h5 CURVES.h5 ...``: the map of any variable (``var``) with the fold,
    period-doubling and grazing curves over it, codimension-two points marked, and for the
    effective model the corrected theory's fold and Hopf curves (``curves``).
Branch files (``vrsweep continue``)
    R of the continued orbits against the parameter (stable solid, unstable dashed) with the
    bifurcations marked and named, sweep files given after it on the same axes and the corrected
    theory's branches (effective model); under it the moduli of the Floquet multipliers.
Trajectories (``vrsweep simulate``)
    ``trajectory``   position, velocity and phase portrait, original above effective (Fig. 3-5).
    ``impacts``      impacts in each slow period against the period number (Fig. impact_no).
    ``slowflow``     the effective system against the slow-flow reconstruction (Fig. 6).

Units: the paper's model is dimensionless (units "1"), so no axis shows a unit (a real unit in a
file's attributes would be shown in brackets); the caption says so once. The gain R = |Q|/c of eq3.3
and the analytic amplitude A of eq2.21 are different quantities (ERRATA 6): on a gain plot the
analytic curves are A/c, on an amplitude plot (``amplitude=True``) the numbers are |Q| and A.

Which R can be trusted (issue 5, docs/trust.md, "Can R be trusted?"): trust is judged by R_err alone --
a point is drawn filled where R_err <= RELATIVE_ERROR_LIMIT of R and hollow where not -- and the
kind of motion by ``period``: a circle where a period was found, a square where none was (chaos,
quasi-periodic, a period above max_period, or a motion still settling; with a tiny R_err the last
two are common and harmless). Points keep their curve's colour. Failed points (status not ok)
have no value: they are x marks in a strip of their own under the panel (selection.failure_strip),
where no value is drawn, and the title counts them (issue 15).

One module per concern: ``labels`` (constants, axis labels, captions), ``selection`` (loading a
file, ``select``: fixing axes through xarray, which points to trust), ``analytic`` (the theory's
branches and the resonance), ``sweeps`` (the sweep figures, ``map_figure`` for any variable with
one value per grid point), ``lyapunov``, ``trajectories`` and ``basins``. This module dispatches: ``plot``
draws what ``vrsweep plot`` draws.

Every figure function takes the keyword arguments title, size, style (and the maps vmin, vmax):
``labels.figure_options``. Font sizes are the style's (relative sizes only, never points), and
``render`` writes the figure with its full description in the file's metadata.
"""

from __future__ import annotations

import os

from matplotlib.figure import Figure

from vrsweep.errors import UsageError
from vrsweep.plot.analytic import analytic_branches, resonance_positions
from vrsweep.plot.basins import basin_figure, basin_plot
from vrsweep.plot.branches import branch_figure, is_branch
from vrsweep.plot.curves import curves_figure, is_curves
from vrsweep.plot.labels import (
    KINDS, LOG_SPAN, RELATIVE_ERROR_LIMIT, SWEEP_KINDS, TRAJECTORY_KINDS, description, figure_options, metadata,
    layout_note, legend_note, parameter_label, parse_size, read_description, render, resolve_style,
)
from vrsweep.plot.lyapunov import lyapunov_figure
from vrsweep.plot.selection import _grid_axes, _sweep_default, load, select
from vrsweep.plot.sweeps import (
    bifurcation_figure, impacts_figure, map_figure, mappable_variables, response_figure, status_figure, motion_figure,
    variable_figure,
)
from vrsweep.plot.trajectories import (
    impacts_per_period_figure, parse_periods, slow_flow_figure, slow_periods_in, trajectory_figure, with_impacts,
)


def default_kind(data) -> str:
    """What ``vrsweep plot FILE`` draws when no --kind is given."""
    from vrsweep.store.trajectory_file import TrajectoryData

    if isinstance(data, TrajectoryData):
        return "trajectory"
    return _sweep_default(_grid_axes(data))


def plot(sources, kind=None, amplitude=False, at=None, x_axis=None, log=None, periods=None, var=None, *,
         title=True, size=None, style=None, vmin=None, vmax=None, xlim=None, ylim=None, legend=None, zoom=None,
         table=False) -> Figure:
    """The figure ``vrsweep plot`` draws for ``sources`` (one file; several for trajectory impacts).

    sources: a path, what ``load`` returned (a sweep's Dataset, a trajectory's TrajectoryData), what
    the Python API returns (``vrsweep.sweep``'s or ``vrsweep.open_results``'s Dataset,
    ``vrsweep.simulate``'s Dataset or its dict of them), or a list of these. at: {axis: value} fixing
    sweep axes; x_axis: the swept parameter to draw against; log: True for a logarithmic response
    axis (or colour scale of a map), False for a linear one, None to choose (response plots: log
    when the measured values span two decades or more; maps: linear); periods: (first, last) slow periods
    of a trajectory to show; var: the stored variable a map shows (default R, or Q_amplitude with
    ``amplitude``). title, size, style: as every figure function takes them (``figure_options``):
    False for no title at all (the description stays in ``description(fig)``, the file's metadata),
    (width, height) in inches, a matplotlib style sheet's name or .mplstyle path; vmin, vmax: the
    ends of a map's colour scale; xlim, ylim: (low, high) of the main panel's axes (and of every
    panel showing the same quantity); legend: 'best', 'outside' or 'none' (``figure_options``).
    Branch files only: zoom ('bifurcations', 'none'; default: by itself when the bifurcations span
    under 1 % of the axis) and table (the bifurcations in a table below the figure).
    """
    from vrsweep.store.trajectory_file import TrajectoryData

    from collections.abc import Mapping

    from vrsweep.plot.labels import check_flags

    # The library's arguments are typed, as the command line's options are parsed: amplitude="no"
    # and log="no" acted as True (a log axis), at="g=20" failed in an AttributeError.
    check_flags(amplitude=amplitude, table=table)
    if log is not None:
        check_flags(log=log)
    if at is not None and not isinstance(at, Mapping):
        raise UsageError.naming("{at} must be a mapping of axis -> value, e.g. {{'g': 20}}, got {value!r}", value=at)
    options = dict(title=title, size=size, style=style, xlim=xlim, ylim=ylim, legend=legend)
    limits = dict(vmin=vmin, vmax=vmax)
    if not isinstance(sources, (list, tuple)):  # one source; a Dataset or a dict iterates over names
        sources = [sources]
    if not sources:
        raise UsageError.naming("no file to plot")
    data = [_loaded(s) for s in sources]
    if any(is_curves(d) for d in data):
        return _curves_plot(data, kind, amplitude, at, x_axis, log, periods, var, options, limits)
    if is_branch(data[0]):
        # vrsweep continue's files (several: e.g. branches from several starts), then sweep files
        # drawn on the same axes
        _refuse_for_branches(kind=kind, at=at, x_axis=x_axis, var=var, periods=periods, amplitude=amplitude,
                             log=log)
        count = 1
        while count < len(data) and is_branch(data[count]):
            count += 1
        if any(is_branch(d) or not hasattr(d, "attrs") for d in data[count:]):
            raise UsageError.naming("after the branch files come sweep files only (vrsweep run results)")
        if len({str(d.attrs.get("parameter")) for d in data[:count]}) > 1:
            raise UsageError.naming("branch files drawn together must continue the same parameter")
        return branch_figure(data[0], data[count:], more_branches=data[1:count], zoom=zoom, table=table, **options,
                             **limits)
    if zoom is not None or table:  # never ignored quietly
        raise UsageError.naming("{zoom} and {table} are for branch files (vrsweep continue), whose bifurcations "
                                "they show")
    if any(is_branch(d) for d in data):
        # A sweep first and a branch after ran into the line below, which said several files go
        # together only for trajectories' impacts: branches go first, and the sweeps after them.
        raise UsageError.naming("branch files (vrsweep continue) go first, the sweep files drawn with them after: "
                                "vrsweep plot BRANCH.h5 [BRANCH2.h5 ...] SWEEP.h5 [SWEEP2.h5 ...]")
    trajectories = [isinstance(d, TrajectoryData) for d in data]
    if any(trajectories) and not all(trajectories):
        raise UsageError.naming("plot sweep results and trajectory files separately")
    if len(data) > 1 and not (all(trajectories) and kind == "impacts"):
        raise UsageError.naming("several files go on one figure only with {kind} impacts of trajectory files "
                                "(Fig. impact_no); plot the others one at a time")
    if all(trajectories):
        kind = kind or "trajectory"
        if kind not in TRAJECTORY_KINDS:
            raise UsageError.naming("{kind} {value} is for sweep results; a trajectory file takes {kinds}",
                                    value=kind, kinds=", ".join(TRAJECTORY_KINDS))
        if at or x_axis or amplitude or log is not None or var is not None:  # never ignored quietly
            raise UsageError.naming("{at}, {x_axis}, {var}, {amplitude} and {log}/{linear} are for sweep results, "
                                    "not trajectory files")
        if kind == "impacts" and periods is not None:  # it was drawn over every period, without a word
            raise UsageError.naming("{periods} is for {kind} trajectory and {kind} slowflow; {kind} impacts draws "
                                    "every period of each file")
        if kind == "impacts":
            return impacts_per_period_figure(data, **options, **limits)
        if kind == "slowflow":
            return slow_flow_figure(data[0], periods=periods, **options, **limits)
        return trajectory_figure(data[0], periods=periods, **options, **limits)
    if periods is not None:
        raise UsageError.naming("{periods} is for trajectory files (vrsweep simulate), not sweep results")
    ds = select(data[0], at or {})
    # After at, a fixed axis no longer counts; a variable is mapped over two axes, drawn against one.
    parameter_axes = [name for name in _grid_axes(ds) if name != "direction"]
    kind = kind or ("map" if var is not None and len(parameter_axes) >= 2 else
                    "response" if var is not None else _sweep_default(_grid_axes(ds)))
    if kind not in SWEEP_KINDS:
        raise UsageError.naming("{kind} {value} is for trajectory files (vrsweep simulate); a sweep result "
                                "takes {kinds}", value=kind, kinds=", ".join(SWEEP_KINDS))
    if var is not None and kind not in ("map", "response"):
        raise UsageError.naming("{var} is for {kind} map and {kind} response (against one axis), not {kind} {value}",
                                value=kind)
    if var is not None and amplitude:  # never ignored quietly
        raise UsageError.naming("{amplitude} maps Q_amplitude and {var} names the variable itself: give one of them")
    if kind == "response" and var is not None:
        return variable_figure(ds, var, x_axis=x_axis, log=log, **options, **limits)
    if kind == "response":
        return response_figure(ds, amplitude=amplitude, x_axis=x_axis, log=log, **options, **limits)
    if kind == "map":
        return map_figure(ds, var or ("Q_amplitude" if amplitude else "R"), x_axis=x_axis, log=bool(log),
                          **options, **limits)
    if kind == "impacts":
        return impacts_figure(ds, x_axis=x_axis, log=bool(log), **options, **limits)
    if log:  # never ignored quietly
        raise UsageError.naming("{log} is for response, map and impacts plots, not {kind} {value}", value=kind)
    if kind == "status":
        return status_figure(ds, x_axis=x_axis, **options, **limits)
    if kind == "motion":
        return motion_figure(ds, x_axis=x_axis, **options, **limits)
    if kind in ("lyapunov", "bifurcation+lyapunov"):
        return lyapunov_figure(ds, x_axis=x_axis, bifurcation=kind == "bifurcation+lyapunov", **options, **limits)
    return bifurcation_figure(ds, x_axis=x_axis, **options, **limits)


def _loaded(source):
    """One source of ``plot``, in the form the figures draw: a path loaded (``load``); a sweep's,
    branch's or curves' Dataset as it is; a trajectory's Dataset, or simulate's dict of them, as
    the TrajectoryData its file gives. Anything else is a UsageError saying what is accepted (a
    Dataset was iterated as the names of its variables, each then refused as a missing file; a
    trajectory's Dataset failed in a KeyError)."""
    from vrsweep.store.trajectory_file import TrajectoryData, from_datasets, is_trajectory_dataset

    if isinstance(source, (str, os.PathLike)):
        return load(source)
    if isinstance(source, TrajectoryData):
        return source
    if is_trajectory_dataset(source) or isinstance(source, dict):
        try:
            return from_datasets(source)
        except ValueError as error:
            raise UsageError.naming("cannot plot {what}: {reason}", what=type(source).__name__,
                                    reason=error) from None
    attrs = getattr(source, "attrs", None)
    if hasattr(source, "data_vars") and isinstance(attrs, dict) and attrs.get("vrsweep_file"):
        return source
    raise UsageError.naming("cannot plot {what}: give a result file's path, or a Dataset that vrsweep.sweep, "
                            "vrsweep.simulate or vrsweep.open_results returned", what=_what(source))


def _what(source):
    if hasattr(source, "dims") and not hasattr(source, "data_vars"):
        return f"a DataArray ({getattr(source, 'name', None)!r}): pass its Dataset"
    if hasattr(source, "data_vars"):
        return "a Dataset that no vrsweep file or function made (no vrsweep_file attribute)"
    return f"{type(source).__name__} {source!r}"[:120]


# What a branch figure cannot do with each option it is given: one line each, never ignored quietly.
_BRANCH_REFUSALS = {
    "kind": "{kind} {value}: a branch file has one figure (R and the Floquet multipliers along the branch)",
    "at": "{at}: a branch file has no axes to fix; its points lie along the branch",
    "x_axis": "{x_axis} {value}: a branch file is drawn against its continued parameter",
    "var": "{var} {value}: a branch file's figure is R along the branch; read other variables with "
           "vrsweep.open_results",
    "periods": "{periods} is for trajectory files (vrsweep simulate), not branch files",
    "amplitude": "{amplitude}: a branch file's figure is the gain R; read Q_amplitude with vrsweep.open_results",
    "log": "{log}/{linear}: a branch file's figure chooses its scales (the multipliers' panel turns "
           "logarithmic by itself)",
}


# What each option is when it was not given (others: None; log=False is --linear, given).
_NOT_GIVEN = {"amplitude": False, "at": {}}


def _refuse_for_branches(**given):
    """UsageError for the first option a branch figure cannot honour (given: {option: value})."""
    for name, value in given.items():
        if value is not None and value != _NOT_GIVEN.get(name):
            raise UsageError.naming(_BRANCH_REFUSALS[name], value=value)


def _curves_plot(data, kind, amplitude, at, x_axis, log, periods, var, options, limits):
    """A map (the first file, a sweep over two parameters) with the curves files after it."""
    from vrsweep.store.trajectory_file import TrajectoryData

    map_data, curve_files = data[0], data[1:]
    if is_curves(map_data) or isinstance(map_data, TrajectoryData) or is_branch(map_data) or not curve_files:
        raise UsageError.naming("curves files go after the map they are drawn over: vrsweep plot MAP.h5 "
                                "CURVES.h5 [CURVES2.h5 ...], MAP.h5 a sweep over the curves' two parameters")
    if not all(is_curves(d) for d in curve_files):
        raise UsageError.naming("after a map come curves files only (the bifurcation curves vrsweep continue "
                                "writes from a branch file)")
    if kind not in (None, "map"):
        raise UsageError.naming("curves go over a map: {kind} {value} does not take curves files", value=kind)
    if periods is not None:
        raise UsageError.naming("{periods} is for trajectory files (vrsweep simulate), not maps")
    if var is not None and amplitude:  # never ignored quietly
        raise UsageError.naming("{amplitude} maps Q_amplitude and {var} names the variable itself: give one of them")
    ds = select(map_data, at or {})
    return curves_figure(ds, curve_files, var or ("Q_amplitude" if amplitude else "R"), x_axis=x_axis,
                         log=bool(log), **options, **limits)


__all__ = [
    "curves_figure", "KINDS", "SWEEP_KINDS", "TRAJECTORY_KINDS", "RELATIVE_ERROR_LIMIT", "LOG_SPAN", "load", "default_kind", "plot",
    "select", "mappable_variables", "basin_plot", "basin_figure", "response_figure", "variable_figure", "map_figure", "impacts_figure", "status_figure", "motion_figure", "bifurcation_figure",
    "trajectory_figure", "impacts_per_period_figure", "slow_flow_figure", "analytic_branches",
    "resonance_positions", "with_impacts", "parse_periods", "slow_periods_in", "parameter_label",
    "figure_options", "description", "metadata", "render", "layout_note", "legend_note", "read_description", "resolve_style", "parse_size",
]
