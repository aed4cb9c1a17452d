"""Basins of attraction (issue 13): the x0-v0 plane of a sweep over the initial state, coloured
by the attractor each start reached."""

from __future__ import annotations

import os

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from vrsweep.errors import ResultFileError, UsageError
from vrsweep.plot.labels import MODEL_EQUATIONS, literal, written_equation, parameter_symbol, _legend_columns, _wrap, figure_options, _new_figure, _number, _title, _width, period_words, gain_words
from vrsweep.plot.palettes import QUALITATIVE, categorical
from vrsweep.plot.selection import cell_ticks, _grid_axes, _path, _progress_note, _Sweep, load, select
from vrsweep.results import Status


# --------------------------------------------------------------------------------------------
# Basins of attraction (issue 13): sweeps with x0 / v0 axes
# --------------------------------------------------------------------------------------------

# Apart in lightness on a greyscale page (palettes.py; tab10's orange and green were one grey), and
# from the black of failed points and the white of missing ones. Beyond six attractors: in order
# from dark to light (``categorical``).
BASIN_COLOURS = QUALITATIVE
BASIN_FAILED = "black"        # a point whose integration failed (label -1)
BASIN_NOT_COMPUTED = "white"  # an unfinished file's missing points
OUTSIDE_PLANE = "0.9"         # around the swept plane, where the view widens to show an orbit


def basin_plot(results, at=None, **options) -> Figure:
    """``vrsweep plot FILE --kind basin``: the x0-v0 plane of one slice coloured by attractor.

    results: a path, or the Dataset of a sweep with x0 and/or v0 axes (``load``,
    ``vrsweep.open_results``); at: {axis: value} fixing every other axis with more than one value
    (a slice's parameters); options: title, size, style (``figure_options``).
    """
    from vrsweep.store.trajectory_file import TrajectoryData

    data = load(results) if isinstance(results, (str, os.PathLike)) else results
    if isinstance(data, TrajectoryData):
        raise UsageError.naming("{kind} basin is for sweep results with x0 / v0 axes, not trajectory files")
    kind = data.attrs.get("vrsweep_file")
    if kind in ("branch", "curves"):  # no grid at all: _grid_axes would fail on their missing done mask
        raise UsageError.naming("{kind} basin is for sweep results with x0 / v0 axes, not {file_kind} files",
                                file_kind=kind)
    axes = _grid_axes(data)
    if "attractor" not in data.data_vars:
        path = _path(data)
        if data.attrs.get("shard"):
            raise UsageError.naming("{path} is a shard: attractors are labelled over whole slices, after "
                                    "vrsweep merge; plot the merged file", path=path)
        if not data.attrs.get("vrsweep_complete", 0):
            raise UsageError.naming("{path} is unfinished: attractors are labelled when the sweep ends "
                                    "({finish} finishes it)", {"finish": "resuming the sweep"}, path=path)
        if not any(name in axes for name in ("x0", "v0")):
            raise UsageError.naming("{path} has no x0 or v0 axis: a basin plot needs a sweep over the "
                                    "initial state (sweep: {{x0: ..., v0: ...}})", path=path)
        raise ResultFileError.naming("{path} has x0 / v0 axes but no attractor labels (merged or written by a "
                                     "vrsweep that does not label them): {finish} adds them without computing "
                                     "any point again", {"finish": "resuming the sweep into it"}, path=path)
    at = dict(at or {})
    for name, values in axes.items():  # a one-value axis needs no at
        if name not in at and name not in ("x0", "v0") and len(values) == 1:
            at[name] = str(values[0])
    return basin_figure(select(data, at), **options)


