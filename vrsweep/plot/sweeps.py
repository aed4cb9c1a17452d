"""The sweep figures: response (Fig. 1, Fig. 2), map, impacts, status and bifurcation; each takes
an xarray Dataset (``vrsweep.open_results``, ``plot.load``), its axes fixed with ``select``."""

from __future__ import annotations

import re

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from vrsweep.errors import ResultFileError, UsageError
from vrsweep.plot import layout
from vrsweep.plot.analytic import (
    barrier_positions,
    RESONANCE_CUT, THEORY_CUT, _draw_branches, _draw_resonance_curve, _fine_parameters, _resonance_label, analytic_branches,
    resonance_roots,
)
from vrsweep.plot.palettes import (
    MAX_CATEGORIES, MAX_SCALE_CURVES, NO_VALUE_GREY, NOT_COMPUTED_GREY, STATUS_COLOURS, cased, categorical,
    scale_colours,
)
from vrsweep.plot.labels import (
    parameter_symbol, stuck_words,
    FAILED_COLOUR, FINE_POINTS, LOG_SPAN, LYAPUNOV_SYMBOL, MARKERS, MAX_CURVES, RELATIVE_ERROR_LIMIT, RELIABLE_COLOURS,
    _caption, _legend_columns, _new_figure, _number, _symbol, _title, _width, figure_options, parameter_label, units_suffix,
    period_words, written_expression, written_gain, written_model, written_response_label,
)
from vrsweep.plot.selection import (
    _choose_x_axis, _draw_failed_rug, _failure_note, _grid_axes, _map_axes, _map_panels, _point_classes,
    _progress_note, _span_grid, _Sweep, _sweep_default, cell_edges, cell_ticks, fine_grid, map_mesh,
)
from vrsweep.results import Motion, Status


# --------------------------------------------------------------------------------------------
# Sweep figures
# --------------------------------------------------------------------------------------------


LEGEND_CURVES = 3        # more curves over one other parameter than this: a colour scale, not a legend
# Each curve of a --var or impacts figure its own marker as well as its colour (RELIABLE_COLOURS,
# every two apart in grey): the marks mean nothing else there, and tell the curves apart where the
# colours alone do not (a legend's small samples).
CURVE_MARKERS = "os^Dv<>p"
MAX_SCALED_CURVES = MAX_SCALE_CURVES  # with a colour scale, neighbours stay apart in grey up to this many (9)
BARRIER_COLOUR = "0.35"
BARRIER_DASHES = (0, (7, 2, 1.5, 2, 1.5, 2))  # dash-dot-dot: unlike the dotted joins, dashed unstable branches


@figure_options
def response_figure(ds, amplitude=False, x_axis=None, log=None, xlim=None, ylim=None) -> Figure:
    """R (or |Q|) against one axis with the analytic branches and the resonance (Fig. 1, Fig. 2).

    Markers follow docs/trust.md, "Can R be trusted?": filled where R_err <= 10% of R (R can be
    trusted), hollow where not; a circle where a period was found, a square where none was
    (period 0); always in the curve's colour. More than LEGEND_CURVES curves over one other
    parameter take their colours from a scale of its value, with a colour bar, not a legend.
    Failed points (status not ok, R = NaN) are x marks in a strip under the panel, one row per curve,
    and counted in the title.

    log: True/False for a logarithmic/linear response axis; None chooses: logarithmic when the
    measured values span LOG_SPAN or more. The theory counts for the limits only near the
    measured values, and is clipped beyond, said in the caption (``_response_axes``): at small
    Omega its A/c fell to 1e-6 and forced a log axis of 7 decades on R of 0.2 to 44.

    xlim, ylim: the view asked for (--xlim, --ylim), set here rather than after the figure is made
    (``figure_options`` hands them to a figure function that takes them), so that the caption says
    what that view leaves out, not what the automatic one would have.

    In pieces: ``_curve_colours`` (a legend's colours, or a colour scale), ``_draw_measured``
    (each curve's points by trust and kind), ``_draw_analytic`` (the theory's branches, the
    barrier's level, the resonance), ``_response_legend`` and ``_response_axes`` (labels, scale).
    """
    view = _Sweep(ds)
    x_axis = _choose_x_axis(view, x_axis)
    name = "Q_amplitude" if amplitude else "R"
    view.require(name, "status")
    curves = view.curve_coordinates(x_axis)
    others = [n for n in view.axes if n != x_axis]
    # Many curves over one other parameter: colours from a scale of its value, named by a colour
    # bar, instead of a legend entry (and a resonance entry) per curve.
    scale_axis = others[0] if len(curves) > LEGEND_CURVES and len(others) == 1 and others[0] != "direction" else None
    _refuse_too_many_curves(view, curves, MAX_SCALED_CURVES if scale_axis else MAX_CURVES, name, x_axis)
    x = np.asarray(view.axes[x_axis], dtype=np.float64)
    fig = _new_figure(8.0, 6.0)
    ax = fig.subplots()
    colour_of = _curve_colours(fig, ax, ds, view, scale_axis)
    written = view.config is not None and view.config.written  # no analytic side: the paper's theory only
    what = ("numerical |Q|" if amplitude else "numerical R") if written else \
        ("numerical |Q| (eq3.1-3.2)" if amplitude else "numerical R = |Q|/c (eq3.3)")
    # The barrier level Delta (or Delta/c) is the same for every curve unless Delta or c is swept.
    analytic = _Analytic(barrier_shared=not any(axis in ("Delta", "c") for axis in others))
    curve_handles, drawn, theory = [], [], []  # the values measured and the theory's: to choose the scale
    kinds_seen = {"aperiodic": False, "untrusted": False}
    for k, (where, label) in enumerate(curves):
        colour = colour_of(k, where)
        drawn.append(_draw_measured(ax, view, name, x_axis, x, where, colour, k, len(curves), kinds_seen))
        if scale_axis is None:
            curve_handles.append(Line2D([], [], ls=":", lw=0.8, marker="o", color=colour, ms=4,
                                        label=f"{what}{', ' + label if label else ''}"))
        elif not curve_handles:
            curve_handles.append(Line2D([], [], ls=":", lw=0.8, marker="o", color="0.3", ms=4,
                                        label=f"{what}; colour: {_symbol(scale_axis)} (colour bar)"))
        if view.config is not None and not written:
            theory += _draw_analytic(ax, view, x_axis, x, where, colour, amplitude, scale_axis, analytic)
    failure_note = _failure_note(view, "in the strip under the panel")
    handles = _response_legend(curve_handles, kinds_seen, failure_note, len(curves), amplitude,
                               analytic if view.config is not None and not written else None)
    fig.legend(handles=handles, fontsize="x-small", loc="outside lower center", ncol=_legend_columns(fig, 2))
    if scale_axis is None and len(curves) > 1:  # kept, by their labels alone, where the whole legend has no room
        fig._vrsweep_curve_labels = {handle.get_label(): label for handle, (_, label) in zip(curve_handles, curves)
                                     if label}
    scale_note, reach = _response_axes(ax, view, x_axis, x, drawn, theory, amplitude, log, analytic.barrier_levels)
    quantity = "amplitude |Q|" if amplitude else "gain R"
    theory_note = ("" if written else "; analytic: first-order theory of the effective system "
                   f"(ERRATA 1-3{'' if amplitude else ', divided by c: ERRATA 6'})")
    asked = xlim is not None or ylim is not None
    layout.apply_limits(fig, xlim, ylim)
    # What the view leaves out, as it is now: with --xlim/--ylim the automatic limits' reason for
    # leaving the theory out ('more than 10 times from the measured values') no longer holds.
    beyond = _beyond_view(ax, drawn, theory, analytic.barrier_levels, amplitude, None if asked else reach)
    notes = "; ".join(note for note in (_progress_note(view), failure_note, scale_note, beyond,
                                        THEORY_CUT if analytic.theory_cut else
                                        RESONANCE_CUT if analytic.resonance_cut else "") if note)
    _title(fig, f"Response {quantity} against {parameter_symbol(x_axis)}{theory_note}",
           _caption(view.path, view.config, view.model, view.selected, notes, _width(fig)))
    return fig


def _refuse_too_many_curves(view, curves, limit, name, x_axis):
    """UsageError when more than ``limit`` curves would share one plot: fix the other axes (or draw a
    map, where ``name`` has one value per point: not strobe_x, a bifurcation diagram's samples)."""
    if len(curves) > limit:
        others = [n for n in view.parameter_axes if n != x_axis]
        mappable = name in view.variables and np.ndim(view.variables[name]) == len(view.axes)
        raise UsageError.naming("{n} curves of {name} against {axis} on one plot: fix {others} with {at}"
                                + (", or draw {kind} map" if mappable else ""),
                                n=len(curves), name=name, axis=x_axis, others=", ".join(others))


def _curve_colours(fig, ax, ds, view, scale_axis):
    """colour(k, where) of curve k: the legend's colours in turn, or with ``scale_axis`` a colour
    from a scale of that axis' value, named by a colour bar.

    On the scale the curves are coloured by rank, at equal steps from dark to light
    (``palettes.scale_colours``), and the colour bar has a block per value, labelled with it: by
    value, two close values (Omega = 3 and 3.1 beside 6) took one colour."""
    if scale_axis is None:
        return lambda k, where: RELIABLE_COLOURS[k % len(RELIABLE_COLOURS)]
    from matplotlib.cm import ScalarMappable

    from vrsweep.plot.selection import _cell_texts

    scale_values = np.asarray(view.axes[scale_axis], dtype=np.float64)
    order = np.argsort(scale_values)
    ranked = scale_colours(len(scale_values))
    colours = [None] * len(scale_values)
    for rank, index in enumerate(order):
        colours[index] = ranked[rank]
    blocks = np.arange(len(scale_values) + 1) - 0.5
    bar = fig.colorbar(ScalarMappable(norm=BoundaryNorm(blocks, len(ranked)), cmap=ListedColormap(ranked)), ax=ax,
                       label=parameter_label(scale_axis, ds[scale_axis].attrs.get("units")))
    bar.set_ticks(np.arange(len(scale_values)), labels=_cell_texts(scale_values[order]))
    bar.minorticks_off()
    return lambda k, where: colours[where[scale_axis]]


