"""What every figure gets after it is drawn (``labels.figure_options``): the axis limits asked for
(``xlim``, ``ylim``), the legend where it was asked for (``legend``), and labels rewrapped so that
they fit their axes -- so that a figure at one journal column (3.4 x 2.6 in, no title) keeps every
text inside the canvas, no two texts on top of each other, and its axes at least half the figure
(issue 32; tests/test_figure_layout.py measures all three with matplotlib's renderer).

Which panels a limit applies to: ``xlim`` goes to every panel whose horizontal axis shows what the
main panel's does (the same label: all panels of a map over several directions, the multipliers'
panel under a branch, position and velocity against time), ``ylim`` to every panel whose vertical
axis does (the gain of a branch figure, not its multipliers). The main panel is the figure's first
that is not a colour bar. A panel whose horizontal axis was narrowed and whose vertical one was not
given is refitted to the data in view: a zoom on a few per cent of a branch shows that part of it
at full height.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.transforms import Bbox

from vrsweep.errors import UsageError, clip
from vrsweep.numbertext import to_float

LEGEND_PLACES = ("best", "outside", "none")
# The share of the figure the panels keep at least (the rest: labels, ticks, legend, colour bars).
AXES_SHARE = 0.5
MARGIN = 0.05  # of the data's span, on each side, when a panel is refitted to a zoomed range
MAX_LABEL_LINES = 3
SHORT = 3.75             # inches: a figure lower than this, or narrower than NARROW, is small (``small``)
NARROW = 5.0             # inches: a figure narrower than this is laid out with the margins of a journal column ...
NARROW_PAD = 1.5 / 72.0  # ... 1.5 pt around each panel


def parse_limits(text, option):
    """'LOW,HIGH' (or a pair) -> (low, high), finite, low < high; UsageError naming ``option``."""
    if text is None:
        return None
    parts = text.split(",") if isinstance(text, str) else list(text)
    if len(parts) != 2:
        raise UsageError.naming("{" + option + "} {value}: expected LOW,HIGH, e.g. 17.82,17.84", value=clip(text))
    ends = []
    for part in parts:
        try:
            ends.append(to_float(part))
        except (TypeError, ValueError) as error:  # NumberTextError is a ValueError, its text the reason
            # Text is read by numbertext's rule, which refuses nan and inf as words: such an end
            # is told as a non-finite number given as a number is (below), with its reason.
            raise UsageError.naming("{" + option + "} {value}: both ends must be finite numbers ({end} {reason})",
                                    value=clip(text), end=clip(str(part)),
                                    reason=str(error) or "is not a number") from None
    low, high = ends
    if not (math.isfinite(low) and math.isfinite(high)):
        raise UsageError.naming("{" + option + "} {value}: both ends must be finite numbers", value=clip(text))
    if not low < high:
        raise UsageError.naming("{" + option + "} {value}: LOW must be below HIGH", value=clip(text))
    if max(abs(low), abs(high)) > LIMIT_MAX:
        # matplotlib's tick locator spaces ticks over HIGH - LOW and beyond it: -8e307,8e307 overflowed
        # it, a traceback ("arange: cannot compute length") after the figure was drawn
        raise UsageError.naming("{" + option + "} {value}: both ends must be of magnitude at most {limit:g} (an axis "
                                "wider is beyond what matplotlib's ticks compute in doubles)", value=clip(text),
                                limit=LIMIT_MAX)
    return low, high


LIMIT_MAX = 1e300  # the largest end of --xlim, --ylim: ticks are computed over twice the range and more


LEGEND_COLUMN_WIDTH = 2.6  # inches a column of legend entries needs at the legends' font size


def legend_columns(fig, wanted):
    """``wanted`` legend columns, fewer (down to one) on a narrow figure, e.g. a journal column
    (--size 3.4,2.6): a legend below the axes must not be wider than the figure (``arrange``
    widens it again where its entries are short)."""
    return max(1, min(wanted, int(fig.get_figwidth() // LEGEND_COLUMN_WIDTH)))


def data_axes(fig):
    """The figure's panels, colour bars and tables left out."""
    return [ax for ax in fig.axes if not hasattr(ax, "_colorbar") and ax.axison]


