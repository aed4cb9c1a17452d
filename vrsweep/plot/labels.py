"""What every figure shares: the constants of its look, axis labels with symbols and units,
the caption of what is fixed, and the figure itself (matplotlib's Figure, no pyplot)."""

from __future__ import annotations

import contextvars
import functools
import inspect
import numbers
import os
import re
import warnings
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from vrsweep.errors import UsageError, clip
from vrsweep.numbertext import to_float
from vrsweep.plot import layout
from vrsweep.plot.palettes import LINE_COLOURS

from vrsweep.numerics.model import (
    INITIAL_STATE_LONG_NAMES, INITIAL_STATE_SYMBOLS, PARAMETER_LONG_NAMES, PARAMETER_SYMBOLS,
)


SWEEP_KINDS = ("response", "map", "impacts", "status", "motion", "bifurcation", "lyapunov", "bifurcation+lyapunov")
TRAJECTORY_KINDS = ("trajectory", "impacts", "slowflow")
KINDS = ("response", "map", "impacts", "status", "motion", "bifurcation", "lyapunov", "bifurcation+lyapunov", "trajectory",
         "slowflow")

RELATIVE_ERROR_LIMIT = 0.10
"""R counts as unreliable where R_err > 10% of R (R_err is a 95% half-width, see diagnostics.py).
A periodic point measured over a window that is not a whole number of its cycles carries a few
per cent (R_err includes that offset); a chaotic one tens of per cent."""
MAX_CURVES = 8          # more curves than this on one response plot is unreadable: ask for --at
CURVES_NOT_MAP = 5      # a 2-axis sweep whose shorter axis has at most this many values: curves
FINE_POINTS = 2001      # analytic curves are drawn on a grid this fine, not on the sweep's points
DIMENSIONLESS = ("1", "")  # the paper's model is dimensionless: such axes show no unit at all

MODEL_EQUATIONS = {"original": "original system eq2.1-eq2.2", "effective": "effective system eq2.10"}
DIRECTION_NAMES = {1: "up", -1: "down"}
# One colour per curve, every two apart on a greyscale page (palettes.LINE_COLOURS): as many as
# MAX_CURVES, so that no figure with a legend repeats a colour or a grey.
RELIABLE_COLOURS = LINE_COLOURS
FAILED_COLOUR = "tab:red"
MARKERS = {False: "o", True: "s"}  # period found: circle; none found (period 0): square
LYAPUNOV_SYMBOL = "$\\lambda_1$"  # the largest Lyapunov exponent, on every figure that shows it
LOG_SPAN = 100.0  # measured values spanning this ratio (two decades) or more get a log axis


# --------------------------------------------------------------------------------------------
# Labels and captions
# --------------------------------------------------------------------------------------------


def units_suffix(units) -> str:
    """' [s]' for a real unit; '' for none or a dimensionless one ("1"): an axis of the paper's
    dimensionless model reads 'fast forcing amplitude $g$', never '... [1]'."""
    if units is None:
        return ""
    units = units.decode() if isinstance(units, bytes) else str(units)
    return "" if units.strip() in DIMENSIONLESS else f" [{units.strip()}]"


# The written model whose file is being drawn (numerics.written.WrittenModel), or None for the
# paper's: its parameters are labelled by their names, or the LaTeX symbols its config gives.
_WRITTEN_MODEL = contextvars.ContextVar("vrsweep_written_model", default=None)


def use_model(model):
    """Label parameters as ``model``'s (a written model, or a name of the paper's)."""
    _WRITTEN_MODEL.set(None if isinstance(model, str) or model is None else model)


def written_model():
    """The written model being drawn (``use_model``), or None for the paper's."""
    return _WRITTEN_MODEL.get()


def period_words(symbol=True) -> str:
    """The period a count or a sample is per: the paper's slow period 2 pi/omega, or a written
    model's own period T."""
    if _WRITTEN_MODEL.get() is not None:
        return "period $T$" if symbol else "period"
    return "slow period $2\\pi/\\omega$" if symbol else "slow period"


def stuck_words() -> str:
    """Where a mass with lambda_1 = -inf sat: the paper's one barrier, or one of a written model's."""
    return "stuck on a barrier" if _WRITTEN_MODEL.get() is not None else "stuck on the barrier"


def gain_words() -> str:
    """What R is: the paper's |Q|/c (eq3.3), or a written model's |Q| over its response scale."""
    model = _WRITTEN_MODEL.get()
    if model is not None:
        return written_gain(model.response_scale, mathtext=False)
    return "gain R = |Q|/c (eq3.3)"


def written_expression(text) -> str:
    """A written model's expression (its response frequency or scale) as a label shows it: a bare
    parameter by its symbol ($\\omega$, where the ylabel read 'Q at frequency omega' beside an
    x axis of $\\omega$), anything else as written."""
    return _written_symbol(str(text).strip()) or str(text)


