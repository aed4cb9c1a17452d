"""numerics/jit.py: a kernel function called with constant arguments is compiled once per argument
type, not once per constant, and still computes with the constants' values."""

import math

import numpy as np
from numba import types

from vrsweep.numerics import dop853
from vrsweep.numerics.jit import kernel_jit


@kernel_jit(cache=False)
def _scaled(value, node, flag):
    if flag:
        return value * node
    return value - node


@kernel_jit(cache=False)
def _constants_caller(value):
    # three constants for node, two for flag: five Literal signatures under numba's own dispatcher
    return (_scaled(value, 1, True) + _scaled(value, 2, True) + _scaled(value, 3, False)
            + _scaled(value, 4, False) + _scaled(value, 5, True))


def _literal_signatures(dispatcher):
    return [signature for signature in dispatcher.overloads
            if any(isinstance(argument, types.Literal) for argument in signature)]


def test_constant_arguments_compile_one_signature_and_keep_their_values():
    value = 1.25
    expected = value * 1 + value * 2 + (value - 3) + (value - 4) + value * 5
    assert _constants_caller(value) == expected
    assert len(_scaled.overloads) == 1
    assert _literal_signatures(_scaled) == []


@kernel_jit(cache=False)
def _harmonic_rhs(t, h, node, c, y, coefficients, dydt, scratch):
    # x'' = -x, with the stage index recorded so that the step's constants are seen to arrive
    dydt[0] = y[1]
    dydt[1] = -y[0]
    scratch[node] += 1.0


@kernel_jit(cache=False)
def _one_dop853_step(h):
    y = np.array([1.0, 0.0])
    f = np.array([0.0, -1.0])
    K = np.empty((dop853.N_STAGES_EXTENDED, 2))
    y_new = np.empty(2)
    stage = np.empty(2)
    scratch = np.zeros(dop853.N_STAGES + 1)
    dop853.dop853_step(_harmonic_rhs, 0.0, y, f, h, np.empty(0), K, y_new, stage, scratch, 2)
    return y_new, scratch


def test_dop853_compiles_the_right_hand_side_once_for_its_twelve_stages():
    """dop853's step names its stages by constants 1..12: the right-hand side was compiled once per
    stage (twelve times here, fifteen with the dense output), most of a written model's compile."""
    h = 0.1
    y_new, calls = _one_dop853_step(h)
    assert len(_harmonic_rhs.overloads) == 1
    assert _literal_signatures(_harmonic_rhs) == []
    # each stage 1..12 was evaluated once, with its own index
    assert calls[0] == 0.0 and np.all(calls[1:] == 1.0)
    # an 8th-order step of the harmonic oscillator: cos h, -sin h to its local error, h^9 / 9!
    assert abs(y_new[0] - math.cos(h)) < 1e-12 and abs(y_new[1] + math.sin(h)) < 1e-12