@figure_options
def basin_figure(ds) -> Figure:
    """Attractor labels over the x0-v0 plane (or along x0 or v0), legend from the attractor table;
    ``ds``: one slice of a sweep over the initial state (other axes fixed with ``select``).

    Each attractor's stroboscopic points x(nT), v(nT) -- of the first start in its basin, in grid
    order -- are marked on the plane in its colour with a black edge: the orbit itself, in the
    same section t = nT as the initial states (t = 0). Where they lie outside the swept plane the
    view widens to show them and a dashed frame marks the plane."""
    view = _Sweep(ds)
    state_axes = [name for name in ("x0", "v0") if name in view.axes]
    if not state_axes:
        raise UsageError.naming("{path} has no x0 or v0 axis: a basin plot needs a sweep over the initial "
                                "state (sweep: {{x0: ..., v0: ...}})", path=view.path)
    others = [name for name in view.axes if name not in state_axes]
    if others:
        raise UsageError.naming("{path} also sweeps {others}: pick one slice, e.g. " +
                                " ".join("{at} " + f"{{example{k}}}" for k in range(len(others))),
                                path=view.path, others=", ".join(others),
                                **{f"example{k}": f"{name}={_number(view.axes[name][0])}" for k, name in enumerate(others)})
    view.require("attractor", "attractor_count", "attractor_period", "attractor_R", "attractor_fraction")
    labels = np.asarray(view.variables["attractor"])
    status = np.asarray(view.variables["status"])
    count = int(np.asarray(view.variables["attractor_count"]))
    colours = categorical(count)
    # Colour index: 0 not computed, 1 failed, 2 + label.
    index = np.where(status == Status.NOT_COMPUTED, 0, np.where(labels < 0, 1, labels + 2))
    cmap = ListedColormap([BASIN_NOT_COMPUTED, BASIN_FAILED] + colours)
    norm = BoundaryNorm(np.arange(-0.5, count + 2.5), cmap.N)
    fig = _new_figure(7.8, 5.6 if len(state_axes) == 2 else 3.2)
    ax = fig.subplots()
    if len(state_axes) == 2:
        x_axis, y_axis = state_axes
        z = index if ds["attractor"].dims.index(x_axis) == 0 else index.T
        ax.pcolormesh(view.axes[x_axis], view.axes[y_axis], z.T, shading="nearest", cmap=cmap, norm=norm)
        ax.set_ylabel(_state_label(y_axis))
    else:
        x_axis = state_axes[0]
        ax.pcolormesh(view.axes[x_axis], [0.0, 1.0], np.vstack([index, index]), shading="nearest",
                      cmap=cmap, norm=norm)
        ax.set_yticks([])
    ax.set_xlabel(_state_label(x_axis))
    outside = _mark_attractors(ax, ds, view, labels, colours, state_axes)
    if not outside:  # a view widened to orbits outside the plane keeps round ticks across it
        cell_ticks(ax, view.axes[x_axis], view.axes[y_axis] if len(state_axes) == 2 else None)
    handles = [_basin_handle(view, label, colours[label]) for label in range(count)]
    if count and "strobe_x" in view.variables:
        handles.append(_ringed_dot("0.6", "ringed dot: an attractor's points x(nT), v(nT) in its colour"))
    if outside:
        handles.append(Patch(facecolor=OUTSIDE_PLANE, edgecolor="k", ls="--",
                             label="dashed frame: the swept plane; outside it, no start was tried"))
    n_failed = int(np.sum((labels < 0) & (status != Status.NOT_COMPUTED)))
    if n_failed:
        handles.append(Line2D([], [], marker="s", ls="", color=BASIN_FAILED, markersize=9,
                              label=f"failed ({n_failed} points, see the status map)"))
    n_missing = int(np.sum(status == Status.NOT_COMPUTED))
    if n_missing:
        handles.append(Line2D([], [], marker="s", ls="", color=BASIN_NOT_COMPUTED, markeredgecolor="0.5",
                              markersize=9, label=f"not computed ({n_missing} points)"))
    fig.legend(handles=handles, loc="outside lower center", ncols=_legend_columns(fig, 1 if count <= 4 else 2), fontsize="small",
               title=f"attractor: period, {gain_words()}, impacts, share of the plane",
               title_fontsize="small")
    found = f"{count} attractor{'s' if count != 1 else ''}"
    _title(fig, f"Basins of attraction in the plane of initial states: {found}",
           _basin_caption(view, _width(fig)))
    return fig