def written_response_label(model, amplitude=False) -> str:
    """A written model's response axis: its gain and the frequency Q is read at ('gain $R = |Q|$ /
    |F|, $Q$ at frequency $\\omega$'), or |Q| itself with ``amplitude``. One label for sweeps and
    branches: a branch's said 'gain R = |Q| / |F|' alone, and R = 0 of a period-1 orbit read at
    w/2 looked like a failure."""
    frequency = written_expression(model.response_frequency)
    if amplitude:
        return f"amplitude $|Q|$ of x at {frequency}"
    return f"{written_gain(model.response_scale)}, $Q$ at frequency {frequency}"


def written_gain(scale, mathtext=True) -> str:
    """'gain R = |Q| / |s|' of a written model with response scale ``scale``; 'gain R = |Q|' where
    the scale is 1 (the label read "|Q| / |1.0|")."""
    gain = "gain $R = |Q|$" if mathtext else "gain R = |Q|"
    try:
        if float(str(scale)) == 1.0:
            return gain
    except ValueError:
        pass
    return f"{gain} / |{written_expression(scale)}|" if mathtext else f"{gain}/|{written_expression(scale)}|"


def _written_symbol(name):
    model = _WRITTEN_MODEL.get()
    if model is None or name not in model.parameter_names:
        return None
    given = model.symbol(name)
    return f"${given}$" if given else name


def parameter_label(name: str, units=None) -> str:
    """'fast forcing amplitude $g$' for a parameter, with its symbol and units (``units``: as a
    file's coordinate says; default: the model's, dimensionless, so none shown)."""
    if name == "direction":
        return "continuation direction"
    written = _written_symbol(name)
    if written is not None:
        return f"parameter {written}{units_suffix(units)}"
    if name in INITIAL_STATE_LONG_NAMES:  # x0, v0: 'initial position $x(0)$'
        words = INITIAL_STATE_LONG_NAMES[name].rsplit(" ", 1)[0]
        return f"{words} {INITIAL_STATE_SYMBOLS[name]}{units_suffix(units)}"
    words = PARAMETER_LONG_NAMES.get(name, name)
    if words.endswith(" " + name):
        words = words[: -len(name) - 1]
    return f"{words} {PARAMETER_SYMBOLS.get(name, name)}{units_suffix(units)}"


def _symbol(name: str) -> str:
    """$g$ for a parameter, $x(0)$ for an initial state, the name itself otherwise."""
    return _written_symbol(name) or PARAMETER_SYMBOLS.get(name) or INITIAL_STATE_SYMBOLS.get(name, name)


parameter_symbol = _symbol


def _number(value) -> str:
    return f"{value:.6g}"


def literal(text) -> str:
    """``text`` from outside vrsweep (a file's name, a written model's name) as a figure draws it:
    every $ escaped. matplotlib reads a text with an even number of $ as mathtext: a model named
    'a $\\frac{$ b' (or a file 'p$\\frac{$.h5') stopped every figure with a traceback from its
    parser, and one $ in a file's name ('p$.h5') made the caption's count odd, so every symbol
    of it was drawn as raw markup ('$\\gamma$ = 0.22'). ``description`` gives the text back as it
    was (its \\, { and } too, which it drops from the markup around)."""
    text = str(text)
    shown = text.replace("$", "\\$")
    if any(character in text for character in "$\\{}"):
        _LITERALS[shown] = text
    return shown


_LITERALS = {}  # text from outside as a figure draws it (``literal``) -> as it was, for ``description``


def model_title(model) -> str:
    """A written model's title (its name, or 'written model') as a figure draws it (``literal``)."""
    return literal(model.title)


def _caption(path, config, model, selected=None, extra="", width=100, omit=()):
    """File and model, then the parameters held fixed (swept ones and ``omit`` left out), initial
    state and run length, wrapped at ``width`` characters between items (never inside 'name = value')."""
    selected = dict(selected or {})
    items = [literal(os.path.basename(path)), MODEL_EQUATIONS.get(model, model)]
    if config is not None:
        if config.written:
            items[1] = written_equation(config.model)
        swept = ({axis.name for axis in config.axes} - set(selected)) | set(omit)
        parameters = dict(config.parameters, **selected)
        run = config.integration
        items += [f"{_symbol(name)} = {_number(parameters[name])}"
                  for name in config.parameter_names if name not in swept]
        items += [f"x(0) = {_number(config.initial['x'])}", f"$\\dot{{x}}(0)$ = {_number(config.initial['v'])}",
                  f"{run.transient_periods} transient + {run.measure_periods} measured "
                  f"{'periods T' if config.written else 'slow periods'}"]
    items += ["all quantities dimensionless"] + ([extra] if extra else [])
    return _wrap(items, width)


_PLAIN_EQUATIONS = {}  # a written model's equation as mathtext -> as its config wrote it (``description``)


# A function's name after a factor: mathtext sets "a \cos" as "acos", read as arccos, where TeX puts
# a thin space between a factor and an operator's name.
_FUNCTION_AFTER_FACTOR = re.compile(r"(?<=[\w}]) (\\(?:operatorname|(?:arc)?(?:sin|cos|tan|cot|sec|csc)h?|log|ln|exp"
                                    r"|max|min)(?![a-zA-Z]))")


