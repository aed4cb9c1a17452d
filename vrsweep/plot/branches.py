"""The figure of a branch file (``vrsweep continue``): R along the continued parameter, stable
orbits solid and unstable dashed, the located bifurcations marked and named, sweep files on the
same axes, the corrected theory's branches for the effective model; below, the moduli of the
Floquet multipliers with the unit circle's level."""

from __future__ import annotations

import os

import numpy as np
from matplotlib.figure import Figure

from vrsweep.numerics.model import PARAMETER_SYMBOLS
from vrsweep.plot.analytic import _draw_branches, analytic_branches
from vrsweep.plot.labels import (
    _caption, _legend_columns, _new_figure, _title, _width, figure_options, parameter_label,
)

BIFURCATION_MARKERS = {"fold": ("o", "fold"), "period_doubling": ("s", "period doubling"),
                       "neimark_sacker": ("D", "Neimark-Sacker"), "grazing": ("^", "grazing")}
BRANCH_COLOUR = "C0"
FINE_POINTS = 600
# The multipliers' panel is logarithmic when their moduli span more than this factor.
LOG_SPAN = 100.0


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
def branch_figure(ds, sweeps=()) -> Figure:
    """The figure (two panels, one x axis) of branch Dataset ``ds`` with sweep Datasets ``sweeps``;
    takes the options of every figure (title, size, style: ``labels.figure_options``)."""
    name = str(ds.attrs.get("parameter", "parameter"))
    symbol = PARAMETER_SYMBOLS.get(name, name)
    figure = _new_figure(7.5, 6.5)
    top, bottom = figure.subplots(2, 1, sharex=True, height_ratios=(2.2, 1.0))
    values = np.asarray(ds["parameter"].values)
    gain = np.asarray(ds["R"].values)
    stable = np.asarray(ds["stable"].values).astype(bool)
    modulus = np.asarray(ds["multiplier_modulus"].values)
    branch = np.asarray(ds["branch"].values)
    config = _stored_parameters(ds)
    if config is not None and config.model == "effective" and values.size:
        low, high = values.min(), values.max()
        span = high - low or 1.0
        fine = np.linspace(low - 0.05 * span, high + 0.05 * span, FINE_POINTS)
        _draw_branches(top, analytic_branches(config.parameters, name, fine, gain=True), "0.6")
        top.plot([], [], color="0.6", label="theory (corrected), stable / unstable")
    for number in np.unique(branch):
        mine = branch == number
        for piece, is_stable in _runs(values[mine], stable[mine]):
            style = "-" if is_stable else "--"
            top.plot(values[mine][piece], gain[mine][piece], color=BRANCH_COLOUR, ls=style, lw=1.8, zorder=3)
            for k in range(2):
                bottom.plot(values[mine][piece], modulus[mine][piece, k], color=f"C{k}", ls=style, lw=1.4)
    top.plot([], [], color=BRANCH_COLOUR, lw=1.8, label="continuation: stable")
    top.plot([], [], color=BRANCH_COLOUR, lw=1.8, ls="--", label="continuation: unstable")
    for sweep_number, sweep in enumerate(sweeps):
        _draw_sweep(top, sweep, name, sweep_number)
    kinds = [str(kind) for kind in ds["bifurcation_kind"].values]
    for kind, at, R in zip(kinds, ds["bifurcation_parameter"].values, ds["bifurcation_R"].values):
        marker, label = BIFURCATION_MARKERS.get(kind, ("x", kind))
        # Named in the legend, not beside the point: a fold and a grazing often lie close together.
        top.plot([at], [R], marker=marker, color="k", mfc="w", mew=1.2, ms=8, zorder=5, ls="none",
                 label=f"{label}, {symbol} = {at:.4f}")
        bottom.axvline(at, color="0.75", lw=0.8, zorder=0)
    top.set_ylabel("gain $R = |Q|/c$")
    what = f"Periodic orbits continued in {symbol} ({ds.attrs.get('model', '')} model)"
    path = str(ds.encoding.get("source", "") or ds.attrs.get("path", "") or "branch")
    _title(figure, what, _caption(os.path.basename(path), config, str(ds.attrs.get("model", "")), omit=(name,),
                                  width=_width(figure)))
    bottom.axhline(1.0, color="k", lw=0.8, label="unit circle $|\\mu| = 1$")
    bottom.plot([], [], color="C0", label="$|\\mu_1|$")
    bottom.plot([], [], color="C1", label="$|\\mu_2|$")
    positive = modulus[modulus > 0.0]
    if positive.size and positive.max() / positive.min() > LOG_SPAN:
        bottom.set_yscale("log")  # a strongly unstable or strongly damped branch spans decades
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