def apply_limits(fig, xlim=None, ylim=None):
    """Set ``xlim`` on every panel that shares the main panel's horizontal quantity, ``ylim`` on
    every panel sharing its vertical one; refit the vertical axis to the data in view where only
    the horizontal one was given. UsageError naming ylim/xlim for a log axis and a bound <= 0."""
    panels = data_axes(fig)
    if not panels or (xlim is None and ylim is None):
        return
    main = panels[0]
    same_x = [ax for ax in panels if ax.get_xlabel() == main.get_xlabel() or ax.get_shared_x_axes().joined(ax, main)]
    same_y = [ax for ax in panels if ax.get_ylabel() == main.get_ylabel()]
    for limits, axes, option, axis in ((xlim, same_x, "xlim", "x"), (ylim, same_y, "ylim", "y")):
        if limits is None:
            continue
        for ax in axes:
            scale = ax.get_xscale() if axis == "x" else ax.get_yscale()
            if scale == "log" and limits[0] <= 0:
                raise UsageError.naming("{" + option + "} {low:g},{high:g}: that axis is logarithmic; both ends "
                                        "must be above zero", low=limits[0], high=limits[1])
            (ax.set_xlim if axis == "x" else ax.set_ylim)(*limits)
    if xlim is not None:
        for ax in same_x:
            if ylim is None or ax not in same_y:
                fit_y_to_view(ax)


def settle_strips(fig):
    """Each failure strip (``selection.failure_strip``) takes its panel's horizontal axis label
    (set by the figure after the marks): the label belongs under the lowest of the two."""
    for ax in fig.axes:
        strip = getattr(ax, "_vrsweep_failure_strip", None)
        if strip is not None and ax.get_xlabel():
            strip.set_xlabel(ax.get_xlabel())
            ax.set_xlabel("")


def fit_y_to_view(ax):
    """Vertical limits around the lines' points inside the horizontal limits (lines in data
    coordinates only: marks along an edge or across the axes are placed in axes coordinates; the
    theory's curves drawn for comparison left out, they may reach far beyond the data).
    Nothing changes on a panel with no such points (a map, a status strip)."""
    from matplotlib.collections import QuadMesh

    if ax.images or any(isinstance(c, QuadMesh) for c in ax.collections):
        return  # a map's vertical axis is a parameter: it keeps its range
    low, high = sorted(ax.get_xlim())
    found = []
    for line in ax.get_lines():
        if line.get_transform() != ax.transData or not line.get_visible() or getattr(line, "_vrsweep_context", False):
            continue
        x = np.asarray(line.get_xdata(), dtype=float)
        y = np.asarray(line.get_ydata(), dtype=float)
        if x.shape != y.shape:
            continue
        inside = (x >= low) & (x <= high) & np.isfinite(y)
        if ax.get_yscale() == "log":
            inside &= y > 0
        found.append(y[inside])
    values = np.concatenate(found) if found else np.array([])
    if values.size == 0:
        return
    bottom, top = float(values.min()), float(values.max())
    if ax.get_yscale() == "log":
        # Never below the floor the panel had: a multipliers' panel stops above the roundoff.
        bottom = max(bottom, min(ax.get_ylim()))
        top = max(top, bottom)
        factor = (top / bottom) ** MARGIN if top > bottom else 1.5
        ax.set_ylim(bottom / factor, top * factor)
        return
    pad = MARGIN * (top - bottom) or 0.05 * abs(top) or 1.0
    ax.set_ylim(bottom - pad, top + pad)


# --------------------------------------------------------------------------------------------
# The legend: where it was asked for, or where it leaves the panels their share of the figure
# --------------------------------------------------------------------------------------------


def _legends(fig):
    """(legend, its axes or None) of the figure: the figure's own, then the main panel's."""
    found = [(legend, None) for legend in fig.legends]
    for ax in fig.axes:
        if ax.get_legend() is not None:
            found.append((ax.get_legend(), ax))
    return found


def _entries(legend):
    """(handles, labels) to make ``legend`` again: its own handles, whose markers are already scaled
    by its markerscale, so that a legend made of them takes markerscale 1 (REMADE_SCALE)."""
    return list(legend.legend_handles), [text.get_text() for text in legend.get_texts()]


