"""Round 4 of the hostile inputs, beyond numbers (test_hostile_numbers): YAML tags on a mapping
or a list, and the reason a damaged file gives."""

import pytest

from vrsweep.config import parse_config
from vrsweep.errors import ConfigError


@pytest.mark.parametrize("text, field", [
    ("parameters: !custom {g: 5}\n", "parameters"),
    ("sweep:\n  g: !foo [1, 2]\n", "sweep.g"),
    ("!doc\nparameters: {g: 5}\n", "the config"),
    ("integration: !x {rtol: 1e-8}\n", "integration"),
])
def test_a_tagged_mapping_or_list_is_refused_as_a_tagged_scalar_is(text, field):
    """`parameters: !custom {g: 5}` ran with g = 5, its tag dropped, where `g: !custom 5` is refused."""
    with pytest.raises(ConfigError) as caught:
        parse_config(text, "c.yaml")
    problem = caught.value.problems[0]
    tag = text.split("!")[1].split()[0]
    assert field in problem and f"got !{tag} " in problem, problem


def test_the_standard_tags_are_read():
    config = parse_config("parameters: !!map {g: !!float 5}\nsweep:\n  Omega: !!seq [3, 4]\n")
    assert config.parameters["g"] == 5.0 and list(config.axes[0].values) == [3.0, 4.0]


def test_a_dangling_link_in_a_results_file_is_worded_without_stray_quotes(tmp_path):
    """The reason of a KeyError from h5py was taken from its repr: '... (component not found)')'."""
    import h5py

    from vrsweep.store.reader import corrupt_error

    path = tmp_path / "d.h5"
    with h5py.File(path, "w") as f:
        f["R"] = h5py.SoftLink("/nowhere")
    with h5py.File(path, "r") as f:
        with pytest.raises(KeyError) as caught:
            f["R"]
    message = str(corrupt_error(str(path), caught.value))
    assert message.endswith("(HDF5: component not found)"), message


@pytest.mark.parametrize("setting", ["NUMBA_DISABLE_JIT=yes", "NUMBA_OPT=bogus", "NUMBA_BOUNDSCHECK=maybe"])
def test_a_numba_variable_numba_cannot_read_is_one_line(setting):
    """numba ignores it with a RuntimeWarning holding its parser's traceback (eight lines on every
    command); vrsweep says it in one line, as it says an unreadable NUMBA_NUM_THREADS."""
    import os
    import subprocess
    import sys

    name, value = setting.split("=")
    result = subprocess.run([sys.executable, "-c", "import vrsweep, numba"], capture_output=True, text=True,
                            env={**os.environ, name: value}, timeout=120)
    assert result.returncode == 0, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert lines[0].startswith(f"vrsweep: {name}='{value}' is not a value numba can read"), lines[0]


@pytest.mark.parametrize("number", [30, 5, 2])  # EROFS, EIO, ENOENT
def test_a_file_the_system_will_not_open_is_not_called_corrupt(number):
    """`run --resume` of a sound file on a read-only file system said "is truncated or corrupt (HDF5:
    unable to open file: ... errno = 30, error message = 'Read-only file system' ...)"."""
    import os

    from vrsweep.store.reader import corrupt_error

    error = OSError(f"Unable to synchronously open file (unable to open file: name = 'r.h5', errno = {number}, "
                    f"error message = '{os.strerror(number)}', flags = 1, o_flags = 2)")
    message = str(corrupt_error("r.h5", error))
    assert message == f"r.h5: cannot open it: {os.strerror(number)}", message


def test_a_truncated_file_is_still_called_truncated(tmp_path):
    import h5py

    from vrsweep.store.reader import corrupt_error

    path = tmp_path / "t.h5"
    with h5py.File(path, "w") as f:
        f["x"] = list(range(1000))
    path.write_bytes(path.read_bytes()[:1500])
    with pytest.raises(OSError) as caught:
        h5py.File(path, "r")
    assert "truncated or corrupt" in str(corrupt_error(str(path), caught.value))


def test_output_in_the_home_of_a_user_who_does_not_exist_is_refused(tmp_path, invoke, write_config, monkeypatch):
    """`output: ~nosuchuser/x.h5` stayed as written (os.path.expanduser knows no such user) and the
    run made a folder named '~nosuchuser' in the current directory, as '~/x.h5' once made '~'."""
    import pwd

    user = "vrsweep_no_such_user_7"
    with pytest.raises(KeyError):
        pwd.getpwnam(user)
    monkeypatch.chdir(tmp_path)
    config = write_config(tmp_path, f"model: effective\nintegration: {{transient_periods: 1, measure_periods: 1, "
                                    f"strobe_periods: 1}}\noutput: ~{user}/x.h5\n")
    for command in ("validate", "run"):
        result = invoke(command, config)
        assert result.exit_code == 2, result.output
        assert f"sweep.yaml:3: output: '~{user}/x.h5' starts with ~{user}" in result.output, result.output
    assert sorted(path.name for path in tmp_path.iterdir()) == ["sweep.yaml"]


def test_output_in_a_home_that_exists_is_that_folder():
    import os

    config = parse_config("output: ~/x.h5\n")
    assert str(config.output_path()) == os.path.join(os.path.expanduser("~"), "x.h5")


def test_validate_shows_a_count_as_given(tmp_path, invoke, write_config):
    """`--set max_steps=123456789` was shown as max_steps=1.23457e+08: a count that was not given."""
    config = write_config(tmp_path, "model: effective\n")
    result = invoke("validate", config, "--set", "max_steps=123456789", "--set", "max_impacts_per_period=1234567")
    assert result.exit_code == 0, result.output
    assert "max_steps=123456789 max_impacts_per_period=1234567" in result.output, result.output
