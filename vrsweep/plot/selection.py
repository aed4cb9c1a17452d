"""What the sweep figures draw from: a Dataset with axes fixed by ``select`` (xarray's labelled
selection, after a check that each value is on the grid), the curves to draw, which points to
trust (docs/trust.md, "Can R be trusted?") and which failed, and what part of the grid the file holds."""

from __future__ import annotations

import itertools
import os

import numpy as np

from vrsweep.errors import ResultFileError, UsageError
from vrsweep.plot.labels import (
    parameter_label, parameter_symbol, use_model,
    CURVES_NOT_MAP, DIRECTION_NAMES, FAILED_COLOUR, RELATIVE_ERROR_LIMIT, _number, _parse_config,
)
from vrsweep.results import Status
from vrsweep.store.reading import axis_index


def load(path):
    """A trajectory (TrajectoryData), a sweep result or a curves file (an xarray Dataset, loaded and
    its file closed); ResultFileError otherwise."""
    from vrsweep.store.reading import load_results
    from vrsweep.store.trajectory_file import is_trajectory_file, read_trajectory

    if is_trajectory_file(path):
        return read_trajectory(path)
    ds = load_results(path)  # says what is wrong with anything that is not a results file
    ds.encoding["source"] = os.fspath(path)  # messages name the file as the user did
    return ds


def _grid_axes(ds):
    """The sweep axes still to draw along, {name: values} in sweep order: the dimensions of
    ``done`` (an axis fixed by ``at`` is a scalar coordinate, no longer one of them)."""
    return {name: ds[name].values for name in ds["done"].dims}


def _sweep_default(axes):
    """Two long axes make a map; one axis, or a short second one (e.g. Omega: [4, 5]), curves."""
    parameter_axes = [name for name in axes if name != "direction"]
    if len(parameter_axes) == 2 and min(len(axes[name]) for name in parameter_axes) > CURVES_NOT_MAP:
        return "map"
    return "response"


# --------------------------------------------------------------------------------------------
# Sweeps: selecting what to draw
# --------------------------------------------------------------------------------------------


def select(ds, at: dict):
    """``ds`` with the axes named in ``at`` fixed at one of their values ({axis: value}; a value may
    be text, and 'up'/'down' for direction): xarray's labelled selection, after a check that each
    value is on the grid (never the nearest value quietly)."""
    axes = _grid_axes(ds)
    where = {}
    for name, wanted in at.items():
        if name not in axes:
            raise UsageError.naming("{at} {name}=...: {name} is not an axis of {path} (axes: {axes})",
                                    name=name, path=_path(ds), axes=", ".join(axes) or "none")
        where[name] = axis_index(name, np.asarray(axes[name], dtype=np.float64), wanted)
    return ds.isel(where)


def _path(ds):
    return ds.encoding.get("source", "the Dataset")


class _Values:
    """A Dataset's variables as plain arrays, by name: what the figures draw."""

    def __init__(self, ds):
        self._ds = ds

    def __contains__(self, name):
        return name in self._ds.data_vars

    def __getitem__(self, name):
        return self._ds[name].values

    def get(self, name, default=None):
        return self[name] if name in self else default


