"""The config's ``model``: one of the paper's (``original``, ``effective``) or a model written out as
data (docs/models.md), checked here into a numerics.written.WrittenModel.

    model:
      name: linear impact oscillator                  # optional: titles and files
      acceleration: "-2*zeta*v - x + F*cos(omega*t + phi)"
      parameters: {zeta: 0.05, F: 1.0, omega: 0.8, phi: 0.0, Delta: 1.2, r: 0.8}
      symbols: {zeta: '\\zeta'}                       # optional: LaTeX for axis labels
      barriers:                                        # zero, one or two
        - {position: Delta, side: above, restitution: r}
      period: "2*pi/omega"                             # the stroboscopic period T
      response: {frequency: omega, scale: F}           # R = |Q| / |scale| at that frequency
      max_step: "period/8"                             # optional: the step cap (accuracy of R)

Every expression is checked by numerics.expressions (a whitelist over the syntax tree: a config
never runs code). What needs the grid (a positive period, restitutions in [0, 1], barriers that
do not overlap, a start between them) is checked once the axes are known (check_written_model).

Methods of one validation run (vrsweep.config.validate._Validator), which provides ``report``.
"""

from __future__ import annotations

import keyword
import math

import numpy as np

from vrsweep.config.schema import ANY, INITIAL_STATE_AXES, INTEGRATION_DEFAULTS, PARAMETER_DOMAINS, Domain
from vrsweep.config.wording import did_you_mean, show
import vrsweep.numerics.expressions as expressions
from vrsweep.numerics.model import DEFAULT_PARAMETERS, PARAMETER_NAMES
from vrsweep.numerics.written import SCAN_STEPS_PER_MAX_STEP, SIDES, Barrier, WrittenModel

MODEL_KEYS = ("name", "acceleration", "parameters", "ranges", "symbols", "barriers", "period", "response",
              "max_step")
REQUIRED_KEYS = ("acceleration", "parameters", "period", "response")
BARRIER_KEYS = ("position", "side", "restitution")
RESPONSE_KEYS = ("frequency", "scale")
MAX_PARAMETERS = 64
MAX_NAME_LENGTH = 200
# Names the result files give their own arrays (a sweep's variables and dimensions, a curves
# file's, tests/test_written_models.py keeps this list complete): a parameter of one of these
# names is an axis or a column of the same name, and h5py refused the second after the whole
# run ("name already exists"). The store cannot be imported here (tests/test_layout.py).
STORED_NAMES = frozenset((
    "R", "Qs", "Qc", "Q_amplitude", "R_err", "impacts_per_period", "status", "period", "motion",
    "impacts_per_cycle", "strobe", "strobe_x", "strobe_v", "x_min", "x_max", "impact_speed_min",
    "impact_speed_max", "impact_speed_mean", "impact_phase", "impact_phase_spread", "stuck_fraction",
    "x_final", "v_final", "n_steps", "n_rhs", "lyapunov", "lyapunov_err", "done", "owned",
    "point", "multiplier", "curve_id", "special", "curve", "periods", "barrier_distance", "residual",
    "multiplier_real", "multiplier_imag", "multiplier_modulus", "curve_kind", "curve_periods",
    "curve_end_first_status", "curve_end_first_reason", "curve_end_last_status", "curve_end_last_reason",
    "special_kind", "special_curve",
    # dimensions: a sweep with continuation: both has one named direction (config/grid.py), and a
    # parameter of that name swept beside it stopped the run with "duplicate axis names"
    "direction"))
# A grid this large is checked point by point; a larger one along each axis through the fixed values.
FULL_CHECK_POINTS = 1_000_000


def parameter_names(model) -> tuple[str, ...]:
    return model.parameter_names if isinstance(model, WrittenModel) else PARAMETER_NAMES


def parameter_defaults(model) -> dict[str, float]:
    return model.defaults if isinstance(model, WrittenModel) else dict(DEFAULT_PARAMETERS)


