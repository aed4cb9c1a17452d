"""The trajectory figures of ``vrsweep simulate`` files: position, velocity and phase portrait
(Fig. 3-5), impacts per slow period (Fig. impact_no), the slow flow (Fig. 6)."""

from __future__ import annotations

import os

import numpy as np
from matplotlib.figure import Figure

from vrsweep.errors import UsageError, clip
from vrsweep.numbertext import read_int
from vrsweep.plot.analytic import barrier_positions
from vrsweep.plot.labels import figure_options, literal, model_title, _caption, _legend_columns, _new_figure, _number, _parse_config, _symbol, _title, _width, period_words
from vrsweep.results import Status


# --------------------------------------------------------------------------------------------
# Trajectory figures
# --------------------------------------------------------------------------------------------


def with_impacts(t, x, v, impacts, delta):
    """The samples with each impact inserted twice, (Delta, v before) then (Delta, v after).

    Sampled on a fixed grid, a rebound would be drawn as a chord between the samples on either
    side of it; with the impact points in place, lines reach the barrier and jump there.
    ``delta``: the barrier's position, or a list of (position, side) (a written model's barriers:
    an impact moving up, v before > 0, is on the one above).
    """
    if len(impacts) == 0 or delta is None or (isinstance(delta, list) and not delta):
        return t, x, v
    impact_t = impacts[:, 0]
    if isinstance(delta, list):
        sides = dict((side, position) for position, side in delta)
        at = np.where(impacts[:, 1] > 0, sides.get("above", np.nan), sides.get("below", np.nan))
    else:
        at = np.full(len(impacts), delta)
    all_t = np.concatenate([t, impact_t, impact_t])
    all_x = np.concatenate([x, at, at])
    all_v = np.concatenate([v, impacts[:, 1], impacts[:, 2]])
    rank = np.concatenate([np.ones(len(t)), np.zeros(len(impacts)), np.full(len(impacts), 2.0)])
    order = np.lexsort((rank, all_t))
    return all_t[order], all_x[order], all_v[order]


def parse_periods(text):
    """'FIRST:LAST' (slow periods, 1-based, inclusive; either may be empty) -> (first, last)."""
    first, colon, last = str(text).partition(":")
    try:
        window = (read_int(first) if first.strip() else 1, read_int(last) if last.strip() else None)
    except ValueError:
        window = None
    if not colon or window is None or window[0] < 1 or (window[1] is not None and window[1] < window[0]):
        raise UsageError.naming("{periods} {value}: expected FIRST:LAST slow periods, e.g. 1:20 or 81:100",
                                value=clip(text))
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


def _headline(config) -> tuple:
    """The parameters a trajectory's title names: the paper's g and Ω (what its figures vary);
    every parameter of a written model, whose parameters vrsweep cannot rank (its first four were
    named, and a model's fifth to eighth were in no title)."""
    if config is None:
        return ()
    return tuple(config.parameter_names) if config.written else ("g", "Omega")


def _point_text(config, names) -> str:
    """'g = 5, Ω = 4' (the paper's two as they always read), a written model's in its symbols, as
    the caption writes them."""
    if config is None:
        return ""
    plain = {} if config.written else {"g": "g", "Omega": "Ω"}
    return ", ".join(f"{plain.get(name) or _symbol(name)} = {_number(config.parameters[name])}" for name in names)


def _barriers(config):
    """The barriers to draw: [(position, side)], the paper's one above at Delta or a written model's."""
    if config is None:
        return []
    if not config.written:
        return [(config.parameters["Delta"], "above")]
    positions = barrier_positions(config, config.parameters)
    return [(position, barrier.side) for position, barrier in zip(positions, config.model.barriers)]


def _window_text(window, data):
    slow_period = float(data.attrs.get("slow_period", 0.0))
    if not slow_period:
        return f"t in [{window[0]:.4g}, {window[1]:.4g}]"
    return f"periods {round(window[0] / slow_period) + 1}-{round(window[1] / slow_period)} of T = {slow_period:.4g}"


