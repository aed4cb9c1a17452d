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


def _curve_point(g, Omega, kind="fold"):
    return curves.CurvePoint(kind=kind, values=np.array([g, Omega]), state=np.array([0.1, -0.2]), periods=1,
                             monodromy=np.diag([1.0, 0.3]), R=10.0, impacts_per_period=0.0, x_max=0.8,
                             barrier_distance=0.2, slowest_impact=np.inf, residual=1e-11, newton_iterations=2,
                             jacobian=np.zeros((3, 4)))


def write_curves_file(path, kinds=("fold",)):
    """A curve of five points in (g, Omega) of each kind in ``kinds``, each 0.5 further in g, with a
    cusp on the first."""
    made = []
    for number, kind in enumerate(kinds):
        points = [_curve_point(24.0 + 0.5 * number + 0.1 * k, 3.9 + 0.05 * k, kind) for k in range(5)]
        made.append(curves.Curve(kind, 1, points, {"first": ("left_range", "g left"), "last": ("max_points", "enough")}))
    names = ("g", "Omega")
    special = [curves.SpecialPoint("cusp", made[0].points[2])]
    curve_file.write_curves(path, curve_file.curve_arrays(made, special, names), names, config_from_dict(CONFIG), "rk45")
    return path


CASCADE_CONFIG = {"model": "original", "parameters": {"Omega": 5.0},
                  "continuation": {"parameter": "g", "from": 40.0, "to": [30.0, 55.0]}}
# Issue 32: at Omega = 5 two folds and a period doubling lie within 0.05 of a 25-wide g axis.
CASCADE = (("period_doubling", 45.7483), ("fold", 45.7738), ("fold", 45.7904), ("grazing", 45.8011),
           ("period_doubling", 45.7495))


def write_cascade_branch_file(path, bifurcations=CASCADE):
    """A period-1 branch from g = 30 to 55 (with a fold's S-bend near 45.78) whose bifurcations
    ``bifurcations`` [(kind, g) or (kind, g, R)] lie within 0.06 of g: a branch figure zooms on them by itself."""
    g = np.concatenate([np.linspace(30.0, 45.7, 40), np.linspace(45.7, 45.85, 60)[1:], np.linspace(45.85, 55.0, 40)[1:]])
    orbits = [Orbit(parameter=value, state=np.array([0.5, -0.2]), periods=1,
                    monodromy=np.diag([0.5 if not 45.7738 < value < 45.7904 else 1.5, -0.3]),
                    R=4.0 + 0.1 * value + 0.3 * np.tanh((value - 45.78) / 0.01), Q_amplitude=0.2, impacts_per_period=1.0,
                    x_max=1.0, slowest_impact=0.5, residual=1e-11, newton_iterations=2) for value in g]
    found = []
    for kind, at, *R in bifurcations:  # (kind, g) on this branch, or (kind, g, R) off it (another branch's)
        nearest = orbits[int(np.argmin([abs(o.parameter - at) for o in orbits]))]
        found.append(Bifurcation(kind, Orbit(**{**nearest.__dict__, "parameter": at, **({"R": R[0]} if R else {})})))
    branches = [Branch(periods=1, orbits=orbits, ends={"down": ("left_range", "g left [30, 55]"),
                                                       "up": ("left_range", "g left [30, 55]")})]
    branch_file.write_branch(path, branch_file.branch_arrays(branches, found, 1.0),
                             config_from_dict(CASCADE_CONFIG), "rk45")
    return path


def write_grazing_branch_file(path, impacts_change=True):
    """Nine orbits in g from 22 to 26, like impact_linear's: free and unstable below a graze at
    24.25, the larger multiplier growing to 27 next to it (1/speed of the new impact), impacting
    and stable above it (0.68, 0.68). ``impacts_change`` False: the impact count stored is the same
    on both sides, so only the graze's record says where it is."""
    orbits = []
    for g in np.linspace(22.0, 26.0, 9):
        free = g < 24.25
        orbits.append(Orbit(parameter=g, state=np.array([0.1 * g, -0.2]), periods=1,
                            monodromy=np.diag([3.0 + 10.0 * (g - 22.0), 0.02]) if free else np.diag([0.68, 0.68]),
                            R=10.0 + g, Q_amplitude=0.4, impacts_per_period=0.0 if free or not impacts_change else 1.0,
                            x_max=0.8, slowest_impact=np.inf if free else 0.1, residual=1e-11, newton_iterations=2))
    graze = Orbit(**{**orbits[4].__dict__, "parameter": 24.25, "R": 34.25})
    branches = [Branch(periods=1, orbits=orbits, ends={"down": ("left_range", "g left [21, 27]"),
                                                       "up": ("left_range", "g left [21, 27]")})]
    branch_file.write_branch(path, branch_file.branch_arrays(branches, [Bifurcation("grazing", graze)], 1.0),
                             config_from_dict(CONFIG), "rk45")
    return path


def write_switched_branch_file(path):
    """A period-2 branch in g from 22 to 26 that doubles at 24 (PD1), where a period-4 branch
    (branch 1) is born and runs to 26 with its own doubling at 25 (PD2): two periods, two
    colours, the tags of a cascade."""
    def orbit_at(g, periods, R, mu):
        return Orbit(parameter=g, state=np.array([0.1 * g, -0.2]), periods=periods, monodromy=np.diag([mu, 0.3]),
                     R=R, Q_amplitude=0.4, impacts_per_period=1.0, x_max=0.8, slowest_impact=0.2, residual=1e-11,
                     newton_iterations=2)

    two = [orbit_at(g, 2, 10.0 + g, -0.5 if g < 24.0 else -1.5) for g in np.linspace(22.0, 26.0, 17)]
    four = [orbit_at(g, 4, 34.0 + 2.0 * (g - 24.0), 0.5 if g < 25.0 else -1.5) for g in np.linspace(24.0, 26.0, 9)]
    ends = {"down": ("left_range", "g left [21, 27]"), "up": ("left_range", "g left [21, 27]")}
    branches = [Branch(periods=2, orbits=two, ends=ends), Branch(periods=4, orbits=four, ends=ends)]
    found = [Bifurcation("period_doubling", two[8]), Bifurcation("period_doubling", four[4], branch=1)]
    branch_file.write_branch(path, branch_file.branch_arrays(branches, found, 1.0), config_from_dict(CONFIG), "rk45")
    return path
