"""Which attractor each point of a basin sweep reached: labels and a table of attractors (issue 13).

A sweep with ``x0`` and/or ``v0`` axes starts every point from its own initial state. Points that
differ only in x0 / v0 share every parameter: together they form a *slice* (one slice per setting
of the other axes, ``direction`` included), and within a slice each point is labelled by the
attractor its motion settled on. A grid without x0 / v0 axes gets no labels: every point would be
its own slice, labelled 0 when it ran and -1 when it failed, which ``status`` already says.

Same attractor (labels are per slice, 0, 1, ...; -1 for a failed point)
    Periodic points (``period`` p > 0): same p, and the last p stroboscopic samples (x, v) at
    t = nT (``strobe_x``, ``strobe_v``) coincide with the representative's up to a cyclic shift:
    for some shift s, every |x_k - x_rep,(k+s) mod p| <= tolerance * max(1, max |x_rep|), and the
    same for v. tolerance = SAME_ORBIT_FACTOR * ``period_tolerance``. The factor is there because
    ``period_tolerance`` bounds how much one run's cycle still changes from one cycle to the next,
    not its distance to the orbit it converges to: that distance is r / (1 - rho) for a residual r
    and a contraction rho per cycle, and runs started far apart approach the orbit from different
    sides. Distinct coexisting orbits lie O(0.1-1) apart (hysteresis example: x(nT) = 0.62 on the
    small orbit, -0.28 on the impacting one), far beyond tolerance at the default 1e-6 * 1000.
    Points with no period (``period`` = 0: chaotic, quasi-periodic, a period above max_period, or
    not converged): the same *non-periodic* attractor when their gains agree within the combined
    error, |R_a - R_b| <= hypot(R_err_a, R_err_b), and their ranges [x_min, x_max] overlap. This
    groups the runs of one chaotic attractor (their R scatter within R_err) while keeping apart
    motions of clearly different size or on different sides; it cannot tell two chaotic attractors
    with the same R and overlapping ranges apart, nor a long chaotic transient from a chaotic
    attractor (see diagnostics.py on transient chaos). Such a group has period 0 in the table.

    Grouping is greedy in flat grid order: the first unlabelled point is the representative of a
    new group and takes every unlabelled point that matches it; the groups are then numbered by
    basin size (largest first), then R, then period, then the representative's position. Only the
    stored values enter, so a merge of shards labels exactly as a single run does.

Table (per slice, over an ``attractor_label`` dimension of the largest count of any slice;
rows beyond a slice's count are filled: NaN, -1, 0 points)
    period, R (mean over the basin), R_err (largest in the basin), impacts per cycle (the
    representative's), mean impacts per slow period, points and fraction of the slice's points in
    the basin (failed points count in the slice, in no basin), and the representative's (x0, v0):
    a starting state that reaches the attractor, for ``vrsweep simulate``.
"""

from __future__ import annotations

import numpy as np

from vrsweep.numerics.model import INITIAL_STATE_KEYS
from vrsweep.results import Status

SAME_ORBIT_FACTOR = 1000.0
LABEL_DIMENSION = "attractor_label"
FAILED = -1

# The point variables the labelling reads.
NEEDED = ("status", "period", "strobe_x", "strobe_v", "R", "R_err", "impacts_per_cycle",
          "impacts_per_period", "x_min", "x_max")


def has_initial_state_axes(axis_names) -> bool:
    return any(name in INITIAL_STATE_KEYS for name in axis_names)


def same_orbit_tolerance(period_tolerance) -> float:
    return SAME_ORBIT_FACTOR * float(period_tolerance)