ROW_TITLES = {"original": "original system (eq2.1-eq2.2)", "effective": "effective system (eq2.10)"}
TRANSIENT_COLOUR = "0.65"
STEADY_COLOUR = "tab:blue"
MEAN_COLOUR = "black"  # the impacts figure's mean over the measured periods, over the counts in STEADY_COLOUR


@figure_options
def trajectory_figure(data, periods=None) -> Figure:
    """Position, velocity and phase portrait; original above effective (Fig. 3-5).

    periods: (first, last) slow periods to show (1-based, inclusive), default the whole run. The
    transient (the config's transient_periods) is drawn grey, the rest blue.
    """
    config = _parse_config(data.config_text)
    barriers = _barriers(config)
    window = _time_window(data, periods)
    slow_period = float(data.attrs.get("slow_period", 0.0))
    t_transient = config.integration.transient_periods * slow_period if config is not None else 0.0
    runs = list(data.runs.values())
    if runs and len(runs[0].t):  # split at a sample: nT computed apart differs from the sample's time by roundoff
        t_transient = float(runs[0].t[np.argmin(np.abs(runs[0].t - t_transient))])
    fig = _new_figure(13.0, 3.3 * len(runs) + 0.9)
    grid = fig.subplots(len(runs), 3, squeeze=False)
    letters = iter("abcdef")
    for row, run in zip(grid, runs):
        t, x, v = with_impacts(run.t, run.x, run.v, run.impacts, barriers)
        t, x, v = _in_window(t, window, x, v)
        ax_x, ax_v, ax_phase = row
        for part, colour, label in ((t <= t_transient, TRANSIENT_COLOUR, "transient"),
                                    (t >= t_transient, STEADY_COLOUR, "after the transient")):
            if np.count_nonzero(part) < 2:
                continue
            ax_x.plot(t[part], x[part], lw=0.4, color=colour)
            ax_v.plot(t[part], v[part], lw=0.4, color=colour)
            ax_phase.plot(x[part], v[part], lw=0.3, color=colour, label=label)
        for index, (position, _) in enumerate(barriers):
            ax_x.axhline(position, color="k", lw=0.8, ls="--")
            label = None if index else ("barrier $x = \\Delta$" if not config.written else "barrier")
            ax_phase.axvline(position, color="k", lw=0.8, ls="--", label=label)
        ax_phase.legend(fontsize="x-small", loc="best")
        status = "" if run.status == Status.OK else f" (stopped: {run.status.name.lower()})"
        for ax, what in ((ax_x, "position"), (ax_v, "velocity"), (ax_phase, "phase portrait")):
            # A written model's one row is named by the caption: its name in each panel's title ran
            # off the canvas ("single-well Duffing impact oscillator with two forces: phase portr").
            row_title = ("" if config is not None and config.written and len(runs) == 1
                         else f"{model_title(config.model)}: " if config is not None and config.written
                         else f"{ROW_TITLES.get(run.model, run.model)}: ")
            ax.set_title(f"({next(letters)}) {row_title}{what}{status}", fontsize="small")
            ax.grid(alpha=0.3)
        for ax in (ax_x, ax_v):
            ax.set_xlabel(f"time $t$")
            ax.set_xlim(*window)
        ax_x.set_ylabel(f"position $x$")
        ax_v.set_ylabel(f"velocity $\\dot{{x}}$")
        ax_phase.set_xlabel(f"position $x$")
        ax_phase.set_ylabel(f"velocity $\\dot{{x}}$")
    samples = data.attrs.get("samples_per_period", "?")
    # A written model's parameters are all in the title (wrapped): the caption leaves them out
    # rather than print them twice. The paper's caption keeps g and Ω among the others, as before.
    named = _headline(config)
    _title(fig, f"Trajectory at {_point_text(config, named)}, {_window_text(window, data)}: position, velocity, "
                f"phase portrait ({samples} dense-output samples per {period_words(symbol=False)}"
                f"{', impacts exact; dashed: barrier' if barriers else ''})"
                + _aliasing_note(config, samples, runs),
           _caption(data.path or "", config, " and ".join(ROW_TITLES.get(m, m) for m in data.runs),
                    width=_width(fig), omit=named if config is not None and config.written else ()))
    return fig