def parameter_domains(model) -> dict:
    """The interval each parameter may take: the paper's table, or a written model's declared
    ``ranges`` (closed; any value where none is declared). What a written model's values may not
    make (a negative period, a restitution above one) is checked at the grid's points besides."""
    if isinstance(model, WrittenModel):
        declared = {name: range_domain(low, high) for name, low, high in model.ranges}
        return {name: declared.get(name, ANY) for name in model.parameter_names}
    return PARAMETER_DOMAINS


def range_domain(low, high):
    """A declared range [low, high] (None: unbounded on that side) as a Domain."""
    return Domain(low=-math.inf if low is None else float(low), high=math.inf if high is None else float(high),
                  low_open=low is None, high_open=high is None)


class ModelSection:
    """Checks of ``model``: mixed into the validation run, which provides ``report``."""

    def read_model(self, value):
        """The config's model: a name of the paper's, a WrittenModel, or None after a problem in a
        written one. Anything but a mapping is returned as it is: the document's schema checks it
        (``must be one of original, effective``) with the other sections."""
        if not isinstance(value, dict):
            return "original" if value is None else value
        problems = len(self.problems)
        for key in value:
            if key not in MODEL_KEYS:
                self.report(("model", key), f"unknown key{did_you_mean(str(key), MODEL_KEYS)}",
                            allowed=", ".join(MODEL_KEYS))
        for key in REQUIRED_KEYS:
            if value.get(key) is None:
                self.report(("model", key), f"{_absent(value, key)} (a written model needs acceleration, parameters, "
                                            f"period and response)")
        name = value.get("name")
        if name is not None and not (isinstance(name, str) and 0 < len(name) <= MAX_NAME_LENGTH
                                     and name.isprintable()):
            self.report(("model", "name"), f"must be a line of text of at most {MAX_NAME_LENGTH} characters, "
                                           f"got {show(name)}")
        parameters = self._model_parameters(value.get("parameters"))
        names = tuple(parameters) if parameters is not None else ()
        symbols = self._model_symbols(value.get("symbols"), names)
        ranges = self._model_ranges(value.get("ranges"), parameters or {})
        acceleration = self._expression(value, ("acceleration",), names + expressions.STATE_NAMES, parameters)
        if acceleration is not None:
            switches = expressions.switch_count(expressions.parse(acceleration, names + expressions.STATE_NAMES))
            if switches > expressions.MAX_SWITCHES:
                self.report(("model", "acceleration"),
                            f"has kinks or jumps (abs, sign, min, max of x, v or t) on {switches} surfaces; the kernel "
                            f"locates at most {expressions.MAX_SWITCHES}: write a law of that many segments with "
                            f"fewer, or a smooth one (tanh)")
                acceleration = None
        barriers = self._model_barriers(value.get("barriers"), names, parameters)
        period = self._expression(value, ("period",), names, parameters)
        response = value.get("response")
        frequency = scale = None
        if response is not None and not isinstance(response, dict):
            self.report(("model", "response"), f"must be a mapping {{frequency, scale}}, got {show(response)}")
        elif isinstance(response, dict):
            for key in response:
                if key not in RESPONSE_KEYS:
                    self.report(("model", "response", key), f"unknown key{did_you_mean(str(key), RESPONSE_KEYS)}",
                                allowed=", ".join(RESPONSE_KEYS))
            if response.get("frequency") is None:
                self.report(("model", "response", "frequency"),
                            f"{_absent(response, 'frequency')}: the frequency of R's Fourier component")
            frequency = self._expression(response, ("response", "frequency"), names, parameters)
            scale = self._expression(response, ("response", "scale"), names, parameters, default="1")
        max_step = self._expression(value, ("max_step",), names + ("period",), parameters)
        if len(self.problems) > problems or parameters is None:
            return None
        return WrittenModel(acceleration=acceleration, parameters=tuple(parameters.items()), barriers=barriers,
                            period=period, response_frequency=frequency, response_scale=scale, max_step=max_step,
                            name=name, symbols=symbols, ranges=ranges)

    def _model_parameters(self, value):
        path = ("model", "parameters")
        if value is None:
            return None  # reported as missing
        if not isinstance(value, dict):
            self.report(path, f"must be a mapping of parameter name -> default value, got {show(value)}")
            return None
        if len(value) > MAX_PARAMETERS:
            self.report(path, f"has {len(value)} parameters; at most {MAX_PARAMETERS}")
            return None
        parameters = {}
        for name, default in value.items():
            where = path + (name,)
            reason = _bad_name(name)
            if reason:
                self.report(where, reason)
                continue
            if isinstance(default, bool) or not isinstance(default, (int, float)) \
                    or not math.isfinite(float(default)):
                self.report(where, f"must be a finite number (the parameter's default), got {show(default)}")
                continue
            parameters[name] = float(default)
        return parameters if len(parameters) == len(value) else None

    def _model_ranges(self, value, parameters):
        """``ranges: {name: [low, high]}``: where each named parameter is defined (closed; null for
        no bound on that side). The default must lie inside. Returns ((name, low, high), ...)."""
        path = ("model", "ranges")
        if value is None:
            return ()
        if not isinstance(value, dict):
            self.report(path, f"must be a mapping of parameter name -> [low, high], got {show(value)}")
            return ()
        ranges = []
        for name, bounds in value.items():
            where = path + (name,)
            if name not in parameters:
                self.report(where, f"not a parameter of the model{did_you_mean(str(name), tuple(parameters))}",
                            allowed=", ".join(parameters))
                continue
            if not (isinstance(bounds, list) and len(bounds) == 2 and all(
                    bound is None or (not isinstance(bound, bool) and isinstance(bound, (int, float))
                                      and math.isfinite(float(bound))) for bound in bounds)):
                self.report(where, f"must be [low, high], finite numbers or null (no bound), got {show(bounds)}")
                continue
            low, high = (None if bound is None else float(bound) for bound in bounds)
            if low is None and high is None:
                self.report(where, "bounds nothing: give a low or a high end (or leave the parameter out)")
                continue
            if low is not None and high is not None and not low < high:
                self.report(where, f"must have low < high, got {show(bounds)}")
                continue
            domain = range_domain(low, high)
            if not domain.contains(parameters[name]):
                self.report(("model", "parameters", name),
                            f"the default {domain.range_message(parameters[name])} (model.ranges.{name})")
                continue
            ranges.append((name, low, high))
        return tuple(ranges)

    def _model_symbols(self, value, names):
        if value is None:
            return ()
        if not isinstance(value, dict):
            self.report(("model", "symbols"), f"must be a mapping of parameter name -> LaTeX, got {show(value)}")
            return ()
        symbols = []
        for name, symbol in value.items():
            if name not in names and name not in INITIAL_STATE_AXES:
                self.report(("model", "symbols", name), f"not a parameter of the model{did_you_mean(str(name), names)}",
                            allowed=", ".join(names))
            elif not (isinstance(symbol, str) and 0 < len(symbol) <= MAX_NAME_LENGTH and symbol.isprintable()):
                self.report(("model", "symbols", name), f"must be a short LaTeX string such as '\\\\zeta', got "
                                                        f"{show(symbol)}")
            elif (problem := _mathtext_problem(symbol)) is not None:
                self.report(("model", "symbols", name), f"matplotlib cannot draw ${symbol}$: {problem}")
            else:
                symbols.append((name, symbol))
        return tuple(symbols)

    def _model_barriers(self, value, names, parameters):
        path = ("model", "barriers")
        if value is None:
            return ()
        if not isinstance(value, list) or len(value) > 2:
            self.report(path, f"must be a list of zero, one or two barriers, got {show(value)}",
                        allowed="[{position, side: above|below, restitution}, ...]")
            return ()
        barriers = []
        for index, item in enumerate(value):
            where = path + (index,)
            if not isinstance(item, dict):
                self.report(where, f"must be a mapping {{position, side, restitution}}, got {show(item)}")
                continue
            for key in item:
                if key not in BARRIER_KEYS:
                    self.report(where + (key,), f"unknown key{did_you_mean(str(key), BARRIER_KEYS)}",
                                allowed=", ".join(BARRIER_KEYS))
            for key in BARRIER_KEYS:
                if item.get(key) is None:
                    self.report(where + (key,), _absent(item, key))
            side = item.get("side")
            if side is not None and side not in SIDES:
                self.report(where + ("side",), f"must be above (the mass stays at x <= position) or below "
                                               f"(x >= position), got {show(side)}")
            position = self._expression(item, ("barriers", index, "position"), names, parameters)
            restitution = self._expression(item, ("barriers", index, "restitution"), names, parameters)
            if position is not None and restitution is not None and side in SIDES:
                barriers.append(Barrier(position, side, restitution))
        if len(barriers) == 2 and barriers[0].side == barriers[1].side:
            self.report(path + (1, "side"), f"two barriers on the same side ({barriers[0].side}): only the inner "
                                            f"one could ever be met; give one above and one below")
        return tuple(barriers)

    def _expression(self, mapping, key_path, names, parameters, default=None):
        """The canonical text of an expression at model.<key_path> (numbers are expressions too),
        or ``default`` if absent; None after a problem (the caller counts the problems)."""
        path = ("model",) + key_path
        value = mapping.get(key_path[-1]) if isinstance(mapping, dict) else None
        if value is None:
            return default
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            self.report(path, f"must be an expression (a string such as \"2*pi/omega\", or a number), "
                              f"got {show(value)}")
            return None
        if not isinstance(value, str) and not math.isfinite(float(value)):  # repr: 'inf', "an unknown name"
            self.report(path, f"must be a finite number or an expression, got {show(value)}")
            return None
        text = value if isinstance(value, str) else repr(float(value))
        # With the parameters broken, ``names`` holds only what the field knows besides them (the
        # acceleration's x, v, t; the step cap's period): still known, not "depends on x" blamed on
        # an acceleration that may.
        try:
            expressions.parse(text, names)
        except expressions.ExpressionError as error:
            if parameters is None and ("unknown name" in str(error) or isinstance(error, expressions.NonAsciiError)):
                return None  # the parameters themselves are broken: that is the problem reported
            message = str(error)
            if key_path[0] == "barriers" and key_path[-1] == "position" and "depends on t," in message:
                message += ("; a stop that moves is written in the distance y = x - s(t) to it, where it stands "
                            "still at 0 (docs/models.md, \"A moving stop: write the model in the distance to it\")")
            self.report(path, message)
            return None
        return expressions.canonical(text)


