"""Figures from vrsweep files: every function returns a matplotlib Figure (no pyplot, no display).

Sweep results (``vrsweep run``)
    ``response``     R = |Q|/c (or the amplitude |Q|) against one swept parameter, one curve per
                     value of the other axes, with the analytic branches of the corrected theory
                     (stable solid, unstable dashed) in the same units and the resonance g_res
                     (eq3.4) marked. Fig. 1 and Fig. 2 of the paper.
    ``map``          a heat map over two swept parameters with the resonance curve drawn over it.
    ``impacts``      mean impacts per slow period against the axis (or as a map).
    ``status``       how each point's integration ended.
    ``bifurcation``  the stroboscopic x(nT) against the swept parameter, every sample a dot.
    ``lyapunov``     the largest Lyapunov exponent against the swept parameter, with the zero line;
                     ``bifurcation+lyapunov`` draws it under the bifurcation diagram, one x axis.
Trajectories (``vrsweep simulate``)
    ``trajectory``   position, velocity and phase portrait, original above effective (Fig. 3-5).
    ``impacts``      impacts in each slow period against the period number (Fig. impact_no).
    ``slowflow``     the effective system against the slow-flow reconstruction (Fig. 6).

Units: the paper's model is dimensionless, so every axis says ``[1]``. The gain R = |Q|/c of eq3.3
and the analytic amplitude A of eq2.21 are different quantities (ERRATA 6): on a gain plot the
analytic curves are A/c, on an amplitude plot (``amplitude=True``) the numbers are |Q| and A.

Which R can be trusted (issue 5, README "Can R be trusted?"): trust is judged by R_err alone --
a point is drawn filled where R_err <= RELATIVE_ERROR_LIMIT of R and hollow where not -- and the
kind of motion by ``period``: a circle where a period was found, a square where none was (chaos,
quasi-periodic, a period above max_period, or a motion still settling; with a tiny R_err the last
two are common and harmless). Points keep their curve's colour. Failed points (status not ok)
have no value: they are x marks along the bottom edge, in axes coordinates, so that a log axis
shows them too, and the title counts them (issue 15).
"""

from __future__ import annotations

import itertools
import os

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from vrsweep.errors import ResultFileError, UsageError
from vrsweep.model import (
    INITIAL_STATE_LONG_NAMES, INITIAL_STATE_SYMBOLS, PARAMETER_LONG_NAMES, PARAMETER_NAMES, PARAMETER_SYMBOLS,
)
from vrsweep.results import Status

SWEEP_KINDS = ("response", "map", "impacts", "status", "bifurcation", "lyapunov", "bifurcation+lyapunov")
TRAJECTORY_KINDS = ("trajectory", "impacts", "slowflow")
KINDS = ("response", "map", "impacts", "status", "bifurcation", "lyapunov", "bifurcation+lyapunov", "trajectory",
         "slowflow")

RELATIVE_ERROR_LIMIT = 0.10
"""R counts as unreliable where R_err > 10% of R (R_err is a 95% half-width, see diagnostics.py).
A periodic point measured over a window that is not a whole number of its cycles carries a few
per cent (R_err includes that offset); a chaotic one tens of per cent."""
MAX_CURVES = 8          # more curves than this on one response plot is unreadable: ask for --at
CURVES_NOT_MAP = 5      # a 2-axis sweep whose shorter axis has at most this many values: curves
FINE_POINTS = 2001      # analytic curves are drawn on a grid this fine, not on the sweep's points
UNITS = "[1]"           # dimensionless, like every quantity of the paper's model
UNITS_NOTE = "[1] = dimensionless"

MODEL_EQUATIONS = {"original": "original system eq2.1-eq2.2", "effective": "effective system eq2.10"}
DIRECTION_NAMES = {1: "up", -1: "down"}
RELIABLE_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
                    "tab:pink", "tab:olive")
FAILED_COLOUR = "tab:red"
FAILED_ROW_HEIGHT = 0.035  # axes fraction per row of failed-point marks at the bottom edge
MARKERS = {False: "o", True: "s"}  # period found: circle; none found (period 0): square
LOG_SPAN = 100.0  # drawn values spanning this ratio (two decades) or more get a log axis


# --------------------------------------------------------------------------------------------
# Labels and captions
# --------------------------------------------------------------------------------------------


def parameter_label(name: str, units=None) -> str:
    """'fast forcing amplitude $g$ [1]' for a parameter, with its symbol and units (``units``: as
    a file's coordinate says; default: the model's, dimensionless)."""
    units = f"[{units}]" if units is not None else UNITS
    if name == "direction":
        return "continuation direction"
    if name in INITIAL_STATE_LONG_NAMES:  # x0, v0: 'initial position $x(0)$ [1]'
        words = INITIAL_STATE_LONG_NAMES[name].rsplit(" ", 1)[0]
        return f"{words} {INITIAL_STATE_SYMBOLS[name]} {units}"
    words = PARAMETER_LONG_NAMES.get(name, name)
    if words.endswith(" " + name):
        words = words[: -len(name) - 1]
    return f"{words} {PARAMETER_SYMBOLS.get(name, name)} {units}"


def _symbol(name: str) -> str:
    """$g$ for a parameter, $x(0)$ for an initial state, the name itself otherwise."""
    return PARAMETER_SYMBOLS.get(name) or INITIAL_STATE_SYMBOLS.get(name, name)


def _number(value) -> str:
    return f"{value:.6g}"


