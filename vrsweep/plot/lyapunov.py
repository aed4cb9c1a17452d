"""The largest Lyapunov exponent against a swept parameter, alone or under the bifurcation
diagram (issue 13); maps of it are map_figure's (sweeps.py)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from vrsweep.errors import ResultFileError
from vrsweep.plot.labels import (
    parameter_symbol, stuck_words,
    FAILED_COLOUR, LYAPUNOV_SYMBOL, MAX_CURVES, RELIABLE_COLOURS, _caption, _legend_columns, _new_figure, _title, _width, figure_options,
)
from vrsweep.plot.selection import (
    _choose_x_axis, _draw_failed_rug, _failure_note, _point_classes, _progress_note, _span_grid, _Sweep,
    label_strip,
)
from vrsweep.plot.sweeps import _draw_bifurcation, _draw_resonance_lines, _refuse_too_many_curves



STUCK_COLOUR = "tab:cyan"
CURVE_STYLES = ("-", "--", ":")  # not "-.": the resonance lines (eq3.4) are dash-dot


@figure_options
def lyapunov_figure(ds, x_axis=None, bifurcation=False) -> Figure:
    """The largest Lyapunov exponent against one swept parameter, with the zero line (issue 13).

    Each point is drawn with its 95 % band (lyapunov_err), filled where lambda_1 exceeds its band
    above zero (chaos), hollow where not (periodic, or quasi-periodic when it stays within its band
    of zero). -inf (the mass stuck on the barrier in the window: tangent.py) cannot sit on a data
    axis: such points are triangles in a strip under the panel, counted in the title, as failed
    points are x marks in a strip of their own. ``bifurcation``: the bifurcation diagram above, on the same parameter axis.
    """
    view = _Sweep(ds)
    if "lyapunov" not in view.variables:
        raise ResultFileError(f"{view.path} has no lyapunov: run the sweep with integration.lyapunov: true")
    if bifurcation:
        view.require("strobe_x")
    x_axis = _choose_x_axis(view, x_axis, need_axes=1, over_two="{kind} map {var} lyapunov")
    # -inf has no place on the exponent's axis: a mark inside the panel sat at some height and was
    # read as that exponent (a triangle at "-1.03" beside a point at -1.05). Such points get a strip
    # of their own under the panel, ticked "-inf", which no finite value can reach.
    heights = [3, 2] if bifurcation else [1]
    stuck = bool(np.isneginf(np.asarray(view.variables["lyapunov"], dtype=np.float64)).any())
    if stuck:
        heights.append(STUCK_STRIP * heights[-1])
    fig = _new_figure(8.0, 7.5 if bifurcation else 4.5)
    panels = np.atleast_1d(fig.subplots(len(heights), 1, sharex=True, squeeze=False,
                                        gridspec_kw={"height_ratios": heights})[:, 0])
    if bifurcation:
        failure_note = _draw_bifurcation(panels[0], view, x_axis, below_when_long=False)  # below: the exponent's legend
    ax = panels[1 if bifurcation else 0]
    note = _draw_lyapunov(ax, view, x_axis, strip=panels[-1] if stuck else None)
    if not bifurcation:
        failure_note = _failure_note(view, "in the strip under the panel") if "status" in view.variables else ""
    panels[-1].set_xlabel(view.axis_label(x_axis))
    # Both panels may say one thing (the resonance left out where Omega <= omega): once.
    notes = "; ".join(dict.fromkeys(n for part in (_progress_note(view), failure_note, note)
                                    for n in part.split("; ") if n))
    what = (f"Bifurcation diagram (top) and largest Lyapunov exponent {LYAPUNOV_SYMBOL} (bottom)" if bifurcation
            else f"Largest Lyapunov exponent {LYAPUNOV_SYMBOL}")
    _title(fig, f"{what} against {parameter_symbol(x_axis)}: "
                f"{LYAPUNOV_SYMBOL} > 0 chaos, = 0 quasi-periodic, < 0 periodic",
           _caption(view.path, view.config, view.model, view.selected, notes, _width(fig)))
    return fig


STUCK_STRIP = 0.12  # the -inf strip's height, of the exponent's panel's


def _draw_lyapunov(ax, view, x_axis, strip=None):
    """lambda_1 with its band, the zero line, failed points, and -inf (stuck on the barrier) as
    triangles in ``strip``, a panel of their own under ``ax`` (one row per curve); returns the
    -inf note."""
    x = np.asarray(view.axes[x_axis], dtype=np.float64)
    curves = view.curve_coordinates(x_axis)
    _refuse_too_many_curves(view, curves, MAX_CURVES, "lyapunov", x_axis)  # no more than colours apart in grey
    n_stuck = 0
    for k, (where, label) in enumerate(curves):
        colour = RELIABLE_COLOURS[k % len(RELIABLE_COLOURS)]
        # Each curve its own line style as well as its colour: the lines cross and overlap, and the
        # zero line is black and solid.
        style = CURVE_STYLES[k % len(CURVE_STYLES)] if len(curves) > 1 else "-"
        exponent = view.along("lyapunov", x_axis, **where)
        error = view.along("lyapunov_err", x_axis, **where) if "lyapunov_err" in view.variables \
            else np.zeros_like(exponent)
        finite = np.isfinite(exponent)
        with np.errstate(invalid="ignore"):
            chaotic = finite & (exponent - error > 0.0)
        band = np.where(finite, error, np.nan)
        ax.fill_between(x, exponent - band, exponent + band, where=finite, color=colour, alpha=0.2, lw=0,
                        label=None if k else "95 % band (lyapunov_err)")
        ax.plot(x, np.where(finite, exponent, np.nan), ls=style, color=colour, lw=0.8 if style == "-" else 1.0,
                label=label or None, gid="lyapunov")
        if label and len(curves) > 1:  # kept where a small figure has no room for the whole legend
            ax.figure._vrsweep_curve_labels = {**getattr(ax.figure, "_vrsweep_curve_labels", {}), label: label}
        ax.plot(x[chaotic], exponent[chaotic], "o", ms=3.5, color=colour, ls="none", gid="chaotic",
                label=None if k else f"{LYAPUNOV_SYMBOL} > 0 beyond its band: chaotic")
        calm = finite & ~chaotic
        ax.plot(x[calm], exponent[calm], "o", ms=3.5, mfc="none", mew=1.0, color=colour, ls="none", gid="not_chaotic",
                label=None if k else "not beyond its band: periodic (< 0), quasi-periodic or undecided (≈ 0)")
        stuck = np.isneginf(exponent)
        n_stuck += int(np.sum(stuck))
        if np.any(stuck):
            strip.plot(x[stuck], np.full(int(np.sum(stuck)), float(k)), "v",
                       color=STUCK_COLOUR if len(curves) == 1 else colour, ms=6, zorder=6, clip_on=False,
                       gid="stuck", ls="none")
            if not n_stuck - int(np.sum(stuck)):  # the legend's entry, once (the strip is no panel of its own)
                ax.plot([], [], "v", color=STUCK_COLOUR if len(curves) == 1 else "k", ms=6, ls="none",
                        label=f"in the strip below: {LYAPUNOV_SYMBOL} = $-\\infty$, {stuck_words()}")
        if "status" in view.variables:
            failed = _point_classes(view, x_axis, where)[2]
            _draw_failed_rug(ax, x, failed, row=k, colour=FAILED_COLOUR if len(curves) == 1 else colour)
    ax.axhline(0.0, color="k", lw=0.9, label=f"{LYAPUNOV_SYMBOL} = 0")
    resonance_note = _draw_resonance_lines(ax, view, x_axis, x)
    _span_grid(ax, x)
    ax.set_ylabel(f"{LYAPUNOV_SYMBOL}, per unit time")
    ax.grid(alpha=0.3)
    if strip is not None:
        label_strip(strip, len(curves), f"{LYAPUNOV_SYMBOL} = $-\\infty$")
    # Below the axes: a legend inside would cover points (the exponent fills its whole range).
    handles, labels = ax.get_legend_handles_labels()
    ax.figure.legend(handles, labels, fontsize="x-small", loc="outside lower center",
                      ncol=_legend_columns(ax.figure, 3))
    if not n_stuck:
        return resonance_note
    points = "1 point" if n_stuck == 1 else f"{n_stuck} points"
    stuck_note = f"{points} {stuck_words()} in the window ({LYAPUNOV_SYMBOL} = -inf): ▼ in the strip under the panel"
    return "; ".join(note for note in (stuck_note, resonance_note) if note)