def _aliasing_note(config, samples, runs):
    """The title's warning where the samples do not resolve the fastest force: at Omega = 50 with
    omega = 0.5, 200 samples a slow period are 2 a cycle, every one at a zero of sin(Omega t), and
    the velocity's fast wiggle vanished from the figure without a word. '' where they do."""
    if config is None or not isinstance(samples, (int, np.integer)) or not any(run.model != "effective" for run in runs):
        return ""
    from vrsweep.analysis.diagnostics import sampling_of_forcing
    from vrsweep.analysis.sampling import RESOLVED_SAMPLES_PER_CYCLE, SAMPLES_PER_CYCLE

    cycles = float(sampling_of_forcing(config.model, [config.parameters], 1)[1][0])
    if not cycles > 0 or samples / cycles >= RESOLVED_SAMPLES_PER_CYCLE:
        return ""
    needed = int(np.ceil(SAMPLES_PER_CYCLE * cycles))  # what simulate's default gives
    return (f". NOT RESOLVED: {samples / cycles:.3g} samples per cycle of the fastest force ({cycles:.4g} cycles per "
            f"{period_words(symbol=False)}), so the lines alias its oscillation; simulating with "
            f"{needed} samples per {period_words(symbol=False)} resolves it")


@figure_options
def impacts_per_period_figure(datasets) -> Figure:
    """Impacts in each slow period against the period number, transient included (Fig. impact_no).

    One panel per file (e.g. g = 5 and g = 20), each with its own count axis: a shared one would
    take its limits from one panel and clip the others. The measurement window's mean -- what
    ``vrsweep run`` stores as impacts_per_period -- is drawn over it.
    """
    from matplotlib.ticker import MaxNLocator

    configs = [_parse_config(data.config_text) for data in datasets]
    models = {_model_key(data, config) for data, config in zip(datasets, configs)}
    if len(models) > 1:  # one caption, one count axis, one period: one model's
        raise UsageError.naming("{kind} impacts draws several trajectory files of one model, which differ in "
                                "its parameters; {paths} are of {n} models: plot them one at a time",
                                paths=", ".join(os.path.basename(data.path or "") for data in datasets),
                                n=len(models))
    first = configs[0]
    varying = {}
    if first is not None and len(datasets) > 1:
        varying = {name: first.parameters[name] for name in first.parameter_names
                   if any(c is not None and c.parameters[name] != first.parameters[name] for c in configs)}
    # Each panel names what tells it from the others: the parameters that differ (the caption
    # leaves them out), then the paper's g and Ω. Panels that differed in a written model's fifth
    # parameter, or the paper's e, were titled alike, their values on no part of the figure.
    # A single written model's panel names none: its caption holds them all.
    headline = () if first is None or (first.written and not varying) else (
        tuple(varying) + tuple(name for name in _headline(first) if name not in varying and not first.written))
    fig = _new_figure(8.0, 2.7 * len(datasets) + 1.0)
    axes = fig.subplots(len(datasets), 1, squeeze=False, sharex=len(datasets) > 1)[:, 0]
    for k, (ax, data, config) in enumerate(zip(axes, datasets, configs)):
        run = data.runs.get(data.model) or next(iter(data.runs.values()))
        counts = np.asarray(run.impacts_per_period)
        counts = counts[counts >= 0]  # -1: periods a failed run did not reach, drawn as none
        periods = np.arange(1, len(counts) + 1)
        row_title = model_title(config.model) if config is not None and config.written else ROW_TITLES.get(run.model,
                                                                                                          run.model)
        ax.plot(periods, counts, "o-", color=STEADY_COLOUR, lw=0.7, ms=2.5, label=row_title)
        if config is not None:
            n_transient = config.integration.transient_periods
            if 0 < n_transient < len(counts):
                mean = counts[n_transient:].mean()
                ax.axvline(n_transient + 0.5, color="0.4", ls=":", lw=1.0, label="end of the transient")
                # Black: tab:red (L* 47) was the counts' tab:blue (48) on a greyscale page, and the
                # mean lies on the counts where they hardly vary.
                ax.hlines(mean, n_transient + 0.5, len(counts) + 0.5, color=MEAN_COLOUR, lw=1.4,
                          label=f"mean over the measured periods: {mean:.2f}")
        letter = f"({'abcdefgh'[k]}) " if len(datasets) > 1 else ""
        point = _point_text(config, headline)
        ax.set_title(f"{letter}{point + '  ·  ' if point else ''}{literal(os.path.basename(data.path or ''))}  ·  "
                     f"{int(counts.sum())} impacts in {len(counts)} {period_words(symbol=False)}s", fontsize="small")
        ax.set_ylabel(f"impacts per {period_words(symbol=False)}")
        top = max(1.0, float(counts.max(initial=0)))
        ax.set_ylim(-0.06 * top, 1.08 * top)  # room for the markers of 0 and of the largest count
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_xlim(0.5, len(counts) + 0.5)
        ax.grid(alpha=0.3)
        ax.legend(fontsize="x-small", loc="best")
    config = configs[0]
    # A written model's period is its own expression, not the paper's slow period 2 pi/omega.
    period = (f"period number $n$ (period $T$ = {config.model.as_data()['period']})"
              if config is not None and config.written else "slow period number $n$ (period $T = 2\\pi/\\omega$)")
    axes[-1].set_xlabel(period)
    names = ", ".join(os.path.basename(data.path or "") for data in datasets)
    _title(fig, f"Impacts in each {period_words()}, transient included"
                + (f" (the panels differ in {', '.join(varying)})" if varying else ""),
           _caption(names, config, datasets[0].model, omit=varying, width=_width(fig)))
    return fig