# The markerscale of a legend made of another's handles (_entries): they carry its scale already.
# Its own scale again made a bifurcation diagram's dots 9 times their size under --legend outside,
# and each column count _widen tried 3 times larger again, until drawing them ran out of memory.
REMADE_SCALE = 1.0


def _style_of(legend):
    """What a re-made legend keeps of ``legend``: its frame's colour and its texts' colour (a map's
    legend is dark, with white text, to show white marks), and its title (a basin plot's says
    what each entry lists)."""
    texts = legend.get_texts()
    title = legend.get_title()
    titled = bool(title.get_text()) and title.get_visible()
    return dict(facecolor=legend.get_frame().get_facecolor(), framealpha=legend.get_frame().get_alpha(),
                labelcolor=texts[0].get_color() if texts else None, title=title.get_text() if titled else None,
                title_fontsize=title.get_fontsize() if titled else None)


def place_legend(fig, where):
    """Move the figure's legend (below the figure or inside the main panel) to ``where``: 'best'
    (inside the main panel, where it hides least), 'outside' (below the panels), 'none'
    (removed: every legend of the figure). Legends of other panels stay (a trajectory's phase
    portrait has its own)."""
    if where is None:
        return
    if where not in LEGEND_PLACES:
        raise UsageError.naming("{legend} {value}: one of {places}", value=where, places=", ".join(LEGEND_PLACES))
    legends = _legends(fig)
    panels = data_axes(fig)
    if where == "none":
        for legend, _ in legends:
            legend.remove()
        return
    main = panels[0] if panels else None
    # The legend to move: the figure's, else the main panel's (another panel's legend stays put).
    chosen = [(legend, ax) for legend, ax in legends if ax is None or ax is main]
    if not chosen or main is None:
        return
    legend, owner = chosen[0]
    handles, labels = _entries(legend)
    style = _style_of(legend)
    fontsize = legend.get_texts()[0].get_fontsize() if legend.get_texts() else "x-small"
    markerscale = REMADE_SCALE
    legend.remove()  # a figure legend leaves fig.legends too
    style = {key: value for key, value in style.items() if value is not None}
    if where == "best":
        main.legend(handles, labels, loc="best", fontsize=fontsize, markerscale=markerscale, **style)
    else:
        fig.legend(handles, labels, loc="outside lower center", fontsize=fontsize, markerscale=markerscale,
                   ncol=legend_columns(fig, 2), **style)


# --------------------------------------------------------------------------------------------
# Labels that fit their axes, and the measurements the layout is judged by
# --------------------------------------------------------------------------------------------


def renderer_of(fig):
    """A renderer for ``fig``, its layout done (an Agg canvas is attached where there is none)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if not hasattr(fig.canvas, "get_renderer"):
        FigureCanvasAgg(fig)
    renderer = fig.canvas.get_renderer()
    fig.draw_without_rendering()
    return renderer


def _split_words(text):
    """``text``'s words, a mathtext $...$ kept whole (never broken inside)."""
    words, current, inside = [], "", False
    for character in text:
        if character == "$":
            inside = not inside
        if character == " " and not inside:
            words.append(current)
            current = ""
        else:
            current += character
    return [word for word in words + [current] if word]


def _rewrap(text, lines):
    """``text`` (one line) broken into ``lines`` lines of about equal length, at spaces."""
    words = _split_words(text.replace("\n", " "))
    target = len(text) / lines
    out, current = [], ""
    for word in words:
        if current and len(current) + 1 + len(word) > target * 1.15 and len(out) < lines - 1:
            out.append(current)
            current = word
        else:
            current = f"{current} {word}" if current else word
    return "\n".join(out + [current])


def fit_labels(fig):
    """Rewrap every axis label longer than its axes (a y label taller than its panel, a colour
    bar's label taller than the bar) into two or three lines, then make it smaller if that is not
    enough: at one journal column 'gain R = |Q|/c, analytic A/c' is taller than the panel."""
    renderer = renderer_of(fig)
    changed = False
    for ax in fig.axes:
        box = ax.get_window_extent(renderer)
        for label, room, vertical in ((ax.yaxis.label, box.height, True), (ax.xaxis.label, box.width, False)):
            text = label.get_text()
            if not text or room <= 0:
                continue
            extent = label.get_window_extent(renderer)
            length = extent.height if vertical else extent.width
            if length <= room:
                continue
            original = " ".join(text.split("\n"))
            # A colour bar's label takes its lines from the panels' width: two at most, then smaller.
            most = 2 if hasattr(ax, "_colorbar") else MAX_LABEL_LINES
            for lines in range(len(text.split("\n")) + 1, most + 1):
                label.set_text(_rewrap(original, lines))
                extent = label.get_window_extent(renderer)
                if (extent.height if vertical else extent.width) <= room:
                    break
            for size in ("small", "x-small", "xx-small"):
                extent = label.get_window_extent(renderer)
                if (extent.height if vertical else extent.width) <= room:
                    break
                label.set_fontsize(size)
            changed = True
    if changed:
        fig.draw_without_rendering()


