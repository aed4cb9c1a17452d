"""The branch file of ``vrsweep continue``: periodic orbits followed in one parameter.

Layout (HDF5, flat; ``vrsweep.open_results`` opens it as one xarray Dataset)
---------------------------------------------------------------------------
root attributes: ``vrsweep_file = "branch"``, ``vrsweep_format_version``, ``vrsweep_complete``,
``created``, ``config`` (the resolved YAML), ``model``, ``parameter`` (the continued one),
``method``, CF globals (title, history, source, references, date_created), ``vrsweep_version``.

    point (dim)                   index along the branches, in arc order within each branch
    branch (point)                which branch the point is on (0, 1, ...)
    parameter (point)             value of the continued parameter
    x, v (point)                  the orbit's state at t = 0 mod T (T = 2 pi / omega)
    periods (point)               p: the orbit closes after p slow periods
    R, Q_amplitude (point)        eq3.3 and |Q| (eq3.1, eq3.2) over the orbit's p periods
    impacts_per_period (point)
    x_max (point)                 largest x over the orbit; barrier_distance = Delta - x_max
    slowest_impact (point)        smallest impact speed |x'(-)| (NaN without impacts)
    multiplier (dim, 2)           the Floquet multipliers, larger modulus first
    multiplier_real, multiplier_imag, multiplier_modulus (point, multiplier)
    stable (point)                1 when both |mu| < 1
    residual (point)              max |P^p(y) - y| at convergence
    bifurcation (dim)             the located bifurcation points
    bifurcation_kind (bifurcation)  fold, period_doubling, neimark_sacker, grazing, branch_point; or unlocated_KIND
                                  of any of them: it lies between this point, the branch's orbit
                                  before it, and the branch's next one (for grazing: the impact
                                  count changes there), and could not be located
    bifurcation_branch, bifurcation_parameter, bifurcation_x, bifurcation_v, bifurcation_R (bifurcation)
    bifurcation_multiplier_real, bifurcation_multiplier_imag (bifurcation, multiplier)
    branch_id (dim)               one entry per branch
    branch_periods, branch_end_first_status, branch_end_first_reason, branch_end_last_status,
    branch_end_last_reason (branch_id): why each branch stops at its first and last point
    (statuses: left_range, max_points, newton_failed, sticking, integration_failed, grazing, period_doubling,
    branch_point: a switched branch back at the point it was born at, interrupted, domain_edge: the next
    point would lie outside the model's domain, config/domains.py)

Built in memory and written whole through ``fileio.write_bytes`` (atomic). Every numeric array
carries a Fletcher-32 checksum, and ``check_branch`` (the one check every reader goes through:
``open_results``, ``info``, ``plot``) reads them all and checks the layout above, so a damaged
file is one line, not a traceback or a wrong figure.
"""

from __future__ import annotations

import datetime
import io
import os

import h5py
import numpy as np

from vrsweep import __version__
from vrsweep.errors import ResultFileError
from vrsweep.store.fileio import LIBVER, has_file_kind, open_hdf5, output_target, write_bytes
from vrsweep.store.layout import FORMAT_VERSION

FILE_KIND = "branch"

_POINT_VARIABLES = {
    # name: (long name, units)
    "branch": ("branch number", "1"),
    "parameter": ("continued parameter", "1"),
    "x": ("position x at t = 0 mod T", "1"),
    "v": ("velocity dx/dt at t = 0 mod T", "1"),
    "periods": ("orbit period in slow periods T = 2 pi/omega", "1"),
    "R": ("gain R = |Q|/c over the orbit (eq3.3)", "1"),
    "Q_amplitude": ("response amplitude |Q| over the orbit (eq3.1, eq3.2)", "1"),
    "impacts_per_period": ("impacts per slow period", "1"),
    "x_max": ("largest x over the orbit", "1"),
    "barrier_distance": ("distance Delta - x_max of the orbit from the barrier", "1"),
    "slowest_impact": ("smallest impact speed |x'(-)| of the orbit", "1"),
    "stable": ("1 if both Floquet multipliers lie inside the unit circle", "1"),
    "residual": ("Newton residual max |P^p(y) - y|", "1"),
}