def _caption(path, config, model, selected=None, extra="", width=100, omit=()):
    """File and model, then the parameters held fixed (swept ones and ``omit`` left out), initial
    state and run length, wrapped at ``width`` characters between items (never inside 'name = value')."""
    selected = dict(selected or {})
    items = [os.path.basename(path), MODEL_EQUATIONS.get(model, model)]
    if config is not None:
        swept = ({axis.name for axis in config.axes} - set(selected)) | set(omit)
        parameters = dict(config.parameters, **selected)
        run = config.integration
        items += [f"{PARAMETER_SYMBOLS[name]} = {_number(parameters[name])}"
                  for name in PARAMETER_NAMES if name not in swept]
        items += [f"x(0) = {_number(config.initial['x'])}", f"$\\dot{{x}}(0)$ = {_number(config.initial['v'])}",
                  f"{run.transient_periods} transient + {run.measure_periods} measured slow periods"]
    items += [UNITS_NOTE] + ([extra] if extra else [])
    lines, line = [], ""
    for item in items:
        visible = len(item.replace("$", "").replace("\\", ""))  # mathtext markup takes no room
        if line and len(line.replace("$", "").replace("\\", "")) + visible + 2 > width:
            lines.append(line)
            line = ""
        line = f"{line},  {item}" if line else item
    return "\n".join(lines + [line])


def _parse_config(text):
    """The config stored in a file, or None if it cannot be read back (then captions are shorter)."""
    from vrsweep.config import parse_config
    from vrsweep.errors import ConfigError

    if not text:
        return None
    try:
        return parse_config(text, "<stored config>")
    except ConfigError:
        return None


def _new_figure(width, height):
    return Figure(figsize=(width, height), layout="constrained")


def _title(fig, what, caption):
    fig.suptitle(f"{what}\n{caption}", fontsize=8.5)


def _width(fig):
    """Characters of caption text that fit across ``fig`` at the title's font size."""
    return int(fig.get_figwidth() * 15)


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------


def load(path):
    """A trajectory (TrajectoryData) or a sweep result (an xarray Dataset, loaded and its file
    closed); ResultFileError otherwise."""
    from vrsweep.reading import load_results
    from vrsweep.trajectory_file import is_trajectory_file, read_trajectory

    if is_trajectory_file(path):
        return read_trajectory(path)
    ds = load_results(path)  # says what is wrong with anything that is not a results file
    ds.encoding["source"] = os.fspath(path)  # messages name the file as the user did
    return ds


def default_kind(data) -> str:
    """What ``vrsweep plot FILE`` draws when no --kind is given."""
    from vrsweep.trajectory_file import TrajectoryData

    if isinstance(data, TrajectoryData):
        return "trajectory"
    return _sweep_default(_grid_axes(data))


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


def plot(sources, kind=None, amplitude=False, at=None, x_axis=None, log=None, periods=None, var=None) -> Figure:
    """The figure ``vrsweep plot`` draws for ``sources`` (one file; several for trajectory impacts).

    sources: a path, or a list of paths or of what ``load`` returned (a sweep's Dataset, from
    ``load`` or ``vrsweep.open_results``; a trajectory's TrajectoryData). at: {axis: value} fixing
    sweep axes; x_axis: the swept parameter to draw against; log: True for a logarithmic response
    axis (or colour scale of a map), False for a linear one, None to choose (response plots: log
    when the values span two decades or more; maps: linear); periods: (first, last) slow periods
    of a trajectory to show; var: the stored variable a map shows (default R, or Q_amplitude with
    ``amplitude``).
    """
    from vrsweep.trajectory_file import TrajectoryData

    if isinstance(sources, (str, os.PathLike)):
        sources = [sources]
    if not sources:
        raise UsageError.naming("no file to plot")
    data = [load(s) if isinstance(s, (str, os.PathLike)) else s for s in sources]
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
        if at or x_axis or amplitude or log is not None:
            raise UsageError.naming("{at}, {x_axis}, {amplitude} and {log}/{linear} are for sweep results, "
                                    "not trajectory files")
        if kind == "impacts":
            return impacts_per_period_figure(data)
        if kind == "slowflow":
            return slow_flow_figure(data[0], periods=periods)
        return trajectory_figure(data[0], periods=periods)
    if periods is not None:
        raise UsageError.naming("{periods} is for trajectory files (vrsweep simulate), not sweep results")
    ds = select(data[0], at or {})
    # After at, a fixed axis no longer counts; a variable to map asks for a map.
    kind = kind or ("map" if var is not None else _sweep_default(_grid_axes(ds)))
    if kind not in SWEEP_KINDS:
        raise UsageError.naming("{kind} {value} is for trajectory files (vrsweep simulate); a sweep result "
                                "takes {kinds}", value=kind, kinds=", ".join(SWEEP_KINDS))
    if var is not None and kind != "map":
        raise UsageError.naming("{var} is for {kind} map, not {kind} {value}", value=kind)
    if var is not None and amplitude:  # never ignored quietly
        raise UsageError.naming("{amplitude} maps Q_amplitude and {var} names the variable itself: give one of them")
    if kind == "response":
        return response_figure(ds, amplitude=amplitude, x_axis=x_axis, log=log)
    if kind == "map":
        return map_figure(ds, var or ("Q_amplitude" if amplitude else "R"), x_axis=x_axis, log=bool(log))
    if kind == "impacts":
        return impacts_figure(ds, x_axis=x_axis, log=bool(log))
    if log:  # never ignored quietly
        raise UsageError.naming("{log} is for response, map and impacts plots, not {kind} {value}", value=kind)
    if kind == "status":
        return status_figure(ds, x_axis=x_axis)
    if kind in ("lyapunov", "bifurcation+lyapunov"):
        return lyapunov_figure(ds, x_axis=x_axis, bifurcation=kind == "bifurcation+lyapunov")
    return bifurcation_figure(ds, x_axis=x_axis)


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
        where[name] = _axis_index(name, np.asarray(axes[name], dtype=np.float64), wanted)
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
        self.complete = bool(ds.attrs.get("vrsweep_complete", 0))
        done = np.asarray(ds["done"].values)
        self.n_done, self.n_points = int(np.sum(done)), int(np.size(done))
        self.shard = _text_attr(ds.attrs.get("shard"))

    @property
    def parameter_axes(self):
        return [name for name in self.axes if name != "direction"]

    def parameters(self, **coordinates):
        """The nine parameters at this view's fixed values and the given axis coordinates."""
        if self.config is None:
            raise UsageError.naming("{path} holds no readable config: cannot compute the analytic side",
                                    path=self.path)
        return dict(self.config.parameters, **self.selected, **coordinates)

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
    return f"{PARAMETER_SYMBOLS.get(name, name)} = {_number(value)}"


