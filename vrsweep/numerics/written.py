"""Written models: an oscillator given as data (its acceleration as an expression, its barriers,
period and response), compiled into the same kernel as the paper's models.

    x'' = a(x, v, t; p)                    between impacts, v = x'
    v -> -r v  at x = position             at each barrier (eq2.2's law), above or below the mass

A :class:`WrittenModel` is plain data (the config's ``model:`` mapping, checked by the config
layer). :func:`coefficients` fills its per-point coefficient vectors (the header of
coefficients.py, evaluated from the parameter expressions with numpy, then the parameters in
declared order), and codegen.py turns it into compiled kernels: the right-hand side, the Jacobian
d a / d(x, v) for the tangent vectors and the force at rest on each barrier, all derived
symbolically (sympy) and printed as Python that numba compiles.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field

import numpy as np

from vrsweep.numerics import expressions
from vrsweep.numerics.coefficients import (
    ABOVE, BELOW, HARMONIC, MAX_BARRIERS, MAX_STEP, N_BARRIERS, N_HEADER, PERIOD, POSITION, RESPONSE_FREQUENCY,
    RESPONSE_SCALE, RESTITUTION, SCAN_STEP, SIDE, STICK_SCAN_FRACTION, barrier_slot,
)

SIDES = {"above": ABOVE, "below": BELOW}
# Without a max_step the step is capped at this share of the period T (the paper's effective
# model uses 1/6 of its slow period; a model with a faster forcing than 2 pi / T should say so).
DEFAULT_STEP_SHARE = "period/8"
# The release scan of a stuck mass takes steps of max_step / 8: 1/64 of the shortest forcing
# period when max_step is 1/8 of it, as in the paper's models (coefficients.STICK_SCAN_FRACTION).
SCAN_STEPS_PER_MAX_STEP = 8


@dataclass(frozen=True)
class Barrier:
    """A rigid stop: ``position`` and ``restitution`` are expressions of the parameters; ``side``
    is ``above`` (the mass stays at x <= position) or ``below`` (x >= position)."""

    position: str
    side: str
    restitution: str


@dataclass(frozen=True)
class WrittenModel:
    """A model written in a config (docs/models.md). Expressions are stored in canonical form
    (expressions.canonical), parameters in declared order with their defaults."""

    acceleration: str
    parameters: tuple[tuple[str, float], ...]
    barriers: tuple[Barrier, ...] = ()
    period: str = ""
    response_frequency: str = ""
    response_scale: str = "1"
    max_step: str | None = None
    name: str | None = None
    symbols: tuple[tuple[str, str], ...] = field(default=())
    # Declared ranges (name, low, high), closed, None where unbounded: where the model is defined
    # (config/domains.py). Not in code_key: a range changes no compiled code.
    ranges: tuple[tuple[str, float | None, float | None], ...] = field(default=())

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(name for name, _ in self.parameters)

    @property
    def defaults(self) -> dict[str, float]:
        return dict(self.parameters)

    @property
    def title(self) -> str:
        return self.name or "written model"

    def __str__(self):  # in messages and titles: "the linear impact oscillator model"
        return self.title

    def as_data(self) -> dict:
        """The model as the config writes it (config.dump, stored files)."""
        data = {}
        if self.name is not None:
            data["name"] = self.name
        data["acceleration"] = self.acceleration
        data["parameters"] = dict(self.parameters)
        if self.symbols:
            data["symbols"] = dict(self.symbols)
        if self.ranges:
            data["ranges"] = {name: [low, high] for name, low, high in self.ranges}
        if self.barriers:
            data["barriers"] = [{"position": b.position, "side": b.side, "restitution": b.restitution}
                                for b in self.barriers]
        data["period"] = self.period
        data["response"] = {"frequency": self.response_frequency, "scale": self.response_scale}
        if self.max_step is not None:
            data["max_step"] = self.max_step
        return data

    def code_key(self) -> str:
        """What the compiled code depends on (codegen.py): the acceleration, the parameters' names
        and order, and the response frequency (the quadratures). Everything else is in the header."""
        text = json.dumps([self.acceleration, self.parameter_names, self.response_frequency, len(self.barriers)])
        return hashlib.sha1(text.encode()).hexdigest()[:16]

    def symbol(self, name) -> str | None:
        return dict(self.symbols).get(name)


def parameter_trees(model: WrittenModel) -> dict:
    """The parsed header expressions, names -> trees (each refers to the parameters only)."""
    names = model.parameter_names
    trees = {"period": expressions.parse(model.period, names),
             "response.frequency": expressions.parse(model.response_frequency, names),
             "response.scale": expressions.parse(model.response_scale, names),
             "max_step": expressions.parse(model.max_step or DEFAULT_STEP_SHARE, names + ("period",))}
    for index, barrier in enumerate(model.barriers):
        trees[f"barriers.{index}.position"] = expressions.parse(barrier.position, names)
        trees[f"barriers.{index}.restitution"] = expressions.parse(barrier.restitution, names)
    return trees


def header_values(model: WrittenModel, parameters) -> dict:
    """The header's expressions evaluated at ``parameters`` (name -> scalar or array): name -> array."""
    trees = parameter_trees(model)
    values = {name: np.asarray(parameters[name], dtype=np.float64) for name in model.parameter_names}
    out = {key: expressions.evaluate(tree, values) for key, tree in trees.items() if key != "max_step"}
    out["max_step"] = expressions.evaluate(trees["max_step"], {**values, "period": out["period"]})
    return out


