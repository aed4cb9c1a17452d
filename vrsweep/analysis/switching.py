"""Branch switching (``--switch``): from the branch followed, the branches born on it.

- at a period doubling, the branch of 2p slow periods (analysis/period_doubling.py);
- at a branch point, the second branch of p periods through it, as two branches, one from each
  side of the point (analysis/branch_point.py): on a symmetric branch, the asymmetric orbits of
  its symmetry-breaking pitchfork and their mirror images.

The new branches' own period doublings and branch points are switched in turn, breadth first,
while 2p <= max_period, at most MAX_BRANCHES branches in all. A point that a branch switched
earlier already ended at (a bubble, which closes on the branch it was born on at a second
doubling or branch point) is not switched again.
"""

import numpy as np

from vrsweep.analysis import branch_point, continuation, period_doubling

MAX_BRANCHES = 8


def _doublings(bifurcations, failures):
    """The orbits of the period doublings among ``bifurcations`` whose multiplier is near -1; the
    others go to ``failures`` as (parameter, kind, reason)."""
    orbits = []
    for bifurcation in bifurcations:
        if bifurcation.kind != "period_doubling":
            continue
        if period_doubling.is_doubling(bifurcation.orbit):
            orbits.append(bifurcation.orbit)
        else:
            mu = bifurcation.orbit.multipliers
            nearest = mu[np.argmin(np.abs(mu + 1.0))]
            failures.append((bifurcation.orbit.parameter, "period_doubling",
                             f"no real multiplier within {period_doubling.MULTIPLIER_TOLERANCE:g} of -1 at the "
                             f"located point (nearest {nearest:.4g})"))
    return orbits


def _branch_points(bifurcations):
    return [bifurcation.orbit for bifurcation in bifurcations if bifurcation.kind == continuation.BRANCH_POINT]


def switch_all(problem, branch, bifurcations, lo, hi, max_points, max_period, progress=None):
    """``branch`` (a Branch) and the branches switched at its period doublings and branch points,
    and at theirs (module doc). ``bifurcations``: [Bifurcation] of ``branch``.

    Returns (branches, bifurcations, failures): every Bifurcation's ``branch`` set to its branch's
    index, and [(parameter, kind, reason)] for the points where no branch was found (kind
    "period_doubling" or "branch_point").
    """
    branches = [branch]
    found = list(bifurcations)
    for bifurcation in found:
        bifurcation.branch = 0
    failures = []
    pending = [(0, _doublings(found, failures), _branch_points(found))]
    reached = []  # doublings and branch points a switched branch already ended at
    while pending and len(branches) < MAX_BRANCHES:
        parent, doublings, points = pending.pop(0)
        # A branch point's second branch is switched to on each side of it: two branches (module doc).
        births = ([(orbit, "period_doubling", 1) for orbit in doublings]
                  + [(orbit, "branch_point", side) for orbit in points for side in (1, -1)])
        for orbit, kind, side in births:
            if len(branches) >= MAX_BRANCHES:
                break
            if kind == "period_doubling" and 2 * orbit.periods > max_period:
                continue
            if any(orbit is other for other in reached):
                continue  # a bubble: the branch switched at another point already closed here
            if kind == "period_doubling":
                switched, detail, met = period_doubling.doubled_branch(problem, orbit, lo, hi, max_points, progress,
                                                                       doublings)
            else:
                switched, detail, met = branch_point.switched_branch(problem, orbit, branches[parent], lo, hi,
                                                                     max_points, progress, points, side)
            if switched is None:
                if not any(value == orbit.parameter and what == kind for value, what, _ in failures):
                    failures.append((orbit.parameter, kind, detail))
                continue
            number = len(branches)
            branches.append(switched)
            new = [continuation.Bifurcation(kind, orbit, number) for kind, orbit in detail]
            found.extend(new)
            if continuation.interrupted(switched):  # a signal: keep what is followed, switch no more
                pending.clear()
                break
            reached.extend(met)
            pending.append((number, _doublings(new, failures), _branch_points(new)))
    found.sort(key=lambda b: (b.branch, b.orbit.parameter))
    return branches, found, failures