def _spaced_functions(latex) -> str:
    """``latex`` with a thin space between a factor and the function it multiplies ('a \\,\\cos')."""
    return _FUNCTION_AFTER_FACTOR.sub(lambda match: "\\," + match.group(1), latex)


def written_equation(model) -> str:
    """'name: $\\ddot{x} = ...$' of a written model, in its symbols (``written.acceleration_latex``),
    for a caption; as the config wrote it ("x'' = -2*zeta*v - x + ...") where matplotlib's mathtext
    cannot draw sympy's LaTeX. The figure's description (its file's metadata) keeps the config's text."""
    from matplotlib.mathtext import MathTextParser

    from vrsweep.numerics.written import acceleration_latex

    written = f"{model_title(model)}: x'' = {model.acceleration}"
    try:
        latex = f"${_spaced_functions(acceleration_latex(model))}$"
        MathTextParser("path").parse(latex)
    except Exception:  # noqa: BLE001 -- anything sympy prints that mathtext does not draw
        return written
    _PLAIN_EQUATIONS[latex] = f"x'' = {model.acceleration}"
    return f"{model_title(model)}: {latex}"


class Wrapped(str):
    """A caption as drawn, broken into lines to fit the canvas, that keeps its text unbroken
    (``plain``) for the figure's metadata: where the canvas broke a line says nothing about the
    text, and a PDF's Subject made each break a "; " (γ = 0.22; α = 0.1, "the; barrier's")."""

    def __new__(cls, shown, plain):
        text = super().__new__(cls, shown)
        text.plain = plain
        return text


def plain_text(caption) -> str:
    """``caption`` without the line breaks the canvas put in (a :class:`Wrapped`'s ``plain``);
    a caption's own separate lines (a note of its own) are kept."""
    return getattr(caption, "plain", caption)


def caption_lines(*captions) -> Wrapped:
    """Captions drawn one below the other; unbroken, each its own line."""
    return Wrapped("\n".join(captions), "\n".join(plain_text(caption) for caption in captions))


def _wrap(items, width):
    """Items joined by commas into lines of at most ``width`` visible characters (never broken
    inside an item), as a :class:`Wrapped`: its ``plain`` text is the items on one line."""
    def visible(text):
        return len(text.replace("$", "").replace("\\", ""))  # mathtext markup takes no room

    lines, line = [], ""
    for item in items:
        if line and visible(line) + visible(item) + 2 > width:
            lines.append(line)
            line = ""
        if not line:
            # An item wider than the line (a written model's equation) ran off the canvas: broken
            # at its own spaces, or inside $...$ before a + or - outside any brackets, the
            # mathtext closed at the end of the line and opened again on the next.
            while visible(item) > width:
                cut = _break_at(item, width, visible)
                if cut is None:
                    break
                head, item = cut
                lines.append(head)
        line = f"{line},  {item}" if line else item
    return Wrapped("\n".join(lines + [line]), ", ".join(items))


_SIZED = re.compile(r"\\(left|right)(?![a-zA-Z])")  # \left( ... \right): brackets mathtext pairs


def _break_at(text, width, visible):
    """(the line, the rest) of ``text`` broken at the last place that leaves at most ``width``
    visible characters on the line: a space outside mathtext, or a + or - (with a space either
    side) inside it at the top level, neither in braces nor between \\left and \\right, where
    the line ends the mathtext ($) and the rest opens it again. None where there is none.

    A $ after a backslash is text, as matplotlib reads it (``literal``'s escaped names): one
    taken for mathtext put a name's '\\$' out of step with the caption's real markup."""
    best, in_math, depth, start = None, False, 0, None
    for index, char in enumerate(text):
        if char == "$" and text[index - 1:index] != "\\":
            in_math, depth, start = not in_math, 0, index
        elif in_math and char in "{}" and text[index - 1:index] != "\\":
            depth += 1 if char == "{" else -1
        elif in_math and char == "\\" and _SIZED.match(text, index):
            depth += 1 if _SIZED.match(text, index).group(1) == "left" else -1
        elif char == " " and not in_math and index > 0:
            if visible(text[:index]) > width:
                break
            best = (text[:index].rstrip(), text[index:].lstrip())
        elif (in_math and depth == 0 and char in "+-" and text[index - 1:index] == " "
              and text[index + 1:index + 2] == " " and text[start + 1:index].strip()):
            head = text[:index].rstrip() + "$"
            if visible(head) > width:
                break
            best = (head, "$" + text[index:])
    return best


def _parse_config(text):
    """The config stored in a file, or None if it cannot be read back (then captions are shorter)."""
    from vrsweep.config import parse_config
    from vrsweep.errors import ConfigError

    if not text:
        use_model(None)  # no model known: the paper's words, not the last file's model
        return None
    try:
        config = parse_config(text, "<stored config>")
    except ConfigError:
        use_model(None)
        return None
    use_model(config.model)  # a written model's parameters are labelled by its own symbols
    return config