def _model_key(data, config):
    """What makes two trajectory files the same model: the paper's by name, a written one by
    everything its config writes but the parameters' values."""
    if config is None or not config.written:
        return (data.model, None)
    return (data.model, repr({key: value for key, value in config.model.as_data().items() if key != "parameters"}))


# Told apart by line style and by lightness (palettes.QUALITATIVE's dark blue and teal, the numerical
# line red): tab:blue and tab:red, both solid, were one grey on a greyscale page (L* 48 and 47).
SLOW_FLOW_STYLES = {
    "state": dict(color="#004488", ls="-", lw=1.1,
                  label="slow flow (corrected eq2.24) from $R_0, \\theta_0$ of x(0), $\\dot{x}(0)$ (ERRATA 9)"),
    "paper": dict(color="#009988", ls="--", lw=1.1,
                  label="slow flow (corrected eq2.24) from the paper's $R_0 = \\Delta$, $\\theta_0 = 0$ (eq2.22)"),
    "paper_literal": dict(color="0.35", ls=":", lw=1.1,
                          label="slow flow as printed in the paper (sin/cos swapped, ERRATA 1), paper's start"),
}


STROKES_PER_WIDTH = 3.0  # a line at most a third of the room between two strokes: no solid block


def _line_scale(fig, ax, curves):
    """The factor (at most 1) on the slow-flow figure's line widths that keeps the strokes of its
    time panels apart: over 40 periods lines 1.6 points wide, four of them one over another, drew
    solid blocks. A stroke is a crossing of a curve's mid-height (two a cycle of the position,
    more of the velocity, which jumps at impacts); each line is then at most 1/STROKES_PER_WIDTH
    of the room between the strokes of the busiest curve (1 where that leaves the lines their
    widths: 15 periods across a panel of the default figure). ``curves``: the values drawn against
    time."""
    strokes = max([_strokes(values) for values in curves] or [1])
    width = ax.get_position().width * fig.get_figwidth() * 72.0  # points, before the layout trims it
    room = width * LAYOUT_SHARE / max(strokes, 1)
    return float(min(1.0, room / STROKES_PER_WIDTH / 1.6))


def _strokes(values):
    """How many times ``values`` cross their mid-height."""
    values = np.asarray(values, dtype=np.float64)
    values = values[np.isfinite(values)]
    if values.size < 2:
        return 0
    return int(np.count_nonzero(np.diff(np.sign(values - (values.max() + values.min()) / 2.0)) != 0))


LAYOUT_SHARE = 0.9  # of an axes' first width that the constrained layout leaves it, about


