"""Shards: SLURM array variables -> shard, shards 0..N-1 merged == one run, merge refusals."""

import errno
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from vrsweep.config import parse_config
from vrsweep.errors import UsageError
from vrsweep.execution.job import owned_mask, parse_shard
from vrsweep.store import ResultWriter, VariableSpec
from vrsweep.execution.sweep import Grid, shard_of_points

TINY = """\
    sweep:
      g: {start: 0.0, stop: 30.0, num: 7}
      Omega: [4.0, 5.0]
    integration: {transient_periods: 4, measure_periods: 4, strobe_periods: 2}
    """
N_SHARDS = 3


def slurm(task, count, first=None, step=None):
    env = {"SLURM_ARRAY_TASK_ID": str(task), "SLURM_ARRAY_TASK_COUNT": str(count)}
    if first is not None:
        env["SLURM_ARRAY_TASK_MIN"] = str(first)
    if step is not None:
        env["SLURM_ARRAY_TASK_STEP"] = str(step)
    return env


# ---------------------------------------------------------------------------------------------
# parse_shard
# ---------------------------------------------------------------------------------------------


def test_explicit_shards():
    assert parse_shard(None) == (0, 1)
    assert parse_shard("0/1") == (0, 1)
    assert parse_shard("3/8") == (3, 8)


@pytest.mark.parametrize("env, expected", [
    (slurm(0, 4, first=0), (0, 4)),            # --array=0-3
    (slurm(3, 4, first=0), (3, 4)),
    (slurm(1, 8, first=1), (0, 8)),            # --array=1-8: task 1 is shard 0
    (slurm(8, 8, first=1), (7, 8)),
    (slurm(105, 6, first=100), (5, 6)),        # --array=100-105
    (slurm(20, 4, first=0, step=10), (2, 4)),  # --array=0-30:10
    (slurm(2, 3), (2, 3)),                     # no TASK_MIN (very old SLURM): from 0
])
def test_slurm_array_variables_map_to_the_right_shard(env, expected):
    assert parse_shard("auto", env) == expected


def test_every_task_of_an_array_gets_its_own_shard():
    shards = [parse_shard("auto", slurm(task, 5, first=11)) for task in range(11, 16)]
    assert shards == [(i, 5) for i in range(5)]


@pytest.mark.parametrize("text, env, words", [
    ("auto", {}, "SLURM_ARRAY_TASK_ID"),
    ("auto", slurm(9, 8, first=1), "index 8 is not in 0..7"),       # outside the array
    ("auto", slurm(4, 3, first=1, step=2), "not on the range"),     # task 4 of --array=1-5:2?
    ("auto", slurm(7, 3, first=1), "not a list"),                   # --array=1,4,7
    ("auto", {"SLURM_ARRAY_TASK_ID": "x", "SLURM_ARRAY_TASK_COUNT": "2"}, "SLURM_ARRAY_TASK_ID='x' is not a whole number"),
    # the variable that is wrong, not the two that are set (all four were "needs SLURM_ARRAY_TASK_ID and ...")
    ("auto", {"SLURM_ARRAY_TASK_ID": "1", "SLURM_ARRAY_TASK_COUNT": ""}, "SLURM_ARRAY_TASK_COUNT='' is not a whole"),
    ("auto", {**slurm(1, 2), "SLURM_ARRAY_TASK_STEP": "abc"}, "SLURM_ARRAY_TASK_STEP='abc' is not a whole number"),
    ("auto", {**slurm(1, 2), "SLURM_ARRAY_TASK_MIN": "1.5"}, "SLURM_ARRAY_TASK_MIN='1.5' is not a whole number"),
    ("2/2", {}, "not in 0..1"),
    ("-1/2", {}, "not in 0..1"),
    ("1/0", {}, "number of shards N must be >= 1, got 0"),
    ("1", {}, "expected I/N"),
    ("a/b", {}, "expected I/N"),
])
def test_bad_shards_are_usage_errors(text, env, words):
    with pytest.raises(UsageError, match=words):
        parse_shard(text, env)


@pytest.mark.parametrize("text, env, count", [
    ("0/0", {}, 0),
    ("1/-3", {}, -3),
    ("-1/-1", {}, -1),
    ("auto", slurm(0, 0, first=0), 0),
])
def test_a_shard_count_below_one_is_named_as_such(text, env, count):
    """`--shard 0/0` said "shard index 0 is not in 0..-1", `1/-3` "not in 0..-4": the count is
    what is wrong, and no range of indices exists to name."""
    with pytest.raises(UsageError) as caught:
        parse_shard(text, env)
    assert f"N must be >= 1, got {count}" in str(caught.value)
    assert "not in" not in str(caught.value)


