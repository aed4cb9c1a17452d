"""The sweep figures: response (Fig. 1, Fig. 2), map, impacts, status and bifurcation; each takes
an xarray Dataset (``vrsweep.open_results``, ``plot.load``), its axes fixed with ``select``."""

from __future__ import annotations

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from vrsweep.errors import UsageError
from vrsweep.numerics.model import PARAMETER_SYMBOLS
from vrsweep.plot.analytic import (
    _draw_branches, _draw_resonance_curve, _fine_parameters, _resonance_label, analytic_branches, resonance_positions,
)
from vrsweep.plot.labels import (
    FAILED_COLOUR, FINE_POINTS, LOG_SPAN, MARKERS, MAX_CURVES, RELATIVE_ERROR_LIMIT, RELIABLE_COLOURS, UNITS,
    _caption, _new_figure, _symbol, _title, _width, parameter_label,
)
from vrsweep.plot.selection import (
    _choose_x_axis, _draw_failed_rug, _failure_note, _grid_axes, _map_axes, _map_panels, _point_classes,
    _progress_note, _span_grid, _Sweep, _sweep_default,
)
from vrsweep.results import Status


# --------------------------------------------------------------------------------------------
# Sweep figures
# --------------------------------------------------------------------------------------------


def response_figure(ds, amplitude=False, x_axis=None, log=None) -> Figure:
    """R (or |Q|) against one axis with the analytic branches and the resonance (Fig. 1, Fig. 2).

    Markers follow docs/trust.md, "Can R be trusted?": filled where R_err <= 10% of R (R can be
    trusted), hollow where not; a circle where a period was found, a square where none was
    (period 0); always in the curve's colour. Failed points (status not ok, R = NaN) are x marks
    along the bottom edge, one row per curve, and counted in the title.

    log: True/False for a logarithmic/linear response axis; None chooses: logarithmic when the
    drawn values (numerical and analytic) span LOG_SPAN or more -- the analytic gain A/c reaches
    ~50 with the paper's parameters while the numerical R may go down to 0.01.
    """
    view = _Sweep(ds)
    x_axis = _choose_x_axis(view, x_axis)
    name = "Q_amplitude" if amplitude else "R"
    view.require(name, "status")
    curves = view.curve_coordinates(x_axis)
    if len(curves) > MAX_CURVES:
        others = [n for n in view.parameter_axes if n != x_axis]
        raise UsageError.naming("{n} curves of {name} against {axis} on one plot: fix {others} with {at}, "
                                "or draw {kind} map", n=len(curves), name=name, axis=x_axis, others=", ".join(others))
    x = np.asarray(view.axes[x_axis], dtype=np.float64)
    fig = _new_figure(8.0, 6.0)
    ax = fig.subplots()
    analytic_done = set()
    curve_handles, resonance_handles = [], []
    drawn = []  # every value on the response axis, to choose its scale
    kinds_seen = {"aperiodic": False, "untrusted": False}
    symbol = "|Q|" if amplitude else "R"
    what = "numerical |Q| (eq3.1-3.2)" if amplitude else "numerical R = |Q|/c (eq3.3)"
    for k, (where, label) in enumerate(curves):
        colour = RELIABLE_COLOURS[k % len(RELIABLE_COLOURS)]
        y = view.along(name, x_axis, **where)
        trusted, aperiodic, failed = _point_classes(view, x_axis, where)
        shown = np.isfinite(y) & ~failed
        drawn.append(y[shown])
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
        _draw_failed_rug(ax, x, failed, row=k, colour=FAILED_COLOUR if len(curves) == 1 else colour)
        curve_handles.append(Line2D([], [], ls=":", lw=0.8, marker="o", color=colour, ms=4,
                                    label=f"{what}{', ' + label if label else ''}"))

        # The analytic side depends on the parameters only, not on the continuation direction.
        parameter_where = {axis: index for axis, index in where.items() if axis != "direction"}
        key = tuple(sorted(parameter_where.items()))
        if view.config is None or key in analytic_done:
            continue
        analytic_done.add(key)
        parameters = view.parameters(**{axis: float(view.axes[axis][i]) for axis, i in parameter_where.items()})
        fine = np.linspace(x.min(), x.max(), FINE_POINTS)
        branches = analytic_branches(parameters, x_axis, fine, gain=not amplitude)
        drawn += [branch_y for _, branch_y, _ in branches]
        _draw_branches(ax, branches, colour)
        barrier = _fine_parameters(parameters, x_axis, fine)
        barrier_level = barrier["Delta"] if amplitude else barrier["Delta"] / barrier["c"]
        ax.plot(fine, barrier_level, color=colour, lw=0.8, ls=(0, (1, 3)), zorder=1)
        for position in resonance_positions(parameters, x_axis, fine):
            ax.axvline(position, color=colour, ls="-.", lw=0.9, zorder=1)
            resonance_handles.append(Line2D([], [], color=colour, ls="-.", lw=0.9,
                                            label=_resonance_label(x_axis, position)))

    analytic = "A" if amplitude else "A/c"
    error = "error" if amplitude else "$R_{err}$"  # R_err/R is also the relative error of |Q|
    handles = list(curve_handles)
    handles.append(Line2D([], [], ls="none", marker="o", color="k", ms=4,
                          label=f"filled: {error} ≤ {RELATIVE_ERROR_LIMIT:.0%} of {symbol} (trusted)"))
    if kinds_seen["untrusted"]:
        handles.append(Line2D([], [], ls="none", marker="o", mfc="none", mec="k", ms=4.5,
                              label=f"hollow: {error} > {RELATIVE_ERROR_LIMIT:.0%} of {symbol} (window-dependent)"))
    if kinds_seen["aperiodic"]:
        handles.append(Line2D([], [], ls="none", marker="s", mfc="none", mec="k", ms=4.5,
                              label="square: no period found (period 0)"))
    failure_note = _failure_note(view, "along the bottom edge")
    if failure_note:
        handles.append(Line2D([], [], ls="none", marker="x", mew=1.5,
                              color=FAILED_COLOUR if len(curves) == 1 else "k",
                              label="× at the bottom edge: integration failed"))
    if view.config is not None:
        handles.append(Line2D([], [], color="k", lw=1.3, label=f"analytic {analytic}, stable (corrected eq2.27)"))
        handles.append(Line2D([], [], color="k", lw=1.3, ls="--", label=f"analytic {analytic}, unstable"))
        handles.append(Line2D([], [], color="k", lw=0.8, ls=(0, (1, 3)),
                              label=f"{'A = Δ' if amplitude else 'A/c = Δ/c'}: above, the analytic motion "
                                    "crosses the barrier"))
    handles += resonance_handles
    fig.legend(handles=handles, fontsize=7.5, loc="outside lower center", ncol=2)
    ax.set_xlabel(parameter_label(x_axis))
    if amplitude:
        ax.set_ylabel(f"amplitude $|Q|$ of x at $\\omega$, analytic $A$ {UNITS}")
    else:
        ax.set_ylabel(f"gain $R = |Q|/c$, analytic $A/c$ {UNITS}")
    scale_note = ""
    span = _decades(drawn)
    if log is None:
        log = span >= np.log10(LOG_SPAN)
        if log:
            scale_note = f"log axis: the values span {span:.1f} decades (a linear one on request)"
    if log:
        ax.set_yscale("log")
    else:
        ax.set_ylim(bottom=0.0)
    _span_grid(ax, x)
    ax.grid(alpha=0.3, which="both" if log else "major")
    quantity = "amplitude |Q|" if amplitude else "gain R"
    x_symbol = PARAMETER_SYMBOLS.get(x_axis, x_axis)
    notes = "; ".join(note for note in (_progress_note(view), failure_note, scale_note) if note)
    _title(fig, f"Response {quantity} against {x_symbol}; analytic: first-order theory of the effective system "
                f"(ERRATA 1-3{'' if amplitude else ', divided by c: ERRATA 6'})",
           _caption(view.path, view.config, view.model, view.selected, notes, _width(fig)))
    return fig