def _absent(mapping, key) -> str:
    """A required key left out, or written as null (``period:`` with nothing after it): YAML reads
    both as nothing, and a null passed the check for a missing key, leaving a model without its
    acceleration (a traceback at the run) or a barrier silently dropped."""
    return "missing" if key not in mapping else "is null, which gives no value"


def _mathtext_problem(symbol) -> str | None:
    """Why matplotlib's mathtext cannot draw ``$symbol$`` (the figures' labels), or None.

    Checked here, with matplotlib's own parser (imported only for a model that gives symbols): a
    symbol such as '\\frac{' passed the config and the run, then every figure of the file
    failed with a traceback from deep in matplotlib."""
    from matplotlib.mathtext import MathTextParser

    try:
        MathTextParser("path").parse(f"${symbol}$")
    except ValueError as error:
        lines = str(error).strip().splitlines()
        return lines[-1] if lines else "not mathtext"
    return None


def _bad_name(name) -> str | None:
    if isinstance(name, str) and name.isidentifier() and not name.isascii():
        # 'ζ' is a letter to Python, and was refused as "must be letters, digits and _"
        return (f"must be a name in ASCII letters, digits and _, got {show(name)}: write it in Latin letters "
                f"(zeta) and give its typeset look under model.symbols (zeta: '\\zeta')")
    if not isinstance(name, str) or not name.isidentifier() or not name.isascii():
        return f"must be a name (ASCII letters, digits and _, not starting with a digit), got {show(name)}"
    if keyword.iskeyword(name):
        return f"{name} is a Python keyword and cannot name a parameter"
    if name in expressions.RESERVED:
        return (f"{name} is taken: x, v and t are the state and time, pi the constant, and "
                f"{', '.join(expressions.FUNCTIONS)} the functions")
    if name in INITIAL_STATE_AXES:
        return f"{name} is taken: x0 and v0 are the initial-state axes of a sweep (basins)"
    if name in INTEGRATION_DEFAULTS or name == "model":
        return f"{name} is taken: --set {name}=VALUE sets integration.{name}" if name != "model" else \
            "model is taken: --set model=VALUE chooses the model"
    if name in STORED_NAMES:
        return f"{name} is taken: result files name their own {name!r} array so (rename the parameter)"
    if len(name) > 40:
        return f"is longer than 40 characters: {name[:40]}..."
    return None