def label_slice(values, tolerance):
    """Attractor labels of the points of one slice, and the groups found.

    values: name -> array over the slice's n points (strobe_x, strobe_v: (n, n_strobe)); the names
    in NEEDED. Returns (labels (n,) int64, groups): groups is a list, in label order, of dicts with
    members (indices), representative, period.
    """
    status = np.asarray(values["status"])
    period = np.asarray(values["period"], dtype=np.int64)
    n = status.size
    ok = status == Status.OK
    group_of = np.full(n, FAILED, dtype=np.int64)
    groups = []
    for index in range(n):
        if not ok[index] or group_of[index] != FAILED:
            continue
        free = ok & (group_of == FAILED)
        if period[index] > 0:
            members = _same_cycle(values, index, free & (period == period[index]), tolerance)
        else:
            members = _same_non_periodic(values, index, free & (period == 0))
        members[index] = True  # a representative always matches itself (even with NaN R_err)
        group_of[members] = len(groups)
        groups.append({"members": np.flatnonzero(members), "representative": index,
                       "period": int(period[index])})
    order = sorted(range(len(groups)), key=lambda k: _rank(groups[k], values))
    labels = np.full(n, FAILED, dtype=np.int64)
    for label, k in enumerate(order):
        labels[groups[k]["members"]] = label
    return labels, [groups[k] for k in order]


def _same_cycle(values, index, candidates, tolerance):
    """Candidates whose last p strobe samples equal the representative's up to a cyclic shift."""
    p = int(values["period"][index])
    rows = np.flatnonzero(candidates)
    x = np.asarray(values["strobe_x"])[rows, -p:]
    v = np.asarray(values["strobe_v"])[rows, -p:]
    cycle_x = np.asarray(values["strobe_x"])[index, -p:]
    cycle_v = np.asarray(values["strobe_v"])[index, -p:]
    scale_x = max(1.0, float(np.max(np.abs(cycle_x))))
    scale_v = max(1.0, float(np.max(np.abs(cycle_v))))
    best = np.full(rows.size, np.inf)
    for shift in range(p):
        distance = np.maximum(np.max(np.abs(x - np.roll(cycle_x, -shift)), axis=1) / scale_x,
                              np.max(np.abs(v - np.roll(cycle_v, -shift)), axis=1) / scale_v)
        best = np.fmin(best, distance)
    members = np.zeros(candidates.shape, dtype=bool)
    members[rows[best <= tolerance]] = True
    return members


def _same_non_periodic(values, index, candidates):
    """Candidates with R within the combined R_err of the representative's and overlapping x ranges."""
    R, R_err = np.asarray(values["R"]), np.asarray(values["R_err"])
    x_min, x_max = np.asarray(values["x_min"]), np.asarray(values["x_max"])
    with np.errstate(invalid="ignore"):
        close = np.abs(R - R[index]) <= np.hypot(R_err, R_err[index])
        overlap = (x_min <= x_max[index]) & (x_max >= x_min[index])
    return candidates & close & overlap


def _rank(group, values):
    R = float(np.mean(np.asarray(values["R"])[group["members"]]))
    return (-group["members"].size, R if np.isfinite(R) else np.inf, group["period"], group["representative"])


def _slices(axis_names):
    """Positions of the slice axes (every axis but x0, v0) and of the initial-state axes."""
    state_axes = [k for k, name in enumerate(axis_names) if name in INITIAL_STATE_KEYS]
    slice_axes = [k for k in range(len(axis_names)) if k not in state_axes]
    return slice_axes, state_axes