def _draw_measured(ax, view, name, x_axis, x, where, colour, k, n_curves, kinds_seen):
    """One curve's points: joined by a dotted line, marked by trust (filled or hollow) and kind
    (circle: a period; square: none), failed points in the strip under the panel. Returns (x, values)
    drawn; records in ``kinds_seen`` which kinds of mark appeared (for the legend)."""
    y = view.along(name, x_axis, **where)
    trusted, aperiodic, failed = _point_classes(view, x_axis, where)
    shown = np.isfinite(y) & ~failed
    ax.plot(x, y, color=colour, lw=0.8, ls=":", zorder=3)
    for no_period in (False, True):
        for trust in (True, False):
            mask = shown & (aperiodic == no_period) & (trusted == trust)
            if not mask.any():
                continue
            kinds_seen["aperiodic"] |= no_period
            kinds_seen["untrusted"] |= not trust
            ax.plot(x[mask], y[mask], MARKERS[no_period], color=colour, mec=colour,
                    mfc=colour if trust else "none", ms=4 if trust else 4.5, mew=1.0, zorder=4,
                    gid=f"{'trusted' if trust else 'untrusted'} {'aperiodic' if no_period else 'periodic'}")
    _draw_failed_rug(ax, x, failed, row=k, colour=FAILED_COLOUR if n_curves == 1 else colour)
    return x[shown], y[shown]


class _Analytic:
    """What the analytic side of a response figure has drawn so far (curves share it)."""

    def __init__(self, barrier_shared):
        self.barrier_shared = barrier_shared
        self.barrier_drawn = False
        self.done = set()  # the parameter values whose branches are drawn
        self.resonance_handles = []
        self.barrier_levels = []  # (x, A/c = Delta/c or A = Delta) of each curve: said when out of view
        self.resonance_cut = False  # a resonance left out where Omega <= omega: said in the caption
        self.theory_cut = False  # the branches left out where Omega <= omega: said in the caption


def _draw_analytic(ax, view, x_axis, x, where, colour, amplitude, scale_axis, analytic):
    """The corrected theory's branches (stable solid, unstable dashed), the barrier's level and
    the resonance g_res (eq3.4) at one curve's parameters, once per set of parameter values (it
    depends on the parameters only, not on the continuation direction). Returns the branches drawn,
    [(x, values)]."""
    parameter_where = {axis: index for axis, index in where.items() if axis != "direction"}
    key = tuple(sorted(parameter_where.items()))
    if key in analytic.done:
        return []
    analytic.done.add(key)
    parameters = view.parameters(**{axis: float(view.axes[axis][i]) for axis, i in parameter_where.items()})
    fine = fine_grid(x, FINE_POINTS)
    branches = analytic_branches(parameters, x_axis, fine, gain=not amplitude)
    _draw_branches(ax, branches, colour)
    barrier = _fine_parameters(parameters, x_axis, fine)
    barrier_level = barrier["Delta"] if amplitude else barrier["Delta"] / barrier["c"]
    # Its own dash pattern (never the dotted line that joins a sweep's points) and, when every
    # curve shares it (Delta and c not swept), drawn once in its own colour.
    if not (analytic.barrier_shared and analytic.barrier_drawn):
        ax.plot(fine, barrier_level, color=BARRIER_COLOUR if analytic.barrier_shared else colour, lw=1.0,
                ls=BARRIER_DASHES, zorder=1, gid="barrier")
        analytic.barrier_drawn = True
    positions, cut = resonance_roots(parameters, x_axis, fine)
    analytic.resonance_cut |= cut
    from vrsweep.analysis import theory

    analytic.theory_cut |= not bool(np.all(theory.fast_force(barrier)))  # the branches stop there (analytic_branches)
    for position in positions:
        ax.axvline(position, color=colour, ls="-.", lw=0.9, zorder=1)
        if scale_axis is None:
            analytic.resonance_handles.append(Line2D([], [], color=colour, ls="-.", lw=0.9,
                                                     label=_resonance_label(x_axis, position)))
        elif not analytic.resonance_handles:
            analytic.resonance_handles.append(Line2D([], [], color="0.3", ls="-.", lw=0.9,
                                                     label="resonance (eq3.4), in the curve's colour"))
    analytic.barrier_levels.append((fine, np.broadcast_to(barrier_level, fine.shape)))
    return [(branch_x, branch_y) for branch_x, branch_y, _ in branches]


def _response_legend(curve_handles, kinds_seen, failure_note, n_curves, amplitude, analytic):
    """The legend's entries: the curves, the kinds of mark that appear, failed points, and the
    analytic side's (``analytic``: None for a written model, which has no theory)."""
    symbol = "|Q|" if amplitude else "R"
    error = "error" if amplitude else "$R_{err}$"  # R_err/R is also the relative error of |Q|
    handles = list(curve_handles)
    handles.append(Line2D([], [], ls="none", marker="o", color="k", ms=4,
                          label=f"filled: {error} ≤ {RELATIVE_ERROR_LIMIT:.0%} of {symbol} (trusted)"))
    if kinds_seen["untrusted"]:
        handles.append(Line2D([], [], ls="none", marker="o", mfc="none", mec="k", ms=4.5, mew=1.0,
                              label=f"hollow: {error} > {RELATIVE_ERROR_LIMIT:.0%} of {symbol} (window-dependent)"))
    if kinds_seen["aperiodic"]:
        handles.append(Line2D([], [], ls="none", marker="s", mfc="none", mec="k", ms=4.5, mew=1.0,
                              label="square: no period found (period 0)"))
    if failure_note:
        handles.append(Line2D([], [], ls="none", marker="x", mew=1.5, color=FAILED_COLOUR if n_curves == 1 else "k",
                              label="× in the strip under the panel: integration failed"))
    if analytic is None:
        return handles
    name = "A" if amplitude else "A/c"
    handles.append(Line2D([], [], color="k", lw=1.3, label=f"analytic {name}, stable (corrected eq2.27)"))
    handles.append(Line2D([], [], color="k", lw=1.3, ls="--", label=f"analytic {name}, unstable"))
    handles.append(Line2D([], [], color=BARRIER_COLOUR if analytic.barrier_shared else "k", lw=1.0,
                          ls=BARRIER_DASHES, label=f"{'A = Δ' if amplitude else 'A/c = Δ/c'}: above, the analytic "
                                                   "motion crosses the barrier"))
    return handles + analytic.resonance_handles


THEORY_REACH = 10.0  # on a log axis the theory's curves count for its limits within this factor of the data
LINEAR_THEORY_REACH = 3.0  # on a linear one, up to this many times the largest measured value


def _response_axes(ax, view, x_axis, x, drawn, theory, amplitude, log, barrier_levels=()):
    """Axis labels, the response axis' scale (chosen when ``log`` is None), its limits, the grid;
    returns the caption's notes: a scale chosen logarithmic, a theory curve that leaves the view.

    drawn: the measured values; theory: the analytic curves' values. The axis follows the data:
    log or linear by the measured values' span alone, its limits by them and the theory near
    them (within THEORY_REACH on a log axis, LINEAR_THEORY_REACH times the largest on a linear
    one), so that a theory far from them (A/c ~ 1e-6 at small Omega, where first-order averaging
    says nothing) neither makes the axis logarithmic nor stretches it; it is clipped, and said."""
    ax.set_xlabel(view.axis_label(x_axis))
    if view.config is not None and view.config.written:
        ax.set_ylabel(written_response_label(view.config.model, amplitude))
    elif amplitude:
        ax.set_ylabel("amplitude $|Q|$ of x at $\\omega$, analytic $A$")
    else:
        ax.set_ylabel("gain $R = |Q|/c$, analytic $A/c$")
    notes = []
    measured = np.concatenate([np.ravel(y) for _, y in drawn]) if drawn else np.array([])
    measured = measured[np.isfinite(measured) & (measured > 0)]
    theory = list(theory) + list(barrier_levels)  # the barrier's level A/c = Delta/c is the theory's too
    analytic = np.concatenate([np.ravel(y) for _, y in theory]) if theory else np.array([])
    analytic = analytic[np.isfinite(analytic)]
    # The scale follows the measured values alone; the theory, drawn for comparison, then counts
    # for the limits where it is near them (a decade either way on a log axis, 3 times the
    # largest on a linear one), and what lies beyond is clipped and said.
    decided = measured if measured.size >= 2 else np.concatenate([measured, analytic[analytic > 0]])
    span = _decades([decided])
    if log is None:
        log = span >= np.log10(LOG_SPAN)
        if log:
            notes.append(f"log axis: the measured values span {span:.1f} decades (a linear one on request)")
    if log:
        ax.set_yscale("log")
    if measured.size >= 2:
        reach_low, reach_high = (measured.min() / THEORY_REACH, measured.max() * THEORY_REACH) if log else \
            (-np.inf, measured.max() * LINEAR_THEORY_REACH)
        shown = np.concatenate([measured, analytic[(analytic >= reach_low) & (analytic <= reach_high)]])
    else:
        shown = decided
    positive = shown[shown > 0]
    if log and positive.size:  # out to whole decades: a labelled tick at either end
        low, high = 10.0 ** np.floor(np.log10(positive.min() / 1.2)), 10.0 ** np.ceil(np.log10(positive.max() * 1.2))
    else:
        low, high = 0.0, 1.05 * float(shown.max()) if shown.size else 1.0
    below, above = analytic[analytic < low], analytic[analytic > high]
    clipped = measured.size >= 2 and bool(below.size or above.size)
    if measured.size >= 2 and (clipped or not log):
        ax.set_ylim(low, high)
    elif not log:
        ax.set_ylim(bottom=0.0)
    reach = (f"more than {THEORY_REACH:g} times from the measured values" if log else
             f"above {LINEAR_THEORY_REACH:g} times the largest measured value")
    _span_grid(ax, x)
    ax.grid(alpha=0.3, which="both" if log else "major")
    return "; ".join(notes), reach