def coefficients(model: WrittenModel, parameters):
    """Coefficient vectors (..., N_HEADER + n_parameters) for the kernel: the header, then the
    parameters in declared order. parameters: name -> scalar or array (broadcast together)."""
    names = model.parameter_names
    p = {name: np.asarray(parameters[name], dtype=np.float64) for name in names}
    header = header_values(model, p)
    shape = np.broadcast_shapes(*(value.shape for value in (*p.values(), *header.values())))
    out = np.empty(shape + (N_HEADER + len(names),))
    for index, name in enumerate(names):
        out[..., N_HEADER + index] = p[name]
    out[..., PERIOD] = header["period"]
    out[..., MAX_STEP] = header["max_step"]
    out[..., SCAN_STEP] = header["max_step"] / SCAN_STEPS_PER_MAX_STEP
    out[..., RESPONSE_FREQUENCY] = header["response.frequency"]
    # R = |Q| / |scale|: a gain, never negative. A scale written as a forcing amplitude F may be
    # swept through F < 0, a force of amplitude |F| and phase pi, whose gain is that of |F|.
    out[..., RESPONSE_SCALE] = np.abs(header["response.scale"])
    out[..., N_BARRIERS] = len(model.barriers)
    # The harmonics dop853 rotates are the generated module's to say (models.WrittenKernels):
    # until then the response frequency alone, which every model's quadratures have.
    out[..., HARMONIC] = header["response.frequency"]
    out[..., HARMONIC + 1] = 0.0
    for index in range(MAX_BARRIERS):
        if index < len(model.barriers):
            out[..., barrier_slot(index, POSITION)] = header[f"barriers.{index}.position"]
            out[..., barrier_slot(index, SIDE)] = SIDES[model.barriers[index].side]
            out[..., barrier_slot(index, RESTITUTION)] = header[f"barriers.{index}.restitution"]
        else:
            out[..., barrier_slot(index, POSITION)] = np.nan
            out[..., barrier_slot(index, SIDE)] = ABOVE
            out[..., barrier_slot(index, RESTITUTION)] = np.nan
    return out


assert STICK_SCAN_FRACTION * SCAN_STEPS_PER_MAX_STEP == 1.0 / 8.0  # the paper's share, see above


def acceleration_latex(model: WrittenModel) -> str:
    """The acceleration as LaTeX (no $), in the model's symbols: '\\ddot{x} = F \\cos{\\left(\\omega
    t + \\varphi \\right)} - x - 2 \\zeta \\dot{x}' where the config wrote '-2*zeta*v - x +
    F*cos(omega*t + phi)'. A parameter without a symbol prints as sympy names it (zeta as
    \\zeta, F1 as F_{1}); v as \\dot{x}. For a figure's caption, which printed the config's text
    with the parameters' names. sympy orders the terms."""
    import sympy

    x, t = sympy.Symbol("x", real=True), sympy.Symbol("t", real=True)
    v = sympy.Symbol("~v", real=True)  # named to sort after the parameters: 2 zeta x' as written, not 2 x' zeta
    symbols, names = {"x": x, "v": v, "t": t}, {v: "\\dot{x}"}
    for name in model.parameter_names:
        symbols[name] = sympy.Symbol(name, real=True)
        if model.symbol(name):
            names[symbols[name]] = model.symbol(name)
    tree = expressions.parse(model.acceleration, model.parameter_names + expressions.STATE_NAMES)
    return "\\ddot{x} = " + sympy.latex(expressions.to_sympy(tree, symbols), symbol_names=names)