def point_long_names(config):
    """The point variables' long names for ``config``'s model: a written model's own period,
    response and barrier, not the paper's omega, c and Delta."""
    names = {name: long_name for name, (long_name, _) in _POINT_VARIABLES.items()}
    if config.written:
        model = config.model
        names.update(
            periods=f"orbit period in periods T = {model.period}",
            R=(f"gain R = |Q|/|{model.response_scale}| over the orbit, Q at the response frequency "
               f"{model.response_frequency}"),
            Q_amplitude=f"response amplitude |Q| at {model.response_frequency} over the orbit",
            impacts_per_period="impacts per period T",
            barrier_distance="distance (position - x_max) of the orbit from the first barrier above (inf: none)")
    return names


def branch_arrays(branches, bifurcations, delta):
    """Plain arrays from analysis.continuation's Branch and Bifurcation lists (see the layout).

    ``delta`` is the barrier that ``barrier_distance`` measures to: a number, or a function of the
    continued parameter's value (a barrier that moves with it: the paper's Delta, a written
    model's ``position: D``)."""
    barrier = delta if callable(delta) else (lambda value: delta)
    points = {name: [] for name in _POINT_VARIABLES}
    multipliers = []
    for number, branch in enumerate(branches):
        for orbit in branch.orbits:
            values = dict(branch=number, parameter=orbit.parameter, x=orbit.state[0], v=orbit.state[1],
                          periods=orbit.periods, R=orbit.R, Q_amplitude=orbit.Q_amplitude,
                          impacts_per_period=orbit.impacts_per_period, x_max=orbit.x_max,
                          barrier_distance=barrier(orbit.parameter) - orbit.x_max,
                          slowest_impact=orbit.slowest_impact if np.isfinite(orbit.slowest_impact) else np.nan,
                          stable=int(orbit.stable), residual=orbit.residual)
            for name in points:
                points[name].append(values[name])
            multipliers.append(orbit.multipliers)
    arrays = {name: np.asarray(values, dtype=np.int64 if name in ("branch", "periods", "stable") else np.float64)
              for name, values in points.items()}
    arrays["multipliers"] = np.asarray(multipliers, dtype=np.complex128).reshape(-1, 2)
    table = dict(kind=[], branch=[], parameter=[], x=[], v=[], R=[], multipliers=[])
    for bifurcation in bifurcations:
        orbit = bifurcation.orbit
        for key, value in (("kind", bifurcation.kind), ("branch", bifurcation.branch),
                           ("parameter", orbit.parameter), ("x", orbit.state[0]), ("v", orbit.state[1]),
                           ("R", orbit.R), ("multipliers", orbit.multipliers)):
            table[key].append(value)
    arrays["bifurcations"] = table
    arrays["ends"] = [(branch.periods, branch.ends["down"], branch.ends["up"]) for branch in branches]
    return arrays


def _multipliers(f, mu, dims):
    """The Floquet multipliers mu (n_points, 2), complex, as their real and imaginary parts and
    moduli over ``dims`` (point, multiplier): branch and curves files alike."""
    _variable(f, "multiplier_real", mu.real, dims, "real part of the Floquet multiplier", "1")
    _variable(f, "multiplier_imag", mu.imag, dims, "imaginary part of the Floquet multiplier", "1")
    _variable(f, "multiplier_modulus", np.abs(mu), dims, "modulus of the Floquet multiplier", "1")


def file_attributes(kind, config, method, title, complete=True, **more):
    """The file-level attributes of a branch or curves file: kind, format, provenance, CF.
    ``complete`` False: the run was stopped by a signal, and the file holds what it had followed."""
    import numba

    from vrsweep.store.provenance import cf_attributes, model_attributes

    return {"vrsweep_file": kind, "vrsweep_format_version": np.int32(FORMAT_VERSION),
            "vrsweep_complete": np.int32(1 if complete else 0),
            "created": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "config": config.to_yaml(), **model_attributes(config.model), **more, "method": method,
            "vrsweep_version": __version__, "numba_version": numba.__version__, "numpy_version": np.__version__,
            **cf_attributes(title, model=config.model)}