@figure_options
def slow_flow_figure(data, periods=None, starts=("state", "paper", "paper_literal")) -> Figure:
    """The effective system (numerical) against the first-order reconstruction eq2.21 (Fig. 6)."""
    if "effective" not in data.runs or not data.slow_flow:
        raise UsageError.naming("{path} holds no effective trajectory and slow flow: make it with "
                                "{simulate_compare} (or a config with model: effective)",
                                {"simulate_compare": "a simulation with compare_effective"},
                                path=data.path or "the trajectory")  # vrsweep.simulate's has no file
    config = _parse_config(data.config_text)
    delta = config.parameters["Delta"] if config is not None else None
    window = _time_window(data, periods)
    run = data.runs["effective"]
    t, x, v = with_impacts(run.t, run.x, run.v, run.impacts, delta)
    t, x, v = _in_window(t, window, x, v)
    fig = _new_figure(13.0, 4.8)
    ax_x, ax_v, ax_phase = fig.subplots(1, 3)
    flows = [_in_window(flow.t, window, flow.x, flow.v)[1:] for start, flow in data.slow_flow.items() if start in starts]
    thin = _line_scale(fig, ax_x, [x, v] + [values for pair in flows for values in pair])
    numerical = dict(color="#CC3311", lw=1.6 * thin, alpha=0.8, label="effective system eq2.10, numerical (with impacts)")
    ax_x.plot(t, x, **numerical)[0]._vrsweep_thinned = True
    ax_v.plot(t, v, **numerical)
    ax_phase.plot(x, v, **numerical)
    for start in starts:
        if start not in data.slow_flow:
            continue
        flow = data.slow_flow[start]
        flow_t, flow_x, flow_v = _in_window(flow.t, window, flow.x, flow.v)
        style = dict(SLOW_FLOW_STYLES.get(start, dict(label=start)))
        style["lw"] = style.get("lw", 1.1) * thin
        if not np.isfinite(flow_x).any():  # say so rather than list a curve that draws nothing
            style["label"] += ": no finite value (not drawn)"
        ax_x.plot(flow_t, flow_x, **style)[0]._vrsweep_thinned = True
        ax_v.plot(flow_t, flow_v, **style)
        ax_phase.plot(flow_x, flow_v, **style)
    if delta is not None:
        ax_x.axhline(delta, color="k", lw=0.8, ls="-.", label="barrier $x = \\Delta$")
        ax_phase.axvline(delta, color="k", lw=0.8, ls="-.")
    for ax, what, letter in ((ax_x, "position", "a"), (ax_v, "velocity", "b"), (ax_phase, "phase portrait", "c")):
        ax.set_title(f"({letter}) {what}", fontsize="small")
        ax.grid(alpha=0.3)
    for ax in (ax_x, ax_v):
        ax.set_xlabel(f"time $t$")
        ax.set_xlim(*window)
    ax_x.set_ylabel(f"position $x$, $X$")
    ax_v.set_ylabel(f"velocity $\\dot{{x}}$, $\\dot{{X}}$")
    ax_phase.set_xlabel(f"position $x$, $X$")
    ax_phase.set_ylabel(f"velocity $\\dot{{x}}$, $\\dot{{X}}$")
    handles, labels = ax_x.get_legend_handles_labels()
    if thin < 1.0:  # the legend's samples at the lines' full widths: thinned, the dotted one vanished
        from matplotlib.lines import Line2D

        handles = [Line2D([], [], color=line.get_color(), ls=line.get_linestyle(), alpha=line.get_alpha(),
                          lw=line.get_linewidth() / (thin if getattr(line, "_vrsweep_thinned", False) else 1.0))
                   for line in handles]
    fig.legend(handles, labels, loc="outside lower center", ncol=_legend_columns(fig, 2), fontsize="x-small")
    _title(fig, f"Effective system against the slow-flow reconstruction X = R cos(ωt + θ) (eq2.21) at "
                f"{_point_text(config, _headline(config))}, {_window_text(window, data)}; the first-order theory ignores the barrier",
           _caption(data.path or "", config, "effective system eq2.10 and its slow flow", width=_width(fig)))
    return fig
