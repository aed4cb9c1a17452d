"""The figure of a branch file (``vrsweep continue``): R along the continued parameter, stable
orbits solid and unstable dashed, the located bifurcations marked and named, sweep files on the
same axes, the corrected theory's branches for the effective model; below, the moduli of the
Floquet multipliers (in the branch's colour: |mu_1| thick, |mu_2| thin) with the unit circle's
level, broken at grazes."""

from __future__ import annotations

import os

import numpy as np
from matplotlib.figure import Figure

from vrsweep.errors import UsageError
from vrsweep.plot.analytic import _draw_branches, analytic_branches
from vrsweep.plot.layout import fit_y_to_view
from vrsweep.plot.palettes import LINE_COLOURS, QUALITATIVE, categorical
from vrsweep.plot.labels import (
    model_title, parameter_symbol,
    _caption, _legend_columns, _new_figure, _title, _width, figure_options, parameter_label,
    written_response_label,
)
from vrsweep.store.branch_file import TAG_PREFIXES, UNLOCATED, bifurcation_tags

# One symbol, one meaning: the bifurcations' markers, the periods' markers along the lines and
# the sweeps' markers are three disjoint sets (a sweep's points were "^", the grazing tag's marker;
# the second and third periods' "o" and "s" were the fold's and the period doubling's).
BIFURCATION_MARKERS = {"fold": ("o", "fold"), "period_doubling": ("s", "period doubling"),
                       "neimark_sacker": ("D", "Neimark-Sacker"), "grazing": ("^", "grazing"),
                       "branch_point": ("d", "branch point")}
# Not located: one symbol for it, the tag (G?1, F?1, ...) saying which kind.
BIFURCATION_MARKERS.update({UNLOCATED + kind: ("p", f"{words}, not located")
                            for kind, (_, words) in list(BIFURCATION_MARKERS.items())})
UNKNOWN_BIFURCATION_MARKER = "8"
# A sweep's points: the direction the parameter moved, along the horizontal axis; "x" where no
# direction (every point from the config's initial state).
SWEEP_MARKERS = {None: "x", 1: ">", -1: "<"}
# The sweeps' colours in turn (the sweeps of a figure, apart in grey: palettes.LINE_COLOURS).
SWEEP_COLOURS = LINE_COLOURS[2:]
BRANCH_COLOUR = QUALITATIVE[0]  # the first period's: palettes.categorical's first
# The corrected theory's branches (effective model), under the orbits: a light grey (L* 63) that
# is not the first period's (29), the one period drawn without markers; the others carry markers.
THEORY_COLOUR = "0.6"
# Where a bifurcation is, across the multipliers' panel; named in the legend.
BIFURCATION_LINE = "0.7"
BIFURCATION_LINE_LABEL = "bifurcation, in $|\\mu|$"
FINE_POINTS = 600
# The multipliers' panel is logarithmic when their moduli span more than this factor.
LOG_SPAN = 100.0
ROUNDOFF_SPAN = 1e13


def is_branch(data) -> bool:
    return hasattr(data, "attrs") and data.attrs.get("vrsweep_file") == "branch"


def _runs(values, stable, breaks=None):
    """Index ranges of equal stability; each run shares its last point with the next one, except
    across a break (``breaks[i]``: points i and i + 1 are not to be joined)."""
    start = 0
    for end in range(1, len(values) + 1):
        broken = end < len(values) and breaks is not None and breaks[end - 1]
        if end == len(values) or broken or stable[end] != stable[start]:
            yield slice(start, end if broken else min(end + 1, len(values))), bool(stable[start])
            start = end


GRAZE_MATCH = 0.05  # a graze's R within this share of the branch's R span of a segment's: the segment it lies on


