"""The curves file of ``vrsweep continue BRANCH.h5 --point K --along NAME``: bifurcation curves
in a parameter plane (analysis/curves.py).

Layout (HDF5, flat; ``vrsweep.open_results`` opens it as one xarray Dataset)
---------------------------------------------------------------------------
root attributes: ``vrsweep_file = "curves"``, ``vrsweep_format_version``, ``vrsweep_complete``,
``created``, ``config`` (the resolved YAML), ``model``, ``method``, ``parameter_names`` (the two
parameters in order, a string array, e.g. ["g", "Omega"]), CF globals (title, history, source,
references, date_created), ``vrsweep_version``.

    point (dim)                   index along the curves, in arc order within each curve
    curve (point)                 which curve the point is on (0, 1, ...)
    <first>, <second> (point)     the two parameters, each variable named by its parameter
    x, v (point)                  the orbit's state at t = 0 mod T (T = 2 pi / omega)
    periods (point)               p: the orbit closes after p slow periods
    R (point)                     eq3.3 over the orbit's p periods
    impacts_per_period (point)
    barrier_distance (point)      Delta - x_max of the orbit (0 on a grazing curve, to tolerance)
    residual (point)              max |P^p(y) - y| at convergence
    multiplier (dim, 2)           Floquet multipliers, larger modulus first
    multiplier_real, multiplier_imag, multiplier_modulus (point, multiplier)
    curve_id (dim)                one entry per curve
    curve_kind (curve_id)         fold, period_doubling or grazing
    curve_periods (curve_id)
    curve_end_first_status, curve_end_first_reason, curve_end_last_status, curve_end_last_reason
                  (curve_id)      why each curve stops at its first and last point (statuses:
                                  left_range, max_points, newton_failed, sticking,
                                  integration_failed, fold_grazing, period_doubling_grazing,
                                  interrupted, domain_edge)
    special (dim)                 codimension-two points
    special_kind (special)        fold_grazing, period_doubling_grazing or cusp
    special_curve (special)
    special_<first>, special_<second> (special)

On a grazing curve the orbit is the barrier-free one (it touches the barrier with zero velocity),
so its multipliers are those of the smooth side. Built in memory and written whole through
``fileio.write_bytes`` (atomic), every numeric array with a Fletcher-32 checksum (branch_file's
writers); ``check_curves``, which open_results and info go through, reads them all and checks
the layout, so a damaged file is one line.
"""

from __future__ import annotations

import io
import os

import h5py
import numpy as np

from vrsweep.errors import ResultFileError
from vrsweep.numerics.model import PARAMETER_UNITS, axis_long_name
from vrsweep.store.branch_file import _POINT_VARIABLES as BRANCH_POINT_VARIABLES
from vrsweep.store.branch_file import (
    ATTRIBUTES_CHECKSUM, _dimension, _ends, _multipliers, _attr_text, _text, _variable, check_layout, check_model_attribute, check_values, file_attributes,
    has_file_kind, note_if_unprotected, read_checked, seal_attributes, stored_config, point_long_names,
)
from vrsweep.store.fileio import LIBVER, output_target, write_bytes

FILE_KIND = "curves"

# name: (long name, units), as in a branch file; the two parameters' variables go after "curve"
_POINT_VARIABLES = {name: BRANCH_POINT_VARIABLES[name]
                    for name in ("x", "v", "periods", "R", "impacts_per_period", "barrier_distance", "residual")}
_INTEGER = ("curve", "periods")


def curve_arrays(curves, specials, names):
    """Plain arrays from analysis.curves' Curve and SpecialPoint lists (see the layout)."""
    columns = {name: [] for name in ("curve", *names, *_POINT_VARIABLES)}
    multipliers = []
    for number, curve in enumerate(curves):
        for point in curve.points:
            values = dict(curve=number, x=point.state[0], v=point.state[1], periods=point.periods, R=point.R,
                          impacts_per_period=point.impacts_per_period, barrier_distance=point.barrier_distance,
                          residual=point.residual, **dict(zip(names, point.values)))
            for name in columns:
                columns[name].append(values[name])
            multipliers.append(point.multipliers)
    arrays = {name: np.asarray(values, dtype=np.int64 if name in _INTEGER else np.float64)
              for name, values in columns.items()}
    arrays["multipliers"] = np.asarray(multipliers, dtype=np.complex128).reshape(-1, 2)
    arrays["curves"] = [(curve.kind, curve.periods, curve.ends["first"], curve.ends["last"]) for curve in curves]
    arrays["specials"] = [(special.kind, special.curve, *special.values) for special in specials]
    return arrays


