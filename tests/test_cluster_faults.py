"""What a shared machine does to a run, done for real (issue 14): a full disk, a second run that
wants the same output, a file or folder removed under a running sweep, a kill -9 while the file
is being created. Each ends in one line on stderr and the documented exit code, never in a
traceback, a crash or a lost result; what was saved resumes to the file an uninterrupted run
writes, bit for bit.

The disk-full test needs a small real file system (a tmpfs, mounted as root) and is skipped where
the machine does not allow it; test_errors.py injects the same faults everywhere."""

import os
import shutil
import signal
import subprocess
import sys
import time
import uuid

import h5py
import pytest

from vrsweep.store.reading import load_results

# ~750 cheap points, a ~420 kB file: small enough to fill a tmpfs of a few hundred kB.
SMALL_DISK_SWEEP = """\
    model: effective
    sweep:
      g: {start: 0.0, stop: 40.0, num: 30}
      Omega: {start: 1.0, stop: 10.0, num: 25}
    integration: {transient_periods: 2, measure_periods: 16, strobe_periods: 16}
    """

# Slow enough to act on while it runs: 160 points in chunks of 16 on one thread, ~0.5 s a chunk.
SLOW = """\
    sweep:
      g: {start: 0.0, stop: 40.0, num: 160}
    integration: {transient_periods: 60, measure_periods: 60, strobe_periods: 8}
    """
CHUNK = 16
SHORT_WINDOWS = "integration: {transient_periods: 2, measure_periods: 2, strobe_periods: 2}\n"


def error_lines(stderr):
    lines = [line for line in stderr.strip().splitlines() if line.strip()]
    assert "Traceback" not in stderr, stderr
    return lines


def one_error_line(stderr):
    lines = error_lines(stderr)
    assert len(lines) == 1 and lines[0].startswith("Error: "), stderr
    return lines[0]


def run_process(*args, prefix=(), env=None):
    command = [*prefix, sys.executable, *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=300, env=env)


# --------------------------------------------------------------------------------------------
# A full disk, on a real file system
# --------------------------------------------------------------------------------------------


class SmallDisk:
    """A tmpfs mounted at ``path`` whose size can be changed (``mount -o remount,size=``)."""

    def __init__(self, path):
        self.path = path

    def resize(self, size):
        subprocess.run(["mount", "-o", f"remount,size={size}", str(self.path)], check=True,
                       capture_output=True)

    def entries(self):
        return sorted(p.name for p in self.path.iterdir())


@pytest.fixture
def small_disk(tmp_path):
    mount = tmp_path / "disk"
    mount.mkdir()
    if shutil.which("mount") is None or os.geteuid() != 0:
        pytest.skip("a small real file system needs root and mount")
    probe = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(mount)],
                           capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {probe.stderr.strip()}")
    try:
        yield SmallDisk(mount)
    finally:
        subprocess.run(["umount", "-l", str(mount)], capture_output=True)


# The CLI without reserving the file's space first (as on a file system that cannot allocate
# ahead), so that HDF5 itself meets the full disk.
WITHOUT_RESERVING = ("-c", "import sys, vrsweep.store.writer as writer; "
                     "writer.reserve_space = lambda *args, **kwargs: None; "
                     "from vrsweep.cli import main; sys.exit(main(sys.argv[1:], prog_name='vrsweep'))")


def test_a_full_disk_at_creation_and_at_finish_then_resume_is_identical(small_disk, tmp_path, assert_same_result, invoke, write_config):
    config = write_config(tmp_path, SMALL_DISK_SWEEP)
    reference = tmp_path / "reference.h5"
    assert invoke("run", config, "-o", reference, "-q").exit_code == 0
    out = small_disk.path / "sweep.h5"

    # 256 kB for a ~420 kB file: its space cannot be reserved, so HDF5 writes nothing.
    proc = run_process("-m", "vrsweep", "run", config, "-o", out)
    assert proc.returncode == 1, proc.stderr
    line = one_error_line(proc.stderr)
    assert f"cannot create {out}: No space left on device" in line
    assert "the file needs about" in line and f"free in {small_disk.path}" in line
    assert small_disk.entries() == []

    # The same with HDF5 hitting the full disk itself: HDF5 fails twice (the write, then the
    # close) and, left alone, crashed the interpreter at exit (exit 139).
    proc = run_process(*WITHOUT_RESERVING, "run", config, "-o", out)
    assert proc.returncode == 1, proc.stderr
    assert "No space left on device" in one_error_line(proc.stderr)
    assert small_disk.entries() == []  # no temporary file left

    # Room for the file but not for the copy that finishing makes: every point is saved.
    small_disk.resize("600k")
    proc = run_process("-m", "vrsweep", "run", config, "-o", out, "--resume", "-q")
    assert proc.returncode == 1, proc.stderr
    line = one_error_line(proc.stderr)
    assert f"cannot finish {out}: No space left on device" in line and "needs about" in line
    assert small_disk.entries() == ["sweep.h5"]
    checkpoint = load_results(out)
    assert checkpoint.done.all() and checkpoint.attrs["vrsweep_complete"] == 0

    # Space freed: --resume only finishes, and the file is the uninterrupted run's.
    small_disk.resize("4m")
    result = invoke("run", config, "-o", out, "--resume")
    assert result.exit_code == 0 and "0 of 750 points computed" in result.output
    assert_same_result(out, reference)