@pytest.mark.parametrize("given, shard, expected", [
    ("out.h5", (0, 2), "out.shard0of2.h5"),
    ("out.shard0of2.h5", (0, 2), "out.shard0of2.h5"),      # already this shard's file: kept
    ("run.shard3of16.nc", (3, 16), "run.shard3of16.nc"),
    ("out.shard0of2.h5", (0, 1), "out.shard0of2.h5"),      # a whole run: the name as given
])
def test_a_shard_output_that_names_its_shard_is_not_suffixed_again(given, shard, expected):
    """`run --shard 0/2 -o s.shard0of2.h5` wrote s.shard0of2.shard0of2.h5."""
    from vrsweep.execution.job import shard_output_path

    assert str(shard_output_path(given, shard)) == expected


def test_a_shard_output_that_names_another_shard_is_refused():
    from vrsweep.execution.job import shard_output_path

    with pytest.raises(UsageError, match=r"^output s.shard1of2.h5 names the file of shard 1/2, but this is shard "
                                         r"0/2: give the run's output, s.h5"):
        shard_output_path("s.shard1of2.h5", (0, 2))
    with pytest.raises(UsageError, match=r"names the file of shard 0/20, but this is shard 0/2"):
        shard_output_path("s.shard0of20.h5", (0, 2))


# ---------------------------------------------------------------------------------------------
# Shards end to end
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def runs(tmp_path_factory, invoke, write_config):
    """A single run and the N shards of the same config, as a 1-based SLURM array would run them."""
    directory = tmp_path_factory.mktemp("shards")
    config = write_config(directory, TINY)
    single = directory / "single.h5"
    assert invoke("run", config, "-o", single, "-q").exit_code == 0
    out = directory / "map.h5"
    for task in range(1, N_SHARDS + 1):
        result = invoke("run", config, "-o", out, "--shard", "auto", env=slurm(task, N_SHARDS, first=1))
        assert result.exit_code == 0, result.output
    shards = [directory / f"map.shard{i}of{N_SHARDS}.h5" for i in range(N_SHARDS)]
    return config, single, shards


def test_shards_partition_the_grid_evenly(runs):
    _, _, shards = runs
    owned = []
    for path in shards:
        with h5py.File(path, "r") as f:
            owned.append(f["owned"][()].astype(bool))
            assert (f["done"][()].astype(bool) == owned[-1]).all()  # each did exactly its own points
            assert f.attrs["vrsweep_complete"] == 1
    total = np.sum(owned, axis=0)
    assert (total == 1).all()  # every point in exactly one shard
    sizes = [int(o.sum()) for o in owned]
    assert max(sizes) - min(sizes) <= 1, sizes


def test_merged_shards_equal_a_single_run(runs, tmp_path, assert_same_result, invoke):
    _, single, shards = runs
    merged = tmp_path / "merged.h5"
    result = invoke("merge", *shards[::-1], "-o", merged)  # the order of the shards does not matter
    assert result.exit_code == 0, result.output
    assert "14 of 14 points" in result.output
    assert_same_result(merged, single)


def _labels(path, points):
    """How a message names grid points: 'g=15, Omega=4'."""
    with h5py.File(path, "r") as f:
        g, omega = f["g"][()], f["Omega"][()]
    return [f"g={g[i]:g}, Omega={omega[j]:g}" for i, j in points]


def _owned(path):
    with h5py.File(path, "r") as f:
        return f["owned"][()].astype(bool)


def test_merge_with_a_missing_shard_names_the_shard_and_its_file(runs, tmp_path, invoke):
    """Issue 15: the points missing are those of shard 1/3, whose file was not given."""
    _, _, shards = runs
    merged = tmp_path / "merged.h5"
    result = invoke("merge", shards[0], shards[2], "-o", merged)
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.output
    owned = _owned(shards[1])
    n_missing = int(owned.sum())
    first = "; ".join(_labels(shards[1], np.argwhere(owned)[:3]))  # in C order, as the grid runs
    assert f"{n_missing} of 14 points are missing" in lines[0]
    assert f"{n_missing} ({first}; ...) owned by shard 1/{N_SHARDS} ({shards[1]}, not given)" in lines[0]
    assert "--allow-missing" in lines[0]
    assert not merged.exists()


