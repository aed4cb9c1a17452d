"""Issue 35, class 1: branch and curves files held to the sweep file's standard. Every attribute
and every dataset of each is damaged in the ways tests/test_damaged_structure.py damages a sweep
file (a value of the wrong type, text that is not text, a dataset of the wrong shape or type, a
flipped bit, overwritten metadata) and in the values a command acts on (branch_periods 0, -1,
10**9; a config without a continuation). info, plot and continue each refuse it in one line with
exit 2, before anything is computed: continue never reaches the numerics with a damaged file. Any
change of an attribute (the stored config's gamma 0.05 -> 0.07) fails the attributes' checksum.

The files are made from hand-built orbits and curve points (tests/handmade.py: no kernel is
compiled), and the numerics of continue are replaced by a stub that records that they were reached."""

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import vrsweep
from vrsweep.errors import ResultFileError
from vrsweep.store import branch_file

from damaged import damaged_copy, flip_bit, one_line_error
from handmade import write_branch_file, write_curves_file

HYPOTHESIS = settings(max_examples=25, deadline=None,
                      suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """{"branch": path, "curves": path}: one good file of each kind."""
    folder = tmp_path_factory.mktemp("continuation_files")
    return {"branch": write_branch_file(folder / "branch.h5"), "curves": write_curves_file(folder / "curves.h5")}


class Reached(Exception):
    """continue got as far as the numerics."""


@pytest.fixture
def no_numerics(monkeypatch):
    def run_curve(request, progress=None):
        raise Reached(request.periods)

    monkeypatch.setattr("vrsweep.execution.curves.run_curve", run_curve)


def _commands(kind, path, folder):
    commands = [("info", path), ("plot", path, "-o", folder / "figure.png")]
    if kind == "branch":
        commands.append(("continue", path, "--point", "0", "--along", "Omega", "--to", "3", "5",
                         "-o", folder / "curves_out.h5", "-q"))
    return commands


def _refused_everywhere(invoke, kind, path, folder, words=""):
    """info, plot and (for a branch file) continue: one line naming the file (and ``words``),
    exit 2, no figure, and continue stops before the numerics; open_results raises
    ResultFileError."""
    for command in _commands(kind, path, folder):
        try:
            line = one_line_error(invoke(*command))
        except Reached:
            pytest.fail(f"{command[0]} computed from a damaged file")
        assert str(path) in line and words in line, (command, line)
    assert not (folder / "figure.png").exists() and not (folder / "curves_out.h5").exists()
    with pytest.raises(ResultFileError):
        vrsweep.open_results(path).close()


def _of_unknown_kind(invoke, kind, path, folder):
    """A file whose vrsweep_file is gone or changed is no longer one that vrsweep knows: info
    describes it as such (not as a trajectory, nor as a "vrsweep 7"); plot and continue refuse it
    in one line."""
    for command in _commands(kind, path, folder):
        result = invoke(*command)
        if command[0] == "info" and result.exit_code == 0:
            first = result.output.splitlines()[0]
            assert first.startswith(f"{path}: a vrsweep file of a kind this vrsweep does not know"), first
        else:
            assert str(path) in one_line_error(result), command


_GOOD_INFO = {}


def _good_info(invoke, good):
    """info's output for a good file, its path taken out: read once per file (the good files are
    the module's, never changed), not once per damaged copy of test_one_flipped_bit_anywhere."""
    if good not in _GOOD_INFO:
        result = invoke("info", good)
        assert result.exit_code == 0, result.output
        _GOOD_INFO[good] = result.output.replace(str(good), "")
    return _GOOD_INFO[good]


def _harmless_or_refused(invoke, kind, good, path, folder):
    """A damage that may land where nothing is read (unused bytes): each command either refuses
    the file in one line, or reads it as the good file (continue: reaches the numerics). Every
    array and, from issue 35 on, every attribute carries a checksum: nothing else can change."""
    for command in _commands(kind, path, folder):
        try:
            result = invoke(*command)
        except Reached:
            continue
        if result.exit_code == 0 and command[0] == "info":
            assert result.output.replace(str(path), "") == _good_info(invoke, good)
        elif result.exit_code != 0:
            one_line_error(result)
        (folder / "figure.png").unlink(missing_ok=True)


def test_the_good_files_pass(files, tmp_path, invoke, no_numerics):
    for kind, good in files.items():
        path = damaged_copy(good, tmp_path, None, f"{kind}.h5")
        for command in _commands(kind, path, tmp_path):
            if command[0] == "continue":
                with pytest.raises(Reached):
                    invoke(*command)
            elif command[0] == "plot" and kind == "curves":  # a curves file is drawn over a map
                assert "curves files go after the map" in one_line_error(invoke(*command))
            else:
                assert invoke(*command).exit_code == 0, command


# -- attributes ------------------------------------------------------------------------------
# Files of this version carry a checksum of every attribute (branch_file.ATTRIBUTES_CHECKSUM): any
# change is refused as such. Files written before it are read as they are, with a note; their
# attributes are still checked for what a reader needs of them, which the tests "unprotected" see.

WRONG_VALUES = st.one_of(
    st.integers(-2 ** 31, 2 ** 31 - 1), st.floats(allow_nan=True), st.booleans(),
    st.text(st.characters(blacklist_characters="\x00", blacklist_categories=("Cs",)), max_size=8),
    st.lists(st.integers(0, 9), min_size=2, max_size=4), st.binary(min_size=1, max_size=6))
UNPROTECTED_NOTE = "was written before attributes had checksums"


def _unprotected(change=None):
    """``change``, in a file as vrsweep wrote it before attributes had a checksum."""
    def damage(f):
        del f.attrs[branch_file.ATTRIBUTES_CHECKSUM]
        if change is not None:
            change(f)
    return damage


def _root_attributes(path):
    with h5py.File(path, "r") as f:
        return sorted(f.attrs)


def _is_right(kind, name, value):
    """Whether ``value`` is one the attribute ``name`` may hold in an unprotected file (then it is
    not a damage a reader can see)."""
    if name == "vrsweep_format_version":
        return type(value) is int and value == 1
    if name == "vrsweep_complete":
        return type(value) is int and value == 1
    if name == "vrsweep_file":
        return value == kind
    if name in ("config", "parameter", "parameter_names", "model"):
        return False  # any other value names another config, parameter or model than the file's
    return isinstance(value, str)  # every other attribute vrsweep writes is text


@HYPOTHESIS
@given(kind=st.sampled_from(["branch", "curves"]), index=st.integers(0, 100), value=WRONG_VALUES,
       protected=st.booleans())
def test_every_root_attribute_changed(files, tmp_path, invoke, no_numerics, kind, index, value, protected):
    names = [name for name in _root_attributes(files[kind]) if protected or name != branch_file.ATTRIBUTES_CHECKSUM]
    name = names[index % len(names)]
    with h5py.File(files[kind], "r") as f:
        if isinstance(value, type(f.attrs[name])) and value == f.attrs[name]:
            return  # unchanged
    if not protected and _is_right(kind, name, value):
        return
    if isinstance(value, bytes):
        value = np.bytes_(b"\xff" + value)  # never UTF-8
    stored = np.array(value) if isinstance(value, list) else value
    change = (lambda f: f.attrs.__setitem__(name, stored))
    path = damaged_copy(files[kind], tmp_path, change if protected else _unprotected(change))
    (_of_unknown_kind if name == "vrsweep_file" else _refused_everywhere)(invoke, kind, path, tmp_path)


REQUIRED = ("vrsweep_file", "vrsweep_format_version", "vrsweep_complete", "config")


@pytest.mark.parametrize("protected", [True, False])
@pytest.mark.parametrize("kind,name", [("branch", name) for name in (*REQUIRED, "parameter")]
                         + [("curves", name) for name in (*REQUIRED, "parameter_names")])
def test_a_missing_attribute(files, tmp_path, invoke, no_numerics, kind, name, protected):
    change = lambda f: f.attrs.__delitem__(name)  # noqa: E731
    path = damaged_copy(files[kind], tmp_path, change if protected else _unprotected(change))
    (_of_unknown_kind if name == "vrsweep_file" else _refused_everywhere)(invoke, kind, path, tmp_path)


@pytest.mark.parametrize("kind", ["branch", "curves"])
def test_a_dataset_attribute_changed(files, tmp_path, invoke, no_numerics, kind):
    path = damaged_copy(files[kind], tmp_path, lambda f: f["x"].attrs.__setitem__("units", "m"))
    _refused_everywhere(invoke, kind, path, tmp_path, "do not match their checksum")
    not_text = _unprotected(lambda f: f["x"].attrs.__setitem__("long_name", np.bytes_(b"position \xe1")))
    path = damaged_copy(files[kind], tmp_path, not_text, "unprotected.h5")
    _refused_everywhere(invoke, kind, path, tmp_path, "attribute x.long_name must be text")


def _config_flipped(f):
    """One bit of the stored config, gamma: 0.05 -> 0.07 (the issue's example)."""
    f.attrs["config"] = f.attrs["config"].replace("gamma: 0.05", "gamma: 0.07")


@pytest.mark.parametrize("kind", ["branch", "curves"])
def test_a_changed_config_is_refused(files, tmp_path, invoke, no_numerics, kind):
    """Issue 35: one bit flipped in the stored config went unnoticed: info and the figure stated,
    and continue --point computed at, parameters the numbers were not computed at."""
    path = damaged_copy(files[kind], tmp_path, _config_flipped)
    _refused_everywhere(invoke, kind, path, tmp_path, "do not match their checksum")


@pytest.mark.parametrize("kind", ["branch", "curves"])
def test_a_bit_flipped_in_the_stored_config_on_disk(files, tmp_path, invoke, no_numerics, kind):
    path = damaged_copy(files[kind], tmp_path, None)
    data = bytearray(path.read_bytes())
    offset = data.index(b"gamma: 0.05") + len("gamma: 0.0")
    data[offset] ^= 0b10  # '5' -> '7', behind HDF5's back
    path.write_bytes(bytes(data))
    _refused_everywhere(invoke, kind, path, tmp_path, "do not match their checksum")


@pytest.mark.parametrize("kind", ["branch", "curves"])
def test_a_file_without_the_checksum_opens_with_a_note(files, tmp_path, invoke, no_numerics, kind):
    path = damaged_copy(files[kind], tmp_path, _unprotected())
    result = invoke("info", path)
    assert result.exit_code == 0, result.output
    assert result.stderr.splitlines() == [f"Note: {path} {UNPROTECTED_NOTE}: its config and parameters are read "
                                          "as they are, unprotected against damage"]
    with vrsweep.open_results(path) as ds:
        assert ds.attrs["vrsweep_file"] == kind


def _set_config(text):
    return lambda f: f.attrs.__setitem__("config", text)


CONFIG_DAMAGES = {
    "no continuation": ("model: effective\n", "its config has no continuation section"),
    "not a config": ("model: [\n", "its config is not valid"),
    "another parameter": (None, "attribute parameter is Omega, its config continues g"),
}


@pytest.mark.parametrize("damage", sorted(CONFIG_DAMAGES))
def test_a_branch_file_whose_config_cannot_drive_continue(files, tmp_path, invoke, no_numerics, damage):
    text, words = CONFIG_DAMAGES[damage]
    change = _set_config(text) if text else (lambda f: f.attrs.__setitem__("parameter", "Omega"))
    path = damaged_copy(files["branch"], tmp_path, _unprotected(change))
    _refused_everywhere(invoke, "branch", path, tmp_path, words)


def test_a_branch_files_model_must_be_its_configs(files, tmp_path, invoke, no_numerics):
    path = damaged_copy(files["branch"], tmp_path, _unprotected(lambda f: f.attrs.__setitem__("model", "original")))
    _refused_everywhere(invoke, "branch", path, tmp_path, "attribute model is 'original'")


@pytest.mark.parametrize("wrong", ["original", ""])
def test_a_curves_files_model_must_be_its_configs(files, tmp_path, invoke, no_numerics, wrong):
    """As a branch file's (found by test_every_root_attribute_changed: an empty model was read)."""
    path = damaged_copy(files["curves"], tmp_path, _unprotected(lambda f: f.attrs.__setitem__("model", wrong)))
    _refused_everywhere(invoke, "curves", path, tmp_path, f"attribute model is {wrong!r}")


# -- values a command acts on ----------------------------------------------------------------


def _rewrite(name, change):
    """Change dataset ``name``'s values in place (its checksum rewritten with them)."""
    def damage(f):
        values = f[name][()]
        change(values)
        f[name][...] = values
    return damage


def _set(index, value):
    def change(values):
        values[index] = value
    return change


@pytest.mark.parametrize("periods", [0, -1, 10 ** 9, 17])
def test_branch_periods_out_of_range(files, tmp_path, invoke, no_numerics, periods):
    """continuation.max_period (16 by default) bounds every orbit continue computes: 0 crashed natively,
    -1 gave a traceback, 10**9 tried to allocate 74.5 GiB."""
    path = damaged_copy(files["branch"], tmp_path, _rewrite("branch_periods", _set(0, periods)))
    _refused_everywhere(invoke, "branch", path, tmp_path,
                        f"branch_periods must be 1 to continuation.max_period = 16, found {periods}")


VALUE_DAMAGES = {
    "branch": {
        "periods off its branch's": ("periods", _set(3, 2), "periods differs from its branch's"),
        "stable 2": ("stable", _set(0, 2), "stable must be 0 or 1"),
        "a point that does not count": ("point", _set(2, 7), "point must count 0, 1, ..."),
        "branch_id that does not count": ("branch_id", _set(0, 3), "branch_id must count"),
        **{f"{name} not finite": (name, _set(0, value), f"{name} holds a value that is not a finite number")
           for name, value in (("parameter", np.nan), ("x", np.inf), ("v", -np.inf))},
    },
    "curves": {
        "curve_periods 0": ("curve_periods", _set(0, 0), "curve_periods must be 1 to continuation.max_period"),
        "curve_periods 10**9": ("curve_periods", _set(0, 10 ** 9), "found 1000000000"),
        "periods off its curve's": ("periods", _set(1, 3), "periods differs from its curve's"),
        "special not finite": ("special_Omega", _set(0, np.nan), "special_Omega holds a value that is not a finite"),
        "a parameter not finite": ("g", _set(4, np.inf), "g holds a value that is not a finite number"),
        "curve_id that does not count": ("curve_id", _set(0, 1), "curve_id must count"),
    },
}


@pytest.mark.parametrize("kind,damage", [(kind, damage) for kind in VALUE_DAMAGES for damage in VALUE_DAMAGES[kind]])
def test_values_a_reader_relies_on(files, tmp_path, invoke, no_numerics, kind, damage):
    name, change, words = VALUE_DAMAGES[kind][damage]
    path = damaged_copy(files[kind], tmp_path, _rewrite(name, change))
    _refused_everywhere(invoke, kind, path, tmp_path, words)


def test_continue_refuses_a_bifurcation_without_its_numbers(files, tmp_path, invoke, no_numerics):
    """info prints a NaN in the bifurcation table (tests/test_cli_continue.py); continue cannot start
    a curve there."""
    for name in ("bifurcation_parameter", "bifurcation_x", "bifurcation_v"):
        path = damaged_copy(files["branch"], tmp_path, _rewrite(name, _set(0, np.nan)), f"{name}.h5")
        assert invoke("info", path).exit_code == 0
        line = one_line_error(invoke(*_commands("branch", path, tmp_path)[2]))
        assert "--point = 0 has no finite g, x and v" in line, line


# -- datasets --------------------------------------------------------------------------------


def _datasets(path):
    with h5py.File(path, "r") as f:
        return sorted(name for name in f if isinstance(f[name], h5py.Dataset))


def _replace(f, name, shape, dtype):
    """Dataset ``name`` replaced by one of ``shape`` and ``dtype``, of zeros (text: 'abcd')."""
    old = f[name]
    attrs = {key: value for key, value in old.attrs.items() if key not in ("DIMENSION_LIST", "REFERENCE_LIST",
                                                                           "CLASS", "NAME")}
    if old.is_scale:
        for other in f.values():  # detach it everywhere first: HDF5 keeps back references
            for axis in range(other.ndim if isinstance(other, h5py.Dataset) and not other.is_scale else 0):
                if any(scale.name == old.name for scale in other.dims[axis].values()):
                    other.dims[axis].detach_scale(old)
    del f[name]
    data = np.zeros(shape, dtype=dtype) if dtype != "S4" else np.full(shape, b"abcd")
    new = f.create_dataset(name, data=data)
    new.attrs.update(attrs)


def _expected(kind, path, name):
    """(shape, kind of number) of dataset ``name`` in the good file."""
    with h5py.File(path, "r") as f:
        return f[name].shape, "s" if f[name].dtype.kind in "OSU" else f[name].dtype.kind


@HYPOTHESIS
@given(kind=st.sampled_from(["branch", "curves"]), index=st.integers(0, 100),
       shape=st.lists(st.integers(0, 12), min_size=0, max_size=3),
       dtype=st.sampled_from(["f8", "f4", "i8", "i1", "u2", "S4"]))
def test_every_dataset_of_the_wrong_shape_or_type(files, tmp_path, invoke, no_numerics, kind, index, shape, dtype):
    names = _datasets(files[kind])
    name = names[index % len(names)]
    shape_wanted, number = _expected(kind, files[kind], name)
    if tuple(shape) == shape_wanted and (number == "s") == (dtype == "S4") and (number == "f") == (dtype[0] == "f"):
        return  # the same shape and kind of value: a change of values, the other tests' business
    path = damaged_copy(files[kind], tmp_path, lambda f: _replace(f, name, tuple(shape), dtype))
    _refused_everywhere(invoke, kind, path, tmp_path)


@pytest.mark.parametrize("kind", ["branch", "curves"])
def test_every_dataset_missing(files, tmp_path, invoke, no_numerics, kind):
    for name in _datasets(files[kind]):
        folder = tmp_path / name
        folder.mkdir()
        path = damaged_copy(files[kind], folder, lambda f: _replace(f, name, (), "f8") or f.__delitem__(name))
        _refused_everywhere(invoke, kind, path, folder, f"{name} is missing")


@pytest.mark.parametrize("kind", ["branch", "curves"])
def test_a_flipped_bit_in_every_checksummed_dataset(files, tmp_path, invoke, no_numerics, kind):
    checked = 0
    for name in _datasets(files[kind]):
        folder = tmp_path / name
        folder.mkdir()
        path = damaged_copy(files[kind], folder, None)
        if flip_bit(path, name):
            _refused_everywhere(invoke, kind, path, folder, "is truncated or corrupt")
            checked += 1
    assert checked >= 20  # every numeric array carries a checksum


@pytest.mark.parametrize("kind", ["branch", "curves"])
def test_overwritten_metadata_of_every_dataset(files, tmp_path, invoke, no_numerics, kind):
    """Bytes inside a dataset's object header: HDF5 raises KeyError, RuntimeError or OSError
    depending on what it was reading; each is the same one line."""
    for name in _datasets(files[kind]):
        folder = tmp_path / name
        folder.mkdir()
        with h5py.File(files[kind], "r") as f:
            header = h5py.h5o.get_info(f[name].id).addr
        path = damaged_copy(files[kind], folder, None)
        with open(path, "r+b") as handle:
            handle.seek(header + 16)
            handle.write(b"\xff" * 32)
        _refused_everywhere(invoke, kind, path, folder, "corrupt")


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(kind=st.sampled_from(["branch", "curves"]), where=st.floats(0.0, 1.0, exclude_max=True),
       bit=st.integers(0, 7))
def test_one_flipped_bit_anywhere(files, tmp_path, invoke, no_numerics, kind, where, bit):
    """Anywhere in the file: refused in one line, or (unused bytes) read as the good file; never a
    traceback, never a native crash, never other numbers or parameters."""
    path = damaged_copy(files[kind], tmp_path, None)
    size = path.stat().st_size
    offset = int(where * size)
    with open(path, "r+b") as handle:
        handle.seek(offset)
        original = handle.read(1)[0]
        handle.seek(offset)
        handle.write(bytes([original ^ (1 << bit)]))
    _harmless_or_refused(invoke, kind, files[kind], path, tmp_path)


@pytest.mark.parametrize("kind", ["branch", "curves"])
@pytest.mark.parametrize("text", ["", "   \n", "0", "[1, 2]", "just words"])
def test_a_stored_config_that_is_no_config_at_all(files, tmp_path, invoke, no_numerics, kind, text):
    """In a file without the attributes' checksum (written before it): an empty config read as one
    of defaults, and '0' (no mapping, so no later version's config either) was drawn without one."""
    change = lambda f: f.attrs.__setitem__("config", text)  # noqa: E731
    path = damaged_copy(files[kind], tmp_path, _unprotected(change))
    _refused_everywhere(invoke, kind, path, tmp_path, "config")
