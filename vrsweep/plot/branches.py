"""The figure of a branch file (``vrsweep continue``): R along the continued parameter, stable
orbits solid and unstable dashed, the located bifurcations marked and named, sweep files on the
same axes, the corrected theory's branches for the effective model; below, the moduli of the
Floquet multipliers with the unit circle's level."""

from __future__ import annotations

import os

import numpy as np
from matplotlib.figure import Figure

from vrsweep.plot.analytic import _draw_branches, analytic_branches
from vrsweep.plot.labels import (
    parameter_symbol,
    _caption, _legend_columns, _new_figure, _title, _width, figure_options, parameter_label,
)

BIFURCATION_MARKERS = {"fold": ("o", "fold"), "period_doubling": ("s", "period doubling"),
                       "neimark_sacker": ("D", "Neimark-Sacker"), "grazing": ("^", "grazing")}
BRANCH_COLOUR = "C0"
FINE_POINTS = 600
# The multipliers' panel is logarithmic when their moduli span more than this factor.
LOG_SPAN = 100.0
ROUNDOFF_SPAN = 1e13


def is_branch(data) -> bool:
    return hasattr(data, "attrs") and data.attrs.get("vrsweep_file") == "branch"


def _runs(values, stable):
    """Index ranges of equal stability; each run shares its last point with the next one."""
    start = 0
    for end in range(1, len(values) + 1):
        if end == len(values) or stable[end] != stable[start]:
            yield slice(start, min(end + 1, len(values))), bool(stable[start])
            start = end


def _stored_parameters(ds):
    from vrsweep.config import parse_config

    try:
        return parse_config(str(ds.attrs["config"]), "<the stored config>")
    except Exception:  # noqa: BLE001 - a file without a readable config still gets its branch drawn
        return None