# A config without initial.x starts where the paper's Fig. 6 does: say so, or the message names a
# value the user never wrote.
_DEFAULT_START = ("; the config gives no initial.x, and the default start is the paper's (x, v) = (0.99, 0.5): "
                  "write initial: {x: ..., v: ...}")


def _follows_the_period(model: WrittenModel) -> bool:
    """Whether the step cap is computed from the period (the default period/8 is)."""
    return model.max_step is None or "period" in expressions.names_in(
        expressions.parse(model.max_step, tuple(model.parameter_names) + ("period",)))


# The states at which an acceleration must be finite somewhere: x and v over a few units, t over a
# period, at irrational-looking values that no written singularity (x = 1, v = 0) sits on.
_TRIED_X = (-2.713, -0.917, -0.131, 0.277, 0.853, 1.619, 3.141)
_TRIED_V = (-1.733, -0.293, 0.0, 0.419, 2.237)
_TRIED_PHASES = (0.0, 0.318, 0.707)
_TRIED_POINTS = 64


def _undefined_everywhere(report, model: WrittenModel, values, period) -> bool:
    """Report an acceleration that is NaN or infinite at every state tried (1/(x - x), sqrt(-1 -
    x**2)) at every grid point tried (up to _TRIED_POINTS, spread over the grid): every point would
    end non_finite, after the kernel's compile. One singular state (1/x at a start on x = 0), or one
    grid point (sqrt(-c**2) at c = 1 of c in [0, 1]), stays a status on its grid point."""
    shape = np.broadcast_shapes(*(np.shape(values[name]) for name in model.parameter_names), np.shape(period))
    n_points = math.prod(shape)
    rows = np.unique(np.linspace(0, n_points - 1, min(n_points, _TRIED_POINTS)).astype(np.int64))
    column = (slice(None), None, None, None)  # points along the first axis, states along the others

    def tried(array):
        return np.broadcast_to(np.asarray(array, dtype=np.float64), shape).reshape(-1)[rows][column]

    point = {name: tried(values[name]) for name in model.parameter_names}
    x, v, phase = np.meshgrid(_TRIED_X, _TRIED_V, _TRIED_PHASES, indexing="ij")
    tree = expressions.parse(model.acceleration, model.parameter_names + expressions.STATE_NAMES)
    acceleration = expressions.evaluate(tree, {**point, "x": x, "v": v, "t": phase * tried(period)})
    if np.isfinite(acceleration).any():
        return False
    first = {name: float(array.reshape(-1)[0]) for name, array in point.items()}
    where = ", ".join(f"{name} = {show(value)}" for name, value in first.items())
    points = f"at each of {len(rows)} grid points tried, e.g." if len(rows) > 1 else "at"
    report(("model", "acceleration"), f"is NaN or infinite at every one of the {x.size} states tried "
                                      f"(x in [{_TRIED_X[0]}, {_TRIED_X[-1]}], v in [{_TRIED_V[0]}, {_TRIED_V[-1]}], "
                                      f"t over a period, {points} {where}): every point would end non_finite")
    return True