def _decades(arrays):
    """log10(max/min) over the positive finite values of ``arrays``; 0 with fewer than two."""
    values = np.concatenate([np.ravel(a) for a in arrays]) if arrays else np.array([])
    values = values[np.isfinite(values) & (values > 0)]
    if values.size < 2:
        return 0.0
    return float(np.log10(values.max() / values.min()))


MAP_LABELS = {"R": "gain $R = |Q|/c$", "Q_amplitude": "amplitude $|Q|$",
              "impacts_per_period": "mean impacts per slow period $2\\pi/\\omega$"}
LONG_NAME_IN_LABEL = 45  # characters of a variable's long_name that fit beside a colour bar


def mappable_variables(ds) -> list:
    """The variables of ``ds`` that a map can show: one value per grid point (dimensions exactly
    the sweep axes left after ``select``), numbers, in the file's order."""
    axes = set(_grid_axes(ds))
    return [str(name) for name, variable in ds.data_vars.items()
            if name not in ("done", "owned") and set(variable.dims) == axes and variable.dtype.kind in "iuf"]


def _units_text(attrs):
    """'[1]' from a variable's ``units`` attribute ('' for a flag variable, which has none)."""
    units = attrs.get("units")
    return f"[{units}]" if units is not None else ""


def _variable_label(ds, name):
    """The colour bar's label: what the variable is and its units, from the file's attributes."""
    attrs = ds[name].attrs
    words = MAP_LABELS.get(name)
    if words is None:
        long_name = str(attrs.get("long_name", ""))
        words = name if not long_name or len(long_name) > LONG_NAME_IN_LABEL else f"{name}: {long_name}"
    return f"{words} {_units_text(attrs)}".rstrip()