def _multiplier_breaks(values, gain, impacts, grazes):
    """breaks[i]: points i and i + 1 of one branch lie on either side of a graze or of a change of
    impacts_per_period. The multipliers jump there (through the saltation matrix, e.g. 27 to 0.68
    on impact_linear): a line between them would draw a continuity there is none of. ``grazes``:
    (parameter, R) of the grazes located on this branch."""
    breaks = np.zeros(max(len(values) - 1, 0), dtype=bool)
    if impacts is not None:
        with np.errstate(invalid="ignore"):
            breaks |= impacts[1:] != impacts[:-1]
    span = float(np.nanmax(gain) - np.nanmin(gain)) if len(gain) else 0.0
    for at, R in grazes:
        # The segment that brackets the graze in the parameter, and nearest it in R: a branch that
        # turns back brackets one parameter several times (a fold, the other side of an S).
        lows, highs = np.minimum(values[:-1], values[1:]), np.maximum(values[:-1], values[1:])
        candidates = np.nonzero((lows <= at) & (at <= highs))[0]
        if candidates.size == 0 or not np.isfinite(R):
            continue
        step = values[candidates + 1] - values[candidates]
        share = np.divide(at - values[candidates], step, out=np.zeros_like(step), where=step != 0)
        between = gain[candidates] + share * (gain[candidates + 1] - gain[candidates])
        nearest = int(np.argmin(np.abs(between - R)))
        if abs(between[nearest] - R) <= GRAZE_MATCH * max(span, 1e-12):
            breaks[candidates[nearest]] = True
    return breaks


# Located bifurcations at which a branch's stability changes: drawn into its line, so that solid
# turns to dashed there and not at the next orbit (on a branch of steps of 0.025 in omega the
# symmetric Duffing oscillator's lines changed style 0.0045 past its branch point).
STABILITY_KINDS = ("fold", "period_doubling", "neimark_sacker", "branch_point")


def _with_bifurcations(values, gain, stable, modulus, impacts, points):
    """The branch's arrays with each of ``points`` [(parameter, R, (2,) moduli)] inserted into the
    segment where the stability changes that brackets its parameter (or nearly: a fold's tip lies
    beyond both ends of its segment) and lies nearest it in R, given the next orbit's stability:
    the run before ends there and the next begins there (_runs). A point with no such segment (a
    change of impact count, where the multipliers jump, or no change at all) is left out."""
    for at, R, moduli in sorted(points, reverse=True):  # from the end: earlier indices stay valid
        if not np.isfinite(at) or not np.isfinite(R):
            continue
        same_impacts = (impacts[:-1] == impacts[1:]) | (np.isnan(impacts[:-1]) & np.isnan(impacts[1:]))
        changes = np.nonzero((stable[:-1] != stable[1:]) & same_impacts)[0]
        if changes.size == 0:
            continue
        low = np.minimum(values[changes], values[changes + 1])
        high = np.maximum(values[changes], values[changes + 1])
        # How far beyond its segment a fold's tip may lie: the segment's length on the figure (in
        # the parameter's units, R scaled as the axes scale it). Where one arclength step turns
        # at the fold, its ends differ little in the parameter and much in R: the bouncing ball's
        # fold lay 0.016 beyond a segment 0.004 wide and 0.31 tall, and was left off the line.
        span_values = np.ptp(values) or 1.0
        span_gain = np.ptp(gain[np.isfinite(gain)]) if np.isfinite(gain).any() else 1.0
        chord = span_values * np.hypot((values[changes + 1] - values[changes]) / span_values,
                                       (gain[changes + 1] - gain[changes]) / (span_gain or 1.0))
        reach = np.maximum(high - low, np.nan_to_num(chord))
        near = changes[(low - reach <= at) & (at <= high + reach)]
        if near.size == 0:
            continue
        i = int(near[np.argmin(np.abs(0.5 * (gain[near] + gain[near + 1]) - R))])
        values = np.insert(values, i + 1, at)
        gain = np.insert(gain, i + 1, R)
        stable = np.insert(stable, i + 1, stable[i + 1])
        modulus = np.insert(modulus, i + 1, moduli, axis=0)
        impacts = np.insert(impacts, i + 1, impacts[i])
    return values, gain, stable, modulus, impacts


def _stored_parameters(ds):
    from vrsweep.config import parse_config

    from vrsweep.plot.labels import use_model

    try:
        config = parse_config(str(ds.attrs["config"]), "<the stored config>")
    except Exception:  # noqa: BLE001 - a file without a readable config still gets its branch drawn
        use_model(None)
        return None
    use_model(config.model)  # a written model's parameters are labelled by its own names or symbols
    return config