def write_branch(path, arrays, config, method, overwrite=False, complete=True):
    """Write branch_arrays' ``arrays`` to ``path`` atomically; refuse an existing file unless
    ``overwrite``. ``complete`` False: a continuation stopped by a signal (its ends "interrupted")."""
    path = output_target(os.fspath(path), overwrite=overwrite)  # fileio's one rule of outputs
    parameter = config.continuation.parameter
    attrs = file_attributes(FILE_KIND, config, method,
                            f"vrsweep continuation of periodic orbits of the {config.model} model in {parameter}",
                            complete=complete, parameter=parameter)
    image = io.BytesIO()
    with h5py.File(image, "w", track_order=True, libver=LIBVER) as f:
        for name, value in attrs.items():
            f.attrs[name] = value
        n_points = len(arrays["parameter"])
        point = _dimension(f, "point", np.arange(n_points, dtype=np.int64), "point along the branch")
        multiplier = _dimension(f, "multiplier", np.arange(2, dtype=np.int64),
                                "Floquet multiplier number, larger modulus first")
        words = point_long_names(config)
        for name, (_, units) in _POINT_VARIABLES.items():
            _variable(f, name, arrays[name], (point,), words[name], units)
        _multipliers(f, arrays["multipliers"], (point, multiplier))
        f["parameter"].attrs["long_name"] = f"continued parameter {parameter}"
        table = arrays["bifurcations"]
        bifurcation = _dimension(f, "bifurcation", np.arange(len(table["kind"]), dtype=np.int64),
                                 "located bifurcation point")
        _variable(f, "bifurcation_kind", np.asarray(table["kind"], dtype=object), (bifurcation,),
                  "kind: fold, period_doubling, neimark_sacker, grazing, branch_point, or unlocated_ and one of them", None)
        for key, long_name in (("branch", "branch of the bifurcation point"),
                               ("parameter", f"{parameter} at the bifurcation"),
                               ("x", "position x at t = 0 mod T"), ("v", "velocity at t = 0 mod T"),
                               ("R", "gain R of the orbit at the bifurcation")):
            _variable(f, f"bifurcation_{key}", np.asarray(table[key], dtype=np.int64 if key == "branch" else float),
                      (bifurcation,), long_name, "1")
        bif_mu = np.asarray(table["multipliers"], dtype=np.complex128).reshape(-1, 2)
        _variable(f, "bifurcation_multiplier_real", bif_mu.real, (bifurcation, multiplier),
                  "real part of the Floquet multiplier at the bifurcation", "1")
        _variable(f, "bifurcation_multiplier_imag", bif_mu.imag, (bifurcation, multiplier),
                  "imaginary part of the Floquet multiplier at the bifurcation", "1")
        ends = arrays["ends"]
        branch_id = _dimension(f, "branch_id", np.arange(len(ends), dtype=np.int64), "branch number")
        _variable(f, "branch_periods", np.asarray([e[0] for e in ends], dtype=np.int64), (branch_id,),
                  f"orbit period of the branch in {'periods T' if config.written else 'slow periods'}", "1")
        _ends(f, "branch", branch_id, [e[1] for e in ends], [e[2] for e in ends])
        seal_attributes(f)
    write_bytes(path, image.getvalue())


def _ends(group, what, scale, first, last):
    """``{what}_end_first/last_status/reason`` along ``scale``: why each branch or curve stops at
    its first and last point. first, last: [(status, reason)], one per branch or curve."""
    for side, stops, where in (("first", first, "its first point"), ("last", last, "its last point")):
        _variable(group, f"{what}_end_{side}_status", np.asarray([stop[0] for stop in stops], dtype=object),
                  (scale,), f"why the {what} stops at {where}", None)
        _variable(group, f"{what}_end_{side}_reason", np.asarray([stop[1] for stop in stops], dtype=object),
                  (scale,), f"why the {what} stops at {where}, in words", None)


def _checksummed(values):
    """create_dataset's storage options: a checksum on every non-empty numeric array (HDF5's
    Fletcher-32 filter needs chunked storage, which an empty array cannot have)."""
    return {"fletcher32": True, "chunks": True} if values.size and values.dtype.kind in "iuf" else {}