def _map_norm(values, log, counts=False):
    """Colours from 0 (or the smallest value, if negative) to the 99th percentile of a float
    variable (one wild point must not wash out the map), to the largest of a count or a label
    (``counts``: an integer variable, its points not computed NaN here)."""
    from matplotlib.colors import LogNorm, Normalize

    finite = values[np.isfinite(values)]
    low = min(0.0, float(finite.min())) if finite.size else 0.0
    if not finite.size:
        high = 1.0
    elif counts:
        high = float(finite.max())
    else:
        high = float(np.percentile(finite, 99))
    if high <= low:
        high = low + 1.0
    positive = finite[finite > 0]
    if log and positive.size:
        return LogNorm(vmin=float(positive.min()), vmax=max(high, float(positive.min()) * 10)), finite
    return Normalize(vmin=low, vmax=high), finite


def map_figure(ds, name="R", x_axis=None, log=False) -> Figure:
    """A heat map of ``name`` over two axes with the resonance curve; untrusted R dotted, failed x.

    name: R, Q_amplitude, impacts_per_period or any other variable with one value per grid point
    (``mappable_variables``); points not computed are grey. log: a logarithmic colour scale (from
    the smallest positive value up). The legend goes below the maps, where it hides no cell.
    """
    view = _Sweep(ds)
    x_axis, y_axis = _map_axes(view, x_axis)
    if name in MAP_LABELS:
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
    counts = values.dtype.kind != "f"
    if counts:  # a count or a label: points not computed hold a fill value
        values = np.where(np.asarray(ds["done"].values, dtype=bool), values, np.nan)
    norm, finite = _map_norm(values, log, counts)
    cmap = "viridis"
    if name == "lyapunov" and not log and finite.size:
        # The sign is the message (chaos above zero, periodic below): a diverging map centred on 0.
        from matplotlib.colors import TwoSlopeNorm

        span = max(float(np.abs(finite).max()), 1e-12)
        norm = TwoSlopeNorm(vcenter=0.0, vmin=min(float(finite.min()), -1e-3 * span),
                            vmax=max(float(finite.max()), 1e-3 * span))
        cmap = "RdBu_r"
    handles = {}
    for ax, (where, panel_title) in zip(axes, panels):
        z = _as_x_y(view, name, x_axis, y_axis, where)
        if ds[name].dtype.kind != "f":
            z = np.where(_as_x_y(view, "done", x_axis, y_axis, where) > 0, z, np.nan)
        ax.set_facecolor("0.8")  # NaN cells (not computed, or failed) show the background
        minus_infinity = np.isneginf(z)  # lyapunov where the mass stuck: no colour can say -inf
        z = np.where(minus_infinity, np.nan, z)
        mesh = ax.pcolormesh(view.axes[x_axis], view.axes[y_axis], z.T, shading="nearest", cmap=cmap,
                             norm=norm)
        if minus_infinity.any():
            X, Y = np.meshgrid(view.axes[x_axis], view.axes[y_axis], indexing="ij")
            ax.plot(X[minus_infinity], Y[minus_infinity], "v", color="k", mec="w", mew=0.5, ms=4.5, ls="none",
                    gid="minus_infinity")
            handles["minus_infinity"] = Line2D([], [], ls="none", marker="v", color="k", mec="w", mew=0.5,
                                               label="−∞ (lyapunov: stuck on the barrier)")
        bar = fig.colorbar(mesh, ax=ax, label=label + (" (log scale)" if log else ""),
                           extend="max" if finite.size and finite.max() > norm.vmax else "neither")
        if cmap == "RdBu_r":  # each half of the diverging scale gets its own ticks
            ticks = np.unique(np.concatenate([np.linspace(norm.vmin, 0.0, 5), np.linspace(0.0, norm.vmax, 5)]))
            bar.set_ticks(ticks, labels=[f"{tick:.3g}" for tick in ticks])
        if counts and not log:
            from matplotlib.ticker import MaxNLocator

            bar.locator = MaxNLocator(integer=True)  # a period or a label has no value between integers
            bar.update_ticks()
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
            X, Y = np.meshgrid(view.axes[x_axis], view.axes[y_axis], indexing="ij")
            if untrusted.any():
                ax.plot(X[untrusted], Y[untrusted], ".", color="white", ms=2.5, gid="untrusted")
                handles["untrusted"] = Line2D(
                    [], [], ls="none", marker=".", color="white", mec="k", mew=0.3,
                    label=f"white dot: $R_{{err}}$ > {RELATIVE_ERROR_LIMIT:.0%} of R (R depends on the window)")
            if failed.any():
                ax.plot(X[failed], Y[failed], "x", color=FAILED_COLOUR, ms=4, gid="failed")
                handles["failed"] = Line2D([], [], ls="none", marker="x", color=FAILED_COLOUR,
                                           label="integration failed (status ≠ ok)")
        ax.set_xlabel(parameter_label(x_axis, ds[x_axis].attrs.get("units")))
        ax.set_ylabel(parameter_label(y_axis, ds[y_axis].attrs.get("units")))
        if panel_title:
            ax.set_title(panel_title, fontsize=9)
    if handles:
        legend = fig.legend(handles=list(handles.values()), fontsize=7, loc="outside lower center",
                            ncol=len(handles), facecolor="0.3", framealpha=0.9)
        for text in legend.get_texts():
            text.set_color("white")
    notes = "; ".join(note for note in (_progress_note(view), _failure_note(view, "on its cell")
                                        if name in ("R", "Q_amplitude") and "status" in view.variables else "")
                      if note)
    grey = "not computed or failed" if ds[name].dtype.kind == "f" else "not computed"
    _title(fig, f"{label.split(' [')[0]} over {_symbol(x_axis)} and {_symbol(y_axis)} (grey: no value: {grey})",
           _caption(view.path, view.config, view.model, view.selected, notes, _width(fig)))
    return fig