def test_merge_names_each_shard_that_points_are_missing_from(runs, tmp_path, invoke):
    """A shard not given and a shard given but unfinished (killed before its last points): each
    named with its own missing points, the unfinished one with how far it got."""
    _, _, shards = runs
    unfinished = tmp_path / shards[2].name
    unfinished.write_bytes(shards[2].read_bytes())
    owned = _owned(unfinished)
    lost = np.argwhere(owned)[-2:]  # its last two points in grid order
    with h5py.File(unfinished, "r+") as f:
        done = f["done"][()]
        for i, j in lost:
            done[i, j] = 0
        f["done"][()] = done
        f.attrs.modify("vrsweep_complete", np.int32(0))  # as a kill leaves it: not finished
    result = invoke("merge", shards[0], unfinished, "-o", tmp_path / "merged.h5")
    assert result.exit_code == 2
    n_owned_1, n_owned_2 = int(_owned(shards[1]).sum()), int(owned.sum())
    assert f"{n_owned_1 + 2} of 14 points are missing" in result.output
    # Named beside the first shard given, as `run --shard` names shard files.
    assert f"owned by shard 1/{N_SHARDS} ({shards[1]}, not given)" in result.output
    lost_labels = "; ".join(_labels(unfinished, lost))
    assert (f"2 ({lost_labels}) owned by shard 2/{N_SHARDS} ({unfinished}, which finished "
            f"{n_owned_2 - 2} of its {n_owned_2} points: resume it with --resume)") in result.output


@pytest.mark.parametrize("sweep", [TINY, """\
    model: effective
    sweep:
      g: {start: 21.0, stop: 27.0, num: 9, continuation: both}
      Omega: [4.0, 4.5, 5.0]
    """])
@pytest.mark.parametrize("count", [1, 3, 4])
def test_shard_of_points_is_the_ownership_of_run_shard(sweep, count):
    """The merge's message names shards from sweep.shard_of_points: it must be exactly the set of
    points each `run --shard I/N` runs (whole continuation lines included)."""
    grid = Grid.from_config(parse_config(textwrap.dedent(sweep)))
    owner = shard_of_points(grid, count)
    for index in range(count):
        assert np.array_equal(owner == index, owned_mask(grid, (index, count)))


def test_merge_with_a_foreign_shard_fails_and_names_it(runs, tmp_path, invoke):
    config, _, shards = runs
    foreign = tmp_path / "other.h5"
    result = invoke("run", config, "-o", foreign, "--set", "e=0.9", "--shard", f"1/{N_SHARDS}", "-q")
    assert result.exit_code == 0, result.output
    foreign = tmp_path / f"other.shard1of{N_SHARDS}.h5"
    result = invoke("merge", shards[0], foreign, shards[2], "-o", tmp_path / "merged.h5")
    assert result.exit_code == 2
    assert str(foreign) in result.output and "different config" in result.output
    assert "e: 0.9" in result.output


def test_a_shard_whose_config_only_named_another_output_merges(runs, tmp_path, assert_same_result, invoke):
    # The output key (and a continuation section) change no point: the shard was refused as "written
    # from a different config", as --resume refused such a checkpoint.
    config, single, shards = runs
    renamed = tmp_path / "renamed.yaml"
    renamed.write_text(Path(config).read_text(encoding="utf-8") + "output: results/elsewhere.h5\n"
                       "continuation: {parameter: g, from: 10, to: [5, 20]}\n", encoding="utf-8")
    other = tmp_path / "other.h5"
    result = invoke("run", renamed, "-o", other, "--shard", f"1/{N_SHARDS}", "-q")
    assert result.exit_code == 0, result.output
    merged = tmp_path / "merged.h5"
    result = invoke("merge", shards[0], tmp_path / f"other.shard1of{N_SHARDS}.h5", *shards[2:], "-o", merged)
    assert result.exit_code == 0, result.output
    assert_same_result(merged, single)


def test_merge_refuses_to_overwrite(runs, tmp_path, invoke):
    _, _, shards = runs
    merged = tmp_path / "merged.h5"
    merged.write_bytes(b"precious")
    result = invoke("merge", *shards, "-o", merged)
    assert result.exit_code == 2 and "--overwrite" in result.output
    assert merged.read_bytes() == b"precious"
    assert invoke("merge", *shards, "-o", merged, "--overwrite", "-q").exit_code == 0