def _axis_index(name, values, wanted):
    """Index of ``wanted`` on an axis; 'up'/'down' allowed for direction. Must match a grid value."""
    if name == "direction":
        words = {"up": 1.0, "down": -1.0, "+1": 1.0, "1": 1.0, "-1": -1.0}
        key = str(wanted).strip().lower()
        if key not in words:
            raise UsageError.naming("{at} direction={value}: the direction is up or down (+1 or -1)", value=wanted)
        wanted = words[key]
    try:
        wanted = float(wanted)
    except ValueError:
        raise UsageError.naming("{at} {name}={value}: not a number; {name} takes values {span}",
                                name=name, value=wanted, span=_axis_span(values)) from None
    index = int(np.argmin(np.abs(values - wanted)))
    if abs(values[index] - wanted) > 1e-9 * max(1.0, abs(wanted)):
        raise UsageError.naming("{at} {name}={value}: not a value of the axis {name}; {nearest} (axis: {span})",
                                name=name, value=_number(wanted), nearest=_nearest_text(values, wanted),
                                span=_axis_span(values))
    return index


def _nearest_text(values, wanted):
    """'the nearest are 19.5 and 21' -- the grid values on either side of ``wanted``."""
    below, above = values[values < wanted], values[values > wanted]
    sides = ([_number(below.max())] if below.size else []) + ([_number(above.min())] if above.size else [])
    if len(sides) == 2:
        return f"the nearest are {sides[0]} and {sides[1]}"
    return f"the nearest is {sides[0]}"


def _axis_span(values):
    """'81 values from 0 to 40', or the values themselves when there are few."""
    if len(values) <= 6:
        return ", ".join(_number(v) for v in values)
    return f"{len(values)} values from {_number(np.min(values))} to {_number(np.max(values))}"


def _choose_x_axis(view, x_axis, need_axes=None):
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
        raise UsageError.naming(
            "{path} sweeps {axes}: this plot needs {need} axis(es); fix the others with {at}, e.g. {at} {example}",
            path=view.path, axes=", ".join(axes), need=need_axes,
            example=f"{axes[-1]}={_number(view.axes[axes[-1]][0])}")
    return "g" if "g" in axes else axes[0]


def _point_classes(view, x_axis, where):
    """Masks along x_axis: (trusted, aperiodic, failed), the README's rule ("Can R be trusted?").

    Trust is judged by R_err alone: R is trusted where R_err <= RELATIVE_ERROR_LIMIT of R. The
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
            trusted = (R_err <= RELATIVE_ERROR_LIMIT * np.abs(R)) & ok
    else:  # a file from before R_err: only the period can say anything
        trusted = ok & ~aperiodic
    return trusted, aperiodic, failed


def _failure_counts(view):
    """{'max_steps': 7, ...} over the view's points (failed statuses only)."""
    status = np.asarray(view.variables["status"])
    return {s.name.lower(): int(np.sum(status == s)) for s in Status
            if s not in (Status.OK, Status.NOT_COMPUTED) and np.any(status == s)}


def _failure_note(view, where_drawn):
    """'7 of 9 points failed (7 max_steps): red x along the bottom edge', or ''."""
    counts = _failure_counts(view)
    if not counts:
        return ""
    n_failed = sum(counts.values())
    detail = ", ".join(f"{n} {name}" for name, n in counts.items())
    return (f"{n_failed} of {np.size(view.variables['status'])} points failed ({detail}): "
            f"× {where_drawn}; see vrsweep info")


def _draw_failed_rug(ax, x, failed, row=0, colour=FAILED_COLOUR):
    """Failed points as x marks in a row just above the bottom edge of the axes.

    Their value is NaN, so no data coordinate can show them; axes coordinates can, on a linear
    or a log axis alike, and they do not move the data limits.
    """
    if not np.any(failed):
        return None
    (line,) = ax.plot(np.asarray(x)[failed], np.full(int(np.sum(failed)), FAILED_ROW_HEIGHT * (row + 0.7)),
                      "x", color=colour, ms=6, mew=1.5, zorder=6, clip_on=False,
                      transform=ax.get_xaxis_transform(), gid="failed")
    return line


def _span_grid(ax, values):
    """The x limits of the whole grid (plus a margin), whatever could be drawn."""
    low, high = _limits(values)
    margin = 0.03 * (high - low) if high > low else 0.5 * max(1.0, abs(low))
    ax.set_xlim(low - margin, high + margin)


# --------------------------------------------------------------------------------------------
# Analytic side on a fine grid: branches and resonance positions
# --------------------------------------------------------------------------------------------


def _fine_parameters(parameters, axis, values):
    """Every parameter as an array over ``values`` of ``axis`` (others constant)."""
    fine = {name: np.full(values.shape, float(parameters[name])) for name in PARAMETER_NAMES}
    fine[axis] = values
    return fine


def analytic_branches(parameters, axis, values, gain=True):
    """Branches of the analytic response along ``axis``: list of (x, y, stable) polylines.

    The roots of the fixed-point cubic (theory.analytic_columns: corrected eq2.24/eq2.27, ERRATA
    1-3) come sorted by size, so a root's slot changes where roots appear or vanish in pairs at a
    fold; each branch is followed by continuity instead. y is A/c with ``gain`` (ERRATA 6), else A.
    """
    from vrsweep import theory

    fine = _fine_parameters(parameters, axis, values)
    columns = theory.analytic_columns(fine)
    roots = columns["A_theory"][0]
    stable = columns["A_theory_stable"][0].astype(bool)
    if gain:
        with np.errstate(divide="ignore", invalid="ignore"):
            roots = roots / fine["c"][:, None]
    return _follow_branches(values, roots, stable)