def _dimension(group, name, values, long_name):
    values = np.asarray(values)
    scale = group.create_dataset(name, data=values, **_checksummed(values))
    scale.make_scale(name)
    scale.attrs["units"] = "1"
    scale.attrs["long_name"] = long_name
    return scale


def _variable(group, name, values, scales, long_name, units):
    values = np.asarray(values)
    if values.dtype == object:
        ds = group.create_dataset(name, data=values.astype(str).astype(object), dtype=h5py.string_dtype(),
                                  shape=values.shape)
    else:
        ds = group.create_dataset(name, data=values, **_checksummed(values))
    for axis, scale in enumerate(scales):
        ds.dims[axis].attach_scale(scale)
    if units is not None:
        ds.attrs["units"] = units
    ds.attrs["long_name"] = long_name
    return ds


def is_branch_file(path) -> bool:
    """True for an HDF5 file that says it is a vrsweep branch file; False for anything else."""
    return has_file_kind(path, FILE_KIND)


# What check_branch expects: each array's dimensions and kind of number ("i" whole, "f" real,
# "s" text). A file written by this version has all of them.
STATUSES = ("left_range", "max_points", "newton_failed", "sticking", "integration_failed", "grazing", "period_doubling",
            "branch_point", "interrupted", "domain_edge")
# branch_point: a real multiplier through +1 where the parameter does not turn (a symmetric
# branch's pitchfork, analysis/continuation._branch_point); the branch goes on through it.
LOCATED_KINDS = ("fold", "period_doubling", "neimark_sacker", "grazing", "branch_point")
# A bifurcation the continuation passed but could not locate (analysis/continuation.py): its kind
# with this prefix, tagged with a "?" (G?1: a graze not located).
UNLOCATED = "unlocated_"
KINDS = LOCATED_KINDS + tuple(UNLOCATED + kind for kind in LOCATED_KINDS)
# The short names of the bifurcations, numbered per kind in the file's order (F1, F2, PD1, G1...):
# the same on a branch figure as in ``vrsweep info`` (bifurcation_tags).
TAG_PREFIXES = {"fold": "F", "period_doubling": "PD", "neimark_sacker": "NS", "grazing": "G", "branch_point": "BP"}
TAG_PREFIXES.update({UNLOCATED + kind: f"{prefix}?" for kind, prefix in list(TAG_PREFIXES.items())})


def bifurcation_tags(kinds) -> list[str]:
    """['F1', 'PD1', 'F2', ...]: each bifurcation's kind's prefix and its number among that kind's."""
    counts, tags = {}, []
    for kind in kinds:
        kind = kind.decode() if isinstance(kind, bytes) else str(kind)
        prefix = TAG_PREFIXES.get(kind, kind)
        counts[prefix] = counts.get(prefix, 0) + 1
        tags.append(f"{prefix}{counts[prefix]}")
    return tags
LAYOUT = {
    "point": (("point",), "i"), "multiplier": (("multiplier",), "i"), "bifurcation": (("bifurcation",), "i"),
    "branch_id": (("branch_id",), "i"),
    **{name: (("point",), "i" if name in ("branch", "periods", "stable") else "f") for name in _POINT_VARIABLES},
    **{f"multiplier_{part}": (("point", "multiplier"), "f") for part in ("real", "imag", "modulus")},
    "bifurcation_kind": (("bifurcation",), "s"), "bifurcation_branch": (("bifurcation",), "i"),
    **{f"bifurcation_{key}": (("bifurcation",), "f") for key in ("parameter", "x", "v", "R")},
    **{f"bifurcation_multiplier_{part}": (("bifurcation", "multiplier"), "f") for part in ("real", "imag")},
    "branch_periods": (("branch_id",), "i"),
    **{f"branch_end_{side}_{what}": (("branch_id",), "s") for side in ("first", "last") for what in ("status", "reason")},
}