def _as_x_y(view, name, x_axis, y_axis, where):
    """``name`` as a 2-D array indexed [x, y] at ``where`` (other dims already fixed)."""
    return view.ds[name].isel(where).transpose(x_axis, y_axis).values.astype(np.float64)


def impacts_figure(ds, x_axis=None, log=False) -> Figure:
    """Mean impacts per slow period over the measurement window: a curve (1 axis) or a map (2).

    log: a logarithmic count axis (symmetric-log, so that zero counts stay on it) or colour scale.
    """
    view = _Sweep(ds)
    view.require("impacts_per_period")
    if len(view.parameter_axes) == 2 and x_axis is None and _sweep_default(view.axes) == "map":
        return map_figure(ds, "impacts_per_period", log=log)
    x_axis = _choose_x_axis(view, x_axis)
    curves = view.curve_coordinates(x_axis)
    if len(curves) > MAX_CURVES:
        raise UsageError.naming("{n} curves on one plot: fix the other axes with {at}", n=len(curves))
    x = np.asarray(view.axes[x_axis], dtype=np.float64)
    fig = _new_figure(8.0, 4.5)
    ax = fig.subplots()
    top = 0.0
    for k, (where, label) in enumerate(curves):
        colour = RELIABLE_COLOURS[k % len(RELIABLE_COLOURS)]
        y = view.along("impacts_per_period", x_axis, **where)
        ax.plot(x, y, "o-", ms=3.5, lw=0.9, color=colour, label=label or "measurement window")
        top = max(top, float(np.nanmax(y, initial=0.0)))
        if "status" in view.variables:
            failed = _point_classes(view, x_axis, where)[2]
            _draw_failed_rug(ax, x, failed, row=k, colour=FAILED_COLOUR if len(curves) == 1 else colour)
    failure_note = _failure_note(view, "along the bottom edge") if "status" in view.variables else ""
    if failure_note:
        ax.plot([], [], "x", color=FAILED_COLOUR if len(curves) == 1 else "k", mew=1.5, ls="none",
                label="integration failed (no count)")
    ax.set_xlabel(parameter_label(x_axis))
    ax.set_ylabel(f"mean impacts per slow period $2\\pi/\\omega$ {UNITS}")
    if log:
        ax.set_yscale("symlog", linthresh=1.0)  # zero counts stay on the axis
        ax.set_ylim(-0.1, max(2.0, 1.5 * top))
    else:
        # A little room below zero: points with no impacts are drawn whole, not cut by the edge.
        ax.set_ylim(-0.04 * max(top, 1.0), 1.06 * max(top, 1.0))
    _span_grid(ax, x)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    notes = "; ".join(note for note in (_progress_note(view), failure_note) if note)
    _title(fig, f"Impacts per slow period against {PARAMETER_SYMBOLS.get(x_axis, x_axis)} "
                "(mean over the measurement window)",
           _caption(view.path, view.config, view.model, view.selected, notes, _width(fig)))
    return fig