def test_a_partial_merge_is_completed_by_resume(runs, tmp_path, assert_same_result, invoke):
    """--allow-missing writes what there is; run --resume on the merged file computes the rest."""
    config, single, shards = runs
    merged = tmp_path / "merged.h5"
    result = invoke("merge", shards[0], shards[1], "-o", merged, "--allow-missing")
    assert result.exit_code == 0, result.output
    assert "missing" in result.output and "incomplete" in result.output
    with h5py.File(merged, "r") as f:
        assert f.attrs["vrsweep_complete"] == 0
    result = invoke("run", config, "-o", merged, "--resume")
    assert result.exit_code == 0, result.output
    with h5py.File(shards[2], "r") as f:
        assert f"{int(f['owned'][()].sum())} of 14 points computed" in result.output
    assert_same_result(merged, single)


def test_a_shard_named_as_its_own_file_runs_resumes_and_merges_there(runs, tmp_path, invoke, assert_same_result):
    """-o OUT.shardIofN.h5 with --shard I/N (a job script naming each task's file) is that file:
    run writes it, --resume finds it, merge takes it; a shard given another shard's name is refused."""
    config, single, shards = runs
    own = [tmp_path / f"map.shard{i}of{N_SHARDS}.h5" for i in range(N_SHARDS)]
    for i, path in enumerate(own):
        result = invoke("run", config, "-o", path, "--shard", f"{i}/{N_SHARDS}", "-q")
        assert result.exit_code == 0, result.output
    assert sorted(tmp_path.iterdir()) == own
    result = invoke("run", config, "-o", own[0], "--shard", f"0/{N_SHARDS}", "--resume")
    assert result.exit_code == 0 and "nothing left to compute" in result.output, result.output
    result = invoke("run", config, "-o", own[0], "--shard", f"1/{N_SHARDS}")
    assert result.exit_code == 2 and f"-o {own[0]} names the file of shard 0/{N_SHARDS}" in result.output, result.output
    assert sorted(tmp_path.iterdir()) == own
    assert invoke("merge", *own, "-o", tmp_path / "map.h5", "-q").exit_code == 0
    assert_same_result(tmp_path / "map.h5", single)


def test_a_shard_resumes_only_as_itself(runs, tmp_path, invoke):
    config, _, shards = runs
    copy = tmp_path / f"map.shard1of{N_SHARDS}.h5"
    copy.write_bytes(shards[1].read_bytes())
    result = invoke("run", config, "-o", tmp_path / "map.h5", "--shard", f"1/{N_SHARDS}", "--resume")
    assert result.exit_code == 0 and "0 of" in result.output
    whole = tmp_path / "whole.h5"
    whole.write_bytes(shards[1].read_bytes())
    result = invoke("run", config, "-o", whole, "--resume")  # not as a whole run
    assert result.exit_code == 2 and "shard" in result.output


# ---------------------------------------------------------------------------------------------
# Signals during a merge
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def big_shards(tmp_path_factory):
    """Two shard files of 10^4 points with 64 stroboscopic samples (6 MB each), written by the
    store with values that are a function of the point."""
    directory = tmp_path_factory.mktemp("big")
    axes = [("g", np.linspace(0.0, 40.0, 200)), ("Omega", np.linspace(4.0, 5.0, 50))]
    specs = [VariableSpec("R", np.float64, attrs={"units": "1", "long_name": "gain"}),
             VariableSpec("strobe_x", np.float64, (("strobe", 64),), {"units": "1", "long_name": "x at t = nT"})]
    paths = []
    for index in range(2):
        owned = np.arange(10_000) % 2 == index
        path = directory / f"map.shard{index}of2.h5"
        writer = ResultWriter.create(path, axes, specs, {"config": "sweep: {}\n", "shard": f"{index}/2"},
                                     owned_mask=owned.reshape(200, 50))
        points = np.flatnonzero(owned)
        writer.write_points(points, {"R": np.sin(points), "strobe_x": np.cos(points[:, None] + np.arange(64))})
        writer.finish()
        paths.append(path)
    return paths