# Every attribute (the root's and each variable's) is covered by one checksum (store/sealing.py):
# a flipped bit in the stored config (gamma 0.05 -> 0.07) would otherwise go unnoticed, and info,
# the figure's caption and continue --point would state and use parameters the numbers were not
# computed at.
from vrsweep.store.sealing import (  # noqa: E402 - beside what it replaced; re-exported for curve_file
    ATTRIBUTES_CHECKSUM, attributes_digest, note_if_unprotected, seal_attributes, unless_changed,
)


def _check_attributes(f, path):
    """ResultFileError when the attributes fail their checksum; a file written before they had one
    passes (note_if_unprotected says so once it is found sound)."""
    from vrsweep.store.sealing import check_attributes

    check_attributes(f, path)


def _text(value):
    return value.decode() if isinstance(value, bytes) else value


# The root attributes file_attributes writes as text (and a branch file's parameter): each must
# be text where present, as every other attribute stored as text must be valid UTF-8.
TEXT_ATTRS = ("created", "config", "model", "parameter", "method", "vrsweep_version", "numba_version", "numpy_version",
              "Conventions", "title", "history", "source", "references", "date_created")


def _is_text(value) -> bool:
    """Whether ``value`` (bytes or str, as h5py reads text) is valid UTF-8 text."""
    try:
        (value.decode("utf-8") if isinstance(value, bytes) else value).encode("utf-8")
    except (UnicodeError, AttributeError):
        return False
    return True


def _attr_text(f, path, name, required=False, where="attribute "):
    """Attribute ``name`` of ``f`` (the file, or a dataset with ``where`` "attribute NAME.") as
    text, None when absent (unless ``required``); ResultFileError for anything but valid UTF-8
    text: h5py hands undecodable bytes back as a str with surrogates, which would fail later, in
    the middle of printing a summary."""
    if name not in f.attrs:
        if required:
            raise ResultFileError(f"{path} is corrupt: {where}{name} is missing")
        return None
    value = f.attrs[name]
    if not isinstance(value, (bytes, str)) or not _is_text(value):
        raise ResultFileError(f"{path} is corrupt: {where}{name} must be text")
    return _text(value)


def _texts_are_text(obj, path, where, names=()):
    """Every attribute of ``obj`` stored as text (and each of ``names``) is valid UTF-8: info
    prints them all."""
    for name in obj.attrs:
        if name in names or isinstance(obj.attrs[name], (str, bytes)):
            _attr_text(obj, path, name, where=where)


def _whole(f, path, name, default):
    value = f.attrs.get(name, default)
    if isinstance(value, np.ndarray) and value.shape == (1,):
        value = value[0]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ResultFileError(f"{path} is corrupt: attribute {name} must be a whole number")
    return int(value)


