"""Bifurcation curves over a map (issue 21): ``vrsweep plot MAP.h5 CURVES.h5 [CURVES2.h5 ...]``.

The map is the heat map of any variable that ``map_figure`` draws (R, period, impacts_per_period,
lyapunov...); over it go the curves of one or more curves files (``vrsweep continue BRANCH.h5
--point K --along NAME``, layout in store/curve_file.py): each kind in its own colour and line
style (fold, period doubling, grazing), codimension-two points (fold meeting grazing, period
doubling meeting grazing, cusps) as black markers, every kind named once in the legend. For an
effective-model map the corrected first-order theory's fold curve (``theory.fold_discriminant``:
two fixed points of the slow flow eq2.24 merge) and its Hopf curve (the small fixed point changes
stability; a Neimark-Sacker curve of the orbits) are drawn too, thin, in the same colours as their
numerical counterparts.

The map's two swept axes must be the curves' two parameters (either order); nothing is computed
here but the analytic curves.
"""

from __future__ import annotations

import os

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from vrsweep.errors import UsageError
from vrsweep.plot.palettes import cased
from vrsweep.plot.labels import Wrapped, literal, _legend_columns, _parse_config, _title, _width, caption_lines, figure_options
from vrsweep.plot.selection import _limits, _map_axes, _Sweep, fine_grid

FILE_KIND = "curves"

# Colours that stay apart from each other and from viridis and the discrete maps' colours; each
# line is cased in black or white (palettes.cased), readable on dark and light cells alike.
CURVE_STYLES = {
    "fold": dict(color="#d62728", ls="-", label="fold (saddle-node): $\\mu = 1$"),
    "period_doubling": dict(color="#ff7f0e", ls=(0, (6, 2)), label="period doubling: $\\mu = -1$"),
    "grazing": dict(color="#111111", ls=(0, (1.5, 1.5)), label="grazing: the orbit touches the barrier"),
    "neimark_sacker": dict(color="#e377c2", ls=(0, (5, 1.5, 1.5, 1.5)), label="Neimark-Sacker"),
}
OTHER_CURVE = dict(color="#17becf", ls="-.")
CURVE_WIDTH = 2.2
SPECIAL_MARKERS = {
    "fold_grazing": ("D", "fold meets grazing"),
    "period_doubling_grazing": ("s", "period doubling meets grazing"),
    "cusp": ("*", "cusp: two folds meet"),
}
ANALYTIC_STYLES = {
    "fold": dict(color="#d62728", ls=(0, (3, 2)), lw=1.6,
                 label="theory (corrected): fold, two fixed points of the slow flow merge"),
    "hopf": dict(color="#e377c2", ls=(0, (3, 2)), lw=1.6,
                 label="theory (corrected): Hopf of the slow flow (Neimark-Sacker)"),
}
ANALYTIC_MESH = 400  # points per axis of the mesh the analytic curves are contoured on


def is_curves(data) -> bool:
    return hasattr(data, "attrs") and data.attrs.get("vrsweep_file") == FILE_KIND


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def check_curves(ds):
    """A ResultFileError unless ``ds`` has what the figure draws: two parameters and the curves."""
    from vrsweep.errors import ResultFileError

    path = ds.encoding.get("source", "the curves file")
    names = parameter_names(ds)
    if len(names) != 2:
        raise ResultFileError(f"{path}: a curves file names two parameters (root attribute parameter_names); "
                              f"it has {', '.join(names) or 'none'}")
    missing = [name for name in ("curve", *names, "curve_kind") if name not in ds.variables]
    if missing:
        raise ResultFileError(f"{path}: a curves file without {', '.join(missing)}")


def parameter_names(ds) -> list:
    """The curves' two parameters, in the file's order (root attribute ``parameter_names``)."""
    names = ds.attrs.get("parameter_names")
    if names is None:
        return []
    return [_text(name) for name in np.atleast_1d(names)]


def _path(ds):
    return os.path.basename(str(ds.encoding.get("source", "") or "curves"))