def axes_share(fig, renderer=None):
    """The share of the figure's area its axes take (panels and colour bars; not a table)."""
    renderer = renderer or renderer_of(fig)
    area = sum(ax.get_window_extent(renderer).width * ax.get_window_extent(renderer).height
               for ax in fig.axes if ax.axison)
    return area / (fig.bbox.width * fig.bbox.height)


def arrange(fig, legend=None):
    """``_arrange`` with matplotlib's warning that the layout collapsed kept back: ``render`` draws
    the figure again and turns that warning into a note of what to do (``labels.layout_note``)."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        note = _arrange(fig, legend)
    for warning in caught:
        if "collapsed to zero" not in str(warning.message):
            warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    return note


def small(fig):
    """Whether ``fig`` is a figure for a journal column or smaller: its legend may move (``arrange``)."""
    width, height = fig.get_size_inches()
    return width < NARROW or height < SHORT


def _arrange(fig, legend=None):
    """After ``legend`` was placed as asked: a legend below the panels given as many columns as fit
    across the figure; on a small figure (``small``) with no legend place asked, one that still
    leaves the panels under AXES_SHARE of the figure moved inside the main panel if it fits there
    with room to spare (at one journal column a branch's legend of eleven entries below took two
    thirds of the height), and left off if it does not; labels fitted to their axes; tags on the
    curves (a branch's F1, PD1...) moved apart. Returns a note in words when it moved or left off
    the legend, '' otherwise."""
    engine = fig.get_layout_engine()
    if fig.get_figwidth() < NARROW and engine is not None and hasattr(engine, "set"):
        engine.set(w_pad=NARROW_PAD, h_pad=NARROW_PAD)  # constrained layout's 3 pt around each panel, halved
    labels = {label: (label.get_text(), label.get_fontsize())
              for ax in fig.axes for label in (ax.xaxis.label, ax.yaxis.label)}
    fit_labels(fig)
    note = ""
    if fig.legends:
        _widen(fig.legends[0], fig)
        if legend is None and small(fig) and axes_share(fig) < AXES_SHARE:
            count = len(fig.legends[0].get_texts())
            short = getattr(fig, "_vrsweep_short_legend", None)
            if short is not None:
                # A figure whose legend explains what its marks mean (a branch's tags, periods,
                # stability) keeps it, abbreviated: below the panels if that leaves them half the
                # figure, else in a strip of the main panel above its data.
                note = _abbreviate(fig, short, may_raise=not getattr(fig, "_vrsweep_ylim_given", False))
            if not note:
                place_legend(fig, "best")
                main = data_axes(fig)[0]
                _compact(main)
                if _fits_inside(main):
                    note = "the legend went inside the axes, where it leaves them half the figure"
                else:
                    note = _keep_curve_names(fig, main, count, may_raise=not getattr(fig, "_vrsweep_ylim_given", False))
                    if not note:
                        place_legend(fig, "none")
                        note = (f"the legend ({count} entries) is left off: below the axes it would leave them "
                                "under half the figure, inside it would cover them")
            for label, (text, size) in labels.items():  # wrapped for the old layout: fitted again to the new
                label.set_text(text)
                label.set_fontsize(size)
            fit_labels(fig)
    for ax in data_axes(fig):
        if ax.get_legend() is not None and small(fig) and not getattr(ax.get_legend(), "_vrsweep_strip", False):
            _compact(ax)
        _separate_tags(ax)
    if small(fig):
        _shrink_cell_labels(fig)
    return note


def _shrink_cell_labels(fig):
    """A map's axes ticked at its cells (``selection.cell_ticks``) label them with their values,
    '3.6' where round ticks read '4': at one journal column the wider labels left the panels under
    AXES_SHARE of the figure. Those labels are set smaller, as an axis label is (``fit_labels``),
    until the panels have their share."""
    axes = [(ax, name) for ax in data_axes(fig) for name in getattr(ax, "_vrsweep_cell_ticks", ())]
    for size in ("small", "x-small"):
        if not axes or axes_share(fig) >= AXES_SHARE:
            return
        for ax, name in axes:
            ax.tick_params(axis=name, labelsize=size)
        fig.draw_without_rendering()


# A legend abbreviated to fit a journal column: small text, short handles, no frame (the frame's
# padding alone is a tenth of a row).
COMPACT_LEGEND = dict(fontsize="xx-small", handlelength=1.5, handletextpad=0.4, columnspacing=0.9,
                      labelspacing=0.25, borderpad=0.2, borderaxespad=0.2, frameon=False)
STRIP_GAP = 0.02  # of the panel's height, between a legend strip and the data below it


def _keep_curve_names(fig, main, count, may_raise=True):
    """Where the whole legend fits neither below nor inside: a legend of the entries that name the
    figure's curves alone (``fig._vrsweep_curve_labels``, {label: short label}, set by a figure of
    several curves), abbreviated (``_abbreviate``): at one journal column a bifurcation diagram of
    three Omega lost its legend, and nothing told its curves apart. Returns the note, '' where the
    figure names no two curves (then the legend is left off, as before)."""
    names = getattr(fig, "_vrsweep_curve_labels", None) or {}
    legend = main.get_legend()
    if legend is None or len(names) < 2:
        return ""
    handles, labels = _entries(legend)
    kept = [(handle, label) for handle, label in zip(handles, labels) if label in names]
    if len(kept) < 2:
        return ""
    legend.remove()
    fig.legend([handle for handle, _ in kept], [label for _, label in kept], loc="outside lower center")
    _abbreviate(fig, names, may_raise=may_raise)
    return (f"the legend keeps the curves' names only ({count - len(kept)} of its {count} entries left off: the "
            "whole legend would leave the axes under half the figure)")


def _abbreviate(fig, short, may_raise=True):
    """The figure's legend below the panels with the labels ``short`` gives ({label: shorter}) in
    COMPACT_LEGEND's style; if that still leaves the panels under AXES_SHARE of the figure, and
    ``may_raise`` (no --ylim asked), in a strip across the top of the main panel with the panel's
    vertical axis raised so that no data lies under it. Returns a note in words, '' when neither
    was possible (then the legend is below, abbreviated)."""
    legend = fig.legends[0]
    handles, labels = _entries(legend)
    labels = [short.get(label, label) for label in labels]
    legend.remove()
    legend = fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), **COMPACT_LEGEND)
    _widen(legend, fig, down_to=1)
    if axes_share(fig) >= AXES_SHARE:
        return "the legend was abbreviated to fit below the axes"
    main = data_axes(fig)[0] if data_axes(fig) else None
    if not may_raise or main is None:
        return ""
    fig.legends[0].remove()
    renderer = renderer_of(fig)
    panel = main.get_window_extent(renderer)
    for columns in range(len(labels), 0, -1):
        strip = main.legend(handles, labels, loc="upper center", ncol=columns, **COMPACT_LEGEND)
        if strip.get_window_extent(renderer).width <= 0.98 * panel.width:
            break
    strip._vrsweep_strip = True
    share = strip.get_window_extent(renderer).height / panel.height + STRIP_GAP
    if share >= 0.5:  # the data would keep under half the panel: not worth it
        strip.remove()
        fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), **COMPACT_LEGEND)
        return ""
    low, high = main.get_ylim()
    if main.get_yscale() == "log":
        main.set_ylim(low, low * (high / low) ** (1.0 / (1.0 - share)))
    else:
        main.set_ylim(low, low + (high - low) / (1.0 - share))
    return "the legend was abbreviated into a strip at the top of the axes, above the data"


LEGEND_COVERS_AT_MOST = 0.5  # of the main panel's area, for a legend moved inside it


def _fits_inside(ax):
    """Whether ``ax``'s legend lies within the panel and covers at most LEGEND_COVERS_AT_MOST of it."""
    renderer = renderer_of(ax.figure)
    box, panel = ax.get_legend().get_window_extent(renderer), ax.get_window_extent(renderer)
    inside = panel.x0 - 1 <= box.x0 and box.x1 <= panel.x1 + 1 and panel.y0 - 1 <= box.y0 and box.y1 <= panel.y1 + 1
    return inside and box.width * box.height <= LEGEND_COVERS_AT_MOST * panel.width * panel.height