class _Sweep:
    """What the sweep figures draw from: a Dataset (axes fixed by ``select`` already) and what its
    attributes say (path, parsed config, model, progress)."""

    def __init__(self, ds):
        self.ds = ds
        self.path = _path(ds)
        self.axes = _grid_axes(ds)
        self.variables = _Values(ds)
        # Axes fixed by select() stay as scalar coordinates: the parameters they fix.
        self.selected = {str(name): float(coord.values) for name, coord in ds.coords.items()
                         if coord.ndim == 0 and name != "direction"}
        self.config = _parse_config(ds.attrs.get("config", ""))
        self.model = str(ds.attrs.get("model", self.config.model if self.config else "original"))
        use_model(self.config.model if self.config else None)  # a written model's parameter symbols
        self.complete = bool(ds.attrs.get("vrsweep_complete", 0))
        done = np.asarray(ds["done"].values)
        self.n_done, self.n_points = int(np.sum(done)), int(np.size(done))
        self.shard = _text_attr(ds.attrs.get("shard"))
        # R's relative error due to the integration (execution/solver_error.py); 0 in older files.
        solver_error = _number_attr(ds.attrs.get("R_solver_err"))
        self.solver_error = solver_error if solver_error is not None and np.isfinite(solver_error) else 0.0

    @property
    def parameter_axes(self):
        return [name for name in self.axes if name != "direction"]

    def parameters(self, **coordinates):
        """The nine parameters at this view's fixed values and the given axis coordinates."""
        if self.config is None:
            raise UsageError.naming("{path} holds no readable config: cannot compute the analytic side",
                                    path=self.path)
        return dict(self.config.parameters, **self.selected, **coordinates)

    def axis_label(self, name):
        """The label of axis ``name``: its words and symbol, with the units its coordinate's
        attributes give (only the maps' axes took them: the curves' did not)."""
        units = self.ds[name].attrs.get("units") if name in self.ds.coords else None
        return parameter_label(name, units)

    def with_variable(self, name, values):
        """This view with ``name``'s values replaced (the same shape; the Dataset given is untouched)."""
        import copy

        other = copy.copy(self)
        other.ds = self.ds.assign({name: self.ds[name].copy(data=values)})
        other.variables = _Values(other.ds)
        return other

    def require(self, *names):
        missing = [name for name in names if name not in self.variables]
        if missing:
            raise ResultFileError(f"{self.path} has no {', '.join(missing)} (written by an older vrsweep?)")

    def along(self, name, x_axis, **coordinates):
        """``name`` along ``x_axis`` at the given indices of the other axes (extra dims kept, last)."""
        array = self.ds[name]
        array = array.isel({axis: index for axis, index in coordinates.items() if axis in array.dims})
        if x_axis in array.dims:
            array = array.transpose(x_axis, ...)
        return array.values

    def curve_coordinates(self, x_axis):
        """Every combination of the axes other than ``x_axis``: list of ({axis: index}, label)."""
        others = [name for name in self.axes if name != x_axis]
        combos = []
        for indices in itertools.product(*(range(len(self.axes[name])) for name in others)):
            where = dict(zip(others, indices))
            label = ", ".join(_coordinate_text(name, self.axes[name][i]) for name, i in where.items())
            combos.append((where, label))
        return combos


def _coordinate_text(name, value):
    if name == "direction":
        return f"sweep {DIRECTION_NAMES.get(int(value), value)}"
    return f"{parameter_symbol(name)} = {_number(value)}"


def _choose_x_axis(view, x_axis, need_axes=None, over_two=None):
    """The swept parameter a curve is drawn against. ``over_two``: the figure that shows two axes
    instead, named where a file sweeps two (the lyapunov figure's map), in UsageError's words."""
    axes = view.parameter_axes
    if not axes:
        raise UsageError.naming("{path} is a single point" + (" after {at}" if view.selected else "")
                                + ": nothing to plot against (vrsweep simulate draws one point's trajectory)",
                                path=view.path)
    if x_axis is not None:
        if x_axis not in axes:
            raise UsageError.naming("{x_axis} {value}: not a swept axis of {path} (axes: {axes})",
                                    value=x_axis, path=view.path, axes=", ".join(axes))
        return x_axis
    if need_axes is not None and len(axes) != need_axes:
        # over_two is a template's words ({kind} map ...), reworded as the caller's flags or keywords
        hint = f"; both at once: {over_two}" if over_two and len(axes) == 2 else ""
        raise UsageError.naming(
            "{path} sweeps {axes}: this plot is drawn against one axis; fix the others with {at}, e.g. {at} "
            "{example}" + hint, path=view.path, axes=", ".join(axes),
            example=f"{axes[-1]}={_number(view.axes[axes[-1]][0])}")
    return "g" if "g" in axes else axes[0]


def _point_classes(view, x_axis, where):
    """Masks along x_axis: (trusted, aperiodic, failed), the rule of docs/trust.md, "Can R be trusted?".

    Trust is judged by R's error bar: R is trusted where R_err + R_solver_err |R| (the window's
    variation and the solver's error, execution/solver_error.py) <= RELATIVE_ERROR_LIMIT of R. The
    kind of motion is what ``period`` says: period 0 (no period up to max_period) with a tiny
    R_err is a converged R of a motion that is long-periodic or still settling, not chaos.
    Failed points (status not ok) are neither; points not yet computed are in no mask.
    """
    status = view.along("status", x_axis, **where)
    failed = (status != Status.OK) & (status != Status.NOT_COMPUTED)
    ok = status == Status.OK
    aperiodic = np.zeros(status.shape, dtype=bool)
    if "period" in view.variables:
        aperiodic = (view.along("period", x_axis, **where) == 0) & ok
    if "R_err" in view.variables and "R" in view.variables:
        R = view.along("R", x_axis, **where)
        R_err = view.along("R_err", x_axis, **where)
        with np.errstate(invalid="ignore"):
            trusted = (R_err + view.solver_error * np.abs(R) <= RELATIVE_ERROR_LIMIT * np.abs(R)) & ok
    else:  # a file from before R_err: only the period can say anything
        trusted = ok & ~aperiodic
    return trusted, aperiodic, failed