@figure_options
def curves_figure(ds, curve_files, name="R", x_axis=None, log=False, vmin=None, vmax=None) -> Figure:
    """The map of ``name`` from sweep Dataset ``ds`` (``map_figure``) with the bifurcation curves of
    the curves Datasets ``curve_files`` over it, and for the effective model the analytic fold and
    Hopf curves. Takes the options of every map (title, size, style, vmin, vmax)."""
    from vrsweep.plot.sweeps import map_figure

    view = _Sweep(ds)
    x_axis, y_axis = _map_axes(view, x_axis)
    for curves in curve_files:
        check_curves(curves)
        names = parameter_names(curves)
        if sorted(names) != sorted((x_axis, y_axis)):
            raise UsageError.naming("{path} has curves in ({curve_names}) but the map {map} is over ({map_names}): "
                                    "the curves' parameters must be the map's axes",
                                    path=_path(curves), curve_names=", ".join(names), map=view.path,
                                    map_names=f"{x_axis}, {y_axis}")
        _check_same_system(view, curves)
    # The map itself, undecorated: the options apply once, to the whole figure.
    fig = map_figure.__wrapped__(ds, name, x_axis=x_axis, log=log, vmin=vmin, vmax=vmax)
    maps = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    handles = {}
    for ax in maps:
        x_limits, y_limits = ax.get_xlim(), ax.get_ylim()
        if view.model == "effective" and view.config is not None:
            handles.update(_draw_analytic(ax, view, x_axis, y_axis))
        for curves in curve_files:
            handles.update(_draw_curves(ax, curves, x_axis, y_axis))
        ax.set_xlim(x_limits)  # curves running beyond the map do not stretch it
        ax.set_ylim(y_limits)
    _relegend(fig, handles)
    what, caption = getattr(fig, "_vrsweep_description", ("", ""))
    files = [literal(_path(curves)) + ("," if number < len(curve_files) - 1 else "")
             for number, curves in enumerate(curve_files)]
    counts = _curve_counts(curve_files)
    head, grey, tail = what.partition(" (light grey")  # the map's note on grey cells stays last
    if curve_files:
        what = f"{head} with bifurcation curves{grey}{tail}"
        caption = caption_lines(caption, _wrapped(['curves:'] + files + ([f'({counts})'] if counts else []),
                                                  _width(fig)))
    elif handles:
        what = f"{head} with the corrected theory's fold and Hopf curves{grey}{tail}"
    _title(fig, what, caption)
    return fig


def _wrapped(words, width):
    """Words joined by spaces, a new line before one that would pass ``width`` characters (a
    :class:`Wrapped`: unbroken in the figure's metadata)."""
    lines, line = [], ""
    for word in words:
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}" if line else word
    return Wrapped("\n".join(lines + [line]), " ".join(words))


def _check_same_system(view, curves):
    """Curves of another model, or at other fixed parameters, do not belong on this map."""
    model = _text(curves.attrs.get("model", ""))
    if model and view.model and model != view.model:
        raise UsageError.naming("{path} holds curves of the {model} model and the map {map} is of the "
                                "{map_model} model", path=_path(curves), model=model, map=view.path,
                                map_model=view.model)
    config = _parse_config(_text(curves.attrs.get("config", "")))
    if config is None or view.config is None:
        return
    plane = set(parameter_names(curves))
    swept = {axis.name for axis in view.config.axes}
    for parameter, value in view.config.parameters.items():
        if parameter in plane or parameter in swept:
            continue
        other = float(config.parameters[parameter])
        if not np.isclose(other, float(value), rtol=1e-12, atol=0.0):
            raise UsageError.naming("{path} was computed at {parameter} = {value} and the map {map} at "
                                    "{parameter} = {map_value}", path=_path(curves), parameter=parameter,
                                    value=f"{other:g}", map=view.path, map_value=f"{float(value):g}")


def _curve_counts(curve_files):
    kinds = {}
    for curves in curve_files:
        for kind in np.atleast_1d(curves["curve_kind"].values):
            kinds[_text(kind)] = kinds.get(_text(kind), 0) + 1
    return ", ".join(f"{count} {kind.replace('_', ' ')}" for kind, count in kinds.items())


def _draw_curves(ax, curves, x_axis, y_axis):
    """Every curve of one file, each point list in arc order; the special points as markers."""
    handles = {}
    number = np.asarray(curves["curve"].values)
    xs, ys = np.asarray(curves[x_axis].values, dtype=float), np.asarray(curves[y_axis].values, dtype=float)
    kinds = [_text(kind) for kind in np.atleast_1d(curves["curve_kind"].values)]
    for curve, kind in enumerate(kinds):
        mine = number == curve
        if not mine.any():
            continue
        style = CURVE_STYLES.get(kind, {**OTHER_CURVE, "label": kind.replace("_", " ")})
        line_style = {key: value for key, value in style.items() if key != "label"}
        # Cased in the contrasting colour: a white edge alone vanished with the orange and pink
        # cores over the yellow and green cells (and on a greyscale page).
        ax.plot(xs[mine], ys[mine], lw=CURVE_WIDTH, zorder=6, gid=f"curve_{kind}",
                path_effects=cased(style["color"], CURVE_WIDTH), **line_style)
        handles[f"curve_{kind}"] = Line2D([], [], lw=CURVE_WIDTH, path_effects=cased(style["color"], CURVE_WIDTH),
                                          **style)
    if "special_kind" in curves.variables:
        special_x = np.atleast_1d(np.asarray(curves[f"special_{x_axis}"].values, dtype=float))
        special_y = np.atleast_1d(np.asarray(curves[f"special_{y_axis}"].values, dtype=float))
        for kind, x, y in zip(np.atleast_1d(curves["special_kind"].values), special_x, special_y):
            kind = _text(kind)
            marker, label = SPECIAL_MARKERS.get(kind, ("o", kind.replace("_", " ")))
            ax.plot([x], [y], marker=marker, ms=10 if marker == "*" else 7, color="k", mec="white", mew=1.2,
                    ls="none", zorder=7, gid=f"special_{kind}")
            handles[f"special_{kind}"] = Line2D([], [], marker=marker, color="k", mec="white", mew=1.2, ls="none",
                                                label=label)
    return handles


