"""``vrsweep info RESULTS.h5 [--json]``: what a vrsweep file holds, without plotting it.

For a sweep result or a shard: the format version, whether it is finished (points done of the
total), the model, the axes, the fixed parameters, every variable with its units, the points per
status, and when and with which versions it was written. ``--json`` prints the same as one object
for scripts.

Reading goes through ``vrsweep.store.reading`` (xarray and h5netcdf, as ``vrsweep.open_results``),
which turns every bad file (missing, not HDF5, not vrsweep, truncated, newer format, locked) into
a ResultFileError: the CLI group prints that one line and exits 2. Other vrsweep files (a
``simulate`` trajectory has no grid and no ``done`` mask) are described group by group. The
stored config is read by ``vrsweep.config``, as a run reads it.
"""

from __future__ import annotations

import json
import math
import os

import click
import numpy as np

from vrsweep.commands.options import PathText
from vrsweep.errors import ResultFileError, one_line

# The kind of a file of this format that is none of those this vrsweep writes (hand-made, or of a
# later kind of output): described from its groups.
UNKNOWN_KIND = "unknown"
# Root attributes shown in their own lines (or not at all), not under "attributes".
_KNOWN_ROOT_ATTRS = ("vrsweep_format_version", "vrsweep_complete", "created", "config", "model",
                     "vrsweep_version", "numba_version", "numpy_version", "shard", "vrsweep_attributes_sha256",
                     "R_solver_err", "R_solver_err_points", "R_solver_err_rtol",
                     "vrsweep_unreadable_points")  # the last: open_results' own (store/reading._as_done)


@click.command("info")
@click.argument("path", metavar="RESULTS.h5|FIGURE.png", type=PathText(dir_okay=True))
@click.option("--json", "as_json", is_flag=True, help="Print the summary as one JSON object.")
@click.option("--config", "show_config", is_flag=True, help="Also print the config the file was run from.")
def command(path, as_json, show_config):
    """Summarise a results, shard, trajectory, branch or curves file: grid, progress, status counts, variables.

    A figure from vrsweep plot (.png, .pdf, .svg): its title and full description, kept in the
    file's metadata (also with --no-title)."""
    from pathlib import Path

    from vrsweep.plot.labels import FIGURE_SUFFIXES

    if Path(path).suffix.lower() in FIGURE_SUFFIXES and not _hdf5_named_as_figure(path):
        _describe_figure(path, as_json)
        return
    summary = describe(path)
    if as_json:
        click.echo(json.dumps(summary, indent=2, allow_nan=False))
    else:
        click.echo(format_summary(summary, show_config))


def _describe_figure(path, as_json):
    """Print the title and description ``vrsweep plot`` wrote into a figure's metadata."""
    from vrsweep.plot.labels import read_description

    if not os.path.isfile(path):
        raise ResultFileError(f"{path}: no such file")
    _refuse_what_is_no_figure(path)
    try:
        found = read_description(path)
    except (OSError, ValueError) as error:
        raise ResultFileError(f"{path}: cannot read the figure's metadata ({error})") from None
    if as_json:
        click.echo(json.dumps({"file": os.fspath(path), "kind": "figure", **found}, indent=2))
    elif not (found["Title"] or found["Description"]):
        click.echo(f"{one_line(path)}: a figure without a vrsweep description in its metadata")
    else:
        description = (found["Description"] or found["Title"]).split("\n")
        shown = [one_line(_cut(line, DESCRIPTION_LINE_CHARACTERS)) for line in description[:DESCRIPTION_LINES]]
        if len(description) > DESCRIPTION_LINES:
            shown.append(f"... ({len(description) - DESCRIPTION_LINES} more lines; --json prints them all)")
        click.echo("\n".join([f"{one_line(path)}: figure"] + shown))


def _hdf5_named_as_figure(path):
    """True for an HDF5 file named as a figure (results.png): described as the file it is."""
    from vrsweep.store.fileio import is_hdf5

    return is_hdf5(path)