def _number_attr(value):
    """A numeric attribute as a float, or None (absent, or not a number: a damaged file)."""
    try:
        return float(np.asarray(value).reshape(-1)[0]) if value is not None else None
    except (TypeError, ValueError, IndexError):
        return None


def _failure_counts(view):
    """{'max_steps': 7, ...} over the view's points (failed statuses only)."""
    status = np.asarray(view.variables["status"])
    return {s.name.lower(): int(np.sum(status == s)) for s in Status
            if s not in (Status.OK, Status.NOT_COMPUTED) and np.any(status == s)}


def _failure_note(view, where_drawn):
    """'7 of 9 points failed (7 max_steps): red x in the strip under the panel', or ''."""
    counts = _failure_counts(view)
    if not counts:
        return ""
    n_failed = sum(counts.values())
    detail = ", ".join(f"{n} {name}" for name, n in counts.items())
    return (f"{n_failed} of {np.size(view.variables['status'])} points failed ({detail}): "
            f"× {where_drawn}; see vrsweep info")


FAILED_STRIP = 0.1   # the failed points' strip, of its panel's height
FAILED_STRIP_GAP = 0.08  # between the panel and its strip, of the panel's height


def _draw_failed_rug(ax, x, failed, row=0, colour=FAILED_COLOUR):
    """Failed points as x marks in a strip of their own under the panel ``ax``, one row per curve
    (``failure_strip``), as lambda_1 = -inf has (lyapunov.py).

    Their value is NaN, so no place on the panel's axis can show them: marks in a row along its
    bottom edge sat where data sit (R near 0 on a linear axis, a bifurcation diagram's lowest
    samples) and were read as values. The strip shares the panel's horizontal axis (and scale) and
    nothing else.
    """
    if not np.any(failed):
        return None
    strip = failure_strip(ax)
    (line,) = strip.plot(np.asarray(x)[failed], np.full(int(np.sum(failed)), float(row)),
                         "x", color=colour, ms=6, mew=1.5, zorder=6, clip_on=False, ls="none", gid="failed")
    line._vrsweep_context = True  # no data: a zoom does not fit the strip to it (layout.fit_y_to_view)
    strip._vrsweep_rows = max(getattr(strip, "_vrsweep_rows", 1), row + 1)
    label_strip(strip, strip._vrsweep_rows, "failed")
    return line


def label_strip(strip, rows, name):
    """A strip of marks under a panel (failed points here, lambda_1 = -inf in lyapunov.py): rows
    0 .. rows-1 (a curve each), one tick between them naming what the strip holds."""
    strip.set_ylim(-0.7, rows - 0.3)
    strip.set_yticks([(rows - 1) / 2.0], [name], fontsize="small")
    strip.tick_params(axis="y", length=0)
    strip.grid(alpha=0.3, axis="x")


def failure_strip(ax):
    """The strip under panel ``ax`` for its failed points, made on first use: the panel's place in
    its grid split into the panel and the strip (FAILED_STRIP of its height), the horizontal axis
    shared. The panel's horizontal axis label goes to the strip at the end (``layout.settle_strips``),
    where it is the lowest of the two."""
    strip = getattr(ax, "_vrsweep_failure_strip", None)
    if strip is not None:
        return strip
    fig = ax.figure
    cells = ax.get_subplotspec().subgridspec(2, 1, height_ratios=[1.0, FAILED_STRIP], hspace=FAILED_STRIP_GAP)
    ax.set_subplotspec(cells[0])
    strip = fig.add_subplot(cells[1], sharex=ax)
    strip.set_label("failed points")
    # Tick labels where the panel had them: under a panel with more panels below (a bifurcation
    # diagram above lambda_1) neither shows them.
    labelled = ax.xaxis._major_tick_kw.get("label1On", True)
    ax.tick_params(axis="x", labelbottom=False)
    strip.tick_params(axis="x", labelbottom=labelled)
    ax._vrsweep_failure_strip = strip
    return strip


SPAN_MARGIN = 0.03  # of the grid's span (in log on a logarithmic axis), beyond either end