@pytest.mark.parametrize("signum, code, existing, delay", [
    (signal.SIGTERM, 143, None, 0.0),          # scancel, or a SLURM time limit
    (signal.SIGTERM, 143, None, 0.3),
    (signal.SIGINT, 130, b"precious", 0.1),    # Ctrl-C while --overwrite replaces an older file
])
def test_a_signal_during_merge_leaves_no_partial_output(big_shards, tmp_path, signum, code, existing, delay, vrsweep_process):
    """Issue 14: a real `python -m vrsweep merge` stopped while it writes (as its temporary file
    appears, or ``delay`` seconds later): exit 128 + signal, one line, OUT as it was, and no
    temporary file."""
    out = tmp_path / "merged.h5"
    options = []
    if existing is not None:
        out.write_bytes(existing)
        options = ["--overwrite"]
    # Each shard in 25 copies: every block is read and compared 50 times, so the merge would take
    # seconds; it is stopped as soon as its temporary file appears, long before the end. (Copies,
    # not the same file given 25 times: that is one shard, read once.)
    copies = tmp_path / "copies"
    copies.mkdir()
    shards = []
    for n in range(25):
        for path in big_shards:
            shards.append(copies / f"{n}.{path.name}")
            shutil.copyfile(path, shards[-1])
    child = vrsweep_process("merge", *shards, "-o", out, *options)
    try:
        deadline = time.monotonic() + 120
        while not list(tmp_path.glob(".merged.h5.*.tmp")):
            assert child.poll() is None, child.communicate()
            assert time.monotonic() < deadline, "the merge never started writing"
            time.sleep(0.002)
        time.sleep(delay)
        child.send_signal(signum)
        _, stderr = child.communicate(timeout=120)
    finally:
        if child.poll() is None:
            child.kill()
    assert child.returncode == code, stderr
    state = "left as it was" if existing else "not written"
    name = signal.Signals(signum).name
    assert stderr.strip().splitlines() == [f"Interrupted ({name}): merge stopped, {out} {state} (no partial file)"]
    assert sorted(p.name for p in tmp_path.iterdir()) == (["copies", "merged.h5"] if existing else ["copies"])
    assert existing is None or out.read_bytes() == existing