def _beyond_view(ax, drawn, theory, barrier_levels, amplitude, reach=None):
    """What the view of ``ax`` leaves out, as its limits are now: the analytic curves' values
    beyond it, the barrier's level when wholly out of it, measured points above or below it
    (only where --xlim/--ylim put it: the automatic limits hold every measured value).

    drawn, theory, barrier_levels: [(x, values)] of the measured curves, the theory's branches
    and the barrier's level. reach: why the automatic limits leave the theory out ('more than 10
    times from the measured values'); None where the limits were asked for. From the view as
    drawn, not from the limits first chosen: a note made before --ylim said the curves went on
    beyond a view that then held them, and said nothing of a view that cut them."""
    (x_low, x_high), (low, high) = sorted(ax.get_xlim()), sorted(ax.get_ylim())

    def in_view(pairs):
        """The finite values of ``pairs`` whose x is in view."""
        if not pairs:
            return np.array([])
        x = np.concatenate([np.ravel(x) for x, _ in pairs])
        y = np.concatenate([np.ravel(y) for _, y in pairs]).astype(np.float64)
        return y[(x >= x_low) & (x <= x_high) & np.isfinite(y)]

    def outside(pairs):
        """(values below the view, values above it) of those in view horizontally."""
        y = in_view(pairs)
        return y[y < low], y[y > high]

    notes = []
    below, above = outside(list(theory) + list(barrier_levels))
    if below.size or above.size:
        ends = ([f"down to {float(below.min()):.2g}"] if below.size else []) + \
               ([f"up to {float(above.max()):.2g}"] if above.size else [])
        notes.append(f"the analytic curves go on beyond the view ({' and '.join(ends)}), "
                     f"{reach or 'outside the limits asked for'}")
        levels = in_view(barrier_levels)
        if levels.size and (np.all(levels > high) or np.all(levels < low)):  # its legend entry would name no line
            notes.append(f"the barrier's level {'A = Δ' if amplitude else 'A/c = Δ/c'} "
                         f"({float(levels.min()):.3g}) lies {'above' if np.all(levels > high) else 'below'} the view")
    nonpositive = _nonpositive_note(ax, in_view(list(drawn)), "|Q|" if amplitude else "R")
    if nonpositive:
        notes.append(nonpositive)
    hidden_below, hidden_above = outside(list(drawn))
    hidden_below = hidden_below[hidden_below > 0] if ax.get_yscale() == "log" else hidden_below  # said above
    if reach is None and hidden_below.size + hidden_above.size:
        count = hidden_below.size + hidden_above.size
        notes.append(f"{count} measured point{'s' if count != 1 else ''} outside the limits asked for "
                     f"({hidden_below.size} below, {hidden_above.size} above)")
    return "; ".join(notes)


@figure_options
def variable_figure(ds, name, x_axis=None, log=None) -> Figure:
    """Any stored variable with one value per grid point (``mappable_variables``: impact_speed_min,
    x_max, period, R_err...) against one swept parameter, one curve per value of the other axes
    (issue 31); labelled with the variable's long name and units as the file stores them
    (store/variables.py). Points with no value (not computed, failed, or none to take: no impact
    in the window) are left out, and counted in the caption.

    log: True/False for a logarithmic/linear vertical axis; None: logarithmic when the positive
    values span LOG_SPAN or more and none is zero or negative.
    """
    view = _Sweep(ds)
    x_axis = _choose_x_axis(view, x_axis)
    mappable = mappable_variables(ds)
    if name not in mappable:
        raise UsageError.naming("{var} {value}: {path} has no such variable with one value per grid point; "
                                "it has {names}", value=name, path=view.path, names=", ".join(mappable))
    curves = view.curve_coordinates(x_axis)
    _refuse_too_many_curves(view, curves, MAX_CURVES, name, x_axis)
    x = np.asarray(view.axes[x_axis], dtype=np.float64)
    fig = _new_figure(8.0, 4.5)
    ax = fig.subplots()
    drawn, missing = [], 0
    for k, (where, label) in enumerate(curves):
        colour = RELIABLE_COLOURS[k % len(RELIABLE_COLOURS)]
        y = np.asarray(view.along(name, x_axis, **where), dtype=np.float64)
        done = np.asarray(view.along("done", x_axis, **where), dtype=bool) if "done" in view.variables else True
        y = np.where(done & np.isfinite(y), y, np.nan)
        missing += int(np.sum(np.isnan(y)))
        drawn.append(y[np.isfinite(y)])
        ax.plot(x, y, "-", marker=CURVE_MARKERS[k % len(CURVE_MARKERS)], ms=3.5, lw=0.9, color=colour,
                label=label or None)
    values = np.concatenate(drawn) if drawn else np.array([])
    if log is None:
        log = values.size > 1 and bool(np.all(values > 0)) and _decades([values]) >= np.log10(LOG_SPAN)
    if log:
        ax.set_yscale("log")
    ax.set_xlabel(view.axis_label(x_axis))
    ax.set_ylabel(_line_label(ds, name))
    _span_grid(ax, x)
    ax.grid(alpha=0.3, which="both" if log else "major")
    if len(curves) > 1:
        ax.legend(fontsize="x-small", loc="best")
    long_name = str(ds[name].attrs.get("long_name", "")).split(" (")[0]  # its first words: the title is one line
    nonpositive = _nonpositive_note(ax, values, name)
    notes = "; ".join(note for note in (_progress_note(view), f"{missing} points with no value left out"
                                        if missing else "", nonpositive) if note)
    _title(fig, f"{name} against {parameter_symbol(x_axis)}" + (f" ({long_name})" if long_name else ""),
           _caption(view.path, view.config, view.model, view.selected, notes, _width(fig)))
    return fig


def _map_words(name):
    """MAP_LABELS' words for ``name``, in a written model's own terms where the paper's differ."""
    model = written_model()
    if model is not None and name == "R":
        return written_gain(model.response_scale)
    if name == "impacts_per_period":
        return f"mean impacts per {period_words()}"
    if name == "period":  # its long name is too long for a colour bar, and 'period' alone names no unit
        return f"period, in units of the {period_words()}"
    return MAP_LABELS.get(name)


def _line_label(ds, name):
    """A variable's axis label on a curve figure: the same words as on a map's colour bar."""
    return variable_label(ds, name)


def _nonpositive_note(ax, values, symbol):
    """The caption's words for measured ``values`` <= 0 on a logarithmic vertical axis, which
    matplotlib leaves out without a mark (a written model's R = 0 where its response frequency is
    no harmonic of the orbit; no impacts): '' where there are none or the axis is linear."""
    values = np.asarray(values, dtype=np.float64)
    count = int(np.sum(np.isfinite(values) & (values <= 0.0)))
    if ax.get_yscale() != "log" or not count:
        return ""
    zero = bool(np.all(values[np.isfinite(values) & (values <= 0.0)] == 0.0))
    what = f"{symbol} = 0" if zero else f"{symbol} ≤ 0"
    return (f"{count} measured point{'s' if count != 1 else ''} with {what} not drawn: "
            "below the logarithmic axis (a linear one on request)")


def _decades(arrays):
    """log10(max/min) over the positive finite values of ``arrays``; 0 with fewer than two."""
    values = np.concatenate([np.ravel(a) for a in arrays]) if arrays else np.array([])
    values = values[np.isfinite(values) & (values > 0)]
    if values.size < 2:
        return 0.0
    return float(np.log10(values.max() / values.min()))


MAP_LABELS = {"R": "gain $R = |Q|/c$", "Q_amplitude": "amplitude $|Q|$",
              "impacts_per_period": "mean impacts per slow period $2\\pi/\\omega$",
              "lyapunov": f"{LYAPUNOV_SYMBOL}, per unit time"}
CAP_PERCENTILE = 99      # a linear map's default top: one wild point must not wash out the map ...
CAP_MARGIN = 0.1         # ... if the largest value is more than 10 % of the scale above it (else no cap)
NO_VALUE_COLOUR = NO_VALUE_GREY  # an integer map's 'no period' / 'failed' value: dark grey, set apart
NOT_COMPUTED_COLOUR = NOT_COMPUTED_GREY  # the axes' background, seen where a cell has no value
# Integer variables whose special values mean 'none' rather than a number (store/variables.py,
# analysis/attractors.py): drawn grey and named on the colour bar.
SPECIAL_VALUES = {"period": {0: "no period"}, "impacts_per_cycle": {-1: "no period"},
                  "attractor": {-1: "failed"}}