def _span_grid(ax, values):
    """The x limits of the whole grid (plus a margin), whatever could be drawn, on a logarithmic
    axis where the grid is ``geometric``, as a map's axis is (``map_mesh``): a line plot over
    Omega = 0.25 ... 16 in doublings put five of its seven points in the left tenth of a linear
    axis. Every line plot over a swept axis sets its limits here, so its scale is chosen here too."""
    low, high = _limits(values)
    if geometric(values):
        ax.set_xscale("log")
        factor = (high / low) ** SPAN_MARGIN
        ax.set_xlim(low / factor, high * factor)
        # Ticked at the grid values where they are few, as a map's axis is: the log axis' own
        # ticks named 10^0 and 10^1 alone under seven points from 0.25 to 16.
        cell_ticks(ax, values)
        return
    margin = SPAN_MARGIN * (high - low) if high > low else 0.5 * max(1.0, abs(low))
    ax.set_xlim(low - margin, high + margin)


def fine_grid(values, count):
    """``count`` values from the grid's smallest to its largest, to draw the theory on: evenly in log
    on a logarithmic axis (``_span_grid``), where evenly spaced ones left its lowest decade one or
    two points, else evenly."""
    low, high = _limits(values)
    return (np.geomspace if geometric(values) else np.linspace)(low, high, count)


def _progress_note(view):
    """What part of the grid the file holds: '' for a whole finished sweep."""
    if view.shard:
        # A shard's gaps belong to the other shards, not to a run that stopped.
        unfinished = "" if view.complete else ", UNFINISHED"
        return (f"shard {view.shard}, {view.n_done} of {view.n_points} points{unfinished} "
                "(vrsweep merge joins the shards)")
    if view.complete:
        return ""
    return f"UNFINISHED: {view.n_done} of {view.n_points} points done"


def _text_attr(value):
    if value is None:
        return None
    return value.decode() if isinstance(value, bytes) else str(value)


def _map_axes(view, x_axis):
    axes = view.parameter_axes
    if len(axes) != 2:
        raise UsageError.naming("a map needs two swept axes; {path} has {axes}" + (" left after {at}" if view.selected else ""),
                                path=view.path, axes=", ".join(axes) or "none")
    x_axis = x_axis or ("g" if "g" in axes else axes[0])
    if x_axis not in axes:
        raise UsageError.naming("{x_axis} {value}: not a swept axis of {path} (axes: {axes})",
                                value=x_axis, path=view.path, axes=", ".join(axes))
    return x_axis, next(name for name in axes if name != x_axis)


def _map_panels(view):
    """One panel per continuation direction (one panel without continuation)."""
    if "direction" not in view.axes:
        return [({}, "")]
    return [({"direction": i}, f"sweep {DIRECTION_NAMES.get(int(v), v)}")
            for i, v in enumerate(view.axes["direction"])]


def _limits(values):
    values = np.asarray(values, dtype=np.float64)
    return float(values.min()), float(values.max())


# --------------------------------------------------------------------------------------------
# A map's cells: where each grid value's cell begins and ends, on a linear or logarithmic axis
# --------------------------------------------------------------------------------------------


def geometric(values) -> bool:
    """Whether a map axis of ``values`` is drawn logarithmic: positive, at least three values over at
    least a decade, more evenly spaced in log than linearly (Omega = 0.25, 0.5, ... 32, or 0.1, 0.2,
    0.5, 1, 2, 5). On a linear axis such a grid's small values were squeezed into slivers at the
    bottom, their cells a pixel high and their tick labels printed on top of each other."""
    values = np.sort(np.asarray(values, dtype=np.float64))
    if values.size < 3 or not np.all(np.isfinite(values)) or values[0] <= 0.0 or values[-1] < 10.0 * values[0]:
        return False

    def unevenness(steps):
        return float(steps.max() / steps.min())

    return unevenness(np.diff(np.log(values))) < unevenness(np.diff(values))


def cell_edges(centres, log=False):
    """Edges of the cells around ``centres`` (n -> n + 1): half-way between neighbours, the ends half
    a step beyond; on a logarithmic axis half-way in log (the geometric mean), so that every cell of a
    geometric grid is as tall as the others there."""
    centres = np.asarray(centres, dtype=np.float64)
    if log:
        return np.exp(cell_edges(np.log(centres)))
    if centres.size == 1:
        return np.array([centres[0] - 0.5, centres[0] + 0.5])
    middles = (centres[:-1] + centres[1:]) / 2.0
    return np.concatenate([[2 * centres[0] - middles[0]], middles, [2 * centres[-1] - middles[-1]]])