def _refuse_what_is_no_figure(path):
    """ResultFileError (one line) for a file named as a figure whose bytes are none of that
    format: a text file named text.png was "a figure without a vrsweep description"."""
    from pathlib import Path

    from vrsweep.plot.labels import FIGURE_WORDS, figure_format, file_contents

    suffix = Path(path).suffix.lower()
    try:
        if figure_format(path) == suffix:
            return
        holds = file_contents(path)
    except OSError as error:
        raise ResultFileError(f"cannot read {path}: {error.strerror or error}") from None
    raise ResultFileError(f"{path} holds {holds}, not {FIGURE_WORDS[suffix]} as its name says: info describes "
                          "the figures vrsweep plot writes and vrsweep's HDF5 files")


# A figure's metadata is any file's to write: a description of a megabyte (a PNG made elsewhere,
# or on purpose) was printed whole. vrsweep's own captions are a few lines of at most a few
# hundred characters, well inside these.
DESCRIPTION_LINES = 40
DESCRIPTION_LINE_CHARACTERS = 1000


def _cut(line, limit):
    return line if len(line) <= limit else f"{line[:limit]}... ({len(line) - limit} more characters; --json prints them)"


# --------------------------------------------------------------------------------------------
# The summary as plain data (what --json prints)
# --------------------------------------------------------------------------------------------


def describe(path) -> dict:
    """The summary of a vrsweep file as a JSON-ready dict; ResultFileError for a bad file."""
    return _json_ready(_describe(path))


def _describe(path) -> dict:
    from vrsweep.store.reading import file_kind, load_results

    try:
        kind = file_kind(path)
    except ResultFileError as error:
        # A sweep needs its grid; another vrsweep file of this format (hand-made, or from a
        # later kind of output) is described from its groups. Anything else keeps the reader's
        # own message, which says what is wrong.
        other = _describe_groups(path, None)
        if other is None:
            raise error from None
        return other
    if kind in ("branch", "curves"):
        from vrsweep.store.branch_file import check_branch
        from vrsweep.store.curve_file import check_curves

        check, describe = {"branch": (check_branch, _describe_branches),
                           "curves": (check_curves, _describe_curves)}[kind]
        # A damaged file is one line, as every reader of it says. The check reads every array
        # through its checksum; the summary is made from what it read, not from a second read.
        checked = check(path)
        described = _describe_groups(path, kind)
        if described is None:
            raise ResultFileError(f"{path} is a vrsweep {kind} file this vrsweep cannot describe")
        described["branches" if kind == "branch" else "curves"] = describe(*checked)
        # The continued parameters move along the file: their config value is only the start
        # (a branch in F from 0.3 was shown as 'fixed: ... F=0.3').
        moving = {checked[0]} if kind == "branch" else set(checked[0])
        described["fixed_parameters"] = {name: value for name, value in described["fixed_parameters"].items()
                                         if name not in moving}
        return described
    if kind == "trajectory":
        from vrsweep.store.trajectory_file import check_trajectory, read_trajectory

        check_trajectory(path)  # a damaged file is one line, as every reader of it says
        described = _describe_groups(path, kind)
        if described is None:  # the trajectory reader says what is wrong (a newer format...)
            read_trajectory(path)
            raise ResultFileError(f"{path} is a vrsweep trajectory this vrsweep cannot describe")
        return described
    # Every variable is read, not only what the summary shows: each chunk's checksum is checked,
    # so a damaged file is reported as such instead of described (tests/test_errors.py).
    return _describe_sweep(path, load_results(path))