def status_figure(ds, x_axis=None) -> Figure:
    """How each point ended (ok, max_steps, diverged, ...): a strip (1 axis) or a map (2 axes)."""
    view = _Sweep(ds)
    view.require("status")
    codes = [int(s) for s in Status]
    names = [s.name.lower() for s in Status]
    colours = ["0.85", "tab:green", "tab:orange", "tab:red", "tab:purple", "tab:brown", "k"]
    cmap = ListedColormap(colours)
    norm = BoundaryNorm(np.arange(min(codes) - 0.5, max(codes) + 1.5), cmap.N)
    panels = _map_panels(view)
    two_axes = len(view.parameter_axes) == 2
    fig = _new_figure(7.5 * (len(panels) if two_axes else 1), 4.5 if two_axes else 3.5)
    if two_axes:
        x_axis, y_axis = _map_axes(view, x_axis)
        axes = fig.subplots(1, len(panels), squeeze=False)[0]
        for ax, (where, panel_title) in zip(axes, panels):
            z = _as_x_y(view, "status", x_axis, y_axis, where)
            mesh = ax.pcolormesh(view.axes[x_axis], view.axes[y_axis], z.T, shading="nearest", cmap=cmap, norm=norm)
            bar = fig.colorbar(mesh, ax=ax, ticks=codes)
            bar.ax.set_yticklabels(names, fontsize=7)
            ax.set_xlabel(parameter_label(x_axis))
            ax.set_ylabel(parameter_label(y_axis))
            if panel_title:
                ax.set_title(panel_title, fontsize=9)
    else:
        x_axis = _choose_x_axis(view, x_axis, need_axes=1)
        ax = fig.subplots()
        curves = view.curve_coordinates(x_axis)
        shapes = "os^Dv<>p"
        for k, (where, label) in enumerate(curves):
            status = view.along("status", x_axis, **where).astype(int)
            # Several curves (e.g. up and down): each its own row above each status, and its own
            # marker, named in the legend.
            row = k - (len(curves) - 1) / 2
            ax.scatter(view.axes[x_axis], status + STATUS_ROW_STEP * row,
                       c=[colours[codes.index(s)] for s in status], marker=shapes[k % len(shapes)],
                       s=18, edgecolors="k", linewidths=0.3,
                       label=f"{label}: {_row_name(k, len(curves))}" if label else None)
        ax.set_yticks(codes, names, fontsize=8)
        ax.set_ylim(min(codes) - 0.5, max(codes) + 0.5)
        _span_grid(ax, view.axes[x_axis])
        ax.set_xlabel(parameter_label(x_axis))
        ax.set_ylabel("status of the point")
        ax.grid(alpha=0.3)
        if len(curves) > 1:
            fig.legend(fontsize=7.5, loc="outside lower center", ncol=min(len(curves), 4))
    counts = {name: int(np.sum(view.variables["status"] == code)) for code, name in zip(codes, names)}
    summary = ", ".join(f"{n} {name}" for name, n in counts.items() if n)
    _title(fig, f"How each point's integration ended ({summary})",
           _caption(view.path, view.config, view.model, view.selected, _progress_note(view), _width(fig)))
    return fig