def label_grid(axes, variables, period_tolerance):
    """Labels over the whole grid and the table of attractors per slice.

    axes: ordered name -> values of the grid's axes; variables: name -> array over the grid (plus
    the strobe dimension), the names in NEEDED. Returns (labels over the grid, table: name ->
    array over slice shape + (n_attractors,), counts over the slice shape).
    """
    names = list(axes)
    shape = tuple(len(axes[name]) for name in names)
    slice_axes, state_axes = _slices(names)
    order = slice_axes + state_axes  # x0 / v0 last: a slice is then one row of a 2-D table
    slice_shape = tuple(shape[k] for k in slice_axes)
    n_slices = int(np.prod(slice_shape, dtype=np.int64))
    per_slice = int(np.prod([shape[k] for k in state_axes], dtype=np.int64))

    def by_slice(array):
        array = np.asarray(array)
        extra = array.shape[len(shape):]
        return np.transpose(array, order + list(range(len(shape), array.ndim))).reshape(
            (n_slices, per_slice) + extra)

    arranged = {name: by_slice(variables[name]) for name in NEEDED}
    # Each point's own initial state, for the table's example starting state.
    starts = {}
    for axis_name in INITIAL_STATE_KEYS:
        if axis_name in axes:
            along = [1] * len(shape)
            along[names.index(axis_name)] = shape[names.index(axis_name)]
            grid = np.broadcast_to(np.asarray(axes[axis_name], dtype=np.float64).reshape(along), shape)
            starts[axis_name] = by_slice(grid)
    tolerance = same_orbit_tolerance(period_tolerance)
    labels = np.empty((n_slices, per_slice), dtype=np.int64)
    found = []
    for s in range(n_slices):
        labels[s], groups = label_slice({name: arranged[name][s] for name in NEEDED}, tolerance)
        found.append(groups)
    # At least one row, so that the table exists (HDF5 has no chunked empty datasets) even when
    # every point failed; its filler says "no such attractor".
    n_attractors = max(1, max((len(groups) for groups in found), default=0))
    table = {
        "period": np.full((n_slices, n_attractors), -1, dtype=np.int64),
        "R": np.full((n_slices, n_attractors), np.nan),
        "R_err": np.full((n_slices, n_attractors), np.nan),
        "impacts_per_cycle": np.full((n_slices, n_attractors), -1, dtype=np.int64),
        "impacts_per_period": np.full((n_slices, n_attractors), np.nan),
        "points": np.zeros((n_slices, n_attractors), dtype=np.int64),
        "fraction": np.full((n_slices, n_attractors), np.nan),
        **{axis_name: np.full((n_slices, n_attractors), np.nan) for axis_name in starts},
    }
    for s, groups in enumerate(found):
        for label, group in enumerate(groups):
            members, first = group["members"], group["representative"]
            table["period"][s, label] = group["period"]
            table["R"][s, label] = np.mean(arranged["R"][s][members])
            table["R_err"][s, label] = np.max(arranged["R_err"][s][members])
            table["impacts_per_cycle"][s, label] = arranged["impacts_per_cycle"][s][first]
            table["impacts_per_period"][s, label] = np.mean(arranged["impacts_per_period"][s][members])
            table["points"][s, label] = members.size
            table["fraction"][s, label] = members.size / per_slice
            for axis_name in starts:
                table[axis_name][s, label] = starts[axis_name][s][first]
    # Back to the grid's axis order.
    inverse = np.argsort(order)
    labels = np.transpose(labels.reshape(tuple(shape[k] for k in order)), inverse)
    table = {name: array.reshape(slice_shape + (n_attractors,)) for name, array in table.items()}
    counts = np.array([len(groups) for groups in found], dtype=np.int64).reshape(slice_shape)
    return np.ascontiguousarray(labels), table, counts


_TABLE_ATTRS = {
    "period": ("attractor_period", {
        "units": "1", "long_name": "period of the attractor in slow periods (0: non-periodic; -1: no such attractor)"}),
    "R": ("attractor_R", {"units": "1", "long_name": "gain |Q|/c (eq3.3), mean over the attractor's basin"}),
    "R_err": ("attractor_R_err", {"units": "1", "long_name": "largest R_err over the attractor's basin"}),
    "impacts_per_cycle": ("attractor_impacts_per_cycle", {
        "units": "1", "long_name": "impacts in one cycle of the attractor (-1: non-periodic or no such attractor)"}),
    "impacts_per_period": ("attractor_impacts_per_period", {
        "units": "1", "long_name": "mean impacts per slow period over the attractor's basin"}),
    "points": ("attractor_points", {"units": "1", "long_name": "grid points of the slice in the attractor's basin"}),
    "fraction": ("attractor_fraction", {
        "units": "1", "long_name": "fraction of the slice's grid points in the attractor's basin (failed points "
                                   "count in the slice, in no basin)"}),
    "x0": ("attractor_x0", {"units": "1", "long_name": "an initial position x(0) in the basin (the first in grid order)"}),
    "v0": ("attractor_v0", {"units": "1", "long_name": "an initial velocity x'(0) in the basin (the first in grid order)"}),
}


def _table_attrs(model):
    """_TABLE_ATTRS in a written model's own terms (its period T, its gain), where ``model`` is
    one (numerics.written); the paper's words otherwise."""
    if model is None:
        return _TABLE_ATTRS
    words = {
        "period": (f"period of the attractor in periods T = {model.period} (0: non-periodic; -1: no such "
                   "attractor)"),
        "R": f"gain |Q|/|{model.response_scale}| at {model.response_frequency}, mean over the attractor's basin",
        "impacts_per_period": f"mean impacts per period T = {model.period} over the attractor's basin",
    }
    return {key: (name, dict(attrs, long_name=words[key]) if key in words else attrs)
            for key, (name, attrs) in _TABLE_ATTRS.items()}