_REQUESTED_SIZE = contextvars.ContextVar("vrsweep_figure_size", default=None)


def _new_figure(width, height):
    """A figure of (width, height) inches, or of the size asked for through ``figure_options``
    (made at that size from the start, so that captions wrap to it)."""
    return Figure(figsize=_REQUESTED_SIZE.get() or (width, height), layout="constrained")


def _title(fig, what, caption):
    """The figure's title: what it shows, then the caption. Also kept as the figure's description
    (``description``), which goes into the file's metadata even when the title is left off."""
    # Wrapped as the caption is: a title wider than the figure (a trajectory's, with its warning
    # that the samples alias the fast force) ran off both edges of the canvas.
    shown = _wrap([what], _width(fig))
    fig.suptitle(f"{shown}\n{_within_height(fig, caption, shown.count(chr(10)) + 1)}",
                 fontsize="small")  # relative: follows the style's font size
    fig._vrsweep_description = (what, caption)


# The share of a figure's height its title and caption may take, and the height of one of their
# lines in font sizes (mathtext's sub- and superscripts make a line taller than text's 1.2).
TITLE_HEIGHT_SHARE = 0.4
TITLE_LINE_HEIGHT = 1.35


def _within_height(fig, caption, title_lines):
    """``caption`` as drawn under a title of ``title_lines`` lines: whole where it fits in
    TITLE_HEIGHT_SHARE of the figure's height, else its first and last lines with the middle
    left out (a written model of forty parameters: an equation and a list of them that took half
    the canvas). The figure's description (its file's metadata) keeps the whole caption."""
    from matplotlib.font_manager import FontProperties

    lines = str(caption).split("\n")
    points = FontProperties(size="small").get_size_in_points() * TITLE_LINE_HEIGHT
    room = max(2, int(TITLE_HEIGHT_SHARE * fig.get_figheight() * 72.0 / points) - title_lines)
    if len(lines) <= room:
        return str(caption)
    tail = (room - 1) // 2
    head = room - 1 - tail
    cut = len(lines) - head - tail
    marker = f"... ({cut} lines more in the figure's description: vrsweep info FIGURE)"
    if len(marker) > _width(fig):
        marker = f"... ({cut} lines more)"
    return "\n".join([*lines[:head], marker, *lines[len(lines) - tail:]])


# A legend's columns on a narrow figure: layout.legend_columns (there, as layout re-makes legends).
from vrsweep.plot.layout import LEGEND_COLUMN_WIDTH, legend_columns as _legend_columns  # noqa: E402


def _width(fig):
    """Characters of caption text that fit across ``fig`` at the title's font size (the style's
    'small'; a character is about 0.56 of the font size wide)."""
    from matplotlib.font_manager import FontProperties

    points = FontProperties(size="small").get_size_in_points()
    return max(20, int(fig.get_figwidth() * 72.0 / (0.56 * points)))


# --------------------------------------------------------------------------------------------
# Options every figure takes: title, size, style (and vmin/vmax where there is a colour scale)
# --------------------------------------------------------------------------------------------


def check_flags(**flags):
    """FlagTypeError for the first figure option that is not True or False (numpy's included):
    ``title="no"`` drew the title, as any non-empty string is true."""
    from vrsweep.errors import FlagTypeError

    for name, value in flags.items():
        if not isinstance(value, (bool, np.bool_)):
            raise FlagTypeError(name, value)


def resolve_style(style):
    """A matplotlib style sheet's name (``matplotlib.style.available``, e.g. 'seaborn-v0_8-paper')
    or the path of a .mplstyle file; UsageError naming ``style`` otherwise. None: no style."""
    import matplotlib.style

    if style is None:
        return None
    text = os.fspath(style)
    if text in matplotlib.style.available or text == "default":
        return text
    if Path(text).expanduser().is_file():
        path = str(Path(text).expanduser())
        problem = _style_file_problem(path)
        if problem:
            raise UsageError.naming("{style} {value}: {problem}", value=text, problem=problem)
        try:
            with matplotlib.style.context(path):
                pass
        except (OSError, ValueError) as error:
            raise UsageError.naming("{style} {value}: not a readable matplotlib style file ({reason})",
                                    value=text, reason=str(error).splitlines()[0]) from None
        return path
    raise UsageError.naming("{style} {value}: no such matplotlib style sheet or file; the named styles are "
                            "{names} (or give the path of a .mplstyle file)",
                            value=text, names=", ".join(sorted(matplotlib.style.available)))


# The largest |vmin|, |vmax| a colour bar draws without overflowing (figure_options).
LIMIT_MAGNITUDE = 1e300
# font.family may name these, which matplotlib resolves through its own font lists.
_GENERIC_FAMILIES = ("serif", "sans-serif", "sans", "cursive", "fantasy", "monospace")


def _strip_comment(line) -> str:
    """``line`` without its comment: from the first # outside double quotes (a colour "#eeeeee" is
    a value), as matplotlib reads its style files."""
    inside = False
    for index, character in enumerate(line):
        if character == '"':
            inside = not inside
        elif character == "#" and not inside:
            return line[:index].strip()
    return line.strip()


