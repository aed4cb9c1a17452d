"""What every figure shares: the constants of its look, axis labels with symbols and units,
the caption of what is fixed, and the figure itself (matplotlib's Figure, no pyplot)."""

from __future__ import annotations

import os

from matplotlib.figure import Figure

from vrsweep.numerics.model import (
    INITIAL_STATE_LONG_NAMES, INITIAL_STATE_SYMBOLS, PARAMETER_LONG_NAMES, PARAMETER_NAMES, PARAMETER_SYMBOLS,
)


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