def attractor_extras(axes, variables, period_tolerance, model=None):
    """The derived variables of a basin sweep, as ``ResultWriter.finish`` and a merge take them.

    axes: ordered name -> values of the grid's axes; variables: name -> full-grid array of the
    point variables (those in NEEDED at least); model: a written model (its words for the table's
    long names), None for the paper's. Returns (extra, coords): extra is
    ``{name: (array, dims, attrs)}``, coords ``{attractor_label: (values, attrs)}``; both empty
    when the grid has no x0 / v0 axis.
    """
    names = list(axes)
    if not has_initial_state_axes(names):
        return {}, {}
    labels, table, counts = label_grid(axes, variables, period_tolerance)
    slice_dims = tuple(name for name in names if name not in INITIAL_STATE_KEYS)
    tolerance = same_orbit_tolerance(period_tolerance)
    extra = {
        "attractor": (labels, tuple(names), {
            "units": "1",
            "long_name": ("attractor reached, numbered within each slice of points that differ only in x0, v0 "
                          "(-1: the point failed); see attractor_period, attractor_R, ..."),
            "slice_axes": " ".join(slice_dims),
            "same_orbit_tolerance": tolerance,
            "comment": (f"same attractor: same period and stroboscopic cycles equal up to a cyclic shift to "
                        f"{tolerance:g} (= {SAME_ORBIT_FACTOR:g} * period_tolerance) relative to max(1, max |x|) "
                        "(resp. |v|); non-periodic points: |R_a - R_b| <= hypot(R_err_a, R_err_b) and "
                        "overlapping [x_min, x_max]; labels by basin size, then R (vrsweep.analysis.attractors)"),
        }),
        "attractor_count": (counts, slice_dims, {
            "units": "1", "long_name": "number of attractors found in the slice"}),
    }
    table_attrs = _table_attrs(model)
    for key, array in table.items():
        name, attrs = table_attrs[key]
        extra[name] = (array, slice_dims + (LABEL_DIMENSION,), attrs)
    n_attractors = next(iter(table.values())).shape[-1]
    coords = {LABEL_DIMENSION: (np.arange(n_attractors, dtype=np.int32), {
        "units": "1", "long_name": "attractor label (the values of the variable attractor)"})}
    return extra, coords


def attractor_extras_from_file(f, period_tolerance, model=None):
    """attractor_extras for an open h5py File whose point variables are all written (a merge's
    output before its derived variables are added): the grid's axes are the dimension scales of
    ``done``. Reads only the variables in NEEDED. A merge then adds the result with
    ``store.layout.add_extras(f, *attractor_extras_from_file(f, period_tolerance))``."""
    names = [dim[0].name.rsplit("/", 1)[-1] for dim in f["done"].dims] if f["done"].ndim else []
    if not has_initial_state_axes(names):
        return {}, {}
    axes = {name: f[name][()] for name in names}
    return attractor_extras(axes, {name: f[name][()] for name in NEEDED}, period_tolerance, model)


def attractor_rows(results, at=None):
    """The table of a result file, as a list of (slice description, [row dicts]) for printing.

    results: an xarray Dataset (vrsweep.open_results). at: optional {axis: index} restricting the
    slices.
    """
    if "attractor_count" not in results:
        return []
    slice_dims = tuple(results["attractor_count"].dims)
    counts = np.asarray(results["attractor_count"].values)
    out = []
    for where in np.ndindex(*counts.shape):
        if at and any(where[slice_dims.index(name)] != index for name, index in at.items() if name in slice_dims):
            continue
        described = ", ".join(f"{name}={results[name].values[i]:g}" for name, i in zip(slice_dims, where))
        rows = []
        for label in range(int(counts[where])):
            row = {"label": label}
            for key, (name, _) in _TABLE_ATTRS.items():
                if name in results:
                    value = np.asarray(results[name].values)[where + (label,)]
                    row[key] = value.item()
            rows.append(row)
        out.append((described, rows))
    return out
