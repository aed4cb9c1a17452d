"""Fractional powers of a kinked quantity in a written acceleration: Hertz's contact law
k*max(x - d, 0)**1.5 and the square-root spring sqrt(abs(x))*sign(x).

The steps that end on a kink and leave it hold its side (the frozen mode), and their first and
last stages lie a rounding beyond the surface, where a held side's base is negative: (x - d)**1.5
of -1e-17 is NaN, and every point of either model ended non_finite at its first crossing (0.7.13).
codegen.held_in_domain takes such a power as 0 beyond its surface, the surface's own value, and
leaves every value that was computed before as it was, bit for bit.

The references are SciPy's solve_ivp (DOP853, rtol 1e-13) restarted at each crossing by a
terminal event (tests/reference.forced_with_a_surface), with each side's own right-hand side
written here (no max() or abs() in it).
"""

import math

import numpy as np
import pytest
import sympy
import xarray as xr

import vrsweep
from vrsweep.config import parse_config
from vrsweep.numerics import codegen
from vrsweep.results import Status

from reference import forced_with_a_surface

ZETA, K, D, F, OMEGA = 0.05, 3.0, 0.5, 1.0, 0.8
TRANSIENT, MEASURED = 200, 20
# Hertz's soft stop on the linear oscillator (contact beyond x = d; no rigid barrier).
HERTZ = f"""
model:
  acceleration: "-2*zeta*v - x - k*max(x - d, 0)**1.5 + F*cos(omega*t)"
  parameters: {{k: {K}, d: {D}, zeta: {ZETA}, F: {F}, omega: {OMEGA}}}
  period: "2*pi/omega"
  response: {{frequency: omega, scale: F}}
initial: {{x: 0.0, v: 0.0}}
integration: {{transient_periods: {TRANSIENT}, measure_periods: {MEASURED}}}
"""
# The square-root spring, its force continuous at x = 0 and its stiffness infinite there.
# Started off its surface: from x = 0 at rest the first crossing would be at t = 0.
ROOT = (HERTZ.replace("-2*zeta*v - x - k*max(x - d, 0)**1.5", "-2*zeta*v - k*sqrt(abs(x))*sign(x)")
        .replace("initial: {x: 0.0", "initial: {x: 0.3"))


# SciPy's steps put stages beyond the surface too, before its event cuts the step: there each
# side's power is taken at the surface, max(base, 0), where it is real.
def _hertz_reference():
    # engaged (side +1): -x - k (x - d)^1.5; the stiffness -1 - 1.5 k (x - d)^0.5, continuous at d
    return forced_with_a_surface(lambda x, side: -x - (K * max(x - D, 0.0) ** 1.5 if side > 0 else 0.0),
                                 lambda x, side: -1.0 - (1.5 * K * math.sqrt(max(x - D, 0.0)) if side > 0 else 0.0), D,
                                 ZETA, F, OMEGA, TRANSIENT, MEASURED)


def _root_reference():
    return forced_with_a_surface(lambda x, side: -K * side * math.sqrt(max(side * x, 0.0)), lambda x, side: 0.0, 0.0,
                                 ZETA, F, OMEGA, TRANSIENT, MEASURED, x0=0.3)


def test_hertz_contact_converges_with_the_tolerance_and_its_tangents_are_finite():
    """Every point ended non_finite at its first contact (0.7.13). The force is C1 at the surface
    (its stiffness continuous, its third derivative infinite), located and held there as a kink:
    R within 10 rtol of SciPy's (measured: 0.7 rtol). The tangent vectors step through the held
    Jacobian, whose sqrt(x - d) is held too: at these values the multipliers are a complex pair,
    so lambda_1 is the damping's -zeta (Liouville), which SciPy's monodromy confirms."""
    R_reference, monodromy = _hertz_reference()
    period = 2 * math.pi / OMEGA
    # the reference's own check: the damping's Liouville determinant exp(-2 zeta T)
    assert np.linalg.det(monodromy) == pytest.approx(math.exp(-2 * ZETA * period), rel=1e-10)
    exponent = math.log(max(abs(np.linalg.eigvals(monodromy)))) / period
    assert exponent == pytest.approx(-ZETA, rel=1e-9)
    for rtol in (1e-8, 1e-10):
        result = vrsweep.sweep(HERTZ, rtol=rtol, atol=rtol * 1e-2, lyapunov=True, progress=False)
        assert int(result.status) == Status.OK, Status(int(result.status)).name
        assert int(result.period) == 1
        assert abs(float(result.R) - R_reference) < 10 * rtol, (rtol, float(result.R) - R_reference)
        assert abs(float(result.lyapunov) - exponent) < 10 * rtol, (rtol, float(result.lyapunov) - exponent)