def _follow_branches(x, roots, stable):
    """Join roots at neighbouring x into polylines, nearest to nearest (greedy by distance)."""
    finite = roots[np.isfinite(roots)]
    if finite.size == 0:
        return []
    jump_limit = 0.05 * (finite.max() - finite.min() + abs(finite).max())  # a fold, not a continuation
    active, finished = [], []
    for i in range(len(x)):
        present = [j for j in range(roots.shape[1]) if np.isfinite(roots[i, j])]
        pairs = sorted((abs(branch["y"][-1] - roots[i, j]), b, j)
                       for b, branch in enumerate(active) for j in present)
        matched_branches, matched_roots = set(), set()
        for distance, b, j in pairs:
            if b in matched_branches or j in matched_roots or distance > jump_limit:
                continue
            matched_branches.add(b)
            matched_roots.add(j)
            active[b]["x"].append(x[i])
            active[b]["y"].append(roots[i, j])
            active[b]["stable"].append(stable[i, j])
        still = [branch for b, branch in enumerate(active) if b in matched_branches]
        finished += [branch for b, branch in enumerate(active) if b not in matched_branches]
        still += [{"x": [x[i]], "y": [roots[i, j]], "stable": [stable[i, j]]}
                  for j in present if j not in matched_roots]
        active = still
    finished += active
    return [(np.array(b["x"]), np.array(b["y"]), np.array(b["stable"], dtype=bool)) for b in finished]


def _draw_branches(ax, branches, colour):
    """Stable runs solid, unstable runs dashed; each run shares its end point with the next."""
    for x, y, stable in branches:
        start = 0
        for end in range(1, len(x) + 1):
            if end == len(x) or stable[end] != stable[start]:
                stop = min(end + 1, len(x))
                ax.plot(x[start:stop], y[start:stop], color=colour, lw=1.3,
                        ls="-" if stable[start] else "--", zorder=2)
                start = end


def resonance_positions(parameters, axis, values):
    """Where along ``axis`` the effective frequency meets the slow one, wt2 = omega^2 (eq3.4).

    For the g axis these are +-g_res; for other axes the root is found on the fine grid ``values``
    (linear interpolation between sign changes). Empty where the axis leaves wt2 - omega^2 one-signed.
    """
    from vrsweep import theory

    if axis == "g":
        g_res = float(theory.g_res(parameters["alpha"], parameters["omega0"], parameters["omega"],
                                   parameters["Omega"]))
        return [g for g in (-g_res, g_res) if values.min() <= g <= values.max()]
    fine = _fine_parameters(parameters, axis, values)
    detuning = theory.effective_frequency_squared(fine) - np.square(fine["omega"])
    positions = []
    for i in np.flatnonzero(np.sign(detuning[:-1]) * np.sign(detuning[1:]) < 0):
        fraction = detuning[i] / (detuning[i] - detuning[i + 1])
        positions.append(float(values[i] + fraction * (values[i + 1] - values[i])))
    return positions


def _resonance_label(axis, position):
    if axis == "g":
        return f"$g_{{res}}$ = {position:.3f} (eq3.4)"
    return f"$\\tilde\\omega^2 = \\omega^2$ (eq3.4) at {PARAMETER_SYMBOLS.get(axis, axis)} = {position:.4g}"


# --------------------------------------------------------------------------------------------
# Sweep figures
# --------------------------------------------------------------------------------------------