def _style_file_problem(path) -> str | None:
    """What is wrong with a .mplstyle file, in words, or None: an unknown key, a value matplotlib
    refuses, a font.family that is not installed. matplotlib itself warns of each every time the
    style is applied, and of a missing font at every text drawn: hundreds of lines for one mistake."""
    import matplotlib
    from matplotlib import font_manager

    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as error:
        return f"not a readable matplotlib style file ({error})"
    installed = {font.name for font in font_manager.fontManager.ttflist}
    for number, line in enumerate(lines, 1):
        content = _strip_comment(line)
        if not content:
            continue
        key, colon, value = content.partition(":")
        key, value = key.strip(), value.strip().strip('"')
        if not colon or key not in matplotlib.rcParams.validate:
            return f"line {number}: {key!r} is not a matplotlib setting"
        try:
            checked = matplotlib.rcParams.validate[key](value)
        except (ValueError, TypeError) as error:
            return f"line {number}: {key}: {str(error).splitlines()[0]}"
        if key == "font.family":
            missing = [name for name in checked if name.lower() not in _GENERIC_FAMILIES and name not in installed]
            if missing:
                return f"line {number}: font.family: no font {missing[0]!r} is installed"
    return None


def _usetex_problem(programs=("latex",)) -> str | None:
    """With text.usetex on, the ``programs`` it runs (latex for any figure, dvipng too for a PNG)
    that are not installed here, as a problem in words; None otherwise."""
    import shutil

    import matplotlib

    if not matplotlib.rcParams["text.usetex"]:
        return None
    missing = [name for name in programs if shutil.which(name) is None]
    if not missing:
        return None
    return (f"text.usetex is on, but {' and '.join(missing)} (which it runs for every label) "
            f"{'is' if len(missing) == 1 else 'are'} not installed here; turn text.usetex off (mathtext draws "
            "the same symbols without LaTeX)")


def _settings_problem() -> str | None:
    """What in the matplotlib settings in force (a style applied, or the user's matplotlibrc) no
    figure can be drawn with, in words, or None: text.usetex without LaTeX installed (a traceback
    from deep inside the drawing), a colour cycle with no colour (a ZeroDivisionError)."""
    import matplotlib

    problem = _usetex_problem()
    if problem:
        return problem
    cycle = matplotlib.rcParams["axes.prop_cycle"]
    if len(cycle) == 0 or ("color" in cycle.keys and not cycle.by_key()["color"]):
        return "axes.prop_cycle holds no colour: a figure needs at least one"
    return None


# A PNG is drawn in memory, 4 bytes a pixel, before it is compressed: a canvas of at most this many
# pixels (1 GB while drawn) and of sides at most Agg's own limit (2^16 pixels).
MAX_PIXELS = 250_000_000
MAX_SIDE_PIXELS = 65535


def check_canvas(fig, file_format, dpi):
    """UsageError naming ``size`` and ``dpi`` when a .png of ``fig`` at ``dpi`` would be larger than
    MAX_PIXELS or MAX_SIDE_PIXELS a side (--size 40,40 --dpi 1200 asked for 48000^2 pixels, 9 GB).
    A PDF or SVG is drawn as vectors: its size in pixels is not allocated."""
    if file_format != "png":
        return
    width, height = (float(inches) * dpi for inches in fig.get_size_inches())
    if width * height > MAX_PIXELS or max(width, height) > MAX_SIDE_PIXELS:
        raise UsageError.naming(
            "{size} and {dpi}: a {inches} in figure at {dots} dpi is {width:.0f} x {height:.0f} pixels, more than a "
            "PNG may have here ({limit:.2g} pixels, at most {side} a side); lower {dpi} or {size}, or write a .pdf "
            "or .svg", inches="x".join(f"{i:g}" for i in fig.get_size_inches()), dots=dpi, width=width,
            height=height, limit=MAX_PIXELS, side=MAX_SIDE_PIXELS)


def parse_size(text):
    """'W,H' in inches -> (W, H), both positive; UsageError naming ``size`` otherwise."""
    if isinstance(text, (tuple, list)):
        parts = list(text)
    elif isinstance(text, str):
        parts = text.split(",")  # not 3x2: an x is no separator anywhere else in vrsweep's options
    else:
        parts = None
    try:
        width, height = (to_float(part) for part in parts)
    except (TypeError, ValueError):  # NumberTextError is a ValueError
        raise UsageError.naming("{size} {value}: expected WIDTH,HEIGHT in inches, e.g. 3.4,2.6",
                                value=clip(text)) from None
    if not (0.5 <= width <= 100 and 0.5 <= height <= 100):
        raise UsageError.naming("{size} {value}: width and height must be between 0.5 and 100 inches",
                                value=clip(text))
    return width, height