def _json_ready(value):
    """The summary with every value one json.dumps writes (and the text shows): attributes are the
    file's, of whatever type its writer chose (a numba_version written as a number failed
    json.dumps: a traceback from info --json)."""
    if isinstance(value, dict):
        return {str(key): _json_ready(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(item) for item in value]
    return _plain(value)


def _describe_branches(parameter, values) -> dict:
    """A branch file's continuation (vrsweep continue): per branch its points, stable points,
    parameter range and ends; the bifurcation table. parameter, values: what check_branch read."""
    branch, continued, stable = values["branch"], values["parameter"], values["stable"]
    rows = []
    for number in values["branch_id"]:
        mine = branch == number
        rows.append({
            "branch": int(number), "periods": int(values["branch_periods"][number]),
            "points": int(mine.sum()), "stable_points": int(stable[mine].sum()),
            "min": _number(continued[mine].min()) if mine.any() else None,
            "max": _number(continued[mine].max()) if mine.any() else None,
            "first_end": _end(values, "branch", "first", number),
            "last_end": _end(values, "branch", "last", number),
        })
    from vrsweep.store.branch_file import UNLOCATED, bifurcation_tags

    # The tag (F1, PD1, G1...) is the one the branch figure writes beside the point.
    tags = bifurcation_tags(_plain(kind) for kind in values["bifurcation_kind"])
    bifurcations = [{"kind": _plain(kind), "tag": tag, "branch": int(b), "parameter": _number(p), "R": _number(r)}
                    for kind, tag, b, p, r in zip(values["bifurcation_kind"], tags, values["bifurcation_branch"],
                                                  values["bifurcation_parameter"], values["bifurcation_R"])]
    for row in bifurcations:
        if row["kind"].startswith(UNLOCATED):
            row["between"] = _unlocated_bracket(values, row)
    return {"parameter": str(parameter), "branches": rows, "bifurcations": bifurcations}


def _unlocated_bracket(values, row):
    """[the parameter of an unlocated point's orbit, that of the branch's neighbouring orbit on its
    other side]: where it lies (None where the file holds no such neighbour). The other side of a
    graze is another impact count; of a fold, period doubling or Neimark-Sacker point, the other
    sign of its test function (analysis/continuation.py), from the stored multipliers."""
    from vrsweep.store.branch_file import UNLOCATED

    kind = row["kind"].removeprefix(UNLOCATED)
    mine = np.flatnonzero((values["branch"] == row["branch"]) & (values["parameter"] == row["parameter"]))
    if kind == "grazing":
        side = values["impacts_per_period"]
    else:
        mu = values["multiplier_real"] + 1j * values["multiplier_imag"]
        with np.errstate(invalid="ignore"):
            fold = ((1 - mu[:, 0]) * (1 - mu[:, 1])).real
            test = {"fold": fold, "branch_point": fold, "period_doubling": ((1 + mu[:, 0]) * (1 + mu[:, 1])).real,
                    "neimark_sacker": np.abs(mu[:, 0] * mu[:, 1]) - 1}.get(kind, np.full(len(mu), np.nan))
        side = np.sign(test)
    for index in mine:
        for other in (index - 1, index + 1):
            if (0 <= other < len(side) and values["branch"][other] == row["branch"]
                    and side[other] != side[index]):
                return [row["parameter"], _number(values["parameter"][other])]
    return None


def _describe_curves(names, values) -> dict:
    """A curves file (vrsweep continue BRANCH.h5 --point K --along NAME): per curve its kind,
    period, points, both parameters' ranges and ends; the codimension-two points. names, values:
    what check_curves read."""
    curve = values["curve"]
    rows = []
    for number in values["curve_id"]:
        mine = curve == number
        row = {"curve": int(number), "kind": _plain(values["curve_kind"][number]),
               "periods": int(values["curve_periods"][number]), "points": int(mine.sum()),
               "first_end": _end(values, "curve", "first", number),
               "last_end": _end(values, "curve", "last", number)}
        for name in names:
            along = values[name][mine]
            row[name] = [_number(along.min()), _number(along.max())] if mine.any() else [None, None]
        rows.append(row)
    specials = [{"kind": _plain(kind), "curve": int(number),
                 **{name: _number(values[f"special_{name}"][index]) for name in names}}
                for index, (kind, number) in enumerate(zip(values["special_kind"], values["special_curve"]))]
    return {"parameters": [str(name) for name in names], "curves": rows, "specials": specials}


def _end(values, what, side, number) -> list[str]:
    """[status, reason]: why branch or curve ``number`` stops at its ``side`` ("first", "last")."""
    return [_plain(values[f"{what}_end_{side}_{part}"][number]) for part in ("status", "reason")]


def _format_curves(curves) -> list[str]:
    if not curves:
        return []
    names = curves["parameters"]
    lines = []
    for row in curves["curves"]:
        ranges = ", ".join(f"{name} from {_short(row[name][0])} to {_short(row[name][1])}" for name in names)
        lines.append(f"curve {row['curve']}:     {row['kind']}, period {row['periods']}, {row['points']} points, "
                     f"{ranges}")
        lines += _format_ends(row)
    for row in curves["specials"]:
        where = ", ".join(f"{name} = {_precise(row[name])}" for name in names)
        lines.append(f"special:     {row['kind']} at {where} (curve {row['curve']})")
    return lines


def _format_ends(row) -> list[str]:
    """Why a branch or curve stops, one line per end."""
    return [f"  {side} end:   {row[f'{side}_end'][0]}: {row[f'{side}_end'][1]}" for side in ("first", "last")]


def _format_branches(branches) -> list[str]:
    from vrsweep.store.branch_file import UNLOCATED

    if not branches:
        return []
    name = branches["parameter"]
    lines = []
    for row in branches["branches"]:
        lines.append(f"branch {row['branch']}:    period {row['periods']}, {row['points']} points "
                     f"({row['stable_points']} stable), {name} from {_short(row['min'])} to {_short(row['max'])}")
        lines += _format_ends(row)
    for row in branches["bifurcations"]:
        line = (f"bifurcation: {row['kind']} at {name} = {_precise(row['parameter'])} ({row['tag']} on the "
                f"figure, branch {row['branch']}, R = {_short(row['R'])})")
        if row["kind"].startswith(UNLOCATED):
            between = row.get("between")
            where = (f"between {name} = {_precise(between[0])} and {_precise(between[1])}" if between
                     else f"next to {name} = {_precise(row['parameter'])}")
            kind = row["kind"].removeprefix(UNLOCATED)
            # a fold's parameter turns between the two orbits: the point lies between them along the
            # branch, not between their parameter values
            orbits = (f"between the branch's orbits at {name} = {_precise(between[0])} and {_precise(between[1])}"
                      if between else f"next to the orbit at {name} = {_precise(row['parameter'])}")
            line += (f": the impact count changes {where}, where the graze could not be located" if kind == "grazing"
                     else f": the {kind.replace('_', ' ')} test function changes sign {orbits}, where the point "
                          "could not be located")
        lines.append(line)
    return lines


def _describe_sweep(path, ds) -> dict:
    from vrsweep.store.reading import grid_axes, point_variables, stored_variables

    # Plain values, whatever their HDF5 type: a file of an earlier vrsweep (no checksum) or of
    # another tool may hold a version as a number or a rtol as an array, as _describe_groups reads them.
    attrs = {key: _plain(value) for key, value in ds.attrs.items() if key != "vrsweep_file"}  # open_results' own
    done = np.asarray(ds["done"].values, dtype=bool)
    owned = np.asarray(ds["owned"].values, dtype=bool) if "owned" in ds else np.ones(done.shape, dtype=bool)
    n_total = int(owned.sum())
    n_done = int((done & owned).sum())
    axis_names = grid_axes(ds)
    axes = []
    for name in axis_names:
        values = np.asarray(ds[name].values)
        axes.append({
            "name": name, "size": int(values.size),
            "min": _number(values.min()), "max": _number(values.max()),
            "first": _number(values[0]), "last": _number(values[-1]),
            "units": ds[name].attrs.get("units"), "long_name": ds[name].attrs.get("long_name"),
        })
    points = set(point_variables(ds))
    variables = []
    for name in stored_variables(ds):
        variable = ds[name]
        variables.append({
            "name": name, "dims": list(variable.dims), "shape": list(variable.shape),
            "dtype": str(variable.dtype), "units": variable.attrs.get("units"),
            "long_name": variable.attrs.get("long_name"), "derived": name not in points,
        })
    config = _stored_config(attrs.get("config"))
    shard = attrs.get("shard")
    complete = bool(attrs.get("vrsweep_complete", 0))
    return {
        "path": os.fspath(path),
        "kind": "shard" if shard else "sweep",
        "format_version": _plain(attrs.get("vrsweep_format_version")),
        "complete": complete,
        "shard": shard,
        "points_done": n_done,
        "points_total": n_total,
        # Points that may have been done but cannot be read back (a kill cut their chunk's write):
        # they read as not computed, and --resume computes them again (store/torn.py).
        "points_unreadable": int(attrs.get("vrsweep_unreadable_points", 0)),
        "grid_points": int(math.prod(done.shape)),
        "model": attrs.get("model") or _model(config),
        "axes": axes,
        "fixed_parameters": _fixed_parameters(config, axis_names),
        "integration": _integration(config),
        "status_counts": _status_counts(ds, owned),
        "motion_counts": _motion_counts(ds, owned),
        "solver_error": _solver_error(attrs),
        "attractors": _attractors(ds, config),
        "variables": variables,
        "created": attrs.get("created"),
        "versions": _versions(attrs),
        "attributes": _other_attributes(attrs),
        "config": attrs.get("config"),
    }


def _solver_error(attrs):
    """R's relative error due to the integration (execution/solver_error.py), or None (older files)."""
    if "R_solver_err_points" not in attrs:
        return None
    relative = _number(attrs["R_solver_err"]) if "R_solver_err" in attrs else None
    return {"relative": relative, "points": _plain(attrs.get("R_solver_err_points")),
            "rtol": _number(attrs.get("R_solver_err_rtol", math.nan))}


def _status_counts(ds, owned) -> list[dict]:
    """Points per status over the points this file owns, named by the file's own flag_meanings."""
    if "status" not in ds:
        return []
    from vrsweep.results import MESSAGES, Status

    status = np.asarray(ds["status"].values)[owned]
    names = _flag_names(ds["status"].attrs)
    counts = []
    for code, n in zip(*np.unique(status, return_counts=True)):
        code = int(code)
        name = names.get(code, f"unknown code {code}")
        try:
            meaning = MESSAGES[Status(code)] if Status(code).name.lower() == name else None
        except ValueError:  # a code this vrsweep does not know (a file from another version)
            meaning = None
        counts.append({"status": name, "code": code, "points": int(n), "meaning": meaning})
    return counts


def _flag_names(attrs) -> dict:
    """{code: name} of a CF flag variable, from its own flag_values and flag_meanings; {} where they
    are not whole numbers and words (a file another tool wrote: the codes are then 'unknown code
    N', where flag_values of text was a traceback)."""
    try:
        values = [int(value) for value in np.atleast_1d(attrs.get("flag_values", []))]
    except (TypeError, ValueError, OverflowError):
        return {}
    return dict(zip(values, str(_plain(attrs.get("flag_meanings", ""))).split()))


def _motion_counts(ds, owned) -> dict:
    """Points per kind of motion (0.6.0 on) over the computed points this file owns, by the
    file's own flag_meanings; {} for files without ``motion``."""
    if "motion" not in ds or "status" not in ds:
        return {}
    from vrsweep.results import Status

    computed = np.asarray(ds["status"].values)[owned] != Status.NOT_COMPUTED
    motion = np.asarray(ds["motion"].values)[owned][computed]
    names = _flag_names(ds["motion"].attrs)
    return {names.get(int(code), f"unknown code {int(code)}"): int(n)
            for code, n in zip(*np.unique(motion, return_counts=True))}


def _attractors(ds, config) -> list[dict]:
    """The attractor table of a basin sweep (x0 / v0 axes), one entry per slice; [] otherwise.
    ``per``: the period its periods and impact counts are in (a written model's own T, the
    paper's slow period 2 pi/omega; the paper's too where the config cannot be read)."""
    from vrsweep.analysis.attractors import attractor_rows

    per = "period T" if config is not None and config.written else "slow period"
    return [{"slice": where, "per": per,
             "attractors": [{key: _plain(value) for key, value in row.items()} for row in rows]}
            for where, rows in attractor_rows(ds)]


def _describe_groups(path, kind) -> dict | None:
    """A vrsweep file of this format without a sweep grid (a trajectory), from its groups as
    xarray reads them; None whenever the file is not exactly that, so the caller reports the
    reader's error."""
    from vrsweep.store.reading import open_groups
    from vrsweep.store import FORMAT_VERSION
    from vrsweep.store.fileio import open_hdf5
    from vrsweep.store.sealing import check_attributes_of_any_kind

    try:
        # A file described from its groups may be one whose kind was damaged: its checksum says so.
        with open_hdf5(path, "r") as f:
            # A file of another format may seal its attributes otherwise: the reader's error (a
            # newer format: upgrade) comes first, as every other command says it.
            version = f.attrs.get("vrsweep_format_version")
            if isinstance(version, (int, np.integer)) and int(version) == FORMAT_VERSION:
                check_attributes_of_any_kind(f, path)
    except ResultFileError:
        raise
    except Exception:  # noqa: BLE001 - unreadable: the reader's error says why (below, or the caller's)
        return None
    try:
        groups = open_groups(path)
    except ResultFileError:
        return None
    try:
        attrs = {key: _plain(value) for key, value in groups[""].attrs.items()}
        version = attrs.get("vrsweep_format_version")
        # Not a whole number ("one"): not a file of this format, and the reader says what is wrong.
        if type(version) is not int or version != FORMAT_VERSION or "done" in groups[""]:
            return None
        variables, statuses = [], []
        for group, ds in groups.items():
            if group and "status_name" in ds.attrs:
                # A model run of a trajectory: one point, one status.
                statuses.append({
                    "status": str(_plain(ds.attrs["status_name"])), "code": _plain(ds.attrs.get("status")),
                    "points": 1, "meaning": _plain(ds.attrs.get("status_message")), "group": group,
                })
            for name, variable in ds.variables.items():
                # A dimension without a scale has no name in the file: h5netcdf calls it phony_dim_N.
                dims = ["" if str(dim).startswith("phony_dim") else str(dim) for dim in variable.dims]
                variables.append({
                    "name": f"{group}/{name}" if group else str(name),
                    "dims": [] if name in ds.dims else dims,
                    "shape": list(variable.shape), "dtype": str(variable.dtype),
                    "units": _plain(variable.attrs.get("units")),
                    "long_name": _plain(variable.attrs.get("long_name")), "derived": False,
                })
    finally:
        for ds in groups.values():
            ds.close()
    # In the file's name order, group by group (as HDF5 lists them), not in creation order.
    statuses.sort(key=lambda row: row["group"].split("/"))
    variables.sort(key=lambda variable: variable["name"].split("/"))
    config = _stored_config(attrs.get("config"))
    complete = attrs.get("vrsweep_complete")
    return {
        "path": os.fspath(path),
        # Without a kind (the caller's fallback) the file is none that this vrsweep reads, whatever its
        # vrsweep_file says: "unknown", the attribute shown with the others.
        "kind": kind or UNKNOWN_KIND,
        "format_version": int(version),
        "complete": None if complete is None else bool(complete),
        "shard": None,
        "points_done": None,
        "points_total": None,
        "points_unreadable": None,
        "grid_points": None,
        "model": attrs.get("model") or _model(config),
        "axes": [],
        "fixed_parameters": _fixed_parameters(config, []),
        "integration": _integration(config),
        "status_counts": statuses,
        "variables": variables,
        "created": attrs.get("created"),
        "versions": _versions(attrs),
        "attributes": _other_attributes(attrs),
        "config": attrs.get("config"),
    }


def _versions(attrs) -> dict:
    return {name: attrs.get(f"{name}_version") for name in ("vrsweep", "numba", "numpy")
            if attrs.get(f"{name}_version") is not None}


def _other_attributes(attrs) -> dict:
    return {key: _plain(value) for key, value in attrs.items() if key not in _KNOWN_ROOT_ATTRS}


def _stored_config(config_text):
    """The config a file was run from, read by vrsweep.config, or None: info describes the file
    even if its config is one this version cannot read."""
    if not config_text:
        return None
    from vrsweep.config import parse_config
    from vrsweep.errors import ConfigError

    try:
        return parse_config(str(config_text), "<stored config>")
    except ConfigError:
        return None


def _model(config):
    return None if config is None else config.model


def _fixed_parameters(config, axis_names) -> dict:
    if config is None:
        return {}
    return {name: _plain(value) for name, value in config.parameters.items() if name not in axis_names}


def _integration(config) -> dict:
    """The solver settings as stored: ``method`` only when not the default (as the config's YAML)."""
    if config is None:
        return {}
    import dataclasses

    from vrsweep.config import INTEGRATION_DEFAULTS

    settings = dataclasses.asdict(config.integration)
    if settings.get("method") == INTEGRATION_DEFAULTS["method"]:
        del settings["method"]
    if settings.get("device") == INTEGRATION_DEFAULTS["device"]:  # named only when not the CPU
        del settings["device"]
    return {name: _plain(value) for name, value in settings.items()}


def _number(value):
    """A finite float, or None: JSON has no NaN, and an attribute another tool wrote may be no
    number at all (a rtol of '' or [1, 2] was a traceback in info)."""
    try:
        value = float(value)
    except (TypeError, ValueError, OverflowError):
        return None
    return value if math.isfinite(value) else None


def _plain(value):
    """An HDF5 attribute value as something json.dumps takes."""
    if value is None:
        return None
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, str):  # h5py's str of bytes that are not UTF-8 holds surrogates, which print fails on
        return value.encode("utf-8", "surrogateescape").decode("utf-8", "replace")
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (str, int, float, bool)):
        return value
    return str(value)