def response_figure(ds, amplitude=False, x_axis=None, log=None) -> Figure:
    """R (or |Q|) against one axis with the analytic branches and the resonance (Fig. 1, Fig. 2).

    Markers follow the README ("Can R be trusted?"): filled where R_err <= 10% of R (R can be
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
            scale_note = f"log axis: the values span {span:.1f} decades (--linear for a linear one)"
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


def _draw_resonance_curve(ax, view, x_axis, y_axis):
    """The curve wt2 = omega^2 (eq3.4) in the plane of the two axes, e.g. g_res(Omega)."""
    from vrsweep import theory

    if view.config is None:
        return None
    xs = np.linspace(*_limits(view.axes[x_axis]), 400)
    ys = np.linspace(*_limits(view.axes[y_axis]), 400)
    X, Y = np.meshgrid(xs, ys)
    mesh = {name: np.full(X.shape, float(value)) for name, value in view.parameters().items()}
    mesh[x_axis], mesh[y_axis] = X, Y
    detuning = theory.effective_frequency_squared(mesh) - np.square(mesh["omega"])
    if not (np.nanmin(detuning) < 0.0 < np.nanmax(detuning)):
        return None
    ax.contour(X, Y, detuning, levels=[0.0], colors="white", linewidths=1.6, linestyles="--")
    return Line2D([], [], color="white", ls="--", lw=1.6,
                  label="$g_{res}(\\Omega)$: $\\tilde\\omega^2 = \\omega^2$ (eq3.4)")


def _limits(values):
    values = np.asarray(values, dtype=np.float64)
    return float(values.min()), float(values.max())


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


# --------------------------------------------------------------------------------------------
# Lyapunov exponents
# --------------------------------------------------------------------------------------------

LYAPUNOV_SYMBOL = "$\\lambda_1$"
STUCK_COLOUR = "tab:cyan"


def lyapunov_figure(ds, x_axis=None, bifurcation=False) -> Figure:
    """The largest Lyapunov exponent against one swept parameter, with the zero line (issue 13).

    Each point is drawn with its 95 % band (lyapunov_err), filled where lambda_1 exceeds its band
    above zero (chaos), hollow where not (periodic, or quasi-periodic when it stays within its band
    of zero). -inf (the mass stuck on the barrier in the window: tangent.py) cannot sit on a data
    axis: such points are triangles along the bottom edge, counted in the title, as failed points
    are x marks. ``bifurcation``: the bifurcation diagram above, on the same parameter axis.
    """
    view = _Sweep(ds)
    if "lyapunov" not in view.variables:
        raise ResultFileError(f"{view.path} has no lyapunov: run the sweep with integration.lyapunov: true")
    if bifurcation:
        view.require("strobe_x")
    x_axis = _choose_x_axis(view, x_axis, need_axes=1)
    if bifurcation:
        fig = _new_figure(8.0, 7.5)
        top, ax = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 2]})
        failure_note = _draw_bifurcation(top, view, x_axis)
    else:
        fig = _new_figure(8.0, 4.5)
        ax = fig.subplots()
    note = _draw_lyapunov(ax, view, x_axis)
    if not bifurcation:
        failure_note = _failure_note(view, "along the bottom edge") if "status" in view.variables else ""
    ax.set_xlabel(parameter_label(x_axis))
    notes = "; ".join(n for n in (_progress_note(view), failure_note, note) if n)
    what = (f"Bifurcation diagram (top) and largest Lyapunov exponent {LYAPUNOV_SYMBOL} (bottom)" if bifurcation
            else f"Largest Lyapunov exponent {LYAPUNOV_SYMBOL}")
    _title(fig, f"{what} against {PARAMETER_SYMBOLS.get(x_axis, x_axis)}: "
                f"{LYAPUNOV_SYMBOL} > 0 chaos, = 0 quasi-periodic, < 0 periodic",
           _caption(view.path, view.config, view.model, view.selected, notes, _width(fig)))
    return fig


def _draw_lyapunov(ax, view, x_axis):
    """lambda_1 with its band, the zero line, -inf and failed points; returns the -inf note."""
    x = np.asarray(view.axes[x_axis], dtype=np.float64)
    curves = view.curve_coordinates(x_axis)
    n_stuck = 0
    for k, (where, label) in enumerate(curves):
        colour = RELIABLE_COLOURS[k % len(RELIABLE_COLOURS)]
        exponent = view.along("lyapunov", x_axis, **where)
        error = view.along("lyapunov_err", x_axis, **where) if "lyapunov_err" in view.variables \
            else np.zeros_like(exponent)
        finite = np.isfinite(exponent)
        with np.errstate(invalid="ignore"):
            chaotic = finite & (exponent - error > 0.0)
        band = np.where(finite, error, np.nan)
        ax.fill_between(x, exponent - band, exponent + band, where=finite, color=colour, alpha=0.2, lw=0,
                        label=None if k else "95 % band (lyapunov_err)")
        ax.plot(x, np.where(finite, exponent, np.nan), "-", color=colour, lw=0.8, label=label or None, gid="lyapunov")
        ax.plot(x[chaotic], exponent[chaotic], "o", ms=3.5, color=colour, ls="none", gid="chaotic",
                label=None if k else f"{LYAPUNOV_SYMBOL} > 0 beyond its band: chaotic")
        calm = finite & ~chaotic
        ax.plot(x[calm], exponent[calm], "o", ms=3.5, mfc="none", color=colour, ls="none", gid="not_chaotic",
                label=None if k else "not chaotic: periodic (< 0) or quasi-periodic (= 0)")
        stuck = np.isneginf(exponent)
        n_stuck += int(np.sum(stuck))
        if np.any(stuck):
            ax.plot(x[stuck], np.full(int(np.sum(stuck)), FAILED_ROW_HEIGHT * (len(curves) + k + 0.7)), "v",
                    color=STUCK_COLOUR if len(curves) == 1 else colour, ms=6, zorder=6, clip_on=False,
                    transform=ax.get_xaxis_transform(), gid="stuck", ls="none",
                    label=None if k else f"{LYAPUNOV_SYMBOL} = $-\\infty$: stuck on the barrier")
        if "status" in view.variables:
            failed = _point_classes(view, x_axis, where)[2]
            _draw_failed_rug(ax, x, failed, row=k, colour=FAILED_COLOUR if len(curves) == 1 else colour)
    ax.axhline(0.0, color="k", lw=0.9, label=f"{LYAPUNOV_SYMBOL} = 0")
    _draw_resonance_lines(ax, view, x_axis, x)
    _span_grid(ax, x)
    ax.set_ylabel(f"{LYAPUNOV_SYMBOL}, per unit time {UNITS}")
    ax.grid(alpha=0.3)
    # Below the axes: a legend inside would cover points (the exponent fills its whole range).
    handles, labels = ax.get_legend_handles_labels()
    ax.figure.legend(handles, labels, fontsize=7.5, loc="outside lower center", ncol=3)
    if not n_stuck:
        return ""
    points = "1 point" if n_stuck == 1 else f"{n_stuck} points"
    return f"{points} stuck on the barrier in the window ({LYAPUNOV_SYMBOL} = -inf): ▼ along the bottom edge"


# --------------------------------------------------------------------------------------------
# Trajectory figures
# --------------------------------------------------------------------------------------------


def with_impacts(t, x, v, impacts, delta):
    """The samples with each impact inserted twice, (Delta, v before) then (Delta, v after).

    Sampled on a fixed grid, a rebound would be drawn as a chord between the samples on either
    side of it; with the impact points in place, lines reach the barrier and jump there.
    """
    if len(impacts) == 0 or delta is None:
        return t, x, v
    impact_t = impacts[:, 0]
    all_t = np.concatenate([t, impact_t, impact_t])
    all_x = np.concatenate([x, np.full(len(impacts), delta), np.full(len(impacts), delta)])
    all_v = np.concatenate([v, impacts[:, 1], impacts[:, 2]])
    rank = np.concatenate([np.ones(len(t)), np.zeros(len(impacts)), np.full(len(impacts), 2.0)])
    order = np.lexsort((rank, all_t))
    return all_t[order], all_x[order], all_v[order]


def parse_periods(text):
    """'FIRST:LAST' (slow periods, 1-based, inclusive; either may be empty) -> (first, last)."""
    first, colon, last = str(text).partition(":")
    try:
        window = (int(first) if first.strip() else 1, int(last) if last.strip() else None)
    except ValueError:
        window = None
    if not colon or window is None or window[0] < 1 or (window[1] is not None and window[1] < window[0]):
        raise UsageError.naming("{periods} {value}: expected FIRST:LAST slow periods, e.g. 1:20 or 81:100",
                                value=text)
    return window


def slow_periods_in(data):
    """How many slow periods a trajectory file spans (None if it does not say its slow period)."""
    slow_period = float(data.attrs.get("slow_period", 0.0)) or None
    if slow_period is None:
        return None
    run = next(iter(data.runs.values()))
    return int(round((run.t[-1] - run.t[0]) / slow_period))


def _time_window(data, periods):
    """(t_start, t_end) of slow periods FIRST..LAST; the whole run for None."""
    slow_period = float(data.attrs.get("slow_period", 0.0)) or None
    run = next(iter(data.runs.values()))
    if periods is None or slow_period is None:
        return run.t[0], run.t[-1]
    first, last = periods
    n_periods = slow_periods_in(data)
    last = n_periods if last is None else last
    if first > n_periods:
        raise UsageError.naming("{periods} {value}: the run has {n} slow periods", value=f"{first}:{last}",
                                n=n_periods)
    return (first - 1) * slow_period, min(last, n_periods) * slow_period


def _in_window(t, window, *arrays):
    keep = (t >= window[0] - 1e-9) & (t <= window[1] + 1e-9)
    return (t[keep],) + tuple(a[keep] for a in arrays)


def _point_text(config):
    if config is None:
        return ""
    return f"g = {_number(config.parameters['g'])}, Ω = {_number(config.parameters['Omega'])}"


def _window_text(window, data):
    slow_period = float(data.attrs.get("slow_period", 0.0))
    if not slow_period:
        return f"t in [{window[0]:.4g}, {window[1]:.4g}]"
    return f"slow periods {round(window[0] / slow_period) + 1}-{round(window[1] / slow_period)} of T = 2π/ω"


ROW_TITLES = {"original": "original system (eq2.1-eq2.2)", "effective": "effective system (eq2.10)"}
TRANSIENT_COLOUR = "0.65"
STEADY_COLOUR = "tab:blue"


def trajectory_figure(data, periods=None) -> Figure:
    """Position, velocity and phase portrait; original above effective (Fig. 3-5).

    periods: (first, last) slow periods to show (1-based, inclusive), default the whole run. The
    transient (the config's transient_periods) is drawn grey, the rest blue.
    """
    config = _parse_config(data.config_text)
    delta = config.parameters["Delta"] if config is not None else None
    window = _time_window(data, periods)
    slow_period = float(data.attrs.get("slow_period", 0.0))
    t_transient = config.integration.transient_periods * slow_period if config is not None else 0.0
    runs = list(data.runs.values())
    fig = _new_figure(13.0, 3.3 * len(runs) + 0.9)
    grid = fig.subplots(len(runs), 3, squeeze=False)
    letters = iter("abcdef")
    for row, run in zip(grid, runs):
        t, x, v = with_impacts(run.t, run.x, run.v, run.impacts, delta)
        t, x, v = _in_window(t, window, x, v)
        ax_x, ax_v, ax_phase = row
        for part, colour, label in ((t <= t_transient, TRANSIENT_COLOUR, "transient"),
                                    (t >= t_transient, STEADY_COLOUR, "after the transient")):
            if np.count_nonzero(part) < 2:
                continue
            ax_x.plot(t[part], x[part], lw=0.4, color=colour)
            ax_v.plot(t[part], v[part], lw=0.4, color=colour)
            ax_phase.plot(x[part], v[part], lw=0.3, color=colour, label=label)
        if delta is not None:
            ax_x.axhline(delta, color="k", lw=0.8, ls="--")
            ax_phase.axvline(delta, color="k", lw=0.8, ls="--", label="barrier $x = \\Delta$")
        ax_phase.legend(fontsize=7, loc="lower left")
        status = "" if run.status == Status.OK else f" (stopped: {run.status.name.lower()})"
        for ax, what in ((ax_x, "position"), (ax_v, "velocity"), (ax_phase, "phase portrait")):
            ax.set_title(f"({next(letters)}) {ROW_TITLES.get(run.model, run.model)}: {what}{status}", fontsize=9)
            ax.grid(alpha=0.3)
        for ax in (ax_x, ax_v):
            ax.set_xlabel(f"time $t$ {UNITS}")
            ax.set_xlim(*window)
        ax_x.set_ylabel(f"position $x$ {UNITS}")
        ax_v.set_ylabel(f"velocity $\\dot{{x}}$ {UNITS}")
        ax_phase.set_xlabel(f"position $x$ {UNITS}")
        ax_phase.set_ylabel(f"velocity $\\dot{{x}}$ {UNITS}")
    samples = data.attrs.get("samples_per_period", "?")
    _title(fig, f"Trajectory at {_point_text(config)}, {_window_text(window, data)}: position, velocity, "
                f"phase portrait ({samples} dense-output samples per slow period, impacts exact; dashed: barrier)",
           _caption(data.path or "", config, " and ".join(ROW_TITLES.get(m, m) for m in data.runs),
                    width=_width(fig)))
    return fig


def impacts_per_period_figure(datasets) -> Figure:
    """Impacts in each slow period against the period number, transient included (Fig. impact_no).

    One panel per file (e.g. g = 5 and g = 20), each with its own count axis: a shared one would
    take its limits from one panel and clip the others. The measurement window's mean -- what
    ``vrsweep run`` stores as impacts_per_period -- is drawn over it.
    """
    from matplotlib.ticker import MaxNLocator

    fig = _new_figure(8.0, 2.7 * len(datasets) + 1.0)
    axes = fig.subplots(len(datasets), 1, squeeze=False, sharex=len(datasets) > 1)[:, 0]
    configs = [_parse_config(data.config_text) for data in datasets]
    for k, (ax, data, config) in enumerate(zip(axes, datasets, configs)):
        run = data.runs.get(data.model) or next(iter(data.runs.values()))
        counts = np.asarray(run.impacts_per_period)
        periods = np.arange(1, len(counts) + 1)
        ax.plot(periods, counts, "o-", color="tab:blue", lw=0.7, ms=2.5, label=ROW_TITLES.get(run.model, run.model))
        if config is not None:
            n_transient = config.integration.transient_periods
            if 0 < n_transient < len(counts):
                mean = counts[n_transient:].mean()
                ax.axvline(n_transient + 0.5, color="0.4", ls=":", lw=1.0, label="end of the transient")
                ax.hlines(mean, n_transient + 0.5, len(counts) + 0.5, color="tab:red", lw=1.4,
                          label=f"mean over the measured periods: {mean:.2f}")
        letter = f"({'abcdefgh'[k]}) " if len(datasets) > 1 else ""
        ax.set_title(f"{letter}{_point_text(config)}  ·  {os.path.basename(data.path or '')}  ·  "
                     f"{int(counts.sum())} impacts in {len(counts)} slow periods", fontsize=9)
        ax.set_ylabel(f"impacts per slow period {UNITS}")
        top = max(1.0, float(counts.max(initial=0)))
        ax.set_ylim(-0.06 * top, 1.08 * top)  # room for the markers of 0 and of the largest count
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_xlim(0.5, len(counts) + 0.5)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7.5, loc="upper right")
    axes[-1].set_xlabel(f"slow period number $n$ (period $T = 2\\pi/\\omega$) {UNITS}")
    config = configs[0]
    varying = {}
    if config is not None and len(datasets) > 1:
        varying = {name: config.parameters[name] for name in PARAMETER_NAMES
                   if any(c is not None and c.parameters[name] != config.parameters[name] for c in configs)}
    names = ", ".join(os.path.basename(data.path or "") for data in datasets)
    _title(fig, "Impacts in each slow period $2\\pi/\\omega$, transient included"
                + (f" (the panels differ in {', '.join(varying)})" if varying else ""),
           _caption(names, config, datasets[0].model, omit=varying, width=_width(fig)))
    return fig


SLOW_FLOW_STYLES = {
    "state": dict(color="tab:blue", ls="-", lw=1.1,
                  label="slow flow (corrected eq2.24) from $R_0, \\theta_0$ of x(0), $\\dot{x}(0)$ (ERRATA 9)"),
    "paper": dict(color="tab:green", ls="--", lw=1.1,
                  label="slow flow (corrected eq2.24) from the paper's $R_0 = \\Delta$, $\\theta_0 = 0$ (eq2.22)"),
    "paper_literal": dict(color="0.35", ls=":", lw=1.1,
                          label="slow flow as printed in the paper (sin/cos swapped, ERRATA 1), paper's start"),
}


def slow_flow_figure(data, periods=None, starts=("state", "paper", "paper_literal")) -> Figure:
    """The effective system (numerical) against the first-order reconstruction eq2.21 (Fig. 6)."""
    if "effective" not in data.runs or not data.slow_flow:
        raise UsageError.naming("{path} holds no effective trajectory and slow flow: make it with "
                                "vrsweep simulate --compare effective (or a config with model: effective)",
                                path=data.path)
    config = _parse_config(data.config_text)
    delta = config.parameters["Delta"] if config is not None else None
    window = _time_window(data, periods)
    run = data.runs["effective"]
    t, x, v = with_impacts(run.t, run.x, run.v, run.impacts, delta)
    t, x, v = _in_window(t, window, x, v)
    fig = _new_figure(13.0, 4.8)
    ax_x, ax_v, ax_phase = fig.subplots(1, 3)
    numerical = dict(color="tab:red", lw=1.6, alpha=0.8, label="effective system eq2.10, numerical (with impacts)")
    ax_x.plot(t, x, **numerical)
    ax_v.plot(t, v, **numerical)
    ax_phase.plot(x, v, **numerical)
    for start in starts:
        if start not in data.slow_flow:
            continue
        flow = data.slow_flow[start]
        flow_t, flow_x, flow_v = _in_window(flow.t, window, flow.x, flow.v)
        style = dict(SLOW_FLOW_STYLES.get(start, dict(label=start)))
        if not np.isfinite(flow_x).any():  # say so rather than list a curve that draws nothing
            style["label"] += ": no finite value (not drawn)"
        ax_x.plot(flow_t, flow_x, **style)
        ax_v.plot(flow_t, flow_v, **style)
        ax_phase.plot(flow_x, flow_v, **style)
    if delta is not None:
        ax_x.axhline(delta, color="k", lw=0.8, ls="-.", label="barrier $x = \\Delta$")
        ax_phase.axvline(delta, color="k", lw=0.8, ls="-.")
    for ax, what, letter in ((ax_x, "position", "a"), (ax_v, "velocity", "b"), (ax_phase, "phase portrait", "c")):
        ax.set_title(f"({letter}) {what}", fontsize=9)
        ax.grid(alpha=0.3)
    for ax in (ax_x, ax_v):
        ax.set_xlabel(f"time $t$ {UNITS}")
        ax.set_xlim(*window)
    ax_x.set_ylabel(f"position $x$, $X$ {UNITS}")
    ax_v.set_ylabel(f"velocity $\\dot{{x}}$, $\\dot{{X}}$ {UNITS}")
    ax_phase.set_xlabel(f"position $x$, $X$ {UNITS}")
    ax_phase.set_ylabel(f"velocity $\\dot{{x}}$, $\\dot{{X}}$ {UNITS}")
    handles, labels = ax_x.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=2, fontsize=7.5)
    _title(fig, f"Effective system against the slow-flow reconstruction X = R cos(ωt + θ) (eq2.21) at "
                f"{_point_text(config)}, {_window_text(window, data)}; the first-order theory ignores the barrier",
           _caption(data.path or "", config, "effective system eq2.10 and its slow flow", width=_width(fig)))
    return fig


__all__ = [
    "KINDS", "SWEEP_KINDS", "TRAJECTORY_KINDS", "RELATIVE_ERROR_LIMIT", "load", "default_kind", "plot",
    "select", "response_figure", "map_figure", "impacts_figure", "status_figure", "bifurcation_figure",
    "trajectory_figure", "impacts_per_period_figure", "slow_flow_figure", "analytic_branches",
    "resonance_positions", "with_impacts", "parse_periods", "slow_periods_in", "parameter_label",
]


# --------------------------------------------------------------------------------------------
# Basins of attraction (issue 13): sweeps with x0 / v0 axes
# --------------------------------------------------------------------------------------------

BASIN_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
                 "tab:pink", "tab:olive", "tab:cyan", "gold")
BASIN_FAILED = "black"        # a point whose integration failed (label -1)
BASIN_NOT_COMPUTED = "white"  # an unfinished file's missing points


def basin_plot(results, at=None) -> Figure:
    """``vrsweep plot FILE --kind basin``: the x0-v0 plane of one slice coloured by attractor.

    results: a path, or the Dataset of a sweep with x0 and/or v0 axes (``load``,
    ``vrsweep.open_results``); at: {axis: value} fixing every other axis with more than one value
    (a slice's parameters).
    """
    from vrsweep.trajectory_file import TrajectoryData

    data = load(results) if isinstance(results, (str, os.PathLike)) else results
    if isinstance(data, TrajectoryData):
        raise UsageError.naming("{kind} basin is for sweep results with x0 / v0 axes, not trajectory files")
    axes = _grid_axes(data)
    if "attractor" not in data.data_vars:
        path = _path(data)
        if data.attrs.get("shard"):
            raise UsageError.naming("{path} is a shard: attractors are labelled over whole slices, after "
                                    "vrsweep merge; plot the merged file", path=path)
        if not data.attrs.get("vrsweep_complete", 0):
            raise UsageError.naming("{path} is unfinished: attractors are labelled when the sweep ends "
                                    "(vrsweep run CONFIG --resume finishes it)", path=path)
        if not any(name in axes for name in ("x0", "v0")):
            raise UsageError.naming("{path} has no x0 or v0 axis: a basin plot needs a sweep over the "
                                    "initial state (sweep: {{x0: ..., v0: ...}})", path=path)
        raise ResultFileError(f"{path} has x0 / v0 axes but no attractor labels (merged or written by a "
                              "vrsweep that does not label them): 'vrsweep run CONFIG --resume -o "
                              f"{path}' adds them without computing any point again")
    at = dict(at or {})
    for name, values in axes.items():  # a one-value axis needs no at
        if name not in at and name not in ("x0", "v0") and len(values) == 1:
            at[name] = str(values[0])
    return basin_figure(select(data, at))


def basin_figure(ds) -> Figure:
    """Attractor labels over the x0-v0 plane (or along x0 or v0), legend from the attractor table;
    ``ds``: one slice of a sweep over the initial state (other axes fixed with ``select``)."""
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
    colours = [BASIN_COLOURS[k % len(BASIN_COLOURS)] for k in range(count)]
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
    handles = [_basin_handle(view, label, colours[label]) for label in range(count)]
    n_failed = int(np.sum((labels < 0) & (status != Status.NOT_COMPUTED)))
    if n_failed:
        handles.append(Line2D([], [], marker="s", ls="", color=BASIN_FAILED, markersize=9,
                              label=f"failed ({n_failed} points, see --kind status)"))
    n_missing = int(np.sum(status == Status.NOT_COMPUTED))
    if n_missing:
        handles.append(Line2D([], [], marker="s", ls="", color=BASIN_NOT_COMPUTED, markeredgecolor="0.5",
                              markersize=9, label=f"not computed ({n_missing} points)"))
    fig.legend(handles=handles, loc="outside lower center", ncols=1 if count <= 3 else 2, fontsize=8,
               title="attractor: period, gain R = |Q|/c (eq3.3), impacts, share of the plane", title_fontsize=8)
    found = f"{count} attractor{'s' if count != 1 else ''}"
    _title(fig, f"Basins of attraction in the plane of initial states: {found}",
           _basin_caption(view, _width(fig)))
    return fig


def _state_label(name):
    from vrsweep.model import INITIAL_STATE_LONG_NAMES, INITIAL_STATE_SYMBOLS

    words = INITIAL_STATE_LONG_NAMES[name].rsplit(" ", 1)[0]
    return f"{words} {INITIAL_STATE_SYMBOLS[name]} {UNITS}"


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
        hits = f"{per_period:.3g} impacts per slow period"
    text = f"{label}: {kind}, R = {R:.4g}, {hits}, {100 * fraction:.1f}%"
    return Line2D([], [], marker="s", ls="", color=colour, markersize=9, label=text)


def _basin_caption(view, width):
    """The caption of a basin plot: the slice's parameters (not the config's unused initial state)."""
    items = [os.path.basename(view.path), MODEL_EQUATIONS.get(view.model, view.model)]
    if view.config is not None:
        parameters = view.parameters()
        items += [f"{PARAMETER_SYMBOLS[name]} = {_number(parameters[name])}" for name in PARAMETER_NAMES]
        run = view.config.integration
        items.append(f"{run.transient_periods} transient + {run.measure_periods} measured slow periods")
    items += [UNITS_NOTE] + ([_progress_note(view)] if not view.complete else [])
    lines, line = [], ""
    for item in items:
        visible = len(item.replace("$", "").replace("\\", ""))
        if line and len(line.replace("$", "").replace("\\", "")) + visible + 2 > width:
            lines.append(line)
            line = ""
        line = f"{line},  {item}" if line else item
    return "\n".join(lines + [line])