def figure_options(function):
    """Give a figure function the options every figure takes, as keyword arguments:

    title: False leaves the figure without any title (no suptitle, no panel titles); the full
        description stays in the figure's ``description`` (the file's metadata, see ``metadata``).
    size: (width, height) in inches, or 'W,H'.
    style: a matplotlib style sheet name or .mplstyle path; every artist is made under it, so fonts,
        colours and line widths follow the style (the figure keeps it for ``render``).
    vmin, vmax: the colour scale's limits, passed on to functions that draw one (maps); to any
        other figure they are an error rather than quietly ignored.
    xlim, ylim: (low, high) or 'LOW,HIGH', the main panel's axis limits and those of every panel
        showing the same quantity (``layout.apply_limits``); a function that takes ``xlim`` itself
        (a branch figure, which zooms on its own unless told where) is given it too.
    legend: 'best' (inside the main panel), 'outside' (below the panels) or 'none'; None: each
        figure's own place, moved inside when below it would leave the panels under half the
        figure (``layout.arrange``).

    A function that takes ``xlim`` or ``ylim`` itself is given it and sets it (a branch figure zooms
    on its own unless told where; a response figure's caption says what the view asked for leaves
    out); the others' are set here, on the figure they return.
    """
    takes_limits = "vmin" in inspect.signature(function).parameters
    takes_xlim = "xlim" in inspect.signature(function).parameters
    takes_ylim = "ylim" in inspect.signature(function).parameters

    @functools.wraps(function)
    def wrapper(*args, title=True, size=None, style=None, vmin=None, vmax=None, xlim=None, ylim=None,
                legend=None, **kwargs):
        import matplotlib.style

        check_flags(title=title)
        if style is not None and not isinstance(style, (str, os.PathLike)):
            raise UsageError.naming("{style} must be a style sheet's name or a .mplstyle file's path, got {value!r}",
                                    value=style)
        style = resolve_style(style)
        size = parse_size(size) if size is not None else None
        xlim, ylim = layout.parse_limits(xlim, "xlim"), layout.parse_limits(ylim, "ylim")
        if legend is not None and legend not in layout.LEGEND_PLACES:
            raise UsageError.naming("{legend} {value}: one of {places}", value=legend,
                                    places=", ".join(layout.LEGEND_PLACES))
        if takes_xlim:
            kwargs["xlim"] = xlim
        if takes_ylim:
            kwargs["ylim"] = ylim
        if takes_limits:
            for key, value in (("vmin", vmin), ("vmax", vmax)):
                # matplotlib's colour bar does arithmetic on its ends (tick steps, bin middles): near
                # the float64 limit it overflows, with a page of RuntimeWarnings and a wrong bar.
                if value is not None and (isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real)):
                    # vmin="a" was a ValueError from float(); vmin=True a colour scale from 1
                    raise UsageError.naming("{" + key + "} must be a number, got {value!r}", value=value)
                if value is not None and not abs(float(value)) <= LIMIT_MAGNITUDE:
                    raise UsageError.naming("{" + key + "} {value}: the end of a colour scale must be a finite "
                                            "number of magnitude at most {limit:g}", value=value,
                                            limit=LIMIT_MAGNITUDE)
            kwargs.update(vmin=vmin, vmax=vmax)
        elif vmin is not None or vmax is not None:
            raise UsageError.naming("{vmin} and {vmax} set the colour scale of a map; this figure has none")
        token = _REQUESTED_SIZE.set(size) if size is not None else None
        try:
            with matplotlib.style.context(style or {}):
                problem = _settings_problem()
                if problem:
                    where = "{style} {value}" if style else "matplotlib's settings (matplotlibrc)"
                    raise UsageError.naming(where + ": {problem}", value=style, problem=problem)
                fig = function(*args, **kwargs)
                layout.settle_strips(fig)
                if size is not None and not getattr(fig, "_vrsweep_grown", False):
                    fig.set_size_inches(*size)  # a figure not made by _new_figure gets the size too
                fig._vrsweep_style = style
                fig._vrsweep_title = bool(title)
                fig._vrsweep_ylim_given = ylim is not None  # the layout may not raise a panel's top then
                layout.apply_limits(fig, None if takes_xlim else xlim, None if takes_ylim else ylim)
                if not title:
                    _drop_titles(fig)
                layout.place_legend(fig, legend)
                # Under the style: labels are measured in the fonts they are drawn in.
                fig._vrsweep_legend_note = layout.arrange(fig, legend)
        finally:
            if token is not None:
                _REQUESTED_SIZE.reset(token)
        return fig

    return wrapper


def _drop_titles(fig):
    """No suptitle and no axes title of any kind (left, centre, right) anywhere on ``fig``."""
    if fig._suptitle is not None:
        fig._suptitle.remove()
        fig._suptitle = None
    for ax in fig.get_axes():
        for loc in ("left", "center", "right"):
            ax.set_title("", loc=loc)