# --------------------------------------------------------------------------------------------
# The summary as text
# --------------------------------------------------------------------------------------------


def format_summary(summary, show_config=False) -> str:
    lines = []
    kind = summary["kind"]
    if summary["points_total"] is not None:
        progress = f"{summary['points_done']} of {summary['points_total']} points done"
        if kind == "shard":
            progress += f" (shard {summary['shard']} of a {summary['grid_points']}-point grid)"
        if summary.get("points_unreadable"):
            progress += (f"; {summary['points_unreadable']} more unreadable (a kill cut the write of their chunk: "
                         "`vrsweep run CONFIG --resume` computes them again)")
        state = "complete" if summary["complete"] else "NOT complete"
        if not summary["complete"]:
            # A checkpoint: either a run still writing it (read with file locking off) or one
            # that was stopped; only the second needs --resume.
            state += " (still running, or interrupted: `vrsweep run CONFIG --resume` continues it)"
        lines.append(f"{summary['path']}: vrsweep {kind}, format {summary['format_version']}, {state}")
        lines.append(f"points:      {progress}")
    else:
        state = {True: "complete", False: "NOT complete", None: "completeness not recorded"}[summary["complete"]]
        if kind in ("branch", "curves") and summary["complete"] is False:
            state += (f" (stopped by a signal: what it had followed; `vrsweep continue` again follows the whole "
                      f"{'branch' if kind == 'branch' else 'curve'})")
        what = "a vrsweep file of a kind this vrsweep does not know" if kind == UNKNOWN_KIND else f"vrsweep {kind}"
        lines.append(f"{summary['path']}: {what}, format {summary['format_version']}, {state}")
    if summary["model"]:
        # A written model by its name (its definition follows among the attributes): "written"
        # alone named no model.
        name = (summary.get("attributes") or {}).get("model_name") if summary["model"] == "written" else None
        lines.append(f"model:       {name} (written in its config)" if name else f"model:       {summary['model']}")
    if summary["points_total"] is not None:
        if summary["axes"]:
            for index, axis in enumerate(summary["axes"]):
                label = "axes:" if index == 0 else ""
                lines.append(f"{label:<12} {_describe_axis(axis)}")
        else:
            lines.append("axes:        none (a single point)")
    if summary["fixed_parameters"]:
        fixed = " ".join(f"{name}={_short(value)}" for name, value in summary["fixed_parameters"].items())
        lines.append(f"fixed:       {fixed}")
    integration = summary["integration"]
    if integration:
        # method: only if not rk45; device: only if not the CPU
        keys = ("method", "rtol", "atol", "transient_periods", "measure_periods", "device")
        lines.append("integration: " + " ".join(f"{k}={_short(integration[k])}" for k in keys if k in integration))
    if summary["status_counts"]:
        for index, row in enumerate(summary["status_counts"]):
            label = "status:" if index == 0 else ""
            meaning = f"  ({row['meaning']})" if row["meaning"] else ""
            if "group" in row:  # a trajectory: one status per model run
                lines.append(f"{label:<12} {row['group']}: {row['status']}{meaning}")
            else:
                lines.append(f"{label:<12} {row['points']:>{_count_width(summary)}} {row['status']}{meaning}")
    motions = summary.get("motion_counts")
    if motions:
        lines.append("motion:      " + ", ".join(f"{n} {name.replace('_', '-')}" for name, n in motions.items())
                     + " (docs/trust.md)")
    solver = summary.get("solver_error")
    if solver:
        if solver["relative"] is None:
            # The rerun takes the first points of the grid's shuffled order only (solver_error.py):
            # the file may well hold periodic points the sample did not.
            lines.append("solver:      R's solver error not estimated (the sample of points rerun at a tighter "
                         "tolerance held no periodic or quasi-periodic point; R_err says how far R is from "
                         "converged)")
        else:
            lines.append(f"solver:      R's error from the integration about {solver['relative']:.1e} relative "
                         f"({solver['points']} converged points rerun at rtol "
                         f"{'?' if solver['rtol'] is None else format(solver['rtol'], '.0e')}); "
                         "add it to R_err for R's error bar")
    lines += _format_attractors(summary.get("attractors") or [])
    lines += _format_branches(summary.get("branches"))
    lines += _format_curves(summary.get("curves"))
    created = summary["created"] or "unknown time"
    versions = summary["versions"]
    written = f"{created}"
    if "vrsweep" in versions:
        written += f" by vrsweep {versions['vrsweep']}"
    others = [f"{name} {versions[name]}" for name in ("numba", "numpy") if name in versions]
    if others:
        written += f" ({', '.join(others)})"
    lines.append(f"written:     {written}")
    for key, value in summary["attributes"].items():
        # a value of several lines (a merged file's history) is continued under its first
        for index, piece in enumerate(str(value).split("\n")):
            lines.append(f"{key + ':' if index == 0 else '':<12} {piece}")
    lines.append("variables:")
    name_width = max((len(v["name"]) for v in summary["variables"]), default=0)
    dims_width = max((len(_dims(v)) for v in summary["variables"]), default=0)
    for variable in summary["variables"]:
        units = variable["units"] if variable["units"] is not None else "-"
        text = f"  {variable['name']:<{name_width}}  {_dims(variable):<{dims_width}}  [{units}]"
        if variable["long_name"]:
            text += f"  {variable['long_name']}"
        if variable["derived"]:
            text += "  (derived)"
        lines.append(text)
    # A file's name, its attributes and its variables' names are anyone's text: one line each,
    # whatever they hold ("a<newline>b.h5" printed as two lines, the second passing for a field).
    lines = [one_line(line) for line in lines]
    if show_config and summary["config"]:
        lines.append("config:")
        lines += [f"  {line}" for line in summary["config"].splitlines()]
    return "\n".join(lines)