@figure_options
def branch_figure(ds, sweeps=(), more_branches=(), zoom=None, table=False, xlim=None) -> Figure:
    """The figure (two panels, one x axis) of branch Dataset ``ds`` (and of the branch Datasets
    ``more_branches``, of the same parameter) with sweep Datasets ``sweeps``; takes the options of
    every figure (title, size, style, xlim, ylim, legend: ``labels.figure_options``). Branches are
    coloured by their period (in slow periods), the first file's first branch's period in
    BRANCH_COLOUR. Each bifurcation is tagged on the curve (F1, PD1, NS1, G1: ``bifurcation_tags``,
    the tags ``vrsweep info`` lists), one legend entry per kind.

    zoom: 'bifurcations' narrows the parameter axis to where the bifurcations are, 'none' never;
    None does so when they span under ZOOM_SPAN of the branch's range (a cascade within 0.05 of a
    25-wide axis), saying so on the figure. An ``xlim`` given overrides either. table: a table of
    the bifurcations (tag, kind, parameter, R, branch) below the panels.
    """
    if zoom not in ZOOM_CHOICES:
        raise UsageError.naming("{zoom} {value}: one of {choices}", value=zoom,
                                choices=", ".join(c for c in ZOOM_CHOICES if c))
    name = str(ds.attrs.get("parameter", "parameter"))
    datasets = [ds, *more_branches]
    values = np.concatenate([np.asarray(d["parameter"].values) for d in datasets])
    kinds = [_text(kind) for d in datasets for kind in d["bifurcation_kind"].values]
    places = np.concatenate([np.asarray(d["bifurcation_parameter"].values, dtype=float) for d in datasets])
    heights = np.concatenate([np.asarray(d["bifurcation_R"].values, dtype=float) for d in datasets])
    numbers = np.concatenate([np.asarray(d["bifurcation_branch"].values) for d in datasets])
    tags = bifurcation_tags(kinds)
    figure = _new_figure(7.5, 6.5)
    if table and kinds:
        # The table takes rows of its own below the panels: the figure grows by them, the panels keep their size.
        width, height = figure.get_size_inches()
        figure.set_size_inches(width, height + TABLE_ROW_INCHES * (len(kinds) + 1.5))
        figure._vrsweep_grown = True  # figure_options keeps the height added
        top, bottom, table_axes = figure.subplots(3, 1, height_ratios=(2.2, 1.0, _table_ratio(figure, len(kinds))),
                                                  gridspec_kw=dict(hspace=0.0))
        bottom.sharex(top)
        top.tick_params(labelbottom=False)
    else:
        top, bottom = figure.subplots(2, 1, sharex=True, height_ratios=(2.2, 1.0))
        table_axes = None
    config = _stored_parameters(ds)
    _draw_branch_lines(top, bottom, datasets, values, config, name)
    for sweep_number, sweep in enumerate(sweeps):
        _draw_sweep(top, sweep, name, sweep_number, config)
    window, zoom_note = _zoom_window(values, places, zoom, xlim, name)
    if window is not None:
        top.set_xlim(*window)
        for ax in (top, bottom):
            fit_y_to_view(ax)
    _mark_bifurcations(top, bottom, kinds, places, heights, tags, name)
    written = config is not None and config.written
    top.set_ylabel(written_response_label(config.model) if written else "gain $R = |Q|/c$")
    model_words = model_title(config.model) if written else f"{ds.attrs.get('model', '')} model"
    what = f"Periodic orbits continued in {parameter_symbol(name)} ({model_words})"
    path = str(ds.encoding.get("source", "") or ds.attrs.get("path", "") or "branch")
    # Continuation holds every parameter but its own at the config's value, sweep axes too: the
    # caption left out a swept one (omega = 0.8 of impact_linear) as if it varied.
    held = {axis.name: config.parameters[axis.name] for axis in config.axes
            if axis.name in config.parameters} if config is not None else {}
    _title(figure, what, _caption(os.path.basename(path), config, str(ds.attrs.get("model", "")), held,
                                  omit=(name,), width=_width(figure)))
    bottom.set_xlabel(parameter_label(name))
    if zoom_note:  # in the corner of the multipliers' panel, where the legend never goes
        bottom.text(0.99, 0.96, zoom_note, transform=bottom.transAxes, ha="right", va="top", fontsize="xx-small",
                    color="0.2", gid="zoom note", zorder=6,
                    bbox=dict(facecolor="white", edgecolor="none", alpha=0.8, pad=1.0))
    if table_axes is not None:
        _bifurcation_table(table_axes, tags, kinds, places, heights, numbers, name)
    # One legend below both panels: inside, it covered the branch on a journal-column figure.
    handles, labels = [], []
    for ax in (top, bottom):
        more_handles, more_labels = ax.get_legend_handles_labels()
        handles += more_handles
        labels += more_labels
    figure.legend(handles, labels, fontsize="x-small", loc="outside lower center",
                  ncol=_legend_columns(figure, 3))
    # Without its legend the figure does not say what colours, dashes and tags mean: at one journal
    # column the layout keeps it, in these words (layout._abbreviate), rather than leaving it off.
    figure._vrsweep_short_legend = {label: _short_label(label) for label in labels}
    return figure


