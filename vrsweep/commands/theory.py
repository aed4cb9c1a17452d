"""``vrsweep theory CONFIG.yaml [--set ...] [--json]``: the paper's predictions for a config.

One row per Omega of the config (and per value of any other swept parameter that enters the
theory): g_res (eq3.4), wt2 and K (eq2.11, eq2.12) at the config's g or over its g axis, and the
analytic peak -- the largest stable amplitude of X over the g axis, or over a default grid
0..2 g_res when g is not swept. All numbers come from vrsweep.theory (corrected derivation,
ERRATA 1-3); amplitudes are of X, the gain is A/c (ERRATA 6).
"""

from __future__ import annotations

import itertools
import json
import math
import textwrap

import click
import numpy as np

from vrsweep import theory
from vrsweep.commands.options import config_argument, set_option

# Parameters that enter the first-order theory besides g. Delta and e do not (the theory ignores
# the barrier), so sweeping them gives no extra rows.
THEORY_PARAMETERS = ("gamma", "alpha", "c", "omega0", "omega", "Omega")
DEFAULT_G_POINTS = 2001  # the default peak grid 0..2 g_res, steps of g_res/1000


def _finite_or_none(value):
    value = float(value)
    return value if math.isfinite(value) else None


def _stable_amplitudes(params):
    points = theory.fixed_points(params)
    return [float(R) for R in points.R[points.stable]]


def theory_rows(config) -> list[dict]:
    """The per-Omega objects that ``--json`` prints (and the table shows)."""
    axes = {axis.name: axis.values for axis in config.axes}
    row_axes = [name for name in config.axis_names if name in THEORY_PARAMETERS]
    ignored_axes = [name for name in config.axis_names if name in ("Delta", "e")]
    g_swept = "g" in axes

    rows = []
    for row_values in itertools.product(*(axes[name] for name in row_axes)):
        params = dict(config.parameters)
        params.update({name: float(value) for name, value in zip(row_axes, row_values)})
        notes = [theory.THEORY_NOTE, theory.AMPLITUDE_NOTE]
        resonance_g = float(theory.g_res(params["alpha"], params["omega0"], params["omega"], params["Omega"]))

        if g_swept:
            g_values = np.asarray(axes["g"], dtype=np.float64)
            search = {"source": "sweep axis g", "g_min": float(g_values.min()),
                      "g_max": float(g_values.max()), "num": int(g_values.size)}
        elif math.isfinite(resonance_g):
            g_values = np.linspace(0.0, 2.0 * resonance_g, DEFAULT_G_POINTS)
            search = {"source": "default grid 0..2 g_res", "g_min": 0.0, "g_max": float(g_values[-1]),
                      "num": DEFAULT_G_POINTS}
        else:
            g_values = None
            search = None
            notes.append("g_res is undefined (alpha <= 0: wt2 never reaches omega^2); sweep g to get a peak")

        at_g = dict(params)
        if g_swept:
            at_g["g"] = g_values
        wt2 = np.atleast_1d(theory.effective_frequency_squared(at_g))
        K = np.atleast_1d(theory.damping_level(at_g))

        if math.isfinite(resonance_g):
            at_resonance = dict(params, g=resonance_g)
            stable_at_resonance = _stable_amplitudes(at_resonance)
            K_at_resonance = float(theory.damping_level(at_resonance))
        else:
            stable_at_resonance, K_at_resonance = [], math.nan

        if g_values is not None:
            peak = theory.analytic_peak(params, g_values)
            peak_g, peak_A, peak_gain = float(peak.g), float(peak.amplitude), float(peak.gain)
        else:
            peak_g = peak_A = peak_gain = math.nan
        if g_values is not None and not math.isfinite(peak_A):
            notes.append("no stable fixed point on the g grid: the slow flow may settle on a limit cycle "
                         "(a modulated, quasi-periodic response) that the fixed points do not describe")
        elif g_values is not None and peak_g in (float(g_values.min()), float(g_values.max())):
            notes.append(f"the largest stable amplitude lies at the end g = {peak_g:g} of the g range: "
                         "no interior peak on the stable branch (while K > 0 small amplitudes are "
                         "self-excited and the stable branch is the large, Van der Pol-like one); "
                         "see A(g_res), amplitude_at_g_res in --json")

        amplitudes = [peak_A, *stable_at_resonance]
        if not g_swept:
            stable_at_g = _stable_amplitudes(params)
            amplitudes += stable_at_g
        if any(A > params["Delta"] for A in amplitudes if math.isfinite(A)):
            notes.append(theory.BARRIER_NOTE)
        if ignored_axes:
            notes.append(f"{' and '.join(ignored_axes)} (swept) {'does' if len(ignored_axes) == 1 else 'do'} "
                         "not enter the first-order theory")

        rows.append({
            "Omega": params["Omega"],
            "parameters": {name: (None if name == "g" and g_swept else params[name]) for name in config.parameters},
            "swept": {name: params[name] for name in row_axes if name != "Omega"},
            "g_res": _finite_or_none(resonance_g),
            "g_swept": g_swept,
            "g": None if g_swept else params["g"],
            "g_range": [float(np.min(at_g["g"])), float(np.max(at_g["g"]))],
            "wt2_at_g": None if g_swept else float(wt2[0]),
            "K_at_g": None if g_swept else float(K[0]),
            "wt2_range": [float(wt2.min()), float(wt2.max())],
            "K_range": [float(K.min()), float(K.max())],
            "K_at_g_res": _finite_or_none(K_at_resonance),
            "stable_amplitudes_at_g": None if g_swept else stable_at_g,
            "stable_amplitudes_at_g_res": stable_at_resonance,
            "amplitude_at_g_res": max(stable_at_resonance) if stable_at_resonance else None,
            "peak_search": search,
            "peak_g": _finite_or_none(peak_g),
            "peak_amplitude": _finite_or_none(peak_A),
            "peak_gain": _finite_or_none(peak_gain),
            "notes": notes,
        })
    return rows