def _remake(legend, fig, **changes):
    """``legend`` made again with ``changes`` (ncol, handlelength...), in the same place and with
    the same spacing (an abbreviated legend stays compact)."""
    handles, labels = _entries(legend)
    texts = legend.get_texts()
    options = dict(fontsize=texts[0].get_fontsize() if texts else "x-small", markerscale=REMADE_SCALE,
                   handlelength=legend.handlelength, handletextpad=legend.handletextpad,
                   columnspacing=legend.columnspacing, labelspacing=legend.labelspacing, borderpad=legend.borderpad,
                   borderaxespad=legend.borderaxespad, frameon=legend.get_frame_on(),
                   **{key: value for key, value in _style_of(legend).items() if value is not None})
    options.update(changes)
    owner = legend.axes if legend.axes is not None and legend.axes.get_legend() is legend else None
    legend.remove()
    if owner is not None:
        return owner.legend(handles, labels, loc="best", **options)
    return fig.legend(handles, labels, loc="outside lower center", **options)


def _widen(legend, fig, down_to=None):
    """A legend below the panels in as many columns as fit across the figure (fewer rows: more
    height for the panels); entries are short, so a column needs far less than the 2.6 in
    ``legend_columns`` allows when it cannot measure. ``down_to``: the fewest columns to try (an
    abbreviated legend, made in one row, may need fewer than it has); by default one more than
    the legend has."""
    renderer = renderer_of(fig)
    original = legend._ncols
    for columns in range(len(legend.get_texts()), (original + 1 if down_to is None else down_to) - 1, -1):
        legend = _remake(legend, fig, ncol=columns)
        fig.draw_without_rendering()
        if legend.get_window_extent(renderer).width <= 0.98 * fig.bbox.width:
            return
    if legend._ncols != original:
        _remake(legend, fig, ncol=original)