# The kinds of motion (periodic, quasi-periodic, chaotic, not settled): Paul Tol's high-contrast
# scheme (blue, yellow, red) and black, apart in lightness (CIE L* 29, 72, 50, 0; the greys of
# 'none' 38 and 87) and for colour-blind readers. tab:green, tab:blue, tab:red were red against
# green, and blue and red of one lightness (L* 48 and 47): one grey on a greyscale page.
MOTION_KIND_COLOURS = ("#004488", "#DDAA33", "#BB5566", "#000000")
# The colours --kind motion uses, so that --var motion reads the same; 'none' (the point failed) is
# a value meaning none, dark grey as on every integer map.
MOTION_FLAG_COLOURS = {"none": NO_VALUE_COLOUR, **dict(zip(("periodic", "quasi_periodic", "chaotic", "not_settled"),
                                                             MOTION_KIND_COLOURS))}
FLAG_COLOURS = {**STATUS_COLOURS, **MOTION_FLAG_COLOURS}
MAX_TICK_LABELS = 20  # an integer colour bar with more values labels every k-th only
NARROW_FIGURE = 5.0   # inches: a figure narrower than this (a journal column) gets fewer colour-bar ticks


def mappable_variables(ds) -> list:
    """The variables of ``ds`` that a map can show: one value per grid point (dimensions exactly
    the sweep axes left after ``select``), numbers, in the file's order."""
    axes = set(_grid_axes(ds))
    return [str(name) for name, variable in ds.data_vars.items()
            if name not in ("done", "owned") and set(variable.dims) == axes and variable.dtype.kind in "iuf"]


def _variable_label(ds, name):
    """A map's colour-bar label (``variable_label``)."""
    return variable_label(ds, name)


# What a variable is, in words short enough for a colour bar, where its long name's first words are
# too long or say too little (every stored per-point variable has words: store/variables.py; a
# colour bar read "R_err", "motion", "stuck_fraction" alone where the long name did not fit).
VARIABLE_WORDS = {
    "Qs": "sine component of x at $\\omega$ (eq3.1)",
    "Qc": "cosine component of x at $\\omega$ (eq3.2)",
    "R_err": "95 % half-width of R",
    "lyapunov_err": f"95 % half-width of {LYAPUNOV_SYMBOL}, per unit time",
    "status": "how the integration ended",
    "motion": "kind of motion",
    "impacts_per_cycle": "impacts in one cycle of the period",
    "impact_speed_min": "slowest impact speed |v-|",
    "impact_speed_max": "fastest impact speed |v-|",
    "impact_speed_mean": "mean impact speed |v-|",
    "impact_phase": "mean impact phase $\\omega t$ mod $2\\pi$",
    "impact_phase_spread": "circular spread of the impact phase",
    "stuck_fraction": "fraction of the time stuck on a barrier",
    "A_theory_max_stable": "largest stable analytic amplitude $A$",
}
# A written model's: its response frequency is no omega (Qs and Qc name it: ``variable_label``).
# Its time stuck counts sliding on v = c too (friction on a belt: stick-slip), where "on a barrier"
# named something the model may not even have.
WRITTEN_VARIABLE_WORDS = {"impact_phase": "mean impact phase at the response frequency",
                          "stuck_fraction": "fraction of the time stuck (on a barrier, or sliding at v = c)"}


def variable_label(ds, name):
    """A variable's label, on a map's colour bar and a curve figure's axis alike: 'name: words'
    (the name is what --var takes) and its units from the file (dimensionless ones not shown).
    The words: MAP_LABELS' for the usual maps, else VARIABLE_WORDS', else the file's long name up
    to its first parenthesis, colon, semicolon or comma; the bare name only for a variable the file
    says nothing about."""
    attrs = ds[name].attrs
    words = _map_words(name)
    if words is None:
        model = written_model()
        table = dict(VARIABLE_WORDS, **WRITTEN_VARIABLE_WORDS) if model is not None else VARIABLE_WORDS
        short = table.get(name)
        if model is not None and name in ("Qs", "Qc"):  # at its response frequency, by its symbol
            short = (f"{'sine' if name == 'Qs' else 'cosine'} component of x at "
                     f"{written_expression(model.response_frequency)}")
        if short is None:
            short = re.split(r" \(|: |; |, ", str(attrs.get("long_name", "")).strip(), maxsplit=1)[0].strip()
        words = f"{name}: {short}" if short else name
    return f"{words}{units_suffix(attrs.get('units'))}"


def _flag_names(attrs):
    """{value: meaning} of a CF flag variable (status), {} for any other."""
    values, meanings = attrs.get("flag_values"), attrs.get("flag_meanings")
    if values is None or meanings is None:
        return {}
    meanings = meanings.decode() if isinstance(meanings, bytes) else str(meanings)
    return {int(v): m for v, m in zip(np.ravel(values), meanings.split())}


def discrete_scale(name, values, attrs=None):
    """The colour scale of an integer variable: one colour per value present, the values that mean
    'none' (period 0, impacts_per_cycle -1: no period; attractor -1: failed) in grey and named.
    More ordinary values than the palette has categories apart (``palettes.MAX_CATEGORIES``, 12):
    binned into as many runs of consecutive values, each of about equal cells, a colour and a
    label ('13–16') each (``_bins``). Past 12 they took viridis, a colour each: a continuous scale
    for categories, on which periods 14 and 15 were one colour to the eye.

    values: the variable's values (any shape; NaN where not computed). Returns (cmap, norm, ticks,
    tick_labels, note): a ListedColormap of exactly len(ticks) colours, a BoundaryNorm putting each
    value present (or bin) in its own colour, where on a uniformly spaced colour bar to name each,
    and the caption's words for a binned scale ('' where every value has its colour).
    """
    finite = np.asarray(values, dtype=np.float64)
    present = np.unique(finite[np.isfinite(finite)]).astype(np.int64)
    if present.size == 0:
        present = np.array([0])
    flags = _flag_names(attrs or {})
    special = SPECIAL_VALUES.get(name, {})
    # A flag with no colour of its own takes one of the palette's, as a number would: one shared
    # grey for all of them drew a map of motion as a single grey block.
    ordinary = [v for v in present if v not in special and (v not in flags or flags[v] not in FLAG_COLOURS)]
    finite_values = finite[np.isfinite(finite)].astype(np.int64)
    cells = {value: int(np.count_nonzero(finite_values == value)) for value in ordinary}
    # Blocks of the colour bar, in order of value: (first value, last value), one value each but
    # for the bins of many ordinary values. The values meaning 'none' lie below every ordinary one
    # (SPECIAL_VALUES), and the flag variables have fewer values than bins: no bin spans them.
    bins = _bins(ordinary, cells, MAX_CATEGORIES) if len(ordinary) > MAX_CATEGORIES else [(v, v) for v in ordinary]
    bin_of = {value: (low, high) for low, high in bins for value in ordinary if low <= value <= high}
    # Apart in lightness from each other and from the greys of 'no period' and 'not computed' (tab10's
    # were pairs of one grey on a greyscale page), the six that are: to the blocks of most cells.
    bin_cells = {block: sum(cells[v] for v in ordinary if bin_of[v] == block) for block in bins}
    by_cells = sorted(bins, key=lambda block: (-bin_cells[block], block))
    block_colours = dict(zip(by_cells, categorical(len(bins))))
    blocks, colours, labels = [], [], []
    for value in present:
        if value in bin_of and bin_of[value] in blocks:
            continue  # a bin's later values: drawn in its block
        if value in flags and value not in bin_of:
            blocks.append((value, value))
            colours.append(FLAG_COLOURS[flags[value]])
            # --var motion names its values as --kind motion does ('failed (none)', 'quasi-periodic').
            labels.append(MOTION_NAMES.get(int(value), flags[value]) if name == "motion" else flags[value])
        elif value in special:
            blocks.append((value, value))
            colours.append(NO_VALUE_COLOUR)
            labels.append(f"{value}: {special[value]}")
        else:
            low, high = bin_of[value]
            blocks.append((low, high))
            colours.append(block_colours[(low, high)])
            if value in flags:
                labels.append(MOTION_NAMES.get(int(value), flags[value]) if name == "motion" else flags[value])
            else:
                labels.append(str(low) if low == high else f"{low}\u2013{high}")
    spans = blocks
    cmap = ListedColormap(colours)
    edges = np.array([spans[0][0] - 0.5] + [(spans[k][1] + spans[k + 1][0]) / 2.0 for k in range(len(spans) - 1)]
                     + [spans[-1][1] + 0.5], dtype=np.float64)
    norm = BoundaryNorm(edges, cmap.N)
    if len(spans) > MAX_TICK_LABELS:  # every k-th block named, the special ones always
        step = int(np.ceil(len(spans) / MAX_TICK_LABELS))
        labels = [text if (k % step == 0 or spans[k][0] in special or spans[k][0] in flags) else ""
                  for k, text in enumerate(labels)]
    note = ""
    if len(bins) < len(ordinary):
        note = (f"{len(ordinary)} values of {name} binned into {len(bins)} colours, runs of consecutive values "
                "of about equal cells (labels on the colour bar)")
    # Ticks in the middle of each block (equal blocks: the colour bar's spacing="uniform").
    return cmap, norm, list((edges[:-1] + edges[1:]) / 2.0), labels, note


