"""Issue 24, class 2: nothing grows without a bound the user chose.

Memory per grid point does not depend on the transient's length (the kernel keeps the
measurement window's records only), `validate` and `run` count the records a run holds and refuse
a run that cannot fit before any file exists, a config's size and its alias expansion are bounded,
and thread or worker counts beyond the machine are capped or refused, each with one line.
"""

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vrsweep.config import parse_config
from vrsweep.config.validate import MAX_CONFIG_BYTES
from vrsweep.config.yaml import MAX_EXPANDED_VALUES
from vrsweep.errors import ConfigError, InvalidArgument
from vrsweep.execution import chunks, estimate
from vrsweep.execution.distributed import parse_local
from vrsweep.execution.threads import machine_cpus

SWEEP = """\
model: effective
sweep: {{g: {{start: 0, stop: 1, num: {n}}}}}
integration: {{transient_periods: {transient}, measure_periods: {measure}, strobe_periods: 1}}
"""


def _config(n=40, transient=0, measure=1):
    # max_steps to match: each period takes at least one step (config/rules.check_periods_can_finish)
    max_steps = max(20_000_000, -(-(transient + measure) // 2))
    return parse_config(SWEEP.format(n=n, transient=transient, measure=measure).replace(
        "strobe_periods: 1", f"strobe_periods: 1, max_steps: {max_steps}"))


def test_record_row_bytes_is_the_kernels_record():
    from vrsweep.numerics import records

    assert chunks.RECORD_ROW_BYTES == records.N_RECORD * np.dtype(np.float64).itemsize


@settings(max_examples=60, deadline=None)
@given(transient=st.integers(0, 10 ** 15), measure=st.integers(1, 10 ** 6), n=st.integers(2, 500),
       threads=st.integers(1, 64))
def test_memory_does_not_depend_on_the_transient(transient, measure, n, threads):
    with_transient = estimate.memory_bytes(_config(n, transient, measure), threads)
    assert with_transient == estimate.memory_bytes(_config(n, 0, measure), threads)
    # What a chunk holds: its points' records over the window, within CHUNK_RECORD_BYTES unless one
    # point alone is more.
    point = measure * chunks.RECORD_ROW_BYTES
    assert with_transient <= max(chunks.CHUNK_RECORD_BYTES, point)
    assert with_transient % point == 0


@settings(max_examples=40, deadline=None)
@given(measure=st.integers(1, 10 ** 9), line_length=st.integers(1, 1000), threads=st.integers(1, 256))
def test_chunks_never_grow_past_the_memory_bound(measure, line_length, threads):
    integration = _config(measure=measure).integration
    most = chunks.max_chunk_lines(integration, line_length)
    assert most >= 1
    assert most <= chunks.MAX_CHUNK_LINES
    if most > 1:
        assert most * line_length * chunks.point_record_bytes(integration) <= chunks.CHUNK_RECORD_BYTES


def test_the_kernel_keeps_only_the_window_and_gets_the_same_answer():
    """A sweep's records (measurement window only) against a trajectory's (every period): the same
    window rows and the same summary, bit for bit, for both methods and with tangent vectors."""
    from vrsweep.numerics import kernel
    from vrsweep.numerics.model import kernel_coefficients
    from vrsweep.numerics.trajectory import settings_vector

    config = parse_config("integration: {transient_periods: 7, measure_periods: 5, strobe_periods: 2}")
    settings_ = settings_vector(**vars(config.integration))
    coefficients = kernel_coefficients(config.parameters, config.model)
    for method in ("rk45", "dop853"):
        for lyapunov in (False, True):
            integrate = kernel.integrator(method, lyapunov)
            rows = {}
            summaries = {}
            for n_rows in (12, 5):
                records = np.full((n_rows, kernel.N_RECORD), np.nan)
                summary = np.full(kernel.N_SUMMARY, np.nan)
                status = integrate(coefficients, np.array([0.99, 0.5]), settings_, records, summary, np.empty(0),
                                   np.empty((0, 2)), np.empty((0, 3)), np.empty((0, 2)))
                assert status == 0
                rows[n_rows], summaries[n_rows] = records[-5:], summary
            np.testing.assert_array_equal(rows[5], rows[12])
            np.testing.assert_array_equal(summaries[5], summaries[12])


def test_validate_counts_memory_and_run_refuses_what_cannot_fit(tmp_path, invoke, write_config):
    # 40 points, a transient of three million periods: as little memory as a transient of none.
    config = write_config(tmp_path, SWEEP.format(n=40, transient=3_000_000, measure=100))
    done = invoke("validate", config, "--threads", 2)
    assert done.exit_code == 0, done.output
    # A chunk of 16 x 2 = 32 of the 40 points x 100 periods x a record row, whatever the transient.
    expected = 32 * 100 * chunks.RECORD_ROW_BYTES / 1000
    assert f"memory:      {expected:.1f} kB of per-period records held at once" in done.output, done.output
    # measure_periods 1e11: 8 TB of records for one point. Refused by validate and by run, even
    # with --allow-large, in one line and before any file exists.
    # (with max_steps to match: 1e11 periods need at least as many steps, config/rules.py)
    huge = write_config(tmp_path, SWEEP.format(n=40, transient=0, measure=10 ** 11).replace(
        "strobe_periods: 1", f"strobe_periods: 1, max_steps: {10 ** 11}"), name="huge.yaml")
    out = tmp_path / "out" / "huge.h5"
    for args in (("validate", huge), ("run", huge, "-o", out, "--allow-large")):
        done = invoke(*args)
        assert done.exit_code == 2, done.output
        lines = done.output.strip().splitlines()
        assert len(lines) == 1 and "measure_periods" in lines[0] and "memory" in lines[0], done.output
    assert not (tmp_path / "out").exists()


def _alias_bomb(depth, width, key="unknown_key"):
    lines = [f"{key}:", f"  a0: &a0 [{', '.join(['x'] * width)}]"]
    for level in range(1, depth):
        lines.append(f"  a{level}: &a{level} [{', '.join([f'*a{level - 1}'] * width)}]")
    return "\n".join(lines) + "\n"


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(depth=st.integers(2, 12), width=st.integers(2, 12))
def test_alias_expansion_is_bounded(depth, width):
    text = _alias_bomb(depth, width)
    # Values plain_data visits: the root, unknown_key's mapping, and each anchor's list expanded
    # in full (a list of width scalars; a list of width copies of the level below).
    sizes = [1 + width]
    for _ in range(1, depth):
        sizes.append(1 + width * sizes[-1])
    expanded = 2 + sum(sizes)
    with pytest.raises(ConfigError) as error:
        parse_config(text, "bomb.yaml")
    message = str(error.value)
    if expanded > MAX_EXPANDED_VALUES:
        assert "aliases expand to more than" in message
    else:
        assert "unknown_key" in message and "aliases" not in message


def test_the_alias_bomb_and_dev_zero_are_refused_by_validate(tmp_path, invoke):
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(_alias_bomb(10, 10))
    assert len(bomb.read_bytes()) < 2000
    large = tmp_path / "large.yaml"
    large.write_text("# padding\n" * (MAX_CONFIG_BYTES // 10 + 1))
    for path in (bomb, large, "/dev/zero"):
        done = invoke("validate", path)
        assert done.exit_code == 2, done.output
        assert len(done.output.strip().splitlines()) == 1, done.output


@pytest.mark.parametrize("value", [str(machine_cpus() + 1), "100000", "99999999999999999999"])
def test_numba_num_threads_beyond_the_machine_is_capped(tmp_path, write_config, value):
    config = write_config(tmp_path, SWEEP.format(n=2, transient=0, measure=1))
    env = dict(os.environ, NUMBA_NUM_THREADS=value)
    done = subprocess.run([sys.executable, "-m", "vrsweep", "validate", str(config)], capture_output=True,
                          text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stderr == (f"vrsweep: NUMBA_NUM_THREADS={value} is more than the {machine_cpus()} CPUs of "
                           f"this machine: using {machine_cpus()}\n")
    cpus = machine_cpus()
    assert f"on {cpus} thread{'s' if cpus != 1 else ''}" in done.stdout


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 10 ** 30))
def test_local_dask_workers_beyond_the_machine_are_refused(n):
    if n <= machine_cpus():
        assert parse_local(f"local:{n}") == n
    else:
        with pytest.raises(InvalidArgument, match="N <= "):
            parse_local(f"local:{n}")


def test_dask_local_beyond_the_machine_is_one_line(tmp_path, invoke, write_config):
    config = write_config(tmp_path, SWEEP.format(n=2, transient=0, measure=1))
    done = invoke("run", config, "-o", tmp_path / "out.h5", "--dask", "local:99999")
    assert done.exit_code == 2, done.output
    assert done.output.strip().splitlines() == [
        f"Error: --dask local:99999: local:N starts N worker processes; this machine has {machine_cpus()} "
        f"CPUs, so N <= {machine_cpus()}"]
    assert not (tmp_path / "out.h5").exists()


def test_validate_states_the_memory_held(tmp_path, invoke, write_config):
    config = write_config(tmp_path, textwrap.dedent(SWEEP.format(n=3, transient=5, measure=1000)))
    done = invoke("validate", config, "--threads", 1)
    assert done.exit_code == 0, done.output
    # 3 points (a chunk of max(1, 16) lines holds all three) x 1000 periods x a record row.
    expected = 3 * 1000 * chunks.RECORD_ROW_BYTES / 1000
    assert f"memory:      {expected:.1f} kB of per-period records held at once" in done.output, done.output


@pytest.mark.parametrize("transient", [4_000_000, 10 ** 12])
def test_a_trajectorys_records_are_bounded_too(tmp_path, invoke, write_config, transient):
    """simulate keeps every period's record (impacts per period, transient included): bounded."""
    config = write_config(tmp_path, f"""\
        model: effective
        integration: {{transient_periods: {transient}, measure_periods: 1, strobe_periods: 1}}
        """)
    done = invoke("simulate", config, "-o", tmp_path / "t.h5", "--samples-per-period", 1)
    assert done.exit_code == 2, done.output
    assert len(done.output.strip().splitlines()) == 1 and "slow periods" in done.output, done.output
    assert not (tmp_path / "t.h5").exists()


@pytest.mark.parametrize("command", [["validate"], ["run", "--allow-large", "--dry-run"], ["run", "--allow-large"]])
def test_a_grid_past_int64_is_refused_in_one_line(tmp_path, invoke, write_config, command):
    # Three axes of 10^7 values are 10^21 points: their indices and the file's bytes overflow
    # int64. --dry-run ended in numpy's "array is too big" traceback, run in posix_fallocate's
    # OverflowError; --allow-large cannot allow what cannot be done.
    config = write_config(tmp_path, """\
        model: effective
        sweep:
          g: {start: 0, stop: 40, num: 10000000}
          Omega: {start: 1, stop: 5, num: 10000000}
          e: {start: 0.5, stop: 1, num: 10000000}
        """)
    result = invoke(command[0], config, *command[1:], *(["-o", tmp_path / "out.h5"] if command[0] == "run" else []))
    assert result.exit_code == 2, result.output
    assert "a grid of 1000000000000000000000 points" in result.output and "int64" in result.output
    assert not (tmp_path / "out.h5").exists()


def test_a_grid_past_int64_is_a_config_error_in_python(tmp_path):
    import vrsweep
    from vrsweep.errors import ConfigError

    axes = {name: {"start": low, "stop": high, "num": 10_000_000}
            for name, low, high in (("g", 0, 40), ("Omega", 1, 5), ("e", 0.5, 1))}
    with pytest.raises(ConfigError, match="int64"):
        vrsweep.sweep({"model": "effective", "sweep": axes}, allow_large=True, progress=False)