def _compact(ax):
    """A legend inside a panel with short entries, in two columns when it has many: half the height."""
    legend = ax.get_legend()
    texts = [text.get_text() for text in legend.get_texts()]
    if texts and len(texts) >= 5 and max(len(text) for text in texts) <= 28 and legend._ncols == 1:
        _remake(legend, ax.figure, ncol=2, handlelength=1.5, columnspacing=0.8)


# Where a tag may go around its point, in order of preference: below, above, beside, then the
# diagonals; each at TAG_RINGS distances, one tag height apart.
TAG_DIRECTIONS = ((0, -1), (0, 1), (1, 0), (-1, 0), (1, -1), (1, 1), (-1, -1), (-1, 1))
TAG_RINGS = 6
TAG_GAP_POINTS = 1.5      # between a marker's edge and its tag
TAG_COVER_COST = 4.0      # per pixel of data under a tag, against 1 per ring and 0.1 per direction further out


def _separate_tags(ax):
    """Place each tag of ``ax`` (annotations marked _vrsweep_tag) next to its point, greedily from
    left to right: of the places around the point (TAG_DIRECTIONS, nearest ring first), the one
    that lies in the panel and clear of the tags placed before, of every bifurcation's marker and
    of the legend, and covers the least of the data; a leader line only for a tag not beside its
    point. A tag with no clear place is named in its nearest neighbour's ('PD3, PD2')."""
    tags = [text for text in ax.texts if getattr(text, "_vrsweep_tag", False) and text.get_visible()]
    if not tags:
        return
    renderer = renderer_of(ax.figure)
    panel = ax.get_window_extent(renderer)
    legend = ax.get_legend()
    blocked = [legend.get_window_extent(renderer)] if legend is not None else []
    markers = [line for line in ax.get_lines() if (line.get_gid() or "").startswith("bifurcation")]
    blocked += [line.get_window_extent(renderer) for line in markers]
    data = _data_pixels(ax, exclude=markers)
    per_point = ax.figure.dpi / 72.0
    placed = []
    tags.sort(key=lambda text: text.xy[0])
    for text in tags:
        point = ax.transData.transform(text.xy)
        if not (panel.x0 <= point[0] <= panel.x1 and panel.y0 <= point[1] <= panel.y1) or not np.all(np.isfinite(point)):
            continue
        box = _text_box(text, renderer)
        width, height = box.width, box.height
        if not width:
            continue
        radius = getattr(text, "_vrsweep_marker_points", 4.0) + TAG_GAP_POINTS
        step = height / per_point + 1.0
        best = None
        for ring in range(TAG_RINGS):
            for order, (dx, dy) in enumerate(TAG_DIRECTIONS):
                reach = radius + ring * step
                # The box's edge nearest the point at ``reach`` from it (its corner, on a diagonal).
                x0 = point[0] + (dx * reach * per_point if dx else -width / 2) - (width if dx < 0 else 0)
                y0 = point[1] + (dy * reach * per_point if dy else -height / 2) - (height if dy < 0 else 0)
                candidate = (x0, y0, x0 + width, y0 + height)
                if candidate[0] < panel.x0 or candidate[2] > panel.x1 or candidate[1] < panel.y0 or candidate[3] > panel.y1:
                    continue
                if any(_overlap(Bbox.from_extents(*candidate), other) for other in blocked + [b for _, b in placed]):
                    continue
                covered = _covered(data, candidate)
                cost = ring + 0.1 * order + TAG_COVER_COST * covered
                if best is None or cost < best[0]:
                    best = (cost, ring, dx, dy, reach, candidate)
        if best is None:
            # Crowded everywhere: named in the tag of its nearest neighbour ('F1, PD2'), not on top of it.
            if placed:
                nearest = min((other for other, _ in placed), key=lambda other: abs(other.xy[0] - text.xy[0]))
                nearest.set_text(f"{nearest.get_text()}, {text.get_text()}")
                text.set_visible(False)
            continue
        _, ring, dx, dy, reach, candidate = best
        text.set_ha({1: "left", -1: "right", 0: "center"}[dx])
        text.set_va({1: "bottom", -1: "top", 0: "center"}[dy])
        text.xyann = (dx * reach, dy * reach)
        if text.arrow_patch is not None:
            text.arrow_patch.set_visible(ring > 0)  # beside its point a tag needs no line to it
        placed.append((text, Bbox.from_extents(*candidate)))