SHORT_LABELS = {"stable (dashed: unstable)": "stable (- - unstable)", "theory (corrected)": "theory",
                "PD: period doubling": "PD: doubling", "NS: Neimark-Sacker": "NS: Neim.-Sacker",
                BIFURCATION_LINE_LABEL: "bif. in $|\\mu|$"}


def _short_label(label):
    """``label`` in a few characters: 'period 2 T' is '2T'."""
    if label.startswith("period ") and label.endswith(" T"):
        return label[len("period "):-len(" T")] + "T"
    return SHORT_LABELS.get(label, label)


ZOOM_CHOICES = (None, "bifurcations", "none")
ZOOM_SPAN = 0.01      # bifurcations spanning under 1 % of the branch's range: zoom on them by itself
ZOOM_MARGIN = 0.25    # the zoomed window reaches this share of the bifurcations' span past each end ...
ZOOM_AT_LEAST = 0.002  # ... and at least this share of the branch's range (one bifurcation, or a tight cascade)
TABLE_ROW_INCHES = 0.17


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _zoom_window(values, places, zoom, xlim, name):
    """((low, high), note) of the parameter axis, or (None, '') to show the whole branch."""
    if xlim is not None:
        return xlim, ""
    places = places[np.isfinite(places)]
    if zoom == "none" or places.size == 0 or values.size < 2:
        return None, ""
    low, high = float(np.nanmin(values)), float(np.nanmax(values))
    whole = high - low
    span = float(places.max() - places.min())
    if whole <= 0 or (zoom is None and (places.size < 2 or span >= ZOOM_SPAN * whole)):
        return None, ""
    pad = max(ZOOM_MARGIN * span, ZOOM_AT_LEAST * whole)
    window = (float(places.min()) - pad, float(places.max()) + pad)
    symbol = parameter_symbol(name)
    return window, f"zoomed on the bifurcations; the branch: {symbol} from {low:.6g} to {high:.6g}"