def check_layout(f, path, layout, kind):
    """Raise ResultFileError (one line) unless the open HDF5 file ``f`` holds every array of
    ``layout`` ({name: (dimensions, "i" | "f" | "s")}) with lengths that agree along each
    dimension (a dimension's length is that of its own array, whose values count 0, 1, ...), its
    root attributes of their types, and every checksum holds (each array is read whole). Returns
    {name: values} of the arrays read."""
    # (a refusal for what an attribute says names the checksum too where the attributes fail it)
    if _attr_text(f, path, "vrsweep_file") != kind:
        raise ResultFileError(f"{path} is not a vrsweep {kind} file" + unless_changed(f, path))
    version = _whole(f, path, "vrsweep_format_version", 0)
    if version != FORMAT_VERSION:
        raise ResultFileError(f"{path} has {kind} format {version}; this vrsweep reads format {FORMAT_VERSION}"
                              + unless_changed(f, path))
    complete = _whole(f, path, "vrsweep_complete", 0)
    if complete not in (0, 1):
        raise ResultFileError(f"{path} is corrupt: attribute vrsweep_complete must be 0 or 1, found {complete}")
    # 0: a run stopped by a signal wrote what it had followed (its ends say "interrupted"); a reader
    # shows it as such (info, plot), and a curves file's only through its own writer, always 1.
    if not _attr_text(f, path, "config", required=True).strip():  # '' would read as a config of defaults
        raise ResultFileError(f"{path} is corrupt: attribute config is empty")
    _texts_are_text(f, path, "attribute ", TEXT_ATTRS)
    # No array is read before its size is known to fit in the file: a damaged dataspace could
    # otherwise claim any size and have it allocated (no array of these files is compressed).
    file_bytes = os.path.getsize(path)
    values = {}
    for name, (dimensions, number) in layout.items():
        if name not in f or not isinstance(f[name], h5py.Dataset):
            raise ResultFileError(f"{path} is corrupt: {name} is missing")
        data = f[name]
        wanted = {"i": "iu", "f": "f", "s": "OSU"}[number]
        if data.ndim != len(dimensions) or data.dtype.kind not in wanted:
            raise ResultFileError(f"{path} is corrupt: {name} must be {'text' if number == 's' else 'numbers'} "
                                  f"over ({', '.join(dimensions)}), found shape {data.shape} {data.dtype}")
        if data.size * data.dtype.itemsize > file_bytes:
            raise ResultFileError(f"{path} is corrupt: {name} claims {data.size} values, more than the file holds")
        _texts_are_text(data, path, f"attribute {name}.")
        values[name] = data[()]
        if number == "s" and not all(_is_text(value) for value in values[name].reshape(-1)):
            raise ResultFileError(f"{path} is corrupt: {name} must be text")
    for name, (dimensions, _) in layout.items():
        for axis, dimension in enumerate(dimensions):
            length = len(values[dimension])
            if values[name].shape[axis] != length:
                raise ResultFileError(f"{path} is corrupt: {name} has {values[name].shape[axis]} values along "
                                      f"{dimension}, which has {length}")
    for name, (dimensions, _) in layout.items():
        # A dimension's values are its positions: readers index the other arrays with them.
        if dimensions == (name,) and not np.array_equal(values[name], np.arange(len(values[name]))):
            raise ResultFileError(f"{path} is corrupt: {name} must count 0, 1, ... along its dimension")
    if len(values.get("multiplier", ())) != 2:
        raise ResultFileError(f"{path} is corrupt: multiplier must have 2 values (the two Floquet multipliers)")
    # Only a branch stopped by a signal is written unfinished (its ends "interrupted"), and it says so.
    stopped = any(_is_text(v) and _text(v) == "interrupted" for name in values
                  if name.endswith(("_end_first_status", "_end_last_status")) for v in values[name].reshape(-1))
    if complete != 1 and not stopped:
        raise ResultFileError(f"{path} is incomplete: the run that wrote it did not finish")
    if complete == 1 and stopped:
        raise ResultFileError(f"{path} is corrupt: it ends interrupted in a file marked complete")
    # After the layout: an array replaced whole loses its attributes too, and its own message says more.
    _check_attributes(f, path)
    return values


def read_checked(path, read):
    """``read(f)`` on the HDF5 file ``path`` opened for reading, with whatever HDF5 or h5py raise
    for a damaged file (OSError, RuntimeError, KeyError, UnicodeDecodeError... depending on what
    the damage hit) as one line: the one entry of check_branch and check_curves."""
    path = os.fspath(path)
    try:
        with open_hdf5(path, "r") as f:
            return read(f)
    except ResultFileError:
        raise
    except Exception as error:  # noqa: BLE001 - damaged metadata surfaces as any h5py error type
        from vrsweep.store.reader import corrupt_error

        raise corrupt_error(path, error) from None


def stored_config(path, text, required):
    """The Config a file stores (its resolved YAML), with a continuation section when ``required``
    (ResultFileError otherwise); when not required, None for one this version cannot read."""
    from vrsweep.config import parse_config
    from vrsweep.errors import ConfigError

    try:
        config = parse_config(text, f"{path} (its config)", line_numbers=False)
    except ConfigError as error:
        if not required and _is_mapping(text):  # a later version's config, say: the figure goes without it
            return None
        raise ResultFileError(f"{path} is corrupt: its config is not valid ({error.problems[0]})") from None
    if required and config.continuation is None:
        raise ResultFileError(f"{path} is corrupt: its config has no continuation section")
    return config