def check_written_model(report, model: WrittenModel, fixed: dict, axes: dict, initial: dict, swept_initial: dict,
                        initial_given=True, velocity_given=True, run=None):
    """The rules a written model's values must keep at every grid point (or along each axis through
    the fixed values, for a grid beyond FULL_CHECK_POINTS): each reported once, at the model's field.

    fixed: name -> the parameter's fixed value; axes: name -> values of the swept parameters;
    initial: {"x", "v"} (None where invalid); swept_initial: x0 / v0 -> values; run: the sweep's
    (periods, max_steps) for the time-scale rules (time_scale_problem), None where there is no
    sweep to run (a branch's domain).
    """
    from vrsweep.numerics.written import header_values

    names = model.parameter_names
    swept = [name for name in names if name in axes]
    n_points = math.prod(len(axes[name]) for name in swept) if swept else 1
    if n_points <= FULL_CHECK_POINTS:
        grids = np.meshgrid(*(np.asarray(axes[name], dtype=np.float64) for name in swept), indexing="ij")
        points = {name: fixed[name] for name in names}
        points.update({name: grid.reshape(-1) for name, grid in zip(swept, grids)})
        samples = [points]
    else:
        samples = [{**{n: fixed[n] for n in names}, name: np.asarray(axes[name], dtype=np.float64)} for name in swept]
    for values in samples:
        header = header_values(model, values)

        def first_bad(array, good):
            array = np.broadcast_to(np.asarray(array, dtype=np.float64), np.broadcast_shapes(
                *(np.shape(v) for v in values.values()), np.shape(array)))
            with np.errstate(invalid="ignore"):
                bad = ~good(array)
            if not bad.any():
                return None
            index = int(np.argmax(bad.reshape(-1)))
            where = ", ".join(f"{name} = {show(float(np.broadcast_to(values[name], array.shape).reshape(-1)[index]))}"
                              for name in names if np.ndim(values[name]) > 0)
            return float(array.reshape(-1)[index]), (f" at {where}" if where else "")

        rules = [(("period",), header["period"], lambda a: np.isfinite(a) & (a > 0), "must be > 0 and finite"),
                 (("response", "frequency"), header["response.frequency"], lambda a: np.isfinite(a) & (a > 0),
                  "must be > 0 and finite"),
                 (("response", "scale"), header["response.scale"], lambda a: np.isfinite(a) & (a != 0),
                  "must be finite and not 0 (R = |Q| / |scale|)"),
                 (("max_step",), header["max_step"], lambda a: np.isfinite(a) & (a > 0), "must be > 0 and finite")]
        for index in range(len(model.barriers)):
            rules.append((("barriers", index, "position"), header[f"barriers.{index}.position"], np.isfinite,
                          "must be finite"))
            rules.append((("barriers", index, "restitution"), header[f"barriers.{index}.restitution"],
                          lambda a: (a >= 0) & (a <= 1), "must be in [0, 1] (eq2.2: a rebound cannot gain energy)"))
        failed = period_failed = False
        for key_path, array, good, message in rules:
            if key_path == ("max_step",) and period_failed and _follows_the_period(model):
                continue  # a step cap of period/8 is bad because the period is: one problem, said there
            found = first_bad(array, good)
            if found is not None:
                value, where = found
                report(("model",) + key_path, f"{message}, got {show(value)}{where}")
                failed = True
                period_failed = period_failed or key_path == ("period",)
        if failed:
            return
        if run is not None:
            scales = [header[key] for key in ("period", "max_step", "response.frequency")]
            swept_shape = np.broadcast_shapes(*(np.shape(a) for a in scales))
            # The default cap, period/8, is 8 steps a period: a run beyond max_steps then is a small
            # budget, which a point's status reports, not a step cap out of scale with the period.
            problem = time_scale_problem(*scales, run[0], run[1] if model.max_step is not None else math.inf)
            if problem is not None:
                field, message, index = problem
                where = _point_at(values, names, index) if math.prod(swept_shape) > 1 else ""
                path = {"period": ("model", "period"), "frequency": ("model", "response", "frequency"),
                        "max_step": ("model", "max_step")}[field]
                report(path, f"{message}{where}")
                return
        if _undefined_everywhere(report, model, values, header["period"]):
            return
        if len(model.barriers) == 2:
            above = next(i for i, b in enumerate(model.barriers) if b.side == "above")
            below = 1 - above
            gap = header[f"barriers.{above}.position"] - header[f"barriers.{below}.position"]
            found = first_bad(gap, lambda a: a > 0)
            if found is not None:
                report(("model", "barriers", above, "position"),
                       f"must lie above the barrier below (model.barriers[{below}]), but the gap is "
                       f"{show(found[0])}{found[1]}")
                return
        x_values = swept_initial.get("x0", initial.get("x"))
        if x_values is None:
            return
        v_values = swept_initial.get("v0", initial.get("v"))
        for index, barrier in enumerate(model.barriers):
            position = header[f"barriers.{index}.position"]
            side = 1.0 if barrier.side == "above" else -1.0
            # The start nearest the barrier, measured towards it (x for a barrier above, -x below).
            nearest = float(np.max(side * np.asarray(x_values, dtype=np.float64)))
            found = first_bad(side * position, lambda level: nearest <= level)
            if found is not None:
                field = "sweep.x0" if "x0" in swept_initial else "initial.x"
                relation = "below" if barrier.side == "above" else "above"
                report(("sweep", "x0") if "x0" in swept_initial else ("initial", "x"),
                       f"must be {relation} or on model.barriers[{index}] (the mass starts between its barriers), "
                       f"got {field} = {show(side * nearest)} and the barrier at {show(side * found[0])}"
                       f"{found[1]}{'' if initial_given or 'x0' in swept_initial else _DEFAULT_START}")
                return
            if v_values is None:
                continue  # reported at the velocity itself
            # On the barrier the mass may rest or move away (a rebound's or a release's state);
            # moving into it, it is the state just before an impact, which has no after.
            into = float(np.max(side * np.asarray(v_values, dtype=np.float64)))
            found = first_bad(side * position, lambda level: (nearest < level) | (into <= 0.0))
            if found is not None and "v0" not in swept_initial and not velocity_given:
                report(("sweep", "x0") if "x0" in swept_initial else ("initial", "x"),
                       f"must be {'below' if side > 0 else 'above'} model.barriers[{index}], or on it only at rest "
                       f"or moving away: the config gives no initial.v, and the default {show(side * into)} moves "
                       f"into the barrier (the instant before an impact, not a state), got the barrier at "
                       f"{show(side * found[0])}{found[1]}")
                return
            if found is not None:
                field = "sweep.v0" if "v0" in swept_initial else "initial.v"
                start = "sweep.x0 reaches" if "x0" in swept_initial else "initial.x is on"
                sign = "<=" if barrier.side == "above" else ">="
                report(("sweep", "v0") if "v0" in swept_initial else ("initial", "v"),
                       f"must be {sign} 0 where the mass starts on a barrier ({start} model.barriers[{index}] at "
                       f"{show(side * found[0])}{found[1]}): a velocity into the barrier is the instant before an "
                       f"impact, not a state; give the velocity after it, got {field} = {show(side * into)}")
                return