def _number(value, spec):
    return "-" if value is None else format(value, spec)


def _span(low, high, spec):
    return format(low, spec) if low == high else f"{format(low, spec)}..{format(high, spec)}"


def format_table(rows) -> str:
    """The rows as an aligned text table followed by their notes (each note once)."""
    swept_names = list(rows[0]["swept"]) if rows else []
    fixed_g = rows and not rows[0]["g_swept"]
    header = [*swept_names, "Omega", "g_res (eq3.4)", "g", "wt2 (eq2.11)", "K (eq2.12)", "A(g_res)"]
    if fixed_g:
        header.append("A(g) stable")
    header += ["peak g", "peak A", "peak gain A/c"]

    lines = []
    for row in rows:
        cells = [format(row["swept"][name], "g") for name in swept_names]
        cells += [
            format(row["Omega"], "g"),
            _number(row["g_res"], ".3f"),
            _span(*row["g_range"], ".3f"),
            _span(*row["wt2_range"], ".4f"),
            _span(*row["K_range"], ".4f"),
            _number(row["amplitude_at_g_res"], ".4f"),
        ]
        if fixed_g:
            cells.append(", ".join(format(A, ".4f") for A in row["stable_amplitudes_at_g"]) or "none")
        cells += [_number(row["peak_g"], ".3f"), _number(row["peak_amplitude"], ".4f"),
                  _number(row["peak_gain"], ".2f")]
        lines.append(cells)

    widths = [max(len(str(column[i])) for column in [header, *lines]) for i in range(len(header))]
    text = ["  ".join(cell.rjust(width) for cell, width in zip(cells, widths)) for cells in [header, *lines]]
    text.insert(1, "  ".join("-" * width for width in widths))

    notes = []
    if rows and rows[0]["g_swept"]:
        search = rows[0]["peak_search"]
        notes.append(f"peak: largest stable A over the sweep's {search['num']} values of g in "
                     f"[{search['g_min']:g}, {search['g_max']:g}]")
    elif any(row["peak_search"] is not None for row in rows):
        notes.append(f"peak: largest stable A over {DEFAULT_G_POINTS} values of g in [0, 2 g_res] of each row "
                     "(g is not swept)")
    for row in rows:
        for note in row["notes"]:
            if note not in notes:
                notes.append(note)
    text.append("")
    text += [textwrap.fill(note, width=100, initial_indent="- ", subsequent_indent="  ") for note in notes]
    return "\n".join(text)


@click.command("theory")
@config_argument
@set_option
@click.option("--json", "as_json", is_flag=True, help="Print the same data as JSON (a list of per-Omega objects).")
def command(config_path, overrides, as_json):
    """Analytic predictions for CONFIG.yaml: g_res (eq3.4), wt2 and K (eq2.11, eq2.12), and the
    analytic peak per Omega (corrected derivation, ERRATA 1-3; amplitudes are of X, ERRATA 6)."""
    from vrsweep.config import load_config  # ConfigError propagates: the CLI group exits 2

    rows = theory_rows(load_config(config_path, overrides))
    if as_json:
        click.echo(json.dumps(rows, indent=2, allow_nan=False))
    else:
        click.echo(format_table(rows))