def _bins(ordinary, cells, count):
    """At most ``count`` runs of the sorted values ``ordinary`` as (first, last), each of about equal
    cells (``cells``: {value: cells}); each next run takes values while it stays within an equal
    share of the cells left, so that a value of many cells (period 1 over half the map) is a run
    of its own and the rare ones share runs."""
    values = list(ordinary)
    weights = [cells[value] for value in values]
    runs, start = [], 0
    while start < len(values):
        left = count - len(runs)
        if len(values) - start <= left:
            runs += [(value, value) for value in values[start:]]
            break
        if left == 1:
            runs.append((values[start], values[-1]))
            break
        target = sum(weights[start:]) / left
        end, total = start, weights[start]
        while len(values) - (end + 2) >= left - 1 and (total + weights[end + 1] <= target or total == 0):
            end += 1
            total += weights[end]
        runs.append((values[start], values[end]))
        start = end + 1
    return runs


CYCLIC_VARIABLES = {"impact_phase": (0.0, 2.0 * np.pi)}  # a circle's values: (start, end) of one turn


def continuous_scale(name, values, log=False, vmin=None, vmax=None):
    """The colour scale of a float variable: (norm, cmap, extend, (short_note, long_note)).

    Linear: from 0 (or the smallest value, if negative) to the CAP_PERCENTILE-th percentile, so one
    wild point does not wash out the map (unless the largest value is within CAP_MARGIN of the
    scale above it); a cap is stated, on the colour bar ('capped at 9.74 = 99th pct.; max 16.5')
    and in the caption (``long_note``), and shown by the colour bar's arrow (``extend``).
    lyapunov: a diverging scale symmetric about zero, -m..m with m the largest |lambda_1|.
    log: from the smallest positive value. vmin/vmax replace either end (for lyapunov one of
    them sets both, symmetric).
    """
    from matplotlib.colors import LogNorm, Normalize

    values = np.asarray(values, dtype=np.float64)
    finite = values[np.isfinite(values)]
    cmap = "viridis"
    note_top = ""
    if name in CYCLIC_VARIABLES and not log:
        # A phase: 0.1 and 6.2 rad are neighbours, which viridis drew darkest and lightest, and a cap
        # at the 99th percentile cut the circle. A cyclic scale over the whole circle, the same
        # colour at both ends.
        cmap = "twilight"
        low, high = CYCLIC_VARIABLES[name]
        low, high = (low if vmin is None else vmin), (high if vmax is None else vmax)
        if high <= low:
            raise UsageError.naming("{vmin} {low} and {vmax} {high}: the bottom of the colour scale must be below "
                                    "its top", low=_number(low), high=_number(high))
    elif name == "lyapunov" and not log:
        cmap = "RdBu_r"  # the sign is the message: chaos above zero (red), periodic below (blue)
        if vmin is None and vmax is None:
            span = float(np.abs(finite).max()) if finite.size else 1.0
            low, high = -(span or 1.0), (span or 1.0)
        elif vmin is None or vmax is None:
            span = abs(vmax if vmax is not None else vmin)
            low, high = -span, span
        else:
            low, high = vmin, vmax
    else:
        low = min(0.0, float(finite.min())) if finite.size else 0.0
        high = float(np.percentile(finite, CAP_PERCENTILE)) if finite.size else 1.0
        if finite.size and float(finite.max()) > high + CAP_MARGIN * (high - low):
            note_top = f"the {CAP_PERCENTILE}th percentile"
        elif finite.size:
            high = float(finite.max())  # the top is no outlier: no cap needed
        if log:
            positive = finite[finite > 0]
            low = float(positive.min()) if positive.size else 1e-3
            high = max(high, low * 10)
        if vmin is not None:
            low = vmin
        if vmax is not None:
            high, note_top = vmax, ("set" if finite.size and vmax < float(finite.max()) else "")
        if high <= low:
            if vmin is not None and vmax is not None:
                raise UsageError.naming("{vmin} {low} and {vmax} {high}: the bottom of the colour scale must be "
                                        "below its top", low=_number(vmin), high=_number(vmax))
            high = low + 1.0 if vmax is None else high
            low = low if vmax is None else high - 1.0
        if log and low <= 0:
            raise UsageError.naming("{vmin} {value}: a logarithmic colour scale starts above zero", value=_number(low))
    norm = (LogNorm if log and name != "lyapunov" else Normalize)(vmin=low, vmax=high)
    above = int(np.sum(finite > high))
    below = int(np.sum(finite < low))
    extend = {(False, False): "neither", (True, False): "max", (False, True): "min", (True, True): "both"}[
        (above > 0, below > 0)]
    long_notes, short_notes = [], []
    if above:
        percentile = note_top == f"the {CAP_PERCENTILE}th percentile"
        cells = "1 cell" if above == 1 else f"{above} cells"
        long_notes.append(f"capped at {_number(high)}{', ' + note_top if percentile else ''}: {cells} above, "
                          f"up to {_number(float(finite.max()))}, in the top colour ▲")
        short_notes.append(f"capped at {high:.3g}{f' = {CAP_PERCENTILE}th pct.' if percentile else ''}; "
                           f"max {float(finite.max()):.3g}")
    if below:
        cells = "1 cell" if below == 1 else f"{below} cells"
        long_notes.append(f"floored at {_number(low)}: {cells} below, down to {_number(float(finite.min()))} ▼")
        short_notes.append(f"floored at {low:.3g}; min {float(finite.min()):.3g}")
    return norm, cmap, extend, ("\n".join(short_notes), "; ".join(long_notes))


def _hatch_cells(ax, xs, ys, mask, hatch="////"):
    """Hatch the cells of ``mask`` (indexed [x, y]) of a nearest-shaded map; returns the collection."""
    from matplotlib.collections import PatchCollection
    from matplotlib.patches import Rectangle

    x_edges = cell_edges(xs, ax.get_xscale() == "log")
    y_edges = cell_edges(ys, ax.get_yscale() == "log")
    cells = [Rectangle((x_edges[i], y_edges[j]), x_edges[i + 1] - x_edges[i], y_edges[j + 1] - y_edges[j])
             for i, j in zip(*np.nonzero(mask))]
    collection = PatchCollection(cells, facecolor="none", edgecolor="0.15", linewidth=0.0, hatch=hatch,
                                 gid="within_error_of_zero")
    ax.add_collection(collection, autolim=False)
    return collection


# A mark on a map's cell (a white dot, an x) is at least its small size and grows with the cells up
# to this share of a cell's shorter side, and no more than MAP_MARK_LARGEST points: on an 8 x 6 map
# a 2.5-point dot in a cell of 70 points was all but invisible.
MAP_MARK_SHARE = 0.15
MAP_MARK_LARGEST = 9.0


def _cell_marker_size(ax, shape, smallest):
    """Marker size in points for a mark on each cell of a map of ``shape`` (nx, ny) cells."""
    box = ax.get_position()  # in figure fractions: the axes as laid out so far
    width, height = ax.figure.get_size_inches()
    cell = 72.0 * min(box.width * width / max(shape[0], 1), box.height * height / max(shape[1], 1))
    return float(np.clip(MAP_MARK_SHARE * cell, smallest, MAP_MARK_LARGEST))


