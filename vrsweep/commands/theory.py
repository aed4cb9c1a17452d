"""``vrsweep theory CONFIG.yaml [--set ...] [--json]``: the paper's predictions for a config.

One row per Omega of the config (and per value of any other swept parameter that enters the
theory): g_res (eq3.4), wt2 and K (eq2.11, eq2.12) at the config's g or over its g axis, and the
analytic peak -- the largest stable amplitude of X over the g axis, or over a default grid
0..2 g_res when g is not swept. All numbers come from vrsweep.analysis.theory (corrected derivation,
ERRATA 1-3); amplitudes are of X, the gain is A/c (ERRATA 6).
"""

from __future__ import annotations

import json
import math
import textwrap

import click

from vrsweep.commands.options import config_argument, set_option
from vrsweep.analysis.theory import DEFAULT_G_POINTS, theory_rows

# Beyond this a number is written with an exponent: g_res = 1.3e200 (Omega = 1e100) was 201
# digits of ".3f", one column wider than the terminal.
_FIXED_AT_MOST = 1e9


def _number(value, spec):
    if value is None:
        return "-"  # the theory has no such number (a row outside it: its note says why)
    if math.isfinite(value) and abs(value) >= _FIXED_AT_MOST:
        return format(value, ".4g")
    return format(value, spec)


def _span(low, high, spec):
    return _number(low, spec) if low == high else f"{_number(low, spec)}..{_number(high, spec)}"


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
            stable = row["stable_amplitudes_at_g"]
            cells.append("-" if stable is None else ", ".join(_number(A, ".4f") for A in stable) or "none")
        cells += [_number(row["peak_g"], ".3f"), _number(row["peak_amplitude"], ".4f"),
                  _number(row["peak_gain"], ".2f")]
        lines.append(cells)

    widths = [max(len(str(column[i])) for column in [header, *lines]) for i in range(len(header))]
    text = ["  ".join(cell.rjust(width) for cell, width in zip(cells, widths)) for cells in [header, *lines]]
    text.insert(1, "  ".join("-" * width for width in widths))

    notes = []
    searches = [row["peak_search"] for row in rows if row["peak_search"] is not None]  # a row outside the theory has none
    if rows and rows[0]["g_swept"] and searches:
        search = searches[0]
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


def _finite_or_null(value):
    """``value`` with every float that is not finite (inf, nan) replaced by None, at any depth."""
    if isinstance(value, dict):
        return {key: _finite_or_null(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_null(item) for item in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


@click.command("theory")
@config_argument
@set_option
@click.option("--json", "as_json", is_flag=True, help="Print the same data as JSON (a list of per-Omega objects).")
def command(config_path, overrides, as_json):
    """Analytic predictions of the paper's model for CONFIG.yaml: g_res (eq3.4), wt2 and K (eq2.11,
    eq2.12), and the analytic peak per Omega (corrected derivation, ERRATA 1-3; amplitudes are of X,
    ERRATA 6). A written model has no theory here."""
    from vrsweep.config import load_config  # ConfigError propagates: the CLI group exits 2

    rows = theory_rows(load_config(config_path, overrides))
    if as_json:
        # JSON has no inf or nan: a value that overflows (g >= 1e155 squares past the largest
        # float) is written as null, as the table writes "-" for a value that does not exist.
        click.echo(json.dumps(_finite_or_null(rows), indent=2, allow_nan=False))
    else:
        click.echo(format_table(rows))