# The kernel's shortest step at time t is 4 ulps of max(t, T) (kernel._smallest_step): a time scale
# shorter than that at the run's end cannot be stepped through, and a run shorter than that
# against a time scale moves nothing in doubles.
_ROUNDING_STEPS = 4.0 * float(np.finfo(np.float64).eps)
# The steps a cycle of the response must hold at least: a stuck mass's release scan steps 1/64 of
# the shortest forcing period, and R's quadrature needs a cycle resolved (at T = 1e14 a cycle of
# 7.85 was 3.4 of those shortest steps, and every point ended step_too_small).
CYCLE_STEPS = 64


def time_scale_problem(period, max_step, frequency, periods, max_steps):
    """Whether the period T can be integrated against the model's other time scales, the response
    frequency's cycle 2 pi / w and the step cap, over ``periods`` periods within ``max_steps``
    steps: None, or (field, message, flat index of the first bad point) where it cannot.

    ``period: 1e-300`` ran every point "ok": its 32 periods moved nothing in doubles (x stayed
    x0, R = 2 |x0| the mean, no Fourier component); ``period: 1e20`` ended each point
    step_too_small with advice to loosen the tolerance, since a cycle of 7.85 is below the
    rounding of t = 1e21; a step cap of T/1e12 would take 1e12 steps a period before max_steps."""
    with np.errstate(all="ignore"):
        period, max_step, frequency = (np.ravel(array) for array in np.broadcast_arrays(
            *(np.asarray(a, dtype=np.float64) for a in (period, max_step, frequency))))
        span = periods * period  # the whole run's time, where t's rounding is coarsest
        cycle = 2.0 * np.pi / frequency
        rounding = _ROUNDING_STEPS * span
        rules = (
            ("period", span <= _ROUNDING_STEPS * cycle,
             lambda i: f"T = {show(float(period[i]))} is too short to be integrated against the response frequency's "
                       f"cycle 2*pi/w = {show(float(cycle[i]))}: the whole run ({periods} periods) is below that cycle's "
                       f"rounding in doubles, so nothing moves and R is no Fourier component"),
            ("frequency", cycle <= CYCLE_STEPS * rounding,
             lambda i: f"w = {show(float(frequency[i]))} turns too fast for the time of the run in doubles: its cycle "
                       f"{show(float(cycle[i]))} is less than {CYCLE_STEPS} of the shortest steps at t = {show(float(span[i]))} "
                       f"({periods} periods of T = {show(float(period[i]))}); the period is too long against it"),
            ("max_step", max_step <= rounding,
             lambda i: f"the step cap {show(float(max_step[i]))} is below the rounding of t = {show(float(span[i]))} ({periods} "
                       f"periods of T = {show(float(period[i]))}): steps would not advance time"),
            # Flight takes a step per cap at least, a mass stuck on a stop a scan per cap/8, each
            # with a budget of max_steps: beyond 1 + 1/8 budgets at the cap no point can finish.
            ("max_step", span / max_step > (1.0 + 1.0 / SCAN_STEPS_PER_MAX_STEP) * max_steps,
             lambda i: f"the step cap {show(float(max_step[i]))} makes at least {span[i] / max_step[i]:.3g} steps "
                       f"over the run ({periods} periods of T = {show(float(period[i]))}), more than integration.max_steps "
                       f"= {max_steps}: every point would end max_steps"),
        )
        for field, bad, message in rules:
            if bad.any():
                index = int(np.argmax(bad))
                return field, message(index), index
    return None


def _point_at(values, names, index) -> str:
    """' at name = value, ...' for the swept names of flat point ``index`` ('' if nothing is swept)."""
    shape = np.broadcast_shapes(*(np.shape(values[name]) for name in names))
    swept = [name for name in names if np.ndim(values[name]) > 0]
    if not swept or index >= math.prod(shape):
        return ""
    return " at " + ", ".join(f"{name} = {show(float(np.broadcast_to(values[name], shape).reshape(-1)[index]))}"
                              for name in swept)