@figure_options
def map_figure(ds, name="R", x_axis=None, log=False, vmin=None, vmax=None) -> Figure:
    """A heat map of ``name`` over two axes with the resonance curve; untrusted R dotted, failed x.

    name: R, Q_amplitude, impacts_per_period or any other variable with one value per grid point
    (``mappable_variables``); points not computed are grey. An integer variable (period,
    impacts_per_cycle, attractor, status...) gets one colour per value present, 'no period' set
    apart in dark grey and named (``discrete_scale``); lyapunov a diverging scale symmetric about
    zero, cells within their 95 % band of zero hatched; any other a continuous scale whose cap is
    stated on the colour bar (``continuous_scale``). log: a logarithmic colour scale (from the
    smallest positive value up). vmin, vmax: the ends of a continuous scale. The legend goes below
    the maps, where it hides no cell. Also title, size, style (``figure_options``).
    """
    view = _Sweep(ds)
    x_axis, y_axis = _map_axes(view, x_axis)
    if name in MAP_LABELS and name != "lyapunov":
        view.require(name)  # the usual maps: a file without them is from an older vrsweep
    mappable = mappable_variables(ds)
    if name not in mappable:
        raise UsageError.naming("{var} {value}: {path} has no such variable with one value per grid point; "
                                "it has {names}", value=name, path=view.path, names=", ".join(mappable))
    panels = _map_panels(view)
    fig = _new_figure(7.5 * len(panels), 5.6)
    axes = np.atleast_1d(fig.subplots(1, len(panels), squeeze=False)[0])
    label = _variable_label(ds, name)
    values = view.variables[name]
    integer = values.dtype.kind != "f"
    if integer:  # a count or a label: points not computed hold a fill value
        if log:
            raise UsageError.naming("{log}: {var} {value} holds integers, drawn one colour per value", value=name)
        if vmin is not None or vmax is not None:
            raise UsageError.naming("{vmin} and {vmax} set a continuous colour scale; {var} {value} holds "
                                    "integers, drawn one colour per value", value=name)
        values = np.where(np.asarray(ds["done"].values, dtype=bool), values, np.nan)
        cmap, norm, ticks, tick_labels, bin_note = discrete_scale(name, values, ds[name].attrs)
        extend, cap_note, cap_caption = "neither", "", ""
    else:
        shown = np.where(np.isneginf(values), np.nan, values)  # -inf (stuck) has its own mark
        norm, cmap, extend, (cap_note, cap_caption) = continuous_scale(name, shown, log=log, vmin=vmin, vmax=vmax)
        bin_note = ""
    handles = {}
    X, Y = np.meshgrid(view.axes[x_axis], view.axes[y_axis], indexing="ij")
    for ax, (where, panel_title) in zip(axes, panels):
        z = _as_x_y(view, name, x_axis, y_axis, where)
        if integer:
            z = np.where(_as_x_y(view, "done", x_axis, y_axis, where) > 0, z, np.nan)
        ax.set_facecolor(NOT_COMPUTED_COLOUR)  # NaN cells (not computed, or failed) show the background
        minus_infinity = np.isneginf(z)  # lyapunov where the mass stuck: no colour can say -inf
        z = np.where(minus_infinity, np.nan, z)
        if log and not integer:
            # A logarithmic norm masks values <= 0 as it masks NaN: a count of no impacts was drawn
            # as the background, 'no value', where the colour bar's arrow and the caption put it in
            # the bottom colour. Below the scale's bottom, they are drawn there (under).
            with np.errstate(invalid="ignore"):
                z = np.where(np.isfinite(z) & (z <= 0.0), norm.vmin / 2.0, z)
        mesh = map_mesh(ax, view.axes[x_axis], view.axes[y_axis], z.T, cmap=cmap, norm=norm)
        if name == "lyapunov" and "lyapunov_err" in view.variables:
            error = _as_x_y(view, "lyapunov_err", x_axis, y_axis, where)
            with np.errstate(invalid="ignore"):
                near_zero = np.isfinite(z) & (np.abs(z) <= error)
            if near_zero.any():
                _hatch_cells(ax, view.axes[x_axis], view.axes[y_axis], near_zero)
                handles["near_zero"] = Patch(facecolor="white", edgecolor="0.15", hatch="////",
                                             label=f"hatched: |{LYAPUNOV_SYMBOL}| within its 95 % band "
                                                   "(lyapunov_err) of zero")
        if minus_infinity.any():
            ax.plot(X[minus_infinity], Y[minus_infinity], "v", color="k", mec="w", mew=0.5, ms=4.5, ls="none",
                    gid="minus_infinity")
            handles["minus_infinity"] = Line2D([], [], ls="none", marker="v", color="k", mec="w", mew=0.5,
                                               label=f"{LYAPUNOV_SYMBOL} = −∞: {stuck_words()}")
        bar_label = label + (" (log scale)" if log else "") + (f"\n{cap_note}" if cap_note else "")
        # spacing="uniform" (the default, said here because discrete_scale's ticks rely on it): an
        # integer map's values get equal blocks on the colour bar, however far apart they are.
        bar = fig.colorbar(mesh, ax=ax, label=bar_label, extend=extend, spacing="uniform")
        if integer:
            bar.set_ticks(ticks, labels=tick_labels)
            bar.minorticks_off()
        elif cmap == "RdBu_r":  # zero in the middle, ticks symmetric about it
            # Nine ticks, five on a narrow figure (one journal column): their labels take its width.
            # Round values, not eighths of the largest |lambda_1|: those, printed to two digits,
            # put '1.5' at 1.46 (a label is read as the value where it sits).
            from matplotlib.ticker import MaxNLocator

            count = 9 if fig.get_figwidth() >= NARROW_FIGURE else 5
            if norm.vmin == -norm.vmax:
                ticks = MaxNLocator(nbins=count - 1, symmetric=True).tick_values(norm.vmin, norm.vmax)
                bar.set_ticks(ticks[(ticks >= norm.vmin) & (ticks <= norm.vmax)])
        resonance = _draw_resonance_curve(ax, view, x_axis, y_axis)
        if resonance is not None:
            handles["resonance"] = resonance
        if name in ("R", "Q_amplitude") and "status" in view.variables:
            untrusted = np.zeros(z.shape, dtype=bool)
            failed = np.zeros(z.shape, dtype=bool)
            for j in range(len(view.axes[y_axis])):
                trusted, _, f = _point_classes(view, x_axis, {**where, y_axis: j})
                computed = view.along("status", x_axis, **where, **{y_axis: j}) == Status.OK
                untrusted[:, j], failed[:, j] = computed & ~trusted, f
            if untrusted.any():
                # Edged black as in the legend: a white dot alone vanished on yellow cells.
                ax.plot(X[untrusted], Y[untrusted], ".", color="white", mec="k", mew=0.3, gid="untrusted",
                        ms=_cell_marker_size(ax, z.shape, 2.5))
                handles["untrusted"] = Line2D(
                    [], [], ls="none", marker=".", color="white", mec="k", mew=0.3,
                    label=f"white dot: $R_{{err}}$ > {RELATIVE_ERROR_LIMIT:.0%} of R (R depends on the window)")
            if failed.any():
                ax.plot(X[failed], Y[failed], "x", color=FAILED_COLOUR, ms=_cell_marker_size(ax, z.shape, 4.0), gid="failed",
                        path_effects=cased(FAILED_COLOUR, 1.0))
                handles["failed"] = Line2D([], [], ls="none", marker="x", color=FAILED_COLOUR,
                                           path_effects=cased(FAILED_COLOUR, 1.0),
                                           label="integration failed (status ≠ ok)")
        ax.set_xlabel(view.axis_label(x_axis))
        ax.set_ylabel(view.axis_label(y_axis))
        cell_ticks(ax, view.axes[x_axis], view.axes[y_axis])
        if panel_title:
            ax.set_title(panel_title, fontsize="medium")
    if handles:
        legend = fig.legend(handles=list(handles.values()), fontsize="x-small", loc="outside lower center",
                            ncol=_legend_columns(fig, min(len(handles), 3)), facecolor="0.3", framealpha=0.9)
        for text in legend.get_texts():
            text.set_color("white")
    notes = "; ".join(note for note in (_progress_note(view), _failure_note(view, "on its cell")
                                        if name in ("R", "Q_amplitude") and "status" in view.variables else "",
                                        f"colour scale {cap_caption}" if cap_caption else "", bin_note,
                                        _map_repeats_note(view, name, x_axis, y_axis))
                      if note)
    grey = "not computed or failed" if ds[name].dtype.kind == "f" else "not computed"
    what = "period" if name == "period" else label.splitlines()[0]  # its unit is the colour bar's, not the title's
    _title(fig, f"{what} over {_symbol(x_axis)} and {_symbol(y_axis)} (light grey: no value: {grey})",
           _caption(view.path, view.config, view.model, view.selected, notes, _width(fig)))
    return fig


# Counted in periods T of the stroboscopic samples: where the forcing repeats only after q > 1 of
# them, a motion locked to it has period q (or a multiple), whatever it does within a cycle.
STROBE_PERIOD_VARIABLES = ("period", "impacts_per_cycle")


def _map_repeats_note(view, name, x_axis, y_axis):
    """The caption's words for a map of a period counted in periods T (``STROBE_PERIOD_VARIABLES``)
    where the forcing repeats only after q > 1 of them: a row of Omega/omega = 1/2 showed period 2
    throughout, read as a period doubling, with no word that it is the forcing's own period there
    (the bifurcation diagram says so of its samples: ``_unlocked_note``)."""
    if name not in STROBE_PERIOD_VARIABLES or view.config is None:
        return ""
    from vrsweep.analysis.diagnostics import sampling_of_forcing

    xs, ys = (np.asarray(view.axes[axis], dtype=np.float64) for axis in (x_axis, y_axis))

    def at(axis, value):
        return {axis: float(value)} if axis in view.config.parameters else {}

    sets = [view.parameters(**at(x_axis, x), **at(y_axis, y)) for x in xs for y in ys]
    q = sampling_of_forcing(view.config.model, sets, LONGEST_REPEAT)[0].reshape(len(xs), len(ys))
    unlocked = q != 1
    if not unlocked.any():
        return ""
    finite = sorted({int(n) for n in q[unlocked] if n > 1})
    what = [f"q = {finite[0]}{'' if len(finite) == 1 else f' to {finite[-1]}'}"] if finite else []
    if np.any(q == 0):
        what.append(f"not within {LONGEST_REPEAT}")
    # Where: the rows (or columns) that hold them, when they are few, as on a map over Omega (whose
    # column g = 0, no fast force, repeats every T).
    where = ""
    for axis, values, lines in ((y_axis, ys, q.T), (x_axis, xs, q)):
        held = [(value, sorted({int(n) for n in line[line != 1]})) for value, line in zip(values, lines)
                if np.any(line != 1)]
        if len(held) <= 4:
            where = " (" + ", ".join(f"{_symbol(axis)} = {_number(float(value))}: q = "
                                     + " or ".join(str(n) if n else "none" for n in found)
                                     for value, found in held) + ")"
            break
    return (f"in {int(unlocked.sum())} of {q.size} cells the forcing repeats only after {' or '.join(what)} "
            f"{period_words(symbol=False)}s{where}: there a motion locked to it has period q, which is no "
            "period doubling")


def _as_x_y(view, name, x_axis, y_axis, where):
    """``name`` as a 2-D array indexed [x, y] at ``where`` (other dims already fixed)."""
    return view.ds[name].isel(where).transpose(x_axis, y_axis).values.astype(np.float64)