def _draw_branch_lines(top, bottom, datasets, values, config, name):
    """R along each branch (top) and the multipliers' moduli (bottom), stable solid, unstable
    dashed, each branch in its period's colour; the theory's branches for the effective model."""
    gain = np.concatenate([np.asarray(d["R"].values) for d in datasets])
    stable = np.concatenate([np.asarray(d["stable"].values).astype(bool) for d in datasets])
    modulus = np.concatenate([np.asarray(d["multiplier_modulus"].values).reshape(-1, 2) for d in datasets])
    periods = np.concatenate([np.asarray(d["periods"].values) for d in datasets])
    # One number per (file, branch): the branches of every file in turn.
    offsets = np.cumsum([0] + [len(d["branch_id"]) for d in datasets[:-1]])
    branch = np.concatenate([np.asarray(d["branch"].values) + offset for d, offset in zip(datasets, offsets)])
    impacts = np.concatenate([np.asarray(d["impacts_per_period"].values, dtype=float) if "impacts_per_period" in d
                              else np.full(len(d["parameter"]), np.nan) for d in datasets])
    # The grazes of each (file, branch): where the multipliers are not joined.
    grazes, changes = {}, {}
    for d, offset in zip(datasets, offsets):
        moduli = np.hypot(np.asarray(d["bifurcation_multiplier_real"].values),
                          np.asarray(d["bifurcation_multiplier_imag"].values)).reshape(-1, 2)
        for kind, at, R, number, pair in zip(d["bifurcation_kind"].values, d["bifurcation_parameter"].values,
                                             d["bifurcation_R"].values, d["bifurcation_branch"].values, moduli):
            if _text(kind) in ("grazing", UNLOCATED + "grazing"):
                grazes.setdefault(int(number) + int(offset), []).append((float(at), float(R)))
            elif _text(kind) in STABILITY_KINDS:
                changes.setdefault(int(number) + int(offset), []).append((float(at), float(R), pair))
    colours = _period_colours(periods)
    if config is not None and config.model == "effective" and values.size:
        low, high = values.min(), values.max()
        span = high - low or 1.0
        fine = np.linspace(low - 0.05 * span, high + 0.05 * span, FINE_POINTS)
        _draw_branches(top, analytic_branches(config.parameters, name, fine, gain=True), THEORY_COLOUR)
        top.plot([], [], color=THEORY_COLOUR, label="theory (corrected)")
    marks = _period_marks(periods)
    for number in np.unique(branch):
        mine = branch == number
        period = int(periods[mine][0]) if mine.any() else None
        colour = colours.get(period, BRANCH_COLOUR)
        # Colour says the period in both panels, and so do markers along the line (greyscale).
        look = dict(color=colour, marker=marks.get(period, "None"), markevery=MARK_EVERY, ms=MARK_SIZE)
        along, its_gain, its_stable, its_modulus, its_impacts = _with_bifurcations(
            values[mine], gain[mine], stable[mine], modulus[mine], impacts[mine], changes.get(int(number), []))
        for piece, is_stable in _runs(along, its_stable):
            style = "-" if is_stable else "--"
            top.plot(along[piece], its_gain[piece], ls=style, lw=1.8, zorder=3, **look)
        # R is continuous through a graze; the multipliers are not.
        breaks = _multiplier_breaks(along, its_gain, its_impacts, grazes.get(int(number), []))
        for piece, is_stable in _runs(along, its_stable, breaks):
            style = "-" if is_stable else "--"
            for k, width in enumerate(MULTIPLIER_WIDTHS):
                bottom.plot(along[piece], its_modulus[piece, k], ls=style, lw=width,
                            gid=f"multiplier {k + 1}", **look)
    top.plot([], [], color="k", lw=1.8, label="stable (dashed: unstable)")
    if len(colours) > 1:
        for period, colour in colours.items():
            top.plot([], [], color=colour, lw=1.8, marker=marks[period], ms=MARK_SIZE + 1, label=f"period {period} T")
    # The unit circle's level: a multiplier crossing it is a bifurcation. The multipliers are
    # stored larger modulus first, so |mu_1| is always the upper line: drawn thicker, |mu_2| thin.
    bottom.axhline(1.0, color="k", lw=0.8)
    positive = modulus[modulus > 0.0]
    if positive.size and positive.max() / positive.min() > LOG_SPAN:
        bottom.set_yscale("log")  # a strongly unstable or strongly damped branch spans decades
        # Below ROUNDOFF_SPAN of the largest, a modulus is the eigenvalue solver's roundoff
        # (e.g. the second multiplier of P^4 when det P ~ 1e-8), not worth a dozen decades.
        bottom.set_ylim(bottom=max(positive.min(), positive.max() / ROUNDOFF_SPAN) / 2.0)
    bottom.set_ylabel("Floquet $|\\mu|$")


MARKER_SIZE = 6.0


# More than CLUSTER_TAGS bifurcations within CLUSTER_WIDTH of the parameter axis in view of each
# other (chained) get one tag together, their count and range: Fig. 1's period-3 window ends with
# some thirty within 0.3 of a 40-wide g axis, and their tags, joined and led out by lines, were
# unreadable. --zoom, --xlim and --table show each (docs/continuation.md).
CLUSTER_TAGS = 8
CLUSTER_WIDTH = 0.01