def description(fig) -> str:
    """The figure's full title and caption as plain text (mathtext's $ and \\ dropped)."""
    what, caption = getattr(fig, "_vrsweep_description", ("", ""))
    text = f"{what}\n{plain_text(caption)}".strip()
    for equation, plain in _PLAIN_EQUATIONS.items():  # a written model's, as its config wrote it
        text = text.replace(equation, plain)
    # Text from outside (``literal``) is kept as it was: set aside while the markup goes.
    kept = sorted(_LITERALS.items(), key=lambda item: -len(item[0]))
    for number, (shown, _) in enumerate(kept):
        text = text.replace(shown, f"\x00{number}\x00")
    for markup, plain in MATHTEXT_PLAIN.items():
        text = text.replace(markup, plain)
    text = text.replace("$", "").replace("\\", "")
    for number, (_, original) in enumerate(kept):
        text = text.replace(f"\x00{number}\x00", original)
    return text


def _greek() -> dict:
    """Every Greek letter's LaTeX name -> the letter: a written model's symbols are any of them
    (its \\zeta and \\varphi were "zeta" and "varphi" in a figure's metadata)."""
    import unicodedata

    letters = ("alpha beta gamma delta epsilon zeta eta theta iota kappa lambda mu nu xi omicron pi rho sigma tau "
               "upsilon phi chi psi omega").split()
    table = {}
    for name in letters:
        table[f"\\{name}"] = unicodedata.lookup(f"GREEK SMALL LETTER {name.upper().replace('LAMBDA', 'LAMDA')}")
        table[f"\\{name.capitalize()}"] = unicodedata.lookup(
            f"GREEK CAPITAL LETTER {name.upper().replace('LAMBDA', 'LAMDA')}")
    table.update({"\\varphi": "φ", "\\varepsilon": "ε", "\\vartheta": "ϑ", "\\varrho": "ϱ", "\\varsigma": "ς"})
    # longest first: \\varphi before \\phi would not matter, but \\epsilon inside \\varepsilon would
    return dict(sorted(table.items(), key=lambda item: -len(item[0])))


MATHTEXT_PLAIN = {"\\dot{x}": "ẋ", "\\tilde\\omega": "ω̃", "\\omega_0": "ω0", "\\lambda_1": "λ1",
                  **_greek(), "\\infty": "∞", "{": "", "}": ""}


def metadata(fig, file_format) -> dict:
    """The metadata matplotlib's savefig writes for ``file_format`` (png, pdf, svg): the figure's
    title line as Title and its full description (title and caption) as Description (PNG, SVG) or
    Subject (PDF, whose info dictionary has no Description)."""
    from vrsweep._version import __version__

    text = description(fig)
    title = text.splitlines()[0] if text else ""
    software = f"vrsweep {__version__}"
    if file_format == "pdf":
        return {"Title": title, "Subject": text.replace("\n", "; "), "Creator": software}
    if file_format == "svg":
        return {"Title": title, "Description": text, "Creator": software}
    return {"Title": title, "Description": text, "Software": software}


def render(fig, file_format, dpi) -> bytes:
    """``fig`` as the bytes of a .png/.pdf/.svg file at ``dpi``, with its description in the
    metadata, drawn under the style it was made with."""
    import io

    import matplotlib.style

    check_canvas(fig, file_format, dpi)
    image = io.BytesIO()
    with matplotlib.style.context(getattr(fig, "_vrsweep_style", None) or {}), \
            warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        problem = _usetex_problem(("latex", "dvipng")) if file_format == "png" else None
        if problem:
            style = getattr(fig, "_vrsweep_style", None)
            where = "{style} {value}" if style else "matplotlib's settings (matplotlibrc)"
            raise UsageError.naming(where + ": {problem}", value=style, problem=problem)
        fig.savefig(image, format=file_format, dpi=dpi, metadata=metadata(fig, file_format))
    # matplotlib's own warning names its internals; say what to do instead (layout_note).
    fig._vrsweep_layout_note = "too small" if any("collapsed to zero" in str(w.message) for w in caught) else ""
    for w in caught:
        if "collapsed to zero" not in str(w.message):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return image.getvalue()


TOO_SMALL = "the figure is too small for its {texts}, so they overlap the axes: {advice}"


def layout_note(fig) -> str:
    """'' or why the last ``render`` of ``fig`` could not lay it out (too small for its texts), with
    what to do about it -- never to leave off a title that is already off."""
    if not getattr(fig, "_vrsweep_layout_note", ""):
        return ""
    if getattr(fig, "_vrsweep_title", True):
        return TOO_SMALL.format(texts="title, labels and legend", advice="leave the title off or make the figure larger")
    return TOO_SMALL.format(texts="labels and legend", advice="make the figure larger or leave the legend off")


def legend_note(fig) -> str:
    """'' or where the legend went when its own place would have left the panels under half the
    figure (``layout.arrange``)."""
    return getattr(fig, "_vrsweep_legend_note", "")