@figure_options
def impacts_figure(ds, x_axis=None, log=False, vmin=None, vmax=None) -> Figure:
    """Mean impacts per slow period over the measurement window: a curve (1 axis) or a map (2).

    log: a logarithmic count axis (symmetric-log, so that zero counts stay on it) or colour scale.
    """
    view = _Sweep(ds)
    view.require("impacts_per_period")
    if len(view.parameter_axes) == 2 and x_axis is None and _sweep_default(view.axes) == "map":
        return map_figure(ds, "impacts_per_period", log=log, vmin=vmin, vmax=vmax)
    if vmin is not None or vmax is not None:
        raise UsageError.naming("{vmin} and {vmax} set the colour scale of a map; this is a curve")
    x_axis = _choose_x_axis(view, x_axis)
    curves = view.curve_coordinates(x_axis)
    _refuse_too_many_curves(view, curves, MAX_CURVES, "impacts_per_period", x_axis)
    x = np.asarray(view.axes[x_axis], dtype=np.float64)
    fig = _new_figure(8.0, 4.5)
    ax = fig.subplots()
    top = 0.0
    for k, (where, label) in enumerate(curves):
        colour = RELIABLE_COLOURS[k % len(RELIABLE_COLOURS)]
        y = view.along("impacts_per_period", x_axis, **where)
        ax.plot(x, y, "-", marker=CURVE_MARKERS[k % len(CURVE_MARKERS)], ms=3.5, lw=0.9, color=colour,
                label=label or "measurement window")
        top = max(top, float(np.nanmax(y, initial=0.0)))
        if "status" in view.variables:
            failed = _point_classes(view, x_axis, where)[2]
            _draw_failed_rug(ax, x, failed, row=k, colour=FAILED_COLOUR if len(curves) == 1 else colour)
    failure_note = _failure_note(view, "in the strip under the panel") if "status" in view.variables else ""
    if failure_note:
        ax.plot([], [], "x", color=FAILED_COLOUR if len(curves) == 1 else "k", mew=1.5, ls="none",
                label="integration failed (no count)")
    ax.set_xlabel(view.axis_label(x_axis))
    ax.set_ylabel(f"mean impacts per {period_words()}")
    if log:
        ax.set_yscale("symlog", linthresh=1.0)  # zero counts stay on the axis
        ax.set_ylim(-0.1, max(2.0, 1.5 * top))
    else:
        # A little room below zero: points with no impacts are drawn whole, not cut by the edge.
        ax.set_ylim(-0.04 * max(top, 1.0), 1.06 * max(top, 1.0))
    _span_grid(ax, x)
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small", loc="best")
    notes = "; ".join(note for note in (_progress_note(view), failure_note) if note)
    _title(fig, f"Impacts per {period_words(symbol=False)} against {parameter_symbol(x_axis)} "
                "(mean over the measurement window)",
           _caption(view.path, view.config, view.model, view.selected, notes, _width(fig)))
    return fig


@figure_options
def status_figure(ds, x_axis=None) -> Figure:
    """How each point ended (ok, max_steps, diverged, ...): a strip (1 axis) or a map (2 axes)."""
    view = _Sweep(ds)
    view.require("status")
    # The colours --var status draws in (one list: the strip and the map of --var status agree).
    colours = [STATUS_COLOURS[s.name.lower()] for s in Status]
    return _flag_figure(view, "status", [int(s) for s in Status], [s.name.lower() for s in Status], colours,
                        x_axis, "status of the point", "How each point's integration ended")


# {code: colour} of --kind motion: a point not computed (the stored fill, -1) light grey as on every
# figure, one that failed (Motion.NONE) dark grey as a value meaning none on every integer map (both
# were light grey: a failed point read as one not yet run), then periodic, quasi-periodic, chaotic,
# not settled (MOTION_KIND_COLOURS), as --var motion draws them.
NOT_COMPUTED_CODE = -1
MOTION_COLOURS = {NOT_COMPUTED_CODE: NOT_COMPUTED_GREY, int(Motion.NONE): NO_VALUE_GREY,
                  **dict(zip((int(kind) for kind in Motion if kind != Motion.NONE), MOTION_KIND_COLOURS))}
MOTION_NAMES = {NOT_COMPUTED_CODE: "not computed", int(Motion.NONE): "failed (none)",
                **{int(kind): kind.name.lower().replace("_", "-") for kind in Motion if kind != Motion.NONE}}


@figure_options
def motion_figure(ds, x_axis=None) -> Figure:
    """The kind of motion at each point (periodic, quasi-periodic, chaotic, not settled; none where
    it failed: analysis/motion.py): a strip (1 axis) or a map (2 axes)."""
    view = _Sweep(ds)
    if "motion" not in view.variables:
        raise ResultFileError(f"{view.path} has no motion (written by vrsweep before 0.6.0): run the sweep "
                              "again to classify its points")
    codes = list(MOTION_COLOURS)
    return _flag_figure(view, "motion", codes, [MOTION_NAMES[code] for code in codes],
                        [MOTION_COLOURS[code] for code in codes], x_axis, "kind of motion",
                        "The kind of motion at each point")


def _flag_figure(view, name, codes, names, colours, x_axis, y_label, title):
    """A flag variable (one code per point, one colour per code): a strip (1 axis) or a map (2).

    codes: every code drawn, NOT_COMPUTED_CODE among them; a point not done (or holding a value
    that is no code: a fill) is drawn and counted as not computed, never taken for another code
    (motion's fill -1 was drawn as 'none', and a strip of a partial file ended in a ValueError)."""
    codes = list(codes)
    flags = np.asarray(view.variables[name])
    if "done" in view.variables:
        flags = np.where(np.asarray(view.variables["done"], dtype=bool), flags, NOT_COMPUTED_CODE)
    flags = np.where(np.isin(flags, codes), flags, NOT_COMPUTED_CODE)
    view = view.with_variable(name, flags)
    cmap = ListedColormap(colours)
    norm = BoundaryNorm(np.arange(min(codes) - 0.5, max(codes) + 1.5), cmap.N)
    panels = _map_panels(view)
    two_axes = len(view.parameter_axes) == 2
    fig = _new_figure(7.5 * (len(panels) if two_axes else 1), 4.5 if two_axes else 3.5)
    if two_axes:
        x_axis, y_axis = _map_axes(view, x_axis)
        axes = fig.subplots(1, len(panels), squeeze=False)[0]
        for ax, (where, panel_title) in zip(axes, panels):
            z = _as_x_y(view, name, x_axis, y_axis, where)
            mesh = map_mesh(ax, view.axes[x_axis], view.axes[y_axis], z.T, cmap=cmap, norm=norm)
            bar = fig.colorbar(mesh, ax=ax, ticks=codes)
            bar.ax.set_yticklabels(names, fontsize="x-small")
            ax.set_xlabel(view.axis_label(x_axis))
            ax.set_ylabel(view.axis_label(y_axis))
            cell_ticks(ax, view.axes[x_axis], view.axes[y_axis])
            if panel_title:
                ax.set_title(panel_title, fontsize="medium")
    else:
        x_axis = _choose_x_axis(view, x_axis, need_axes=1)
        ax = fig.subplots()
        curves = view.curve_coordinates(x_axis)
        shapes = "os^Dv<>p"
        for k, (where, label) in enumerate(curves):
            flags = view.along(name, x_axis, **where).astype(int)
            # Several curves (e.g. up and down): each its own row above each code, and its own
            # marker, named in the legend.
            row = k - (len(curves) - 1) / 2
            ax.scatter(view.axes[x_axis], flags + STATUS_ROW_STEP * row,
                       c=[colours[codes.index(f)] for f in flags], marker=shapes[k % len(shapes)],
                       s=18, edgecolors="k", linewidths=0.3,
                       label=f"{label}: {_row_name(k, len(curves))}" if label else None)
        ax.set_yticks(codes, names, fontsize="small")
        ax.set_ylim(min(codes) - 0.5, max(codes) + 0.5)
        _span_grid(ax, view.axes[x_axis])
        ax.set_xlabel(view.axis_label(x_axis))
        ax.set_ylabel(y_label)
        ax.grid(alpha=0.3)
        if len(curves) > 1:
            fig.legend(fontsize="x-small", loc="outside lower center", ncol=_legend_columns(fig, min(len(curves), 4)))
    counts = {label: int(np.sum(view.variables[name] == code)) for code, label in zip(codes, names)}
    summary = ", ".join(f"{n} {label}" for label, n in counts.items() if n)
    _title(fig, f"{title} ({summary})",
           _caption(view.path, view.config, view.model, view.selected, _progress_note(view), _width(fig)))
    return fig


STATUS_ROW_STEP = 0.25  # status strip: offset between the rows of several curves


def _row_name(k, n):
    """Where curve k of n sits around each status: 'lower row', 'upper row', 'row 2 of 3 from below'."""
    if n == 2:
        return ("lower", "upper")[k] + " row"
    return f"row {k + 1} of {n} from below"


@figure_options
def bifurcation_figure(ds, x_axis=None) -> Figure:
    """Stroboscopic x(nT) against one swept parameter, every sample a dot (issue 5)."""
    view = _Sweep(ds)
    view.require("strobe_x")
    x_axis = _choose_x_axis(view, x_axis, need_axes=1)
    fig = _new_figure(8.0, 5.0)
    ax = fig.subplots()
    failure_note = _draw_bifurcation(ax, view, x_axis)
    ax.set_xlabel(view.axis_label(x_axis))
    notes = "; ".join(note for note in (_progress_note(view), failure_note) if note)
    _title(fig, f"Bifurcation diagram: x sampled once per {period_words(symbol=False)} against "
                f"{parameter_symbol(x_axis)} "
                "(one dot per period: a period-p orbit shows p dots)",
           _caption(view.path, view.config, view.model, view.selected, notes, _width(fig)))
    return fig


