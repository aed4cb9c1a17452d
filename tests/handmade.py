"""Branch and curves files made from hand-built orbits and curve points, as vrsweep continue writes
them (store/branch_file.py, store/curve_file.py): for tests of what reads them, which need no
kernel compiled."""

import numpy as np

from vrsweep.analysis import curves
from vrsweep.analysis.continuation import Bifurcation, Branch, Orbit
from vrsweep.config.validate import config_from_dict
from vrsweep.store import branch_file, curve_file

CONFIG = {"model": "effective", "parameters": {"gamma": 0.05, "alpha": 0.05},
          "continuation": {"parameter": "g", "from": 23.0, "to": [21.0, 27.0]}}


def orbit(g, stable):
    return Orbit(parameter=g, state=np.array([0.1 * g, -0.2]), periods=1,
                 monodromy=np.diag([0.5 if stable else 1.5, 0.3]), R=10.0 + g, Q_amplitude=0.4 + g / 100,
                 impacts_per_period=0.0, x_max=0.8, slowest_impact=np.inf, residual=1e-11, newton_iterations=2)


def write_branch_file(path):
    """Nine orbits in g from 22 to 26 (stable below 24), a fold at 24 (bifurcation 0)."""
    orbits = [orbit(g, g < 24.0) for g in np.linspace(22.0, 26.0, 9)]
    branches = [Branch(periods=1, orbits=orbits, ends={"down": ("left_range", "g left [21, 27]"),
                                                       "up": ("grazing", "the orbit touches the barrier")})]
    branch_file.write_branch(path, branch_file.branch_arrays(branches, [Bifurcation("fold", orbits[4])], 1.0),
                             config_from_dict(CONFIG), "rk45")
    return path


def _curve_point(g, Omega):
    return curves.CurvePoint(kind="fold", values=np.array([g, Omega]), state=np.array([0.1, -0.2]), periods=1,
                             monodromy=np.diag([1.0, 0.3]), R=10.0, impacts_per_period=0.0, x_max=0.8,
                             barrier_distance=0.2, slowest_impact=np.inf, residual=1e-11, newton_iterations=2,
                             jacobian=np.zeros((3, 4)))


def write_curves_file(path):
    """One fold curve of five points in (g, Omega) with a cusp on it."""
    points = [_curve_point(24.0 + 0.1 * k, 3.9 + 0.05 * k) for k in range(5)]
    curve = curves.Curve("fold", 1, points, {"first": ("left_range", "g left"), "last": ("max_points", "enough")})
    names = ("g", "Omega")
    curve_file.write_curves(path, curve_file.curve_arrays([curve], [curves.SpecialPoint("cusp", points[2])], names),
                            names, config_from_dict(CONFIG), "rk45")
    return path
