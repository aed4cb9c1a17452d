"""The sweep's axes, each checked on its own: its form ({start, stop, num}, a list, {values: [...]}),
its values (in their parameter's range, strictly monotonic, distinct in float64) and continuation.

Methods of one validation run (vrsweep.config.validate._Validator), kept here by what they check;
they report through vrsweep.config.report.Report.
"""

from __future__ import annotations

import numpy as np
from pydantic import ValidationError

from vrsweep.config.report import without_missing_typos
from vrsweep.config.schema import AXIS_FORMS, LinearAxis, ListAxis, ValuesAxis
from vrsweep.config.wording import did_you_mean, show, show_number
from vrsweep.numerics.model import INITIAL_STATE_AXES, INITIAL_STATE_KEYS


MAX_DIMENSIONS = 32  # of an HDF5 dataset (H5S_MAX_RANK)


class SweepAxes:
    """Checks of ``sweep``: mixed into the validation run, which provides ``report``."""

    def validate_sweep(self, sweep):
        """{name: (values, continuation, spec_kind)} for the axes that are valid."""
        axes = {}
        if not isinstance(sweep, dict):
            return axes  # None: no sweep; anything else was reported by validate_document
        for name, spec in sweep.items():
            path = ("sweep", name)
            if name not in self.axis_names:
                self.report(path, f"not a parameter{did_you_mean(name, self.axis_names)}",
                            allowed=", ".join(self.axis_names))
                continue
            if isinstance(spec, list):
                model, data, kind = ListAxis, {"values": spec}, "list"
            elif isinstance(spec, dict):
                model, data, kind = ((ValuesAxis, spec, "values") if "values" in spec
                                     else (LinearAxis, spec, "linear"))
            else:
                self.report(path, f"must be {{start, stop, num}}, a list or {{values: [...]}}, got "
                                  f"{show(spec)} (to fix {name} at one value, set {_home(name)})",
                            allowed=AXIS_FORMS)
                continue
            try:
                axis = model.model_validate(data)
            except ValidationError as error:
                for item in without_missing_typos(error.errors(include_url=False)):
                    loc = tuple(item["loc"])
                    if kind == "list":
                        loc = loc[1:]  # the wrapper's "values" is not in the YAML
                    self.report_pydantic({**item, "loc": loc}, path)
                continue
            continuation = getattr(axis, "continuation", None)
            if continuation and name in INITIAL_STATE_AXES:
                # A continuation line starts each point from the previous one's final state, which
                # is exactly what an initial-state axis overrides: the two contradict each other.
                key = INITIAL_STATE_KEYS[name]
                self.report(path + ("continuation",),
                            f"{name} is the initial state, not a parameter: there is nothing to continue "
                            f"along it (each point starts from its own {name}); remove continuation, or "
                            f"put it on a parameter axis (each line then starts from its {name})",
                            allowed=f"continuation on a parameter axis; initial.{key} or sweep.{name} "
                                    "without continuation")
                continue
            values = self.axis_values(path, axis, kind)
            if values is not None:
                axes[name] = (values, continuation, kind)
        # Each variable of the file is an HDF5 dataset over the axes, a two-way sweep's direction
        # and its own dimension (the strobe's): HDF5 holds 32 dimensions at most. A written model
        # swept over 32 axes ended its run in h5py's "Chunk dimensionality is too large", over 33
        # validate in numpy's "only supports up to 32 dimensions", both tracebacks.
        limit = MAX_DIMENSIONS - 1 - any(spec[1] == "both" for spec in axes.values())
        if len(axes) > limit:
            self.report(("sweep",), f"has {len(axes)} axes; a result file holds at most {limit} (HDF5's {MAX_DIMENSIONS} "
                                    f"dimensions, less the strobe's{' and the direction' if limit < MAX_DIMENSIONS - 1 else ''}"
                                    f"): fix the others at one value in the parameters")
            return {}
        return axes

    def axis_values(self, path, axis, kind):
        """The axis's values after the per-axis rules, or None (reported)."""
        name = path[1]
        if kind == "linear":
            if axis.stop < axis.start:
                self.report(path + ("stop",), f"must be >= start = {show(axis.start)}, got {show(axis.stop)}; "
                                              "use an explicit list or swap start and stop; "
                                              "continuation: down sweeps downwards")
                return None
            if axis.num == 1 and axis.start != axis.stop:
                self.report(path + ("num",), f"num = 1 needs start == stop, got start = {show(axis.start)}, "
                                             f"stop = {show(axis.stop)}; use num >= 2 or a one-element list")
                return None
            with np.errstate(all="ignore"):
                values = np.linspace(axis.start, axis.stop, axis.num, dtype=np.float64)
            if not np.all(np.isfinite(values)):  # start and stop so far apart that stop - start overflows
                self.report(path, f"{show(axis.start)} .. {show(axis.stop)} cannot be divided into "
                                  f"{axis.num} finite values")
                return None
            if axis.num > 1 and axis.stop == axis.start:  # every point the same: like a repeated value
                self.report(path + ("stop",), f"must be > start = {show(axis.start)} when num = {axis.num}, "
                                              f"got {show(axis.stop)} (the same point {axis.num} times); "
                                              f"to fix {name} at one value, set {_home(name)}")
                return None
            if not np.all(np.diff(values) > 0):  # so close together that float64 rounding repeats values
                self.report(path, f"{show(axis.start)} .. {show(axis.stop)} cannot be divided into "
                                  f"{axis.num} distinct float64 values")
                return None
            # The domains are intervals, so the ends decide for the whole linspace.
            ok = self.check_values(name, path + ("start",), [axis.start])
            ok &= self.check_values(name, path + ("stop",), [axis.stop])
        else:
            values = np.array(axis.values, dtype=np.float64)
            item_path = path if kind == "list" else path + ("values",)
            ok = self.check_values(name, item_path, axis.values, indexed=True)
            ok = ok and self.check_monotonic(item_path, axis.values)
        if not ok:
            return None
        values.flags.writeable = False  # Axis is frozen; so are its values
        return values

    def check_monotonic(self, path, values) -> bool:
        """An explicit list must be strictly increasing or strictly decreasing.

        A repeated value would compute and store the same grid point twice (and make the axis
        useless for selecting by value); an unordered one draws a zigzag. Decreasing lists are
        allowed: the stored axis keeps the config's order.
        """
        first_index = {}
        repeated = False
        for index, value in enumerate(values):
            if value in first_index:
                first = first_index[value]
                where = f"item {first}"
                first_line, line = self.line_of(path + (first,)), self.line_of(path + (index,))
                if first_line != line:
                    where += f", line {first_line}"
                self.report(path + (index,), f"{show_number(value)} is listed twice (also {where}): axis values "
                                             "must be strictly increasing or strictly decreasing")
                repeated = True
            else:
                first_index[value] = index
        if repeated:
            return False
        steps = np.sign(np.diff(values))
        breaks = np.flatnonzero(steps != steps[0]) if len(steps) else []
        if len(breaks):
            index = int(breaks[0]) + 1
            order = "increasing" if steps[0] > 0 else "decreasing"
            self.report(path + (index,), f"{show_number(values[index])} after {show_number(values[index - 1])} breaks "
                                         f"the order of the list ({order} up to item {index - 1}): axis values "
                                         "must be strictly increasing or strictly decreasing")
            return False
        return True

    def check_values(self, name, path, values, indexed=False) -> bool:
        """Each swept value must obey its parameter's domain."""
        domain = self.axis_domains[name]
        ok = True
        for index, value in enumerate(values):
            if not domain.contains(value):
                self.report(path + ((index,) if indexed else ()), domain.range_message(value))
                ok = False
        return ok


def _home(axis_name) -> str:
    """Where a sweep axis's fixed value lives: parameters.g, initial.x (for x0)."""
    key = INITIAL_STATE_KEYS.get(axis_name)
    return f"initial.{key}" if key else f"parameters.{axis_name}"