def _draw_bifurcation(ax, view, x_axis, below_when_long=True):
    """The bifurcation diagram's panel; returns the notes for the caption (failures, samples not
    at the forcing's period). Its legend goes inside, or below the panel when longer than
    LONG_LEGEND and ``below_when_long`` (the figure has no other legend there)."""
    x = np.asarray(view.axes[x_axis], dtype=np.float64)
    n_strobe = view.variables["strobe_x"].shape[-1]
    curves = view.curve_coordinates(x_axis)
    # No more curves than colours apart in grey (an x axis asked for on a map drew a curve per row,
    # their colours in turn).
    _refuse_too_many_curves(view, curves, MAX_CURVES, "strobe_x", x_axis)
    repeats = []  # (label, q at each x) of each curve: the caption counts them curve by curve
    # The entries that tell the curves apart, kept (shortened) where a small figure has no room for
    # the whole legend (layout._keep_curve_names).
    names = {} if len(curves) > 1 else None
    for k, (where, label) in enumerate(curves):
        colour = RELIABLE_COLOURS[k % len(RELIABLE_COLOURS)]
        strobe = view.along("strobe_x", x_axis, **where)  # (n_x, n_strobe)
        q = _forcing_repeats(view, x_axis, x, where)
        at_period = q == 1
        repeats.append((label, q))
        # A curve with no sample at the forcing's period gets no legend entry for filled dots it
        # does not draw: its hollow entry names it.
        named = at_period.any() or at_period.size == 0
        ax.plot(np.repeat(x[at_period], n_strobe), strobe[at_period].reshape(-1), ".", ms=2.5, color=colour,
                label=(label or f"x(nT), last {n_strobe} {period_words(symbol=False)}s of each point") if named
                else None, gid="strobe")
        if names is not None and label:
            names[label] = label
        if not at_period.all():
            # Samples at t = nT where the forcing repeats only after q periods T (Omega/omega = 1/10:
            # q = 10) or never: a motion locked to the forcing shows q dots, or a curve, where its
            # own stroboscopic map would show one. Another mark, so that they are not read as chaos.
            hollow = (f"{label}: " if label else "") + "hollow: x(nT) where the forcing repeats only after " \
                "q > 1 periods T, or never (caption)"
            ax.plot(np.repeat(x[~at_period], n_strobe), strobe[~at_period].reshape(-1), "o", ms=1.6, mew=0.5,
                    mfc="none", color=colour, gid="strobe off the forcing's period", label=hollow)
            if names is not None and label:
                names[hollow] = f"{label}, hollow"
        if "status" in view.variables:
            failed = _point_classes(view, x_axis, where)[2]
            _draw_failed_rug(ax, x, failed, row=k, colour=FAILED_COLOUR if len(curves) == 1 else colour)
    failure_note = _failure_note(view, "in the strip under the panel") if "status" in view.variables else ""
    if failure_note:
        ax.plot([], [], "x", color=FAILED_COLOUR if len(curves) == 1 else "k", mew=1.5, ms=2.0, ls="none",
                label="integration failed: no samples")  # ms x markerscale 3 = the drawn marks
    strobe_note = _unlocked_note(repeats, x, x_axis)
    resonance_note = _draw_resonance_lines(ax, view, x_axis, x)
    if view.config is not None:
        levels = _barrier_levels(view, x_axis, x)
        for index in range(levels.shape[1]):
            label = ("barrier" if view.config.written else "barrier $x = \\Delta$") if index == 0 else None
            if np.all(levels[:, index] == levels[0, index]):
                ax.axhline(levels[0, index], color="k", lw=0.8, ls="--", label=label)
            else:
                order = np.argsort(x)
                ax.plot(np.asarray(x)[order], levels[order, index], color="k", lw=0.8, ls="--", label=label)
    if names:
        ax.figure._vrsweep_curve_labels = {**getattr(ax.figure, "_vrsweep_curve_labels", {}), **names}
    _span_grid(ax, x)  # the whole grid, even where every point failed
    period = "$T$ the model's period" if view.config is not None and view.config.written else "$T = 2\\pi/\\omega$"
    ax.set_ylabel(f"stroboscopic position $x(nT)$, {period}")
    ax.grid(alpha=0.3)
    handles, labels = ax.get_legend_handles_labels()
    if below_when_long and len(labels) > LONG_LEGEND:
        # Below the panel: 'best' found no empty corner for ten entries (curves of five Omega, their
        # hollow marks and resonances) and laid them over the samples.
        ax.figure.legend(handles, labels, fontsize="x-small", loc="outside lower center", markerscale=3,
                         ncol=_legend_columns(ax.figure, 2))
    else:
        ax.legend(fontsize="x-small", loc="best", markerscale=3)
    return "; ".join(note for note in (failure_note, strobe_note, resonance_note) if note)


LONG_LEGEND = 5  # a bifurcation diagram's legend of more entries goes below the panel


LONGEST_REPEAT = 1000  # periods T: a forcing that repeats after more is said to repeat never


def _forcing_repeats(view, x_axis, x, where):
    """q at each value of ``x``: the periods T after which the forcing repeats (1: every T; 0:
    not within LONGEST_REPEAT), the other axes at ``where``. 1 throughout without a config."""
    if view.config is None:
        return np.ones(len(x), dtype=np.int64)
    from vrsweep.analysis.diagnostics import sampling_of_forcing

    fixed = {axis: float(view.axes[axis][index]) for axis, index in where.items()
             if axis != "direction" and axis in view.config.parameters}
    sets = [view.parameters(**fixed, **({x_axis: float(value)} if x_axis in view.config.parameters else {}))
            for value in x]
    return sampling_of_forcing(view.config.model, sets, LONGEST_REPEAT)[0]


def _unlocked_note(repeats, x, x_axis):
    """The caption's words for the points whose samples at t = nT are not at the forcing's period.

    repeats: (label, q at each value of ``x``) of each curve (q: ``_forcing_repeats``). Curves of
    several Omega repeat after different q: each is counted on its own and named by its label (the
    caption counted the points of all curves as one, with the q of the last curve drawn: "at 6 of
    6 points ... q = 2" of three curves, one of them q = 5)."""
    said = [(label, _repeat_words(q, x, x_axis)) for label, q in repeats]
    said = [(label, words) for label, words in said if words]
    if not said:
        return ""
    tail = ("(hollow dots): sampled at t = nT, not once per the forcing's period, a motion locked to it "
            "shows q dots, or a closed curve, not chaos")
    if len(repeats) == 1:
        return f"{said[0][1]} {tail}"
    return f"the forcing repeats only after q > 1 periods T {tail}; {'; '.join(f'{label}: {words}' for label, words in said)}"


def _repeat_words(q, x, x_axis):
    """'at 2 of 3 points the forcing repeats only after q periods T (q = 10 at g = 5, ...)' for one
    curve's q at each value of ``x``; '' where it repeats every T throughout."""
    q = np.asarray(q)
    unlocked = q != 1
    if not unlocked.any():
        return ""
    finite = sorted({int(n) for n in q[unlocked] if n > 1})
    never = int(np.sum(q == 0))
    parts = []
    if finite:
        examples = ", ".join(f"q = {int(n)} at {_symbol(x_axis)} = {_number(float(value))}"
                             for value, n in zip(x, q) if n > 1)
        # Each point's own q where a few differ; else the range (one q along a curve of one Omega).
        parts.append(f"after q periods T ({examples})" if int(unlocked.sum()) <= 3 and len(finite) > 1 else
                     f"after q = {finite[0]}{'' if len(finite) == 1 else f' to {finite[-1]}'} periods T")
    if never:
        parts.append(f"not within {LONGEST_REPEAT} periods at {never} of them")
    return f"at {int(unlocked.sum())} of {len(q)} points the forcing repeats only {' and '.join(parts)}"


def _barrier_levels(view, x_axis, x):
    """(len(x), barriers): each barrier's position at each drawn value. A barrier may move with the
    swept parameter (the paper's Delta, a written position such as "s*F + 0.2"); a horizontal line
    at the fixed parameters' barrier would put it where no point of the sweep had it."""
    def positions(parameters):
        if view.config.written:
            return barrier_positions(view.config, parameters)
        return [parameters["Delta"]]

    if x_axis not in view.config.parameters:  # an initial-state axis (x0, v0): the barrier stays put
        return np.array([positions(view.parameters())] * len(x)).reshape(len(x), -1)
    return np.array([positions(view.parameters(**{x_axis: float(value)})) for value in x]).reshape(len(x), -1)


def _draw_resonance_lines(ax, view, x_axis, x):
    """g_res (eq3.4) as vertical lines, where it falls on the drawn range (the paper's theory:
    none for a written model, whose parameters are its own): at each curve's parameters, in its
    colour and named by its label where the curves' resonances differ. At the config's parameters
    alone, the curves of Omega = 3 ... 6 got one line, g_res at the config's Omega = 4. Returns the
    caption's note where a resonance was left out because Omega <= omega there (RESONANCE_CUT), else ''."""
    if view.config is None or view.config.written:
        return ""
    fine = fine_grid(x, FINE_POINTS)
    lines = {}  # {positions: [(curve number, label)]}: one line for curves that share their resonance
    any_cut = False
    for k, (where, label) in enumerate(view.curve_coordinates(x_axis)):
        fixed = {axis: float(view.axes[axis][index]) for axis, index in where.items() if axis != "direction"}
        positions, cut = resonance_roots(view.parameters(**fixed), x_axis, fine)
        any_cut |= cut
        lines.setdefault(tuple(positions), []).append((k, label))
    for positions, owners in lines.items():
        k, label = owners[0]
        several = len(lines) > 1
        for position in positions:
            ax.axvline(position, color=RELIABLE_COLOURS[k % len(RELIABLE_COLOURS)] if several else "0.4", ls="-.",
                       lw=0.9, label=(f"{label}: " if several and label else "") + _resonance_label(x_axis, position))
    return RESONANCE_CUT if any_cut else ""