def test_a_full_disk_during_merge_is_one_line_then_a_merge_with_room_is_identical(small_disk, tmp_path, assert_same_result, invoke, write_config):
    config = write_config(tmp_path, SMALL_DISK_SWEEP)
    reference = tmp_path / "reference.h5"
    assert invoke("run", config, "-o", reference, "-q").exit_code == 0
    shards = []
    for index in range(2):
        assert invoke("run", config, "-o", tmp_path / "sweep.h5", "--shard", f"{index}/2", "-q").exit_code == 0
        shards.append(tmp_path / f"sweep.shard{index}of2.h5")
    out = small_disk.path / "merged.h5"
    # Too small for the file, then room for the point values but not for the theory columns,
    # then room for all: one clean line each time, never a crash inside HDF5.
    for size in ("256k", "450k"):
        small_disk.resize(size)
        proc = run_process("-m", "vrsweep", "merge", *shards, "-o", out)
        assert proc.returncode == 1, proc.stderr
        assert f"cannot write {out}: No space left on device" in one_error_line(proc.stderr)
        assert small_disk.entries() == []  # no temporary file left
    small_disk.resize("4m")
    proc = run_process("-m", "vrsweep", "merge", *shards, "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert_same_result(out, reference)


def test_a_file_size_limit_is_named_not_the_free_space(tmp_path, invoke, write_config):
    """`ulimit -f` (or a batch system's limit on file size) stops a write with EFBIG, which was
    worded as a full disk: "File too large (the file needs about 201.3 kB, 78.1 GB free in ...)",
    leaving the user to look for a space problem that is not there."""
    config = write_config(tmp_path, "sweep:\n  g: {start: 0.0, stop: 40.0, num: 8}\n" + SHORT_WINDOWS)
    for i in range(2):
        assert invoke("run", config, "-o", tmp_path / "m.h5", "--shard", f"{i}/2", "-q").exit_code == 0
    shards = [str(tmp_path / f"m.shard{i}of2.h5") for i in range(2)]
    for args in (["merge", *shards, "-o", str(tmp_path / "merged.h5")],
                 ["plot", shards[0], "-o", str(tmp_path / "figure.png")]):
        done = subprocess.run(["bash", "-c", 'ulimit -f 8; exec "$0" -m vrsweep "$@"', sys.executable, *args],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 1, done.stderr
        errors = [line for line in error_lines(done.stderr) if not line.startswith("Note: ")]  # plot: a shard's
        assert len(errors) == 1 and errors[0].startswith("Error: "), done.stderr
        line = errors[0]
        assert "File too large" in line and "may write files of at most 8.2 kB: its file size limit, ulimit -f" in line
        assert " free in " not in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.shard0of2.h5", "m.shard1of2.h5", "sweep.yaml"]


# --------------------------------------------------------------------------------------------
# Two runs, one output; files and folders removed under a running sweep
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def slow_config(tmp_path_factory, invoke, write_config):
    directory = tmp_path_factory.mktemp("slow")
    config = write_config(directory, SLOW)
    # Compile the kernel (if the cache is cold) before any timing-sensitive subprocess.
    assert invoke("run", config, "-o", directory / "warm.h5", "-q", "--set", "transient_periods=1",
                  "--set", "measure_periods=1", "--set", "strobe_periods=1").exit_code == 0
    return config


@pytest.fixture(scope="session")
def start_writer(done_count):
    """The helper below, with the shared helpers it calls (tests/conftest.py)."""
    def start_writer(config, out, env=None):
        """A real ``vrsweep run`` on one thread, returned once its first chunk is on disk."""
        environment = dict(os.environ, **(env or {}))
        child = subprocess.Popen([sys.executable, "-m", "vrsweep", "run", str(config), "-o", str(out),
                                  "--threads", "1"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 text=True, env=environment)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and child.poll() is None:
            if (done_count(out) or 0) >= CHUNK:
                return child
            time.sleep(0.02)
        child.kill()
        pytest.fail(f"no chunk written in time: {child.communicate()}")
    return start_writer


def still_running(child):
    assert child.poll() is None, "the run ended before the fault could be tried; make SLOW slower"


@pytest.mark.parametrize("locking", ["default", "FALSE"], ids=["hdf5-locks", "HDF5_USE_FILE_LOCKING=FALSE"])
def test_overwrite_is_refused_while_another_run_writes_the_file(slow_config, tmp_path, locking, start_writer, write_config):
    """Run A writes ab.h5; run B, another config, asks --overwrite: refused (exit 2), and A
    finishes its file. Also when A runs with HDF5's own locking switched off."""
    out = tmp_path / "ab.h5"
    env = {"HDF5_USE_FILE_LOCKING": "FALSE"} if locking == "FALSE" else None
    writer = start_writer(slow_config, out, env)
    try:
        other = write_config(tmp_path, "sweep:\n  g: {start: 0.0, stop: 40.0, num: 40}\n", name="b.yaml")
        still_running(writer)
        proc = run_process("-m", "vrsweep", "run", other, "-o", out, "--overwrite")
        # Nor may a second writer resume it, even with HDF5's locks switched off.
        resumed = run_process("-m", "vrsweep", "run", slow_config, "-o", out, "--resume",
                              env=dict(os.environ, HDF5_USE_FILE_LOCKING="FALSE"))
        still_running(writer)
        _, stderr = writer.communicate(timeout=120)
    finally:
        if writer.poll() is None:
            writer.kill()
    assert proc.returncode == 2, proc.stderr
    line = one_error_line(proc.stderr)
    assert f"cannot replace {out}: it is being written by another process" in line
    assert resumed.returncode == 2, resumed.stderr
    assert f"cannot resume {out}: it is being written by another process" in one_error_line(resumed.stderr)
    assert writer.returncode == 0, stderr
    written = load_results(out)
    assert written.attrs["vrsweep_complete"] == 1 and written.done.all() and "num: 160" in written.attrs["config"]


@pytest.mark.parametrize("command", ["merge", "simulate", "continue"])
def test_no_command_replaces_a_file_a_running_sweep_writes(slow_config, tmp_path, command, start_writer, invoke,
                                                             write_config):
    """run refused --overwrite of a file another run writes; merge, simulate and continue did
    not: merge --overwrite put the shards' file in its place (the documented way to finish a
    partial merge is a run --resume of that very file), and the run stopped, its points lost."""
    shards = [tmp_path / f"m.shard{i}of2.h5" for i in range(2)]
    for i in range(2):
        assert invoke("run", slow_config, "-o", tmp_path / "m.h5", "--shard", f"{i}/2", "-q",
                      "--set", "transient_periods=1", "--set", "measure_periods=1",
                      "--set", "strobe_periods=1").exit_code == 0
    point = write_config(tmp_path, "parameters: {g: 5.0}\n" + SHORT_WINDOWS, name="point.yaml")
    branch = write_config(tmp_path, """\
        model: effective
        parameters: {Omega: 4.0}
        continuation: {parameter: g, from: 30.0, to: [29.0, 31.0]}
        """, name="branch.yaml")
    out = tmp_path / "ab.h5"
    args = {"merge": ["merge", *shards], "simulate": ["simulate", point],
            "continue": ["continue", branch]}[command]
    writer = start_writer(slow_config, out)
    try:
        still_running(writer)
        proc = run_process("-m", "vrsweep", *args, "-o", out, "--overwrite")
        _, stderr = writer.communicate(timeout=120)
    finally:
        if writer.poll() is None:
            writer.kill()
    assert proc.returncode == 2, proc.stderr
    assert f"cannot replace {out}: it is being written by another process" in one_error_line(proc.stderr)
    assert writer.returncode == 0, stderr
    written = load_results(out)
    assert written.attrs["vrsweep_complete"] == 1 and written.done.all() and "num: 160" in written.attrs["config"]


def test_a_file_a_sweep_starts_writing_during_a_write_is_not_replaced(tmp_path):
    """The rule holds at the rename too: a merge takes minutes, and a sweep that began on its
    output meanwhile (a run --resume) would lose its saved points to the merged file's rename."""
    import fcntl

    from vrsweep.errors import UsageError
    from vrsweep.store.fileio import replacing

    out = tmp_path / "out.h5"
    out.write_bytes(b"a sweep's checkpoint")
    with open(out, "rb") as sweep:  # another open file: its lock is another writer's
        with pytest.raises(UsageError, match="it is being written by another process"):
            with replacing(out) as tmp:
                with open(tmp, "wb") as handle:
                    handle.write(b"merged")
                fcntl.flock(sweep.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)  # the sweep starts
    assert out.read_bytes() == b"a sweep's checkpoint"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.h5"]  # no temporary file left


def test_a_file_that_appears_during_a_write_is_never_replaced_unasked(tmp_path):
    """A path judged empty stays unreplaced to the end: a second merge (or run) of the same
    output that finished first kept its file only until the slower one renamed over it."""
    from vrsweep.errors import UsageError
    from vrsweep.store.fileio import replacing

    out = tmp_path / "out.h5"
    with pytest.raises(UsageError, match="appeared while this command was writing it"):
        with replacing(out) as tmp:
            with open(tmp, "wb") as handle:
                handle.write(b"the slower merge")
            out.write_bytes(b"the faster merge")
    assert out.read_bytes() == b"the faster merge"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.h5"]  # no temporary file left
    # A file that was there when the write began was judged by the output rule: replaced.
    with replacing(out) as tmp:
        with open(tmp, "wb") as handle:
            handle.write(b"with --overwrite")
    assert out.read_bytes() == b"with --overwrite"


def test_two_runs_creating_one_output_at_once_keep_the_first(tmp_path, invoke, write_config, monkeypatch):
    """Two array tasks given the same shard (or one job submitted twice), each with --resume and
    no file yet: the one that renamed its new file second replaced the first's, which then
    stopped (exit 1) with its points lost. Now the second is refused, the first's file kept."""
    import vrsweep.store.writer as writer

    config = write_config(tmp_path, "sweep:\n  g: {start: 0.0, stop: 40.0, num: 3}\n" + SHORT_WINDOWS)
    out = tmp_path / "out.h5"
    original = writer.build_skeleton

    def first_run_creates_it_meanwhile(*args, **kwargs):
        out.write_bytes(b"the first run's file")
        return original(*args, **kwargs)

    monkeypatch.setattr(writer, "build_skeleton", first_run_creates_it_meanwhile)
    result = invoke("run", config, "-o", out, "--resume")
    assert result.exit_code == 2, result.output
    assert "appeared while this command was writing it" in result.stderr and "--overwrite" in result.stderr
    assert "Traceback" not in result.output
    assert out.read_bytes() == b"the first run's file"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.h5", "sweep.yaml"]
    assert h5py.h5f.get_obj_ids(types=h5py.h5f.OBJ_FILE) == []  # the file it built is closed


FIRST_WRITER = """
import sys
import numpy as np
from vrsweep.store import ResultWriter, VariableSpec
spec = VariableSpec("R", np.float64, attrs={"units": "1", "long_name": "response R"})
writer = ResultWriter.create(sys.argv[1], [("g", np.linspace(0.0, 4.0, 5))], [spec], {"config": "x: 1\\n"})
writer.write_points([0], {"R": np.array([1.0])})
print("writing", flush=True)
sys.stdin.readline()
writer.write_points([1], {"R": np.array([2.0])})
writer.close()
"""


def test_two_resumes_at_the_same_moment_never_write_one_file_together(tmp_path, monkeypatch):
    """With HDF5's locking off (NFS, Lustre), two runs resuming one file at the same moment both
    passed the "being written?" test before either locked, and wrote one HDF5 file at once (found
    by starting two --resume runs together: one pair in six). Taking the lock is the test now."""
    import vrsweep.store.fileio as fileio
    from vrsweep.errors import UsageError
    from vrsweep.store import ResultWriter

    monkeypatch.setenv("HDF5_USE_FILE_LOCKING", "FALSE")
    path = tmp_path / "checkpoint.h5"
    first = subprocess.Popen([sys.executable, "-c", FIRST_WRITER, str(path)], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert first.stdout.readline().strip() == "writing", first.stderr.read()
        # The second run made its test a moment before the first took its lock.
        monkeypatch.setattr(fileio, "being_written", lambda path: False)
        # HDF5 reads HDF5_USE_FILE_LOCKING once, when it starts: this process says it per file.
        monkeypatch.setattr(fileio, "hdf5_locking_kwargs", lambda: {"locking": False})
        with pytest.raises(UsageError, match="cannot resume .* it is being written by another process"):
            ResultWriter.open_for_resume(path, "x: 1\n")
        _, stderr = first.communicate("go on\n", timeout=60)
    finally:
        if first.poll() is None:
            first.kill()
    assert first.returncode == 0, stderr
    assert h5py.h5f.get_obj_ids(types=h5py.h5f.OBJ_FILE) == []  # the refused one closed its file
    assert load_results(path).done.values.tolist() == [1, 1, 0, 0, 0]


def test_a_file_replaced_under_a_running_sweep_stops_it_and_stays_untouched(slow_config, tmp_path, start_writer):
    """What --overwrite did before (or any other process can do): the path now names another
    file. The writer stops at its next chunk with one line, and never writes to the new file."""
    out = tmp_path / "ab.h5"
    intruder = tmp_path / "intruder.bin"
    intruder.write_bytes(b"someone else's file\n")
    writer = start_writer(slow_config, out)
    try:
        still_running(writer)
        os.replace(intruder, out)
        _, stderr = writer.communicate(timeout=120)
    finally:
        if writer.poll() is None:
            writer.kill()
    assert writer.returncode == 1, stderr
    line = one_error_line(stderr)
    assert f"{out} was replaced by another file while this run was writing it" in line
    assert out.read_bytes() == b"someone else's file\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ab.h5"]  # no temporary file either


def test_an_output_folder_removed_under_a_running_sweep_stops_it(slow_config, tmp_path, start_writer):
    """A scratch purge takes the folder while the sweep runs: one line, exit 1."""
    folder = tmp_path / "scratch"
    folder.mkdir()
    out = folder / "ab.h5"
    writer = start_writer(slow_config, out)
    try:
        still_running(writer)
        shutil.rmtree(folder)
        _, stderr = writer.communicate(timeout=120)
    finally:
        if writer.poll() is None:
            writer.kill()
    assert writer.returncode == 1, stderr
    line = one_error_line(stderr)
    assert f"{out} is gone: its folder {folder} was removed" in line
    assert not folder.exists()  # not recreated behind the purge's back


# --------------------------------------------------------------------------------------------
# kill -9 while the file is being created
# --------------------------------------------------------------------------------------------

# `vrsweep run` whose file creation stops half-way (after the coordinates and some variables)
# and waits there to be killed.
STUCK_IN_CREATION = ("-c", """
import sys, time
import vrsweep.store.layout as layout
original = layout._create_point_variable
made = []
def slow(*args, **kwargs):
    made.append(1)
    if len(made) == 3:
        args[0].flush()
        print("creating", flush=True)
        time.sleep(120)
    return original(*args, **kwargs)
layout._create_point_variable = slow
from vrsweep.cli import main
sys.exit(main(sys.argv[1:], prog_name="vrsweep"))
""")


def test_kill_9_while_creating_leaves_a_temporary_file_that_the_next_run_removes(tmp_path, invoke, write_config):
    config = write_config(tmp_path, "sweep:\n  g: {start: 0.0, stop: 40.0, num: 3}\n" + SHORT_WINDOWS)
    out = tmp_path / "out.h5"
    child = subprocess.Popen([sys.executable, *STUCK_IN_CREATION, "run", str(config), "-o", str(out)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == "creating", child.stderr.read()
        child.send_signal(signal.SIGKILL)
        child.communicate(timeout=30)
    finally:
        if child.poll() is None:
            child.kill()
    left = [p for p in tmp_path.iterdir() if p.name.startswith(".out.h5.")]
    assert len(left) == 1 and f".{child.pid}." in left[0].name and left[0].name.endswith(".tmp")
    assert not out.exists()

    result = invoke("run", config, "-o", out)
    assert result.exit_code == 0, result.output
    assert f"Removed {left[0]}, left by an interrupted vrsweep (process {child.pid})" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.h5", "sweep.yaml"]
    assert load_results(out).attrs["vrsweep_complete"] == 1


def test_a_temporary_file_of_another_host_is_named_not_removed(tmp_path, invoke, write_config):
    """A temporary file written on another node of a shared file system, or by a vrsweep of
    unknown host: its writer's state cannot be told from here."""
    config = write_config(tmp_path, SHORT_WINDOWS)
    out = tmp_path / "out.h5"
    foreign = tmp_path / f".out.h5.node17.4242.{uuid.uuid4().hex[:8]}.tmp"
    older = tmp_path / f".out.h5.4243.{uuid.uuid4().hex[:8]}.tmp"
    unrelated = tmp_path / f".other.h5.node17.4242.{uuid.uuid4().hex[:8]}.tmp"
    for path in (foreign, older, unrelated):
        path.write_bytes(b"partial")
    result = invoke("run", config, "-o", out, "-q")
    assert result.exit_code == 0, result.output
    notes = result.stderr.strip().splitlines()
    assert notes == [
        f"Note: {older} looks like a temporary file left by vrsweep (process 4243); "
        "delete it if that process is no longer running",
        f"Note: {foreign} looks like a temporary file left by vrsweep (process 4242 on node17); "
        "delete it if that process is no longer running",
    ]
    assert foreign.exists() and older.exists() and unrelated.exists()


def test_a_file_of_the_users_named_like_a_temporary_one_is_never_removed(tmp_path, capfd):
    """clean_stale_temporaries judged a name by its pattern alone: a file of the user's named
    .out.h5.HOST.PID.8HEX.tmp (PID a process gone) was removed, by any write of out.h5 (a run, a
    figure). Only a name vrsweep signed is removed now; the file of the user's is named once, kept."""
    from vrsweep.store.fileio import _HOST, clean_stale_temporaries, temporary_path, write_bytes

    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    out = tmp_path / "out.h5"
    users = tmp_path / f".out.h5.{_HOST}.{gone.pid}.0123abcd.tmp"
    users.write_bytes(b"the user's notes")
    real = tmp_path / os.path.basename(temporary_path(out))  # this process: a live writer's, kept silently
    real.write_bytes(b"partial")
    capfd.readouterr()
    clean_stale_temporaries(out)
    err = capfd.readouterr().err
    assert users.read_bytes() == b"the user's notes" and real.exists()
    assert f"Note: {users} looks like a temporary file left by vrsweep (process {gone.pid} on {_HOST})" in err
    write_bytes(tmp_path / "out.h5", b"x")  # any write of the output: the note is not repeated
    assert users.exists() and str(users) not in capfd.readouterr().err


def test_a_temporary_file_vrsweep_signed_is_removed_when_its_writer_is_gone(tmp_path, capfd):
    from vrsweep.store import fileio

    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    out = tmp_path / "out.h5"
    tag = "89abcdef"  # the name a process now gone gave its temporary file, as temporary_path makes it
    signature = fileio._signature("out.h5", fileio._HOST, gone.pid, tag)
    left = str(tmp_path / f".out.h5.{fileio._HOST}.{gone.pid}.{tag}{signature}.tmp")
    assert len(os.path.basename(left)) == len(os.path.basename(fileio.temporary_path(out))) - len(str(os.getpid())) \
        + len(str(gone.pid))
    with open(left, "wb") as handle:
        handle.write(b"partial")
    fileio.clean_stale_temporaries(out)
    assert not os.path.exists(left)
    assert f"Removed {left}, left by an interrupted vrsweep (process {gone.pid})" in capfd.readouterr().err


def test_a_reader_never_blocks_an_overwrite(slow_config, tmp_path, invoke):
    """Only a writer's lock refuses --overwrite: a file held open for reading is replaced."""
    out = tmp_path / "read.h5"
    assert invoke("run", slow_config, "-o", out, "-q", "--set", "transient_periods=1",
                  "--set", "measure_periods=1", "--set", "strobe_periods=1").exit_code == 0
    with h5py.File(out, "r"):
        result = invoke("run", slow_config, "-o", out, "-q", "--overwrite", "--set", "transient_periods=1",
                        "--set", "measure_periods=2", "--set", "strobe_periods=1")
    assert result.exit_code == 0, result.output
    assert "measure_periods: 2" in load_results(out).attrs["config"]


# --------------------------------------------------------------------------------------------
# The mechanism behind a clean stop on a full disk
# --------------------------------------------------------------------------------------------


def test_closing_without_writing_keeps_the_checkpoint_of_the_last_flush(tmp_path):
    """After a failed write HDF5 must be closed without writing what it still holds (on a full
    disk that write fails again, and the library then crashes at exit). The file keeps the state
    of its last flush: the points marked done then, and nothing of what came after."""
    import numpy as np

    from vrsweep.store.fileio import close_without_writing
    from vrsweep.store import ResultWriter, VariableSpec

    path = tmp_path / "checkpoint.h5"
    spec = VariableSpec("R", np.float64, attrs={"units": "1", "long_name": "response R"})
    writer = ResultWriter.create(path, [("g", np.linspace(0.0, 4.0, 5))], [spec], {"config": "x: 1\n"})
    writer.write_points([0, 1], {"R": np.array([1.0, 2.0])})  # flushed, marked done
    done = writer._file["done"]  # open, as in the frame of a write that failed: HDF5 keeps
    done[2] = 1  # this write in the dataset's chunk cache until the dataset is closed
    writer._file.attrs["unsaved"] = 1
    close_without_writing(writer._file)
    del done

    assert h5py.h5f.get_obj_ids(types=h5py.h5f.OBJ_FILE) == []
    checkpoint = load_results(path)
    assert checkpoint.done.values.tolist() == [1, 1, 0, 0, 0]
    assert checkpoint["R"].values[:2].tolist() == [1.0, 2.0] and "unsaved" not in checkpoint.attrs
    writer._file = None  # closed above


@pytest.mark.parametrize("sweep", [
    "parameters: {g: 5.0}\n",                                                    # one point
    "sweep:\n  g: {start: 0.0, stop: 40.0, num: 9}\n",
    "sweep:\n  g: {start: 0.0, stop: 40.0, num: 200}\n  Omega: {start: 1.0, stop: 10.0, num: 50}\n"
    "integration: {strobe_periods: 32}\n",                                       # the 10^4
    "sweep:\n  g: {start: 0.0, stop: 40.0, num: 1000}\n  Omega: {start: 1.0, stop: 10.0, num: 100}\n",
])
def test_the_space_reserved_covers_the_file_and_its_finishing(tmp_path, monkeypatch, sweep):
    """HDF5 must never meet a full disk (it cannot recover), so a file's space is allocated
    before HDF5 writes: creation_reserve must bound the new file, layout_bytes from below, and
    finish_reserve what finishing adds. Checked on real files from 1 to 10^5 points."""
    import vrsweep.store.fileio
    import vrsweep.store.writer
    from vrsweep.config import parse_config
    from vrsweep.execution.job import _axes, _variable_specs, analytic_extras, root_attributes
    from vrsweep.store import ResultWriter, creation_reserve, finish_reserve, layout_bytes
    from vrsweep.execution.sweep import Grid

    config = parse_config(sweep, "sizes.yaml")
    grid = Grid.from_config(config)
    axes, specs = _axes(grid), _variable_specs(config)
    path = tmp_path / "sizes.h5"
    writer = ResultWriter.create(path, axes, specs, root_attributes(config))
    created = path.stat().st_size
    assert layout_bytes(axes, specs) <= created <= creation_reserve(axes, specs)
    if grid.n_points >= 10_000:  # where a full disk matters, the bounds are tight
        assert creation_reserve(axes, specs) < 1.06 * created
    extras = analytic_extras(config, grid)
    plain = tmp_path / "plain.h5"  # made and finished without reserving: the sizes to end with
    with monkeypatch.context() as patch:
        for module in (vrsweep.store.fileio, vrsweep.store.writer):
            patch.setattr(module, "reserve_space", lambda *args, **kwargs: None)
        plain_writer = ResultWriter.create(plain, axes, specs, root_attributes(config))
        assert plain.stat().st_size == created  # what was reserved and not used is given back
        plain_writer.finish(extra=extras)
    writer.finish(extra=extras)
    assert path.stat().st_size == plain.stat().st_size
    assert 0 < path.stat().st_size - created <= finish_reserve(extras)
    # Finished with no point written (only sizes matter here): a reader refuses such a file as
    # corrupt (a finished file has every point done), so its mark is read plainly.
    with h5py.File(path, "r") as f:
        assert f.attrs["vrsweep_complete"] == 1