def _data_pixels(ax, exclude=()):
    """The data's lines and markers of ``ax`` as points in pixels, a line's segments filled in
    every DATA_SPACING pixels: a tag over a line covers some of them even between its vertices."""
    found = []
    for line in ax.get_lines():
        if line in exclude or line.get_transform() is not ax.transData or not line.get_visible():
            continue
        xy = np.column_stack([np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)])
        if not len(xy):
            continue
        with np.errstate(all="ignore"):
            pixels = ax.transData.transform(xy)
        if line.get_linestyle() not in ("None", "none", " ", "") and len(pixels) > 1:
            segments = pixels[1:] - pixels[:-1]
            counts = np.clip(np.ceil(np.hypot(*segments.T) / DATA_SPACING), 1, 10_000)
            counts[~np.isfinite(counts)] = 1
            counts = counts.astype(int)
            index = np.repeat(np.arange(len(segments)), counts)
            share = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / np.repeat(counts, counts)
            pixels = np.vstack([pixels[index] + segments[index] * share[:, None], pixels[-1:]])
        found.append(pixels[np.all(np.isfinite(pixels), axis=1)])
    return np.vstack(found) if found else np.zeros((0, 2))


DATA_SPACING = 2.0


def _covered(pixels, box):
    x0, y0, x1, y1 = box
    return int(np.count_nonzero((pixels[:, 0] >= x0) & (pixels[:, 0] <= x1) & (pixels[:, 1] >= y0) & (pixels[:, 1] <= y1)))


def _text_box(text, renderer):
    """The box of an annotation's text alone (its own extent includes the leader line)."""
    from matplotlib.text import Text

    return Text.get_window_extent(text, renderer)


def _overlap(a, b):
    return min(a.x1, b.x1) - max(a.x0, b.x0) > 0.5 and min(a.y1, b.y1) - max(a.y0, b.y0) > 0.5