FIGURE_SUFFIXES = (".png", ".pdf", ".svg")
FIGURE_WORDS = {".png": "a PNG image", ".pdf": "a PDF", ".svg": "an SVG image"}
# Bytes that open a file of each format: a PNG's signature, a PDF's header (matplotlib writes it
# first), and an SVG's root element (after an XML declaration, a doctype or comments).
_FIGURE_STARTS = {".png": re.compile(rb"\A\x89PNG\r\n\x1a\n"), ".pdf": re.compile(rb"\A%PDF-"),
                  ".svg": re.compile(rb"\A(?:\xef\xbb\xbf)?\s*(?:<\?xml[^>]*>\s*|<!--.*?-->\s*|<!DOCTYPE[^>]*>\s*)*<svg[\s>]",
                                     re.S | re.I)}
_HEAD_BYTES = 4096


def figure_format(path) -> str | None:
    """The figure format (a FIGURE_SUFFIXES entry) the bytes of the file at ``path`` are, whatever
    its name; None for any other file (``file_contents`` says what it holds)."""
    with open(path, "rb") as handle:
        head = handle.read(_HEAD_BYTES)
    return next((suffix for suffix, start in _FIGURE_STARTS.items() if start.match(head)), None)


def file_contents(path) -> str:
    """What the file at ``path`` holds, in a few words ('text', 'an HDF5 file', 'a PNG image'...),
    as its bytes say, for a file that is not what its name says."""
    from vrsweep.store.fileio import is_hdf5

    found = figure_format(path)
    if found is not None:
        return FIGURE_WORDS[found]
    if is_hdf5(path):
        return "an HDF5 file"
    with open(path, "rb") as handle:
        head = handle.read(_HEAD_BYTES)
    if not head:
        return "nothing (0 bytes)"
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as error:
        text = head[:error.start].decode("utf-8") if error.start > len(head) - 4 else None
    if text is not None and "\x00" not in text:
        return "text"
    return "data of another kind"


def read_description(path) -> dict:
    """{'Title': ..., 'Description': ...} that ``render`` wrote into a figure file (.png, .pdf,
    .svg); empty strings where the file holds none (a figure not made by vrsweep)."""
    suffix = Path(path).suffix.lower()
    found = {"Title": "", "Description": ""}
    if not made_by_vrsweep(path):
        # Another program's title is no description of ours: matplotlib's own SVG names its
        # creator in a dc:title ("Matplotlib v3.11.2, ..."), which info printed as the figure's.
        return found
    if suffix == ".png":
        from PIL import Image

        with Image.open(path) as image:
            text = dict(getattr(image, "text", {}) or {})
        found.update({key: text.get(key, "") for key in found})
    elif suffix == ".svg":
        text = Path(path).read_text(encoding="utf-8", errors="replace")
        for key, tag in (("Title", "title"), ("Description", "description")):
            match = re.search(rf"<dc:{tag}>(.*?)</dc:{tag}>", text, re.S)
            if match:
                import html

                found[key] = html.unescape(match.group(1))
    elif suffix == ".pdf":
        data = Path(path).read_bytes()
        for key, field in (("Title", b"Title"), ("Description", b"Subject")):
            match = re.search(rb"/" + field + rb" \((.*?)(?<!\\)\)", data, re.S)
            if match:
                found[key] = _pdf_string(match.group(1))
    return found


# What ``metadata`` writes into each format, as it lands in the file's bytes: a PNG's tEXt chunk
# "Software", a PDF's /Creator, an SVG's dc:creator.
_MADE_BY_VRSWEEP = re.compile(rb"Software\x00vrsweep \d|/Creator \(vrsweep \d|<dc:title>vrsweep \d")
# A figure vrsweep wrote is well under this; a larger file is someone else's.
_FIGURE_BYTES_AT_MOST = 256 * 1024 * 1024


def made_by_vrsweep(path) -> bool:
    """Whether the file at ``path`` is a figure vrsweep wrote (``render``'s metadata names vrsweep
    as its software): such a file is replaced unasked, any other only when asked to."""
    try:
        if os.path.getsize(path) > _FIGURE_BYTES_AT_MOST:
            return False
        with open(path, "rb") as handle:
            return _MADE_BY_VRSWEEP.search(handle.read()) is not None
    except OSError:
        return False


def _pdf_string(raw: bytes) -> str:
    """A PDF literal string as text: backslash escapes undone (matplotlib writes plain ASCII or
    a UTF-16 string with a byte-order mark)."""
    out, i = bytearray(), 0
    while i < len(raw):
        if raw[i:i + 1] == b"\\" and i + 1 < len(raw):
            nxt = raw[i + 1:i + 2]
            mapping = {b"n": b"\n", b"r": b"\r", b"t": b"\t", b"(": b"(", b")": b")", b"\\": b"\\"}
            if nxt in mapping:
                out += mapping[nxt]
                i += 2
                continue
            if nxt.isdigit():
                digits = raw[i + 1:i + 4]
                octal = re.match(rb"[0-7]{1,3}", digits).group(0)
                out.append(int(octal, 8))
                i += 1 + len(octal)
                continue
        out += raw[i:i + 1]
        i += 1
    if out.startswith(b"\xfe\xff"):
        return out[2:].decode("utf-16-be", errors="replace")
    return out.decode("latin-1")