def write_curves(path, arrays, names, config, method, overwrite=False, complete=True):
    """Write curve_arrays' ``arrays`` to ``path`` atomically; refuse an existing file unless ``overwrite``.

    names: the two parameters in order; config: the Config whose resolved YAML is stored;
    ``complete`` False: a continuation stopped by a signal (its ends "interrupted")."""
    path = output_target(os.fspath(path), overwrite=overwrite)  # fileio's one rule of outputs
    first, second = names
    attrs = file_attributes(FILE_KIND, config, method,
                            f"vrsweep bifurcation curves of the {config.model} model in ({first}, {second})",
                            complete=complete)
    image = io.BytesIO()
    with h5py.File(image, "w", track_order=True, libver=LIBVER) as f:
        for name, value in attrs.items():
            f.attrs[name] = value
        f.attrs.create("parameter_names", np.asarray(names, dtype=object), dtype=h5py.string_dtype())
        point = _dimension(f, "point", np.arange(len(arrays["curve"]), dtype=np.int64), "point along the curves")
        multiplier = _dimension(f, "multiplier", np.arange(2, dtype=np.int64),
                                "Floquet multiplier number, larger modulus first")
        _variable(f, "curve", arrays["curve"], (point,), "curve number", "1")
        for name in names:
            _variable(f, name, arrays[name], (point,), axis_long_name(name, config.written),
                      PARAMETER_UNITS.get(name, "1"))
        words = point_long_names(config)
        for name, (_, units) in _POINT_VARIABLES.items():
            _variable(f, name, arrays[name], (point,), words[name], units)
        _multipliers(f, arrays["multipliers"], (point, multiplier))
        curves = arrays["curves"]
        curve_id = _dimension(f, "curve_id", np.arange(len(curves), dtype=np.int64), "curve number")
        _variable(f, "curve_kind", np.asarray([c[0] for c in curves], dtype=object), (curve_id,),
                  "kind: fold, period_doubling or grazing", None)
        _variable(f, "curve_periods", np.asarray([c[1] for c in curves], dtype=np.int64), (curve_id,),
                  f"orbit period of the curve in {'periods T' if config.written else 'slow periods'}", "1")
        _ends(f, "curve", curve_id, [c[2] for c in curves], [c[3] for c in curves])
        specials = arrays["specials"]
        special = _dimension(f, "special", np.arange(len(specials), dtype=np.int64), "codimension-two point")
        _variable(f, "special_kind", np.asarray([s[0] for s in specials], dtype=object), (special,),
                  "kind: fold_grazing, period_doubling_grazing or cusp", None)
        _variable(f, "special_curve", np.asarray([s[1] for s in specials], dtype=np.int64), (special,),
                  "curve of the codimension-two point", "1")
        for index, name in enumerate(names):
            _variable(f, f"special_{name}", np.asarray([s[2 + index] for s in specials], dtype=np.float64),
                      (special,), f"{axis_long_name(name, config.written)} at the codimension-two point",
                      PARAMETER_UNITS.get(name, "1"))
        seal_attributes(f)
    write_bytes(path, image.getvalue())


def is_curves_file(path) -> bool:
    """True for an HDF5 file that says it is a vrsweep curves file; False for anything else."""
    return has_file_kind(path, FILE_KIND)


STATUSES = ("left_range", "max_points", "newton_failed", "sticking", "integration_failed", "fold_grazing",
            "period_doubling_grazing", "interrupted", "domain_edge")
KINDS = ("fold", "period_doubling", "grazing")
SPECIAL_KINDS = ("fold_grazing", "period_doubling_grazing", "cusp")


def layout(names):
    """{array: (dimensions, "i" | "f" | "s")} of a curves file in parameters ``names`` (check_layout's form)."""
    return {
        "point": (("point",), "i"), "multiplier": (("multiplier",), "i"), "curve_id": (("curve_id",), "i"),
        "special": (("special",), "i"), "curve": (("point",), "i"),
        **{name: (("point",), "f") for name in names},
        **{name: (("point",), "i" if name in _INTEGER else "f") for name in _POINT_VARIABLES},
        **{f"multiplier_{part}": (("point", "multiplier"), "f") for part in ("real", "imag", "modulus")},
        "curve_kind": (("curve_id",), "s"), "curve_periods": (("curve_id",), "i"),
        **{f"curve_end_{side}_{what}": (("curve_id",), "s") for side in ("first", "last") for what in ("status", "reason")},
        "special_kind": (("special",), "s"), "special_curve": (("special",), "i"),
        **{f"special_{name}": (("special",), "f") for name in names},
    }


def check_curves(path) -> tuple[list, dict]:
    """Raise ResultFileError (one line) unless ``path`` is a sound curves file of this format.

    Returns what the check read, so that a reader needs no second pass over the file: the two
    parameters' names in order and {name: values} of every array of ``layout(names)`` (text as
    bytes)."""
    path = os.fspath(path)

    def read(f):
        names = np.atleast_1d(f.attrs.get("parameter_names", []))
        try:
            names = [_text(name) for name in names]
        except (UnicodeError, AttributeError):
            names = []
        # a written model's parameters are any names (its stored config says which)
        if len(names) != 2 or not all(isinstance(name, str) and name.isidentifier() for name in names) \
                or names[0] == names[1]:
            raise ResultFileError(f"{path} is corrupt: attribute parameter_names must name two parameters")
        return (names, check_layout(f, path, layout(names), FILE_KIND), _attr_text(f, path, "config"),
                _attr_text(f, path, "model"), ATTRIBUTES_CHECKSUM in f.attrs)

    names, values, text, model, protected = read_checked(path, read)
    n_curves = len(values["curve_id"])
    for name in ("curve", "special_curve"):
        if np.any((values[name] < 0) | (values[name] >= n_curves)):
            raise ResultFileError(f"{path} is corrupt: {name} names a curve outside 0..{n_curves - 1}")
    for name, allowed in (("curve_kind", KINDS), ("special_kind", SPECIAL_KINDS),
                          ("curve_end_first_status", STATUSES), ("curve_end_last_status", STATUSES)):
        unknown = sorted({_text(v) for v in values[name]} - set(allowed))
        if unknown:
            raise ResultFileError(f"{path} is corrupt: {name} holds {unknown[0]!r}, not one of {', '.join(allowed)}")
    # Nothing is computed from a curves file: its config only labels the figure, and one this
    # version cannot read is drawn without it.
    config = stored_config(path, text, required=False)
    if config is not None:  # the model the file says must be its config's (as a branch file's)
        check_model_attribute(path, model, config)
    check_values(path, values, config, "curve", (*names, "x", "v", *(f"special_{name}" for name in names)))
    note_if_unprotected(path, protected)
    return names, values