STATUS_ROW_STEP = 0.25  # status strip: offset between the rows of several curves


def _row_name(k, n):
    """Where curve k of n sits around each status: 'lower row', 'upper row', 'row 2 of 3 from below'."""
    if n == 2:
        return ("lower", "upper")[k] + " row"
    return f"row {k + 1} of {n} from below"


def bifurcation_figure(ds, x_axis=None) -> Figure:
    """Stroboscopic x(nT) against one swept parameter, every sample a dot (issue 5)."""
    view = _Sweep(ds)
    view.require("strobe_x")
    x_axis = _choose_x_axis(view, x_axis, need_axes=1)
    fig = _new_figure(8.0, 5.0)
    ax = fig.subplots()
    failure_note = _draw_bifurcation(ax, view, x_axis)
    ax.set_xlabel(parameter_label(x_axis))
    notes = "; ".join(note for note in (_progress_note(view), failure_note) if note)
    _title(fig, "Bifurcation diagram: x sampled once per slow period against "
                f"{PARAMETER_SYMBOLS.get(x_axis, x_axis)} "
                "(one dot per period: a period-p orbit shows p dots)",
           _caption(view.path, view.config, view.model, view.selected, notes, _width(fig)))
    return fig


def _draw_bifurcation(ax, view, x_axis):
    """The bifurcation diagram's panel; returns the failure note for the caption."""
    x = np.asarray(view.axes[x_axis], dtype=np.float64)
    n_strobe = view.variables["strobe_x"].shape[-1]
    curves = view.curve_coordinates(x_axis)
    for k, (where, label) in enumerate(curves):
        colour = RELIABLE_COLOURS[k % len(RELIABLE_COLOURS)]
        strobe = view.along("strobe_x", x_axis, **where)  # (n_x, n_strobe)
        xs = np.repeat(x, strobe.shape[-1])
        ax.plot(xs, strobe.reshape(-1), ".", ms=2.5, color=colour,
                label=label or f"x(nT), last {n_strobe} slow periods of each point")
        if "status" in view.variables:
            failed = _point_classes(view, x_axis, where)[2]
            _draw_failed_rug(ax, x, failed, row=k, colour=FAILED_COLOUR if len(curves) == 1 else colour)
    failure_note = _failure_note(view, "along the bottom edge") if "status" in view.variables else ""
    if failure_note:
        ax.plot([], [], "x", color=FAILED_COLOUR if len(curves) == 1 else "k", mew=1.5, ms=2.0, ls="none",
                label="integration failed: no samples")  # ms x markerscale 3 = the drawn marks
    _draw_resonance_lines(ax, view, x_axis, x)
    if view.config is not None:
        ax.axhline(view.parameters()["Delta"], color="k", lw=0.8, ls="--", label="barrier $x = \\Delta$")
    _span_grid(ax, x)  # the whole grid, even where every point failed
    ax.set_ylabel(f"stroboscopic position $x(nT)$, $T = 2\\pi/\\omega$ {UNITS}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7.5, loc="best", markerscale=3)
    return failure_note


def _draw_resonance_lines(ax, view, x_axis, x):
    """g_res (eq3.4) as vertical lines, where it falls on the drawn range."""
    if view.config is None:
        return
    parameters = view.parameters()
    for position in resonance_positions(parameters, x_axis, np.linspace(x.min(), x.max(), FINE_POINTS)):
        ax.axvline(position, color="0.4", ls="-.", lw=0.9, label=_resonance_label(x_axis, position))