def test_hertz_contact_with_dop853():
    """dop853's stages take the force's phases rotated: the held power is in that rhs too."""
    R_reference, _ = _hertz_reference()
    for rtol in (1e-8, 1e-10):
        result = vrsweep.sweep(HERTZ, rtol=rtol, atol=rtol * 1e-2, method="dop853", progress=False)
        assert int(result.status) == Status.OK, Status(int(result.status)).name
        assert abs(float(result.R) - R_reference) < 10 * rtol, (rtol, float(result.R) - R_reference)


def test_the_square_root_spring_agrees_with_scipy_and_its_lyapunov_is_nan_with_a_note(tmp_path, invoke):
    """Every point ended non_finite at its first crossing of x = 0 (0.7.13). Its stiffness is
    infinite there, so the steps next to the surface are short, and R still converges. The tangent
    vectors cannot be stepped across an infinite stiffness: lyapunov is NaN, the point ok (its other
    results stand), and `run` says so. (Run with tangents, one compile: R's steps are the same.)"""
    R_reference, _ = _root_reference()
    config = tmp_path / "root.yaml"
    config.write_text(ROOT)
    out = tmp_path / "root.h5"
    result = invoke("run", config, "-o", out, "--set", "rtol=1e-7", "--set", "atol=1e-9", "--set", "lyapunov=true")
    assert result.exit_code == 0, result.output
    assert "1 of the 1 points ended ok with a NaN lyapunov" in " ".join(result.output.split())
    with xr.open_dataset(out, engine="h5netcdf") as stored:
        assert int(stored.status) == Status.OK
        assert math.isnan(float(stored.lyapunov))
        assert abs(float(stored.R) - R_reference) < 1e-6, float(stored.R) - R_reference
    result = vrsweep.sweep(ROOT, rtol=1e-10, atol=1e-12, lyapunov=True, progress=False)
    assert int(result.status) == Status.OK, Status(int(result.status)).name
    assert abs(float(result.R) - R_reference) < 1e-9, float(result.R) - R_reference


def test_held_powers_are_zero_beyond_their_surface_and_unchanged_elsewhere():
    x, v, t = sympy.symbols("x v t", real=True)
    m, n = sympy.Symbol("m_0", real=True), sympy.Symbol("p_n", real=True)
    engaged = sympy.Piecewise((x - D, m > 0), (0, True))
    held = codegen.held_in_domain(engaged ** sympy.Rational(3, 2) + engaged ** n, (x, v, t))
    for x_value in (D - 1e-17, D - 0.1, D, D + 1e-17, D + 0.3):
        for n_value in (1.5, 2.0, 3.0):
            value = float(held.subs({x: x_value, m: 1, n: n_value}))
            base = x_value - D
            # the original's value where it has one; 0 where it was NaN (a negative base of a
            # fractional power); an integer power of a negative base is kept (a real value)
            expected = (max(base, 0.0) ** 1.5
                        + (base ** n_value if (base >= 0 or n_value.is_integer()) else 0.0))
            assert value == pytest.approx(expected, rel=1e-15, abs=1e-300), (x_value, n_value)
    # integer powers, a power of the state alone (its sign decided by sympy) and a smooth model
    # are left as they are: their generated code is unchanged
    for expression in (engaged ** 3, sympy.sqrt(1 + x ** 2) * engaged, -x - 0.1 * v):
        assert codegen.held_in_domain(expression, (x, v, t)) == expression


def test_models_without_fractional_powers_of_kinks_generate_the_same_code():
    """Bit for bit: the bilinear spring's rhs is the same text with and without held_in_domain."""
    bilinear = parse_config(HERTZ.replace("max(x - d, 0)**1.5", "max(x - d, 0)"), "m.yaml").model
    acceleration, _, _, _, state = codegen.derived(bilinear)
    frozen, _ = codegen.frozen_acceleration(acceleration, codegen.switching_functions(acceleration, state))
    assert codegen.held_in_domain(frozen, state) == frozen