def map_mesh(ax, xs, ys, z, **style):
    """The cells of a map, z[j, i] at (xs[i], ys[j]), each axis logarithmic where its grid is
    ``geometric``, each cell from ``cell_edges``: pcolormesh's own 'nearest' cells are linear
    midpoints, which on a log axis gave a geometric grid's cells of unequal heights."""
    logs = []
    for values, set_scale in ((xs, ax.set_xscale), (ys, ax.set_yscale)):
        log = geometric(values)
        if log:
            set_scale("log")
        logs.append(log)
    return ax.pcolormesh(cell_edges(xs, logs[0]), cell_edges(ys, logs[1]), z, shading="flat", **style)


# --------------------------------------------------------------------------------------------
# A map's ticks: at its cells when there are few
# --------------------------------------------------------------------------------------------

CELL_TICKS = 12  # a map axis of at most this many cells is ticked at the cells, each labelled with its value


def cell_ticks(ax, x_values=None, y_values=None):
    """Tick a map's axes at its cells' centres (the grid values) where an axis has at most
    CELL_TICKS cells: round ticks between them (Omega = 3.5 ticked in the cell of 3.75 on a map
    of five rows) were read as rows computed there. Labels are the values, as few digits as keep
    each within 2 % of a cell of where it sits; every k-th is labelled where all would not fit."""
    from matplotlib.ticker import FuncFormatter, NullLocator

    for values, axis in ((x_values, ax.xaxis), (y_values, ax.yaxis)):
        if values is None:
            continue
        values = np.asarray(values, dtype=np.float64)
        if not 1 <= len(values) <= CELL_TICKS or not np.all(np.isfinite(values)):
            continue
        texts = _cell_texts(values)
        axis.set_major_locator(_CellLocator(values, texts))
        axis.set_major_formatter(FuncFormatter(
            lambda value, _, values=values, texts=texts: texts[int(np.argmin(np.abs(values - value)))]))
        axis.set_minor_locator(NullLocator())
        ax._vrsweep_cell_ticks = getattr(ax, "_vrsweep_cell_ticks", ()) + (axis.axis_name,)  # layout may shrink them


def _cell_texts(values):
    """The grid values as labels: the fewest significant digits (up to 6) that put each label
    within 2 % of a cell of its value and tell every two apart."""
    step = float(np.min(np.diff(np.sort(values)))) if len(values) > 1 else max(abs(float(values[0])), 1.0)
    for digits in range(1, 7):
        texts = [_significant(value, digits) for value in values]
        if len(set(texts)) == len(texts) and all(abs(float(text) - value) <= 0.02 * step
                                                 for text, value in zip(texts, values)):
            break
    return [text.replace("-", "\u2212") for text in texts]  # matplotlib's minus sign


def _significant(value, digits):
    """``value`` to ``digits`` significant digits, written out where it is of a size a reader takes in
    at a glance (10, 0.25, 60000: '{:.1g}' wrote 10 as '1e+01'), in exponent form beyond."""
    value = float(value)
    if value == 0.0 or not 1e-4 <= abs(value) < 1e6:
        return f"{value:.{digits}g}"
    return np.format_float_positional(value, precision=digits, unique=False, fractional=False, trim="-")


from matplotlib.ticker import Locator  # noqa: E402


class _CellLocator(Locator):
    """Ticks at cell centres, as many as leave room between their labels (from the axis' length when
    drawn and the longest label; a vertical axis needs a line a label): every k-th cell where they
    are evenly spaced on the axis, else the first and then each next one far enough from the last
    (every k-th of an uneven grid printed the labels of its close cells on top of each other)."""

    def __init__(self, values, texts):
        self.values = np.asarray(values, dtype=np.float64)
        self.longest = max(len(text) for text in texts)

    def __call__(self):
        from matplotlib.font_manager import FontProperties
        import matplotlib

        horizontal = self.axis.axis_name == "x"
        size = FontProperties(size=matplotlib.rcParams[f"{self.axis.axis_name}tick.labelsize"]).get_size_in_points()
        room = (0.6 * self.longest + 1.5) * size if horizontal else 1.8 * size
        # Where each cell's centre is drawn, in points along the axis (linear or logarithmic).
        axes = self.axis.axes
        along = axes.transData.transform(np.column_stack([self.values, self.values]))[:, 0 if horizontal else 1]
        along = along * 72.0 / axes.figure.dpi
        steps = np.abs(np.diff(along))
        if steps.size and steps.max() <= 1.01 * steps.min():
            return self.values[::max(1, int(np.ceil(room / steps.min())))]
        chosen = [0]
        for index in range(1, len(self.values)):
            if abs(along[index] - along[chosen[-1]]) >= room:
                chosen.append(index)
        return self.values[chosen]

    def tick_values(self, vmin, vmax):
        return self.values