def analytic_fields(parameters, x_axis, y_axis, x_values, y_values):
    """The functions whose zero sets are the analytic fold and Hopf curves, on the mesh of
    ``x_values`` x ``y_values`` (arrays indexed [y, x], as contour takes them): {"fold": D, "hopf": H}
    with D = ``theory.fold_discriminant`` and H = ``theory.hopf_function`` (NaN where the Hopf
    condition's fixed point is not a focus: K <= 0 or a non-positive Jacobian determinant)."""
    from vrsweep.analysis import theory

    X, Y = np.meshgrid(x_values, y_values)
    mesh = {name: np.full(X.shape, float(value)) for name, value in parameters.items()}
    mesh[x_axis], mesh[y_axis] = X, Y
    fold = theory.fold_discriminant(mesh)
    hopf = theory.hopf_function(mesh)
    K = theory.damping_level(mesh)
    with np.errstate(invalid="ignore", divide="ignore"):
        R = np.sqrt(np.where(K > 0.0, 2.0 * K, np.nan))
        J = theory.slow_flow_jacobian(R, theory.fixed_point_phase(R, mesh), mesh)
        determinant = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    hopf = np.where(np.isfinite(R) & (determinant > 0.0), hopf, np.nan)
    # The effective system averages over the fast force: where Omega <= omega it has none, and
    # neither curve means anything (theory.fast_force).
    fast = np.broadcast_to(theory.fast_force(mesh), X.shape)
    return {"fold": np.where(fast, fold, np.nan), "hopf": np.where(fast, hopf, np.nan)}


def _draw_analytic(ax, view, x_axis, y_axis):
    """The corrected theory's fold and Hopf curves in the plane of the map's axes (effective model;
    none when an axis is Delta or e, which the theory ignores)."""
    from vrsweep.analysis.theory import THEORY_PLANE_PARAMETERS

    if x_axis not in THEORY_PLANE_PARAMETERS or y_axis not in THEORY_PLANE_PARAMETERS:
        return {}
    # Evenly in log on a logarithmic axis (a geometric grid's: selection.fine_grid), as the map's cells are.
    x_values = fine_grid(view.axes[x_axis], ANALYTIC_MESH)
    y_values = fine_grid(view.axes[y_axis], ANALYTIC_MESH)
    parameters = {name: value for name, value in view.parameters().items()}
    handles = {}
    for kind, field in analytic_fields(parameters, x_axis, y_axis, x_values, y_values).items():
        finite = field[np.isfinite(field)]
        if not (finite.size and finite.min() < 0.0 < finite.max()):
            continue
        style = ANALYTIC_STYLES[kind]
        contour = ax.contour(x_values, y_values, field, levels=[0.0], colors=[style["color"]],
                             linewidths=style["lw"], linestyles=[style["ls"]], zorder=4)
        contour.set_gid(f"analytic_{kind}")
        contour.set_path_effects(cased(style["color"], style["lw"]))
        handles[f"analytic_{kind}"] = Line2D([], [], path_effects=cased(style["color"], style["lw"]), **style)
    return handles


def _relegend(fig, handles):
    """One legend below the maps: the map's own entries, then the curves'."""
    old_handles, old_labels = [], []
    for legend in list(fig.legends):
        old_handles += list(legend.legend_handles)
        old_labels += [text.get_text() for text in legend.get_texts()]
        legend.remove()
    order = sorted(handles, key=lambda key: (not key.startswith("curve"), not key.startswith("special"), key))
    new_handles = old_handles + [handles[key] for key in order]
    new_labels = old_labels + [handles[key].get_label() for key in order]
    if not new_handles:
        return
    legend = fig.legend(new_handles, new_labels, fontsize="x-small", loc="outside lower center",
                        ncol=_legend_columns(fig, 2), facecolor="0.3", framealpha=0.9)
    for text in legend.get_texts():
        text.set_color("white")