def _mark_attractors(ax, ds, view, labels, colours, state_axes):
    """Mark each attractor's stroboscopic points on the plane (or the strip); returns True when
    some lie outside the swept plane, which then is framed and the view widened to show them."""
    from matplotlib.patches import Rectangle

    if "strobe_x" not in view.variables or "strobe_v" not in view.variables:
        return False
    dims = tuple(ds["attractor"].dims)
    strobe = {"x0": ds["strobe_x"].transpose(*dims, ...).values, "v0": ds["strobe_v"].transpose(*dims, ...).values}
    limits = {name: (float(np.min(view.axes[name])), float(np.max(view.axes[name]))) for name in state_axes}
    drawn = {name: [] for name in state_axes}
    flat_labels = np.asarray(labels).reshape(-1)
    for label, colour in enumerate(colours):
        members = np.flatnonzero(flat_labels == label)
        if members.size == 0:
            continue
        first = np.unravel_index(members[0], np.shape(labels))  # attractor_x0/v0's start: first in grid order
        points = {name: np.asarray(strobe[name][first], dtype=np.float64) for name in state_axes}
        finite = np.logical_and.reduce([np.isfinite(points[name]) for name in state_axes])
        if not finite.any():
            continue
        xs = points[state_axes[0]][finite]
        ys = points[state_axes[1]][finite] if len(state_axes) == 2 else np.full(xs.shape, 0.5)
        # The points lie in their own basin, where a dot of its colour with a black edge vanished
        # on the dark cells: a black rim around a white ring around the colour stands out on any cell.
        ax.plot(xs, ys, "o", ls="", color=colour, mec=RING_INNER, mew=RING_WIDTH, ms=RING_SIZE, zorder=5,
                path_effects=_rim(), gid=f"attractor {label}")
        for name, values in zip(state_axes, (xs, ys)):
            drawn[name].append(values)
    outside = False
    view_limits = []
    for k, name in enumerate(state_axes):
        values = np.concatenate(drawn[name]) if drawn[name] else np.array([])
        low, high = limits[name]
        cell = (high - low) / max(len(view.axes[name]) - 1, 1) / 2  # the plane reaches half a cell beyond
        low, high = low - cell, high + cell
        if values.size and (values.min() < low or values.max() > high):
            outside = True
            low, high = min(low, float(values.min())), max(high, float(values.max()))
        view_limits.append((low, high))
    if outside:  # widen the view to the orbits, and frame the plane the sweep covered
        for (low, high), set_limits in zip(view_limits, (ax.set_xlim, ax.set_ylim)):
            margin = 0.04 * (high - low)
            set_limits(low - margin, high + margin)
        name = state_axes[0]
        (x_low, x_high) = limits[name]
        x_cell = (x_high - x_low) / max(len(view.axes[name]) - 1, 1) / 2
        if len(state_axes) == 2:
            y_low, y_high = limits[state_axes[1]]
            y_cell = (y_high - y_low) / max(len(view.axes[state_axes[1]]) - 1, 1) / 2
        else:
            y_low, y_high, y_cell = 0.0, 1.0, 0.5
        ax.add_patch(Rectangle((x_low - x_cell, y_low - y_cell), x_high - x_low + 2 * x_cell,
                               y_high - y_low + 2 * y_cell, fill=False, ec="k", lw=1.0, ls="--", zorder=4,
                               gid="swept plane"))
        ax.set_facecolor(OUTSIDE_PLANE)
    return outside


RING_OUTER, RING_INNER = "black", "white"  # an attractor's dots: black rim, white ring, its colour inside
RING_SIZE, RING_WIDTH, RIM_WIDTH = 7.0, 1.4, 1.2  # points


def _rim():
    """The black rim drawn under a dot's white edge (a path effect: the legend's sample has it too)."""
    from matplotlib.patheffects import Normal, Stroke

    return [Stroke(linewidth=RING_WIDTH + 2 * RIM_WIDTH, foreground=RING_OUTER), Normal()]


def _ringed_dot(colour, label):
    """A legend entry drawn as the attractors' dots are: black rim, white ring, ``colour`` inside."""
    return Line2D([], [], marker="o", ls="", color=colour, mec=RING_INNER, mew=RING_WIDTH, markersize=RING_SIZE,
                  path_effects=_rim(), label=label)


def _state_label(name):
    from vrsweep.numerics.model import INITIAL_STATE_LONG_NAMES, INITIAL_STATE_SYMBOLS

    words = INITIAL_STATE_LONG_NAMES[name].rsplit(" ", 1)[0]
    return f"{words} {INITIAL_STATE_SYMBOLS[name]}"


def _basin_handle(view, label, colour):
    period = int(np.asarray(view.variables["attractor_period"])[label])
    R = float(np.asarray(view.variables["attractor_R"])[label])
    fraction = float(np.asarray(view.variables["attractor_fraction"])[label])
    impacts = "attractor_impacts_per_cycle" in view.variables and int(
        np.asarray(view.variables["attractor_impacts_per_cycle"])[label])
    if period > 0:
        kind = f"period {period}"
        hits = f"{impacts} impact{'s' if impacts != 1 else ''} per cycle"
    else:
        kind = "no period (chaotic, quasi-periodic or unsettled)"
        per_period = float(np.asarray(view.variables.get("attractor_impacts_per_period", [np.nan] * (label + 1)))[label])
        hits = f"{per_period:.3g} impacts per {period_words(symbol=False)}"
    text = f"{label}: {kind}, R = {R:.4g}, {hits}, {100 * fraction:.1f}%"
    return Line2D([], [], marker="s", ls="", color=colour, markersize=9, label=text)


def _basin_caption(view, width):
    """The caption of a basin plot: the slice's parameters (not the config's unused initial state)."""
    items = [literal(os.path.basename(view.path)), MODEL_EQUATIONS.get(view.model, view.model)]
    if view.config is not None:
        parameters = view.parameters()
        if view.config.written:
            items[1] = written_equation(view.config.model)
        items += [f"{parameter_symbol(name)} = {_number(parameters[name])}" for name in view.config.parameter_names]
        run = view.config.integration
        items.append(f"{run.transient_periods} transient + {run.measure_periods} measured "
                     f"{'periods T' if view.config.written else 'slow periods'}")
    items += ["all quantities dimensionless"] + ([_progress_note(view)] if not view.complete else [])
    return _wrap(items, width)