def _clusters(places, low, high):
    """Index groups of the bifurcations in view [low, high], by parameter, each a chain of
    neighbours within CLUSTER_WIDTH of the range in view."""
    order = [index for index in np.argsort(places, kind="stable") if low <= places[index] <= high]
    groups = []
    for index in order:
        if groups and places[index] - places[groups[-1][-1]] <= CLUSTER_WIDTH * (high - low):
            groups[-1].append(index)
        else:
            groups.append([index])
    return groups


def _mark_bifurcations(top, bottom, kinds, places, heights, tags, name="parameter"):
    """Each bifurcation marked and tagged (placed beside its point once the layout is done,
    clear of the other tags and markers: layout._separate_tags), a crowd of them (_clusters) with
    one tag saying how many and where; one legend entry per kind."""
    low, high = top.get_xlim()
    bottom_y, top_y = top.get_ylim()
    for index in np.argsort(places):
        kind, at, R, tag = kinds[index], places[index], heights[index], tags[index]
        marker, _ = BIFURCATION_MARKERS.get(kind, (UNKNOWN_BIFURCATION_MARKER, kind))
        top.plot([at], [R], marker=marker, color="k", mfc="w", mew=1.2, ms=MARKER_SIZE, zorder=5, ls="none",
                 gid=f"bifurcation {tag}")
        bottom.axvline(at, color=BIFURCATION_LINE, lw=0.8, zorder=0, gid=f"bifurcation line {tag}")
    for group in _clusters(places, low, high):
        if len(group) > CLUSTER_TAGS:
            top_index = max(group, key=lambda index: heights[index])
            first, last = min(places[index] for index in group), max(places[index] for index in group)
            text = f"{len(group)} bifurcations,\n{parameter_symbol(name)} {first:.5g}\u2013{last:.5g}"
            at, R, gid = places[top_index], heights[top_index], f"tag cluster {tags[group[0]]}"
        else:
            for index in group:
                _tag(top, tags[index], places[index], heights[index], f"tag {tags[index]}")
            continue
        _tag(top, text, at, R, gid)
    for kind in dict.fromkeys(kinds):
        marker, words = BIFURCATION_MARKERS.get(kind, (UNKNOWN_BIFURCATION_MARKER, kind))
        prefix = TAG_PREFIXES.get(kind, kind)
        top.plot([], [], marker=marker, color="k", mfc="w", mew=1.2, ms=6, ls="none", label=f"{prefix}: {words}")
    if kinds:  # the grey verticals of the multipliers' panel would otherwise be unexplained
        top.plot([], [], marker="|", color=BIFURCATION_LINE, mew=1.2, ms=8, ls="none", label=BIFURCATION_LINE_LABEL)
    # Room above and below the curve for the tags (the panel otherwise ends at the curve's extremes).
    if kinds:
        span = top_y - bottom_y
        if top.get_yscale() == "log":
            top.set_ylim(bottom_y / 1.3, top_y * 1.3)
        else:
            top.set_ylim(bottom_y - 0.12 * span, top_y + 0.12 * span)


def _tag(top, text, at, R, gid):
    """A tag at (at, R), placed later (layout._separate_tags)."""
    note = top.annotate(text, (at, R), xytext=(0, -MARKER_SIZE), textcoords="offset points", ha="center",
                        va="top", fontsize="xx-small", annotation_clip=True, gid=gid, zorder=6,
                        arrowprops=dict(arrowstyle="-", lw=0.5, color="0.4", shrinkA=0, shrinkB=MARKER_SIZE / 2 + 1))
    note._vrsweep_tag = True
    note._vrsweep_marker_points = MARKER_SIZE / 2 + 0.6  # the marker's half width and half its edge


def _table_ratio(figure, rows):
    """The table's share of the panels' height ratios (2.2 and 1.0), for ``rows`` rows."""
    height = figure.get_figheight()
    table_inches = TABLE_ROW_INCHES * (rows + 1.5)
    return 3.2 * table_inches / max(height - table_inches, 0.5)