def _is_mapping(text) -> bool:
    """Whether ``text`` reads as a YAML mapping (what any version's config is), not '0' or a list."""
    from vrsweep.config.yaml import load_round_trip

    try:
        return isinstance(load_round_trip(text, allow_duplicate_keys=True), dict)
    except Exception:  # noqa: BLE001 - ruamel raises many kinds for text that is no YAML
        return False


def check_values(path, values, config, what, finite):
    """The checks branch and curves files share, on what check_layout read: the names of
    ``finite`` hold finite numbers; ``{what}_periods`` (one per branch or curve) lies in 1 ..
    continuation.max_period of ``config`` (when there is one) and every point's ``periods`` is
    its branch's (curve's): an orbit's period sizes what is integrated from the file."""
    for name in finite:
        if not np.all(np.isfinite(values[name])):
            raise ResultFileError(f"{path} is corrupt: {name} holds a value that is not a finite number")
    periods = values[f"{what}_periods"]
    limit = config.continuation.max_period if config is not None and config.continuation is not None else None
    wrong = periods[(periods < 1) | (periods > (limit if limit is not None else np.inf))]
    if wrong.size:
        bound = f"1 to continuation.max_period = {limit}" if limit is not None else "at least 1"
        raise ResultFileError(f"{path} is corrupt: {what}_periods must be {bound}, found {wrong[0]}")
    if np.any(values["periods"] != periods[values[what]]):
        raise ResultFileError(f"{path} is corrupt: periods differs from its {what}'s {what}_periods")


def check_model_attribute(path, model, config) -> None:
    """ResultFileError unless the file's ``model`` attribute (text, or None where absent) is the
    one its stored config's model writes (a written model's is not its name)."""
    from vrsweep.store.provenance import model_attributes

    expected = model_attributes(config.model)["model"]
    if model is not None and model != expected:
        raise ResultFileError(f"{path} is corrupt: attribute model is {model!r}, its config's model {expected}")


def check_branch(path) -> tuple[str, dict]:
    """Raise ResultFileError (one line) unless ``path`` is a sound branch file of this format.

    Returns what the check read, so that a reader needs no second pass over the file: the
    continued parameter's name and {name: values} of every array of LAYOUT (text as bytes)."""
    path = os.fspath(path)

    def read(f):
        values = check_layout(f, path, LAYOUT, FILE_KIND)
        return (_attr_text(f, path, "parameter"), _attr_text(f, path, "config"), _attr_text(f, path, "model"),
                values, ATTRIBUTES_CHECKSUM in f.attrs)

    parameter, text, model, values, protected = read_checked(path, read)
    if not parameter:
        raise ResultFileError(f"{path} is corrupt: attribute parameter must name the continued parameter")
    n_branches = len(values["branch_id"])
    for name in ("branch", "bifurcation_branch"):
        if np.any((values[name] < 0) | (values[name] >= n_branches)):
            raise ResultFileError(f"{path} is corrupt: {name} names a branch outside 0..{n_branches - 1}")
    for name, allowed in (("bifurcation_kind", KINDS), ("branch_end_first_status", STATUSES),
                          ("branch_end_last_status", STATUSES)):
        unknown = sorted({_text(v) for v in values[name]} - set(allowed))
        if unknown:
            raise ResultFileError(f"{path} is corrupt: {name} holds {unknown[0]!r}, not one of {', '.join(allowed)}")
    # continue BRANCH.h5 --point K computes from the stored config: it must be one this version
    # runs, of the parameter and model the file says it continued.
    config = stored_config(path, text, required=True)
    if config.continuation.parameter != parameter:
        raise ResultFileError(f"{path} is corrupt: attribute parameter is {parameter}, its config continues "
                              f"{config.continuation.parameter}")
    check_model_attribute(path, model, config)
    if np.any((values["stable"] != 0) & (values["stable"] != 1)):
        raise ResultFileError(f"{path} is corrupt: stable must be 0 or 1")
    # The bifurcation table may hold NaN (a point located elsewhere without its parameter): info
    # prints it as nan, and continue refuses to follow that point (execution/curves.read_request).
    check_values(path, values, config, "branch", ("parameter", "x", "v"))
    note_if_unprotected(path, protected)
    return parameter, values
