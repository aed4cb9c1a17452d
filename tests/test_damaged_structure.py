"""Issue 24, class 4: a damaged result file is refused where it is opened, by every command.

One reader (vrsweep/store/reader.py: open_checked -> check_structure) checks the root attributes'
types, the shapes and types of done, the axes and the variables, and reads every byte through its
checksum (axes included in files of this version). So info, plot, run --resume and merge all give
one line and exit 2 for the same damage, never a traceback, never numbers from a damaged file.
"""

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vrsweep.errors import ResultFileError
from vrsweep.store.reader import open_checked

from damaged import damaged_copy, flip_bit

CONFIG = """\
model: effective
sweep:
  g: {start: 0, stop: 40, num: 5}
  Omega: [3, 4]
integration: {transient_periods: 2, measure_periods: 16}
"""
AXES = ("g", "Omega")
VARIABLES = ("R", "status", "period", "strobe_x", "n_steps", "done")
HYPOTHESIS = settings(max_examples=6, deadline=None,
                      suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@pytest.fixture(scope="module")
def good(tmp_path_factory, sweep_file):
    return sweep_file(tmp_path_factory.mktemp("damaged"), CONFIG, "good")


def _commands(config, path, out):
    return [("info", path), ("plot", path, "-o", out / "figure.png", "--at", "Omega=4"),
            ("run", config, "-o", path, "--resume", "-q"), ("merge", path, "-o", out / "merged.h5")]


def _refused_everywhere(invoke, config, path, out, words="corrupt", which=None):
    """Every command (or only command ``which``, an index into _commands): exit 2, one line naming
    the file and ``words``, and no output written."""
    commands = _commands(config, path, out)
    for command in commands if which is None else [commands[which]]:
        result = invoke(*command)
        lines = result.output.strip().splitlines()
        assert result.exit_code == 2, (command, result.output)
        assert len(lines) == 1 and str(path) in lines[0] and words in lines[0], (command, result.output)
    assert not (out / "figure.png").exists() and not (out / "merged.h5").exists()


def _damaged(good, tmp_path, change):
    config, path = good
    return config, damaged_copy(path, tmp_path, change)


def test_the_good_file_passes_every_command(good, tmp_path, invoke):
    config, path = good
    copy = damaged_copy(path, tmp_path, None, "copy.h5")  # undamaged: a plain copy
    for command in _commands(config, copy, tmp_path):
        assert invoke(*command).exit_code == 0, command
    with h5py.File(copy) as f:  # new files carry a checksum on every axis
        assert all(f[name].fletcher32 for name in AXES)


WRONG_VALUES = st.one_of(
    st.integers(-2 ** 31, 2 ** 31 - 1), st.floats(allow_nan=True), st.booleans(),
    st.text(st.characters(blacklist_characters='\x00', blacklist_categories=('Cs',)), max_size=8), st.lists(st.integers(0, 9), min_size=2, max_size=4))
TYPED_ATTRS = {  # attribute: is this value of the right kind?
    "config": lambda value: isinstance(value, str),
    "vrsweep_complete": lambda value: type(value) is int and value in (0, 1),
    "vrsweep_format_version": lambda value: type(value) is int and value == 1,
    "model": lambda value: isinstance(value, str),
    "history": lambda value: isinstance(value, str),
}


@HYPOTHESIS
@given(name=st.sampled_from(sorted(TYPED_ATTRS)), value=WRONG_VALUES, which=st.integers(0, 3))
def test_root_attributes_of_the_wrong_type(good, tmp_path, invoke, name, value, which):
    if TYPED_ATTRS[name](value):
        return  # a value of the right kind is another test's business (a different config, ...)
    stored = np.array(value) if isinstance(value, list) else value
    config, path = _damaged(good, tmp_path, lambda f: f.attrs.__setitem__(name, stored))
    words = "newer vrsweep" if name == "vrsweep_format_version" and type(value) is int and value > 1 else (
        "older vrsweep" if name == "vrsweep_format_version" and type(value) is int else
        "corrupt" if name != "vrsweep_format_version" or not isinstance(value, int) or isinstance(value, bool)
        else "")
    _refused_everywhere(invoke, config, path, tmp_path, words, which)


@pytest.mark.parametrize("name,value", [("config", 5), ("vrsweep_complete", "yes"),
                                        ("vrsweep_format_version", "one"), ("vrsweep_complete", 7)])
def test_the_issues_attributes(good, tmp_path, invoke, name, value):
    config, path = _damaged(good, tmp_path, lambda f: f.attrs.__setitem__(name, value))
    _refused_everywhere(invoke, config, path, tmp_path)


def _replace(f, name, shape, dtype):
    """Replace dataset ``name`` with one of ``shape`` and ``dtype``, with the scales of the
    original attached to as many leading dimensions as both have."""
    old = f[name]
    scales = [old.dims[i][0] for i in range(old.ndim)] if not old.is_scale else []
    attrs = dict(old.attrs)
    if old.is_scale:  # an axis: the variables refer to it; write over it in place instead
        return False
    del f[name]
    data = np.zeros(shape, dtype=dtype) if dtype != "S4" else np.full(shape, b"abcd")
    new = f.create_dataset(name, data=data)
    for key, value in attrs.items():
        if key not in ("DIMENSION_LIST", "REFERENCE_LIST"):
            new.attrs[key] = value
    for i in range(min(len(scales), new.ndim)):
        new.dims[i].attach_scale(scales[i])
    return True


@HYPOTHESIS
@given(name=st.sampled_from(VARIABLES), shape=st.lists(st.integers(1, 6), min_size=0, max_size=3),
       dtype=st.sampled_from(["f8", "f4", "i8", "i1", "u2", "S4"]), which=st.integers(0, 3))
def test_variables_of_the_wrong_shape_or_type(good, tmp_path, invoke, name, shape, dtype, which):
    expected = {"R": ((5, 2), "f8"), "status": ((5, 2), "i1"), "period": ((5, 2), "i8"),
                "strobe_x": ((5, 2, 16), "f8"), "n_steps": ((5, 2), "i8"), "done": ((5, 2), "i1")}[name]
    if (tuple(shape), dtype) == expected:
        return
    config, path = _damaged(good, tmp_path, lambda f: _replace(f, name, tuple(shape), dtype))
    _refused_everywhere(invoke, config, path, tmp_path, which=which)


def _set_mask(name, values, dtype=np.int8):
    def change(f):
        _replace(f, name, (5, 2), dtype)
        f[name][()] = values
    return change


@pytest.mark.parametrize("change, words", [
    (_set_mask("done", 0, np.int64), "done must be int8 flags over the grid (5, 2), got (5, 2) of int64"),
    (_set_mask("done", 1, np.uint8), "done must be int8 flags"),
    (_set_mask("done", 2), "done must hold only 0 and 1"),
    (_set_mask("done", 0), "marked finished (vrsweep_complete = 1), but 10 of its 10 points are not done"),
    (_set_mask("done", [[1, 1]] * 4 + [[1, 0]]), "but 1 of its 10 points are not done"),
], ids=["int64 zeros", "uint8 ones", "a 2", "a finished file none done", "a finished file one not done"])
def test_a_done_mask_of_another_type_or_with_points_missing_from_a_finished_file(good, tmp_path, invoke, change,
                                                                                  words):
    """Hypothesis found it (with fresh draws): a done mask replaced by int64 zeros of the grid's
    shape was read as flags, so `info` described the file, `plot` drew an empty figure and `merge`
    said every point was missing, none naming the damage. Every vrsweep wrote done as int8 0/1,
    and a finished file has every point done."""
    config, path = _damaged(good, tmp_path, change)
    _refused_everywhere(invoke, config, path, tmp_path, words)


@HYPOTHESIS
@given(axis=st.sampled_from(AXES), index=st.integers(0, 1),
       value=st.sampled_from([np.nan, np.inf, -np.inf]), which=st.integers(0, 3))
def test_a_non_finite_axis_value(good, tmp_path, invoke, axis, index, value, which):
    def change(f):
        f[axis][index] = value  # rewrites the chunk and its checksum: only the value is wrong

    config, path = _damaged(good, tmp_path, change)
    _refused_everywhere(invoke, config, path, tmp_path, "not a finite number", which)


@HYPOTHESIS
@given(name=st.sampled_from(AXES + ("R", "done", "strobe_x")), bit=st.integers(0, 10 ** 6), which=st.integers(0, 3))
def test_a_flipped_bit_in_an_axis_or_a_variable(good, tmp_path, invoke, name, bit, which):
    config, path = _damaged(good, tmp_path, lambda f: None)
    flip_bit(path, name, bit)
    _refused_everywhere(invoke, config, path, tmp_path, which=which)


def test_resume_on_a_finished_file_whose_R_fails_its_checksum(good, tmp_path, invoke):
    """Not "nothing left to compute": the damage is found where the file is opened."""
    config, path = _damaged(good, tmp_path, lambda f: None)
    flip_bit(path, "R", 77)
    result = invoke("run", config, "-o", path, "--resume")
    assert result.exit_code == 2 and "corrupt" in result.output, result.output
    assert "nothing left" not in result.output


def test_an_old_file_without_axis_checksums_still_opens(good, tmp_path):
    """Files written before axes had checksums: their axes are contiguous, read plain."""
    def unchecked_axes(f):
        for name in AXES:
            values, attrs = f[name][()], dict(f[name].attrs)
            users = [(ds, i) for ds in f.values() if isinstance(ds, h5py.Dataset) and not ds.is_scale
                     for i in range(ds.ndim) if ds.dims[i] and ds.dims[i][0].name == f"/{name}"]
            for ds, i in users:
                ds.dims[i].detach_scale(f[name])
            del f[name]
            new = f.create_dataset(name, data=values)
            new.make_scale(name)
            for key, value in attrs.items():
                if key not in ("CLASS", "NAME", "REFERENCE_LIST", "DIMENSION_LIST"):
                    new.attrs[key] = value
            for ds, i in users:
                ds.dims[i].attach_scale(new)

    config, path = _damaged(good, tmp_path, unchecked_axes)
    with h5py.File(path) as f:
        assert not f["g"].fletcher32
    with open_checked(path) as f:
        np.testing.assert_array_equal(f["g"][()], np.linspace(0, 40, 5))
    with pytest.raises(ResultFileError, match="not a finite number"):
        with h5py.File(path, "r+") as f:
            f["Omega"][0] = np.nan
        open_checked(path)