def _bifurcation_table(ax, tags, kinds, places, heights, numbers, name):
    """The bifurcations as a table (tag, kind, parameter to the digits stored, R, branch)."""
    ax.axis("off")
    rows = [[tag, BIFURCATION_MARKERS.get(kind, (UNKNOWN_BIFURCATION_MARKER, kind))[1], f"{at:.8g}", f"{R:.5g}", str(int(number))]
            for tag, kind, at, R, number in zip(tags, kinds, places, heights, numbers)]
    table = ax.table(cellText=rows, colLabels=["", "bifurcation", parameter_symbol(name), "R", "branch"],
                     loc="upper center", cellLoc="left", edges="horizontal")
    table.auto_set_font_size(False)
    from matplotlib.font_manager import FontProperties

    table.set_fontsize(FontProperties(size="x-small").get_size_in_points())
    table.auto_set_column_width(list(range(5)))


# Markers along the periods' lines after the first, which has none: a second cue beside the colour,
# and the only one between a seventh period and the rest (palettes.categorical: six colours apart in
# grey, then others apart in hue only).
PERIOD_MARKERS = ("v", "P", "X", "*", "h", "1")
MARK_EVERY = 0.08   # a marker every this share of the panel's diagonal, however dense the points
MARK_SIZE = 3.0
MULTIPLIER_WIDTHS = (1.4, 0.7)  # |mu_1|, |mu_2|


def _branch_index(sweep, dim, config):
    """The index of ``dim``'s value in ``sweep`` that the branch has; UsageError where it has none."""
    from vrsweep.plot.selection import _path

    values = np.asarray(sweep[dim].values, dtype=np.float64)
    path = os.path.basename(str(_path(sweep) or "the sweep file"))
    if config is None or dim not in config.parameters:
        raise UsageError.naming("{path} is swept over {dim} too, and the branch file does not say its {dim}: "
                                "draw a sweep over the branch's parameter alone", path=path, dim=dim)
    wanted = float(config.parameters[dim])
    close = np.flatnonzero(np.abs(values - wanted) <= 1e-9 * max(1.0, abs(wanted)))
    if close.size == 0:
        raise UsageError.naming("{path} is swept over {dim} too, and none of its values is the branch's "
                                "{dim} = {value}: draw a sweep that has it", path=path, dim=dim,
                                value=f"{wanted:g}")
    return int(close[0])


def _period_colours(periods):
    """{period: colour}: the periods in the order they come, in palettes.categorical's colours
    (the first BRANCH_COLOUR; up to six every two 8 apart in L*, from the greys too). tab10's C0
    and C4, the first two periods' colours, were one grey (L* 48 and 52)."""
    order = list(dict.fromkeys(int(p) for p in periods))
    return dict(zip(order, categorical(len(order))))


def _period_marks(periods):
    """{period: marker} in the order of ``_period_colours``: none for the first period."""
    order = list(dict.fromkeys(int(p) for p in periods))
    return {period: "None" if k == 0 else PERIOD_MARKERS[(k - 1) % len(PERIOD_MARKERS)]
            for k, period in enumerate(order)}


def _draw_sweep(ax, sweep, name, number, config=None):
    if name not in sweep.coords or "R" not in sweep:
        return
    data = sweep["R"]
    others = [dim for dim in data.dims if dim not in (name, "direction")]
    # A sweep over more axes is drawn where the branch is: its first value of each (Omega = 3
    # beside a branch at Omega = 4) was drawn as if it were the branch's.
    for dim in others:
        data = data.isel({dim: _branch_index(sweep, dim, config)})
    directions = sweep["direction"].values if "direction" in data.dims else [None]
    for direction in directions:
        line = data.sel(direction=direction) if direction is not None else data
        label = "sweep" if direction is None else f"sweep {'up' if direction > 0 else 'down'}"
        marker = SWEEP_MARKERS[None if direction is None else int(np.sign(direction))]
        ax.plot(sweep[name].values, line.values, ls="none", marker=marker, ms=5, mfc="none", mew=1.0,
                color=SWEEP_COLOURS[number % len(SWEEP_COLOURS)], label=label, zorder=4, gid="sweep")