@pytest.mark.slow
def test_a_merges_memory_is_its_start_up_and_half_the_result_at_most(tmp_path):
    """docs/clusters.md and merge.sbatch size a merge job by its peak memory: start-up plus 0.23 to
    0.54 times the result. The check of each shard's checksums, added later, read 64 MiB at a time
    (a whole variable of this grid) through a 32 MiB chunk cache, and the merge imported numba for
    its version: 2 shards of a 122 MiB result peaked at 253 MiB, 1.05 times the result over a
    start-up of 125 MiB (here 1.49 times; now 0.41). Measured
    as benchmarks/bench_merge.py does (synthetic shards of a real layout, each merge's own peak RSS
    from a small launcher), on a 73 MiB result."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("bench_merge", SLURM_EXAMPLES.parent.parent / "benchmarks"
                                                  / "bench_merge.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    (tmp_path / "small").mkdir()
    small = bench.make_shards(tmp_path / "small", bench.config_text(10, 64), 2, {})
    shards = bench.make_shards(tmp_path, bench.config_text(60_000, 64), 2, {})
    start_up, _ = bench.measure(bench.merge_command(small, tmp_path / "small.h5"), 1)
    peak, _ = bench.measure(bench.merge_command(shards, tmp_path / "merged.h5"), 1)
    result = (tmp_path / "merged.h5").stat().st_size / 2 ** 20
    assert result > 64, result  # larger than the old check's blocks
    assert peak - start_up <= 0.54 * result, (start_up, peak, result)  # merge.sbatch's upper bound
    imported = subprocess.run([sys.executable, "-c", "import sys; from vrsweep.cli import main\n"
                               "try: main(sys.argv[1:])\nexcept SystemExit: pass\nprint('numba' in sys.modules)",
                               "merge", *map(str, small), "-o", str(tmp_path / "again.h5"), "-q"],
                              capture_output=True, text=True, timeout=120)
    assert imported.stdout.split() == ["False"], imported.stdout + imported.stderr  # no numba: 45 MiB


def test_a_write_failure_during_merge_is_one_line_and_leaves_nothing(runs, tmp_path, monkeypatch, invoke):
    """A runtime failure while writing (here a full disk): exit 1, one line naming the output, and
    no temporary file."""
    import vrsweep.store.merge

    def full_disk(out, *args):
        raise OSError(errno.ENOSPC, "No space left on device", out.file.filename)

    monkeypatch.setattr(vrsweep.store.merge, "_merge_variable", full_disk)
    _, _, shards = runs
    out = tmp_path / "merged.h5"
    result = invoke("merge", *shards, "-o", out)
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: cannot write {out}: No space left on device")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------------------------
# examples/slurm, run as written
# ---------------------------------------------------------------------------------------------

SLURM_EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "slurm"

# sbatch as a test can have it: the script at once, each array task in turn, with the variables
# SLURM gives a task (and none it would not); --dependency is met by running in order.
FAKE_SBATCH = r"""#!/bin/bash
array=""; exports=""
while [[ $1 == --* ]]; do
    case $1 in --array=*) array=${1#--array=};; --export=*) exports=${1#--export=};; esac
    shift
done
script=$1
job=$((RANDOM + 1))
IFS=, read -ra pairs <<< "$exports"
envs=()
for pair in "${pairs[@]}"; do [[ $pair == ALL ]] || envs+=("$pair"); done
task() { echo "== $script $*" >> sbatch.log
        env "${envs[@]}" SLURM_JOB_ID=$job SLURM_CPUS_PER_TASK=1 "$@" bash "$script" >> sbatch.log 2>&1 || exit $?; }
if [[ -n $array ]]; then
    first=${array%-*}; last=${array#*-}
    for ((t = first; t <= last; t++)); do
        task SLURM_ARRAY_TASK_ID=$t SLURM_ARRAY_TASK_MIN=$first SLURM_ARRAY_TASK_MAX=$last \
             SLURM_ARRAY_TASK_COUNT=$((last - first + 1)) SLURM_ARRAY_TASK_STEP=1
    done
else
    task
fi
echo $job
"""


@pytest.mark.parametrize("script", sorted(p.name for p in SLURM_EXAMPLES.iterdir() if p.suffix in (".sh", ".sbatch")))
def test_every_slurm_example_script_parses(script):
    """array.sbatch read `${CONFIG:?... the sweep's YAML ...}`: bash 5.2 takes that quote as the
    start of a quoted string, and every task of the array failed with a syntax error."""
    done = subprocess.run(["bash", "-n", str(SLURM_EXAMPLES / script)], capture_output=True, text=True)
    assert done.returncode == 0 and not done.stderr, done.stderr


@pytest.mark.parametrize("out", [None, "results/map.hdf5", "results/map", "results/v1.2/map.nc"])
def test_submit_sh_runs_as_written_and_gives_the_single_run_file(tmp_path, invoke, write_config, assert_same_result,
                                                                 out):
    """submit.sh -> warmup.sbatch -> array.sbatch (3 tasks, --shard auto) -> merge.sbatch, with
    sbatch and srun standing in for SLURM: the merged file is the one a single run writes. Also
    with an OUT that does not end in .h5 (submit.sh takes OUT from the environment): merge.sbatch
    looked for map.hdf5.shard0of3.h5 where the array had written map.shard0of3.hdf5."""
    config = write_config(tmp_path, TINY, name="map.yaml")
    single = tmp_path / "single.h5"
    assert invoke("run", config, "-o", single, "-q").exit_code == 0
    env = dict(os.environ, PATH=_slurm_stand_ins(tmp_path))
    if out is not None:
        env["OUT"] = out
    out = Path(out or "results/map.h5")
    done = subprocess.run(["bash", str(SLURM_EXAMPLES / "submit.sh"), "map.yaml", "3"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)
    log = (tmp_path / "sbatch.log").read_text() if (tmp_path / "sbatch.log").exists() else ""
    assert done.returncode == 0, done.stderr + log
    assert f"result: {out}" in done.stdout
    assert sorted(p.name for p in (tmp_path / out.parent).iterdir()) == sorted(
        [out.name] + [f"{out.stem}.shard{i}of3{out.suffix}" for i in range(3)])
    assert_same_result(single, tmp_path / out)


def _slurm_stand_ins(tmp_path):
    """PATH with sbatch (FAKE_SBATCH), srun and vrsweep standing in for SLURM's and the install's."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for name, text in {"sbatch": FAKE_SBATCH, "srun": '#!/bin/bash\nexec "$@"\n',
                       "vrsweep": f'#!/bin/bash\nexec "{sys.executable}" -m vrsweep "$@"\n'}.items():
        (bin_dir / name).write_text(text)
        (bin_dir / name).chmod(0o755)
    return f"{bin_dir}{os.pathsep}{os.environ['PATH']}"


@pytest.mark.slow
def test_the_warm_up_compiles_the_kernel_the_array_runs(tmp_path, write_config, assert_same_result, invoke):
    """Each model, method, lyapunov setting and device has a kernel of its own. warmup.sbatch ran
    warmup.yaml (the effective model, rk45, no Lyapunov exponent) whatever the array's config, so
    an array of a config with lyapunov: true (or dop853, or a written model) found no kernel in the
    cache it had just warmed, and its tasks compiled, each saying so. Here the cache is empty
    before submit.sh: the warm-up's compile is the only one."""
    config = write_config(tmp_path, TINY.replace("strobe_periods: 2}", "strobe_periods: 2, lyapunov: true}"),
                          name="map.yaml")
    env = dict(os.environ, PATH=_slurm_stand_ins(tmp_path), NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    done = subprocess.run(["bash", str(SLURM_EXAMPLES / "submit.sh"), config.name, "3"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)
    log = (tmp_path / "sbatch.log").read_text() if (tmp_path / "sbatch.log").exists() else ""
    assert done.returncode == 0, done.stderr + log
    jobs = {}
    for part in log.split("== ")[1:]:
        script, _, output = part.partition("\n")
        jobs.setdefault(Path(script.split()[0]).name, []).append(output)
    assert len(jobs["array.sbatch"]) == 3 and len(jobs["merge.sbatch"]) == 1, log
    for task in jobs["array.sbatch"]:
        assert "Compiling" not in task, log
    assert "Compiling" in "".join(jobs["warmup.sbatch"]), log
    single = tmp_path / "single.h5"
    assert invoke("run", config, "-o", single, "-q").exit_code == 0
    assert_same_result(single, tmp_path / "results" / "map.h5")


# SLURM as dask-jobqueue uses it, for examples/slurm/dask_slurm.py: sbatch starts the job script at
# once in the background, a process group of its own (job.pid: the script's process, job.rc: its
# exit status), and scancel sends SIGTERM to the whole group, as SLURM does.
DASK_SBATCH = r"""#!/bin/bash
state=${FAKE_SLURM_DIR:?}
mkdir -p "$state"
while [[ $1 == -* ]]; do shift; done
script=$1; shift
job=100
until mkdir "$state/job$job" 2>/dev/null; do job=$((job + 1)); done  # sbatch runs concurrently
cp "$script" "$state/$job.sh"  # dask-jobqueue deletes its script once sbatch returns
directive() { sed -n "s/^#SBATCH \($1\)[ =]//p" "$script" | tail -1; }
name=$(directive '-J\|--job-name'); name=${name:-$(basename "$script")}
out=$(directive '-o\|--output'); out=${out:-slurm-%j.out}
err=$(directive '-e\|--error'); err=${err:-$out}
out=${out//%[jJ]/$job}; out=${out//%x/$name}; err=${err//%[jJ]/$job}; err=${err//%x/$name}
mkdir -p "$(dirname "$out")" "$(dirname "$err")"
SLURM_JOB_ID=$job SLURM_JOB_NAME=$name SLURM_SUBMIT_DIR=$PWD setsid bash -c \
    'job=$1; shift; bash "$job.sh" "$@" & echo $! > "$job.pid"; wait $!; echo $? > "$job.rc"' \
    wrapper "$state/$job" "$@" >"$out" 2>"$err" </dev/null &
echo $! > "$state/$job.pgid"
echo "Submitted batch job $job"
"""
DASK_SCANCEL = r"""#!/bin/bash
state=${FAKE_SLURM_DIR:?}
for job; do
    echo "$job" >> "$state/cancelled"
    kill -TERM -- -"$(cat "$state/$job.pgid")" 2>/dev/null || true
done
"""
DASK_SQUEUE = r"""#!/bin/bash
state=${FAKE_SLURM_DIR:?}
echo JOBID
for f in "$state"/*.pgid; do [ -e "$f" ] && kill -0 -- -"$(cat "$f")" 2>/dev/null && basename "$f" .pgid; done
exit 0
"""


def test_dask_slurm_runs_stops_on_sigterm_resumes_and_cancels_its_workers(tmp_path, invoke, write_config,
                                                                           assert_same_result, done_count):
    """dask_slurm.sbatch (the client as a job) -> dask_slurm.py -> SLURMCluster's worker jobs, with
    sbatch and scancel standing in for SLURM: the workers are real processes that connect to the
    scheduler. SIGTERM to the client saves what is done and cancels the worker jobs; running it
    again resumes, and the file is the one a single run writes; no process is left."""
    pytest.importorskip("dask_jobqueue", reason="examples/slurm/dask_slurm.py needs dask-jobqueue "
                                                "(the slurm and test extras)")
    config = write_config(tmp_path, """\
        sweep:
          g: {start: 0.0, stop: 40.0, num: 64}
        integration: {transient_periods: 40, measure_periods: 40, strobe_periods: 8}
        """, name="map.yaml")
    assert invoke("run", config, "-o", tmp_path / "single.h5", "-q").exit_code == 0
    (tmp_path / "examples").symlink_to(SLURM_EXAMPLES.parent)  # the job runs examples/... from its submit dir
    bin_dir, state = tmp_path / "bin", tmp_path / "slurm"
    bin_dir.mkdir()
    for name, text in {"sbatch": DASK_SBATCH, "scancel": DASK_SCANCEL, "squeue": DASK_SQUEUE}.items():
        (bin_dir / name).write_text(text)
        (bin_dir / name).chmod(0o755)
    repo = str(SLURM_EXAMPLES.parent.parent)  # the client and the workers import this vrsweep
    env = dict(os.environ, PATH=f"{bin_dir}{os.pathsep}{os.environ['PATH']}", FAKE_SLURM_DIR=str(state),
               CPUS_PER_WORKER="1", PYTHONPATH=os.pathsep.join(filter(None, [repo, os.environ.get("PYTHONPATH")])))
    out = tmp_path / "results" / "map.h5"

    def groups():
        return [int(p.read_text()) for p in state.glob("*.pgid") if p.read_text().strip()]

    def alive(group):
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return False
        return True

    def wait_for(condition, seconds):
        deadline = time.monotonic() + seconds
        while not condition() and time.monotonic() < deadline:
            time.sleep(0.05)
        return condition()

    def logs():
        return "\n".join(f"--- {p.name}\n{p.read_text()[-3000:]}" for p in sorted((tmp_path / "logs").glob("*")))

    client_group = None
    try:
        submitted = subprocess.run(["sbatch", "examples/slurm/dask_slurm.sbatch", "map.yaml", "2"], cwd=tmp_path,
                                   env=env, capture_output=True, text=True, check=True, timeout=30)
        job = submitted.stdout.split()[-1]
        client_group = int((state / f"{job}.pgid").read_text())
        assert wait_for(lambda: (done_count(out) or 0) > 0, 120), logs()
        os.kill(int((state / f"{job}.pid").read_text()), signal.SIGTERM)  # the client: python, exec'd
        assert wait_for(lambda: (state / f"{job}.rc").exists(), 60), logs()
        assert (state / f"{job}.rc").read_text().strip() == "143", logs()
        client_log = (tmp_path / "logs" / f"vrsweep-dask-{job}.out").read_text()
        assert "Interrupted (SIGTERM)" in client_log and "Traceback" not in client_log, client_log
        assert "run it again: sbatch examples/slurm/dask_slurm.sbatch map.yaml 2" in client_log, client_log
        saved = done_count(out)
        assert 0 < saved < 64
        workers = {"101", "102"}
        assert set((state / "cancelled").read_text().split()) == workers
        assert wait_for(lambda: not any(alive(g) for g in groups()), 30), logs()

        resumed = subprocess.run([sys.executable, "examples/slurm/dask_slurm.py", "map.yaml", "2"], cwd=tmp_path,
                                 env=env, capture_output=True, text=True, timeout=120, start_new_session=True)
        assert resumed.returncode == 0, resumed.stderr + logs()
        assert f"{64 - saved} of 64 points computed" in resumed.stderr, resumed.stderr
        assert set((state / "cancelled").read_text().split()) == workers | {"103", "104"}
        assert wait_for(lambda: not any(alive(g) for g in groups()), 30), logs()
        assert_same_result(tmp_path / "single.h5", out)
    finally:  # whatever failed: no job's process outlives the test
        for group in groups() + [client_group]:
            if group is not None and alive(group):
                os.killpg(group, signal.SIGKILL)