def _format_attractors(slices) -> list[str]:
    """One line per attractor of each slice: label, period, R, impacts, basin fraction, a start."""
    lines = []
    for entry in slices:
        where = f" at {entry['slice']}" if entry["slice"] else ""
        found = len(entry["attractors"])
        lines.append(f"attractors:  {found} found{where}")
        for row in entry["attractors"]:
            per = entry.get("per", "slow period")
            period = f"period {row['period']}" if row["period"] > 0 else "no period"
            if row["impacts_per_cycle"] >= 0:
                impacts = f"{row['impacts_per_cycle']} impact{'' if row['impacts_per_cycle'] == 1 else 's'} per cycle"
            else:
                impacts = f"{_short(row['impacts_per_period'])} impacts per {per}"
            R = "R = nan" if row["R"] is None else f"R = {row['R']:.6g} +- {row['R_err']:.2g}"
            start = ""
            if row.get("x0") is not None or row.get("v0") is not None:
                start = "  e.g. from " + ", ".join(
                    f"{name}={_short(row[name])}" for name in ("x0", "v0") if row.get(name) is not None)
            lines.append(f"  {row['label']:>3}: {period}, {R}, {impacts}, basin {100 * row['fraction']:.1f}% "
                         f"({row['points']} points){start}")
    return lines


def _describe_axis(axis) -> str:
    n = axis["size"]
    if n == 1:
        values = f"1 value, {_short(axis['first'])}"
    else:
        values = f"{n} values from {_short(axis['first'])} to {_short(axis['last'])}"
    units = f" [{axis['units']}]" if axis["units"] is not None else ""
    long_name = f"  {axis['long_name']}" if axis["long_name"] else ""
    return f"{axis['name']}: {values}{units}{long_name}"


def _dims(variable) -> str:
    if any(variable["dims"]) and len(variable["dims"]) == len(variable["shape"]):
        return "(" + ", ".join(f"{dim}: {n}" for dim, n in zip(variable["dims"], variable["shape"])) + ")"
    return "x".join(str(n) for n in variable["shape"]) or "scalar"


def _count_width(summary) -> int:
    return max(len(str(row["points"])) for row in summary["status_counts"])


def _short(value) -> str:
    return format(value, "g") if isinstance(value, float) else str(value)


def _precise(value) -> str:
    """A located parameter to 8 digits; a missing one (NaN in the file, None here) as "nan"."""
    return "nan" if value is None else format(value, ".8g")