@figure_options
def branch_figure(ds, sweeps=(), more_branches=()) -> Figure:
    """The figure (two panels, one x axis) of branch Dataset ``ds`` (and of the branch Datasets
    ``more_branches``, of the same parameter) with sweep Datasets ``sweeps``; takes the options of
    every figure (title, size, style: ``labels.figure_options``). Branches are coloured by their
    period (in slow periods), the first file's first branch's period in BRANCH_COLOUR."""
    name = str(ds.attrs.get("parameter", "parameter"))
    symbol = parameter_symbol(name)
    figure = _new_figure(7.5, 6.5)
    top, bottom = figure.subplots(2, 1, sharex=True, height_ratios=(2.2, 1.0))
    datasets = [ds, *more_branches]
    values = np.concatenate([np.asarray(d["parameter"].values) for d in datasets])
    gain = np.concatenate([np.asarray(d["R"].values) for d in datasets])
    stable = np.concatenate([np.asarray(d["stable"].values).astype(bool) for d in datasets])
    modulus = np.concatenate([np.asarray(d["multiplier_modulus"].values).reshape(-1, 2) for d in datasets])
    periods = np.concatenate([np.asarray(d["periods"].values) for d in datasets])
    # One number per (file, branch): the branches of every file in turn.
    offsets = np.cumsum([0] + [len(d["branch_id"]) for d in datasets[:-1]])
    branch = np.concatenate([np.asarray(d["branch"].values) + offset for d, offset in zip(datasets, offsets)])
    colours = _period_colours(periods)
    config = _stored_parameters(ds)
    if config is not None and config.model == "effective" and values.size:
        low, high = values.min(), values.max()
        span = high - low or 1.0
        fine = np.linspace(low - 0.05 * span, high + 0.05 * span, FINE_POINTS)
        _draw_branches(top, analytic_branches(config.parameters, name, fine, gain=True), "0.6")
        top.plot([], [], color="0.6", label="theory (corrected), stable / unstable")
    for number in np.unique(branch):
        mine = branch == number
        colour = colours[int(periods[mine][0])] if mine.any() else BRANCH_COLOUR
        for piece, is_stable in _runs(values[mine], stable[mine]):
            style = "-" if is_stable else "--"
            top.plot(values[mine][piece], gain[mine][piece], color=colour, ls=style, lw=1.8, zorder=3)
            for k in range(2):
                bottom.plot(values[mine][piece], modulus[mine][piece, k], color=f"C{k}", ls=style, lw=1.4)
    top.plot([], [], color=BRANCH_COLOUR, lw=1.8, label="continuation: stable")
    top.plot([], [], color=BRANCH_COLOUR, lw=1.8, ls="--", label="continuation: unstable")
    if len(colours) > 1:
        for period, colour in colours.items():
            top.plot([], [], color=colour, lw=1.8, label=f"period {period} T")
    for sweep_number, sweep in enumerate(sweeps):
        _draw_sweep(top, sweep, name, sweep_number)
    kinds = [str(kind) for d in datasets for kind in d["bifurcation_kind"].values]
    places = np.concatenate([np.asarray(d["bifurcation_parameter"].values, dtype=float) for d in datasets])
    heights = np.concatenate([np.asarray(d["bifurcation_R"].values, dtype=float) for d in datasets])
    for kind, at, R in zip(kinds, places, heights):
        marker, label = BIFURCATION_MARKERS.get(kind, ("x", kind))
        # Named in the legend, not beside the point: a fold and a grazing often lie close together.
        top.plot([at], [R], marker=marker, color="k", mfc="w", mew=1.2, ms=8, zorder=5, ls="none",
                 label=f"{label}, {symbol} = {at:.4f}")
        bottom.axvline(at, color="0.75", lw=0.8, zorder=0)
    written = config is not None and config.written
    top.set_ylabel(f"gain $R = |Q|$ / {config.model.response_scale}" if written else "gain $R = |Q|/c$")
    model_words = config.model.title if written else f"{ds.attrs.get('model', '')} model"
    what = f"Periodic orbits continued in {symbol} ({model_words})"
    path = str(ds.encoding.get("source", "") or ds.attrs.get("path", "") or "branch")
    _title(figure, what, _caption(os.path.basename(path), config, str(ds.attrs.get("model", "")), omit=(name,),
                                  width=_width(figure)))
    bottom.axhline(1.0, color="k", lw=0.8, label="unit circle $|\\mu| = 1$")
    bottom.plot([], [], color="C0", label="$|\\mu_1|$")
    bottom.plot([], [], color="C1", label="$|\\mu_2|$")
    positive = modulus[modulus > 0.0]
    if positive.size and positive.max() / positive.min() > LOG_SPAN:
        bottom.set_yscale("log")  # a strongly unstable or strongly damped branch spans decades
        # Below ROUNDOFF_SPAN of the largest, a modulus is the eigenvalue solver's roundoff
        # (e.g. the second multiplier of P^4 when det P ~ 1e-8), not worth a dozen decades.
        bottom.set_ylim(bottom=max(positive.min(), positive.max() / ROUNDOFF_SPAN) / 2.0)
    bottom.set_ylabel("Floquet $|\\mu|$")
    bottom.set_xlabel(parameter_label(name))
    # One legend below both panels: inside, it covered the branch on a journal-column figure.
    handles, labels = [], []
    for ax in (top, bottom):
        more_handles, more_labels = ax.get_legend_handles_labels()
        handles += more_handles
        labels += more_labels
    figure.legend(handles, labels, fontsize="x-small", loc="outside lower center",
                  ncol=_legend_columns(figure, 3))
    return figure


# Colours of the periods after the first (BRANCH_COLOUR); C0/C1 are the multipliers' panel's,
# C2, C3 the sweeps'.
PERIOD_COLOURS = ("C4", "C5", "C6", "C9", "C8", "C7")


def _period_colours(periods):
    """{period: colour}: the first point's period in BRANCH_COLOUR, the others in turn."""
    order = list(dict.fromkeys(int(p) for p in periods))
    return {period: BRANCH_COLOUR if k == 0 else PERIOD_COLOURS[(k - 1) % len(PERIOD_COLOURS)]
            for k, period in enumerate(order)}


def _draw_sweep(ax, sweep, name, number):
    if name not in sweep.coords or "R" not in sweep:
        return
    data = sweep["R"]
    others = [dim for dim in data.dims if dim not in (name, "direction")]
    if others:
        data = data.isel({dim: 0 for dim in others})
    directions = sweep["direction"].values if "direction" in data.dims else [None]
    for direction in directions:
        line = data.sel(direction=direction) if direction is not None else data
        label = "sweep" if direction is None else f"sweep {'up' if direction > 0 else 'down'}"
        ax.plot(sweep[name].values, line.values, ls="none", marker="v" if direction is not None and direction < 0
                else "^", ms=5, mfc="none", mew=1.0, color=f"C{2 + number}", label=label, zorder=4)
