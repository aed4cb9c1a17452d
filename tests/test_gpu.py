"""The GPU target (numerics/cuda.py, docs/gpu.md), tested without a GPU.

- In numba's CUDA simulator the GPU's line kernel gives the CPU's results bit for bit with rk45
  (the same source: kernel._integrate with the same functions), for the paper's model with and
  without the tangent vectors, a written model with two barriers and a hysteresis line; dop853 on
  the GPU evaluates the forcing by the library where the CPU rotates it, and agrees to the tolerance.
- The kernel compiles to PTX for sm_90 (an H100 / H200) and ptxas assembles it: a change that
  breaks the GPU build fails here, on a machine without one.
- Asking for the GPU where there is none is one line and exit 2, before anything is written.

Speed and agreement on a real card: benchmarks/gpu.py (benchmarks/README.md).
"""

import itertools
import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from vrsweep.numerics import kernel, rhs

HERE = Path(__file__).resolve().parent
EXAMPLES = HERE.parent / "vrsweep" / "examples"

numba_cuda = pytest.importorskip("numba_cuda", reason="the extra vrsweep[cuda] (numba-cuda) is not installed")

SMALL_MAP = """
sweep:
  g: {values: [5.0, 20.0, 30.0]}
  Omega: {values: [3.5, 4.0]}
"""
BASIN_MAP = SMALL_MAP + "  x0: {values: [-0.5, 0.99]}\n"  # an initial-state axis, as basins have
HYSTERESIS_LINE = """
sweep:
  g: {start: 20.0, stop: 30.0, num: 3, continuation: up}
"""


def _simulated(tmp_path, text_or_path, method, lyapunov, line_length, transient_periods=4, local_coefficients=False,
               measure_periods=16):
    if isinstance(text_or_path, Path):
        config = text_or_path
    else:
        config = tmp_path / "gpu.yaml"
        config.write_text(textwrap.dedent(text_or_path))
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    done = subprocess.run([sys.executable, str(HERE / "gpu_simulated.py"), str(config), method, lyapunov,
                           str(line_length), str(transient_periods), str(local_coefficients).lower(),
                           str(measure_periods)],
                          capture_output=True, text=True, env=env, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    return ({key: np.array(value, dtype=float) for key, value in result["cpu"].items()},
            {key: np.array(value, dtype=float) for key, value in result["gpu"].items()})


# A bilinear spring with friction and a barrier: its switching functions x - d (a kink) and v (a
# jump) change sign every period, and the frozen mode holds their sides for the steps around them.
KINKED = """
model:
  acceleration: "-2*zeta*v - x - k*max(x - d, 0) - mu*sign(v) + F*cos(omega*t)"
  parameters: {zeta: 0.05, k: 3.0, d: 0.5, mu: 0.02, F: 1.0, omega: 0.8, Delta: 1.2, r: 0.8}
  barriers: [{position: Delta, side: above, restitution: r}]
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
sweep:
  F: {values: [0.8, 1.0, 1.2]}
"""

# Stick-slip on a belt (v = belt, on the fixed floor at belt = 0): the kernel follows the sliding
# motion (tests/test_written_sliding.py), two sticks a period, with the tangent vectors.
STICK_SLIP = """
model:
  acceleration: "-2*zeta*v - x - mu*sign(v - belt) + F*cos(omega*t)"
  parameters: {zeta: 0.05, mu: 0.6, F: 1.0, omega: 0.5, belt: 0.2}
  period: "2*pi/omega"
  response: {frequency: omega, scale: F}
sweep:
  belt: {values: [0.0, 0.1, 0.2]}
"""


@pytest.mark.parametrize("case, config, method, lyapunov, line_length, local_coefficients", [
    ("original, with an initial-state axis", BASIN_MAP, "rk45", "false", 1, False),
    ("original, tangent vectors", SMALL_MAP, "rk45", "true", 1, False),
    ("original, hysteresis line", HYSTERESIS_LINE, "rk45", "false", 3, False),
    ("written, two barriers", EXAMPLES / "impact_two_sided.yaml", "rk45", "false", 1, False),
    # cuda.LOCAL_COEFFICIENTS: the loop reads a thread's copy of its point's coefficients
    ("written, two barriers, coefficients copied", EXAMPLES / "impact_two_sided.yaml", "rk45", "false", 1, True),
    # A kink (max) and a jump (sign) the CPU's kernel locates as events, with the tangent vectors
    # (the frozen mode's Jacobian): the GPU's locates them the same way.
    ("written, a kink and a jump, tangent vectors", KINKED, "rk45", "true", 1, False),
    ("written, stick-slip, tangent vectors", STICK_SLIP, "rk45", "true", 1, False),
])
def test_the_gpu_kernel_gives_the_cpu_results_bit_for_bit(tmp_path, case, config, method, lyapunov, line_length,
                                                          local_coefficients):
    if isinstance(config, Path):  # a written model's example: a few of its points
        text = config.read_text().split("sweep:")[0] + "sweep:\n  F: {values: [0.3, 1.5, 2.5]}\n"
        config = text
    # 2 + 4 periods, not 4 + 16: the simulator runs each thread's steps in Python (~750 steps a period
    # of the paper's model), and every case still has its kind of events at each point where it
    # had them over 20 periods (measured on the CPU: 6 to 48 impacts at each impacting point, both
    # stops of the two-sided model, 12 sticks a point on the belt, rejected steps everywhere).
    cpu, gpu = _simulated(tmp_path, config, method, lyapunov, line_length, local_coefficients=local_coefficients,
                          transient_periods=2, measure_periods=4)
    assert (cpu["statuses"] == 0).all(), cpu["statuses"]  # Status.OK: the comparison is of real runs
    events = cpu["summaries"][..., kernel.SUM_STICKS if "stick-slip" in case else kernel.SUM_IMPACTS]
    assert (events > 0).any(), (case, events)  # runs with the case's events (impacts, or sticks on the belt)
    for key in ("statuses", "summaries", "records"):
        np.testing.assert_array_equal(gpu[key], cpu[key], err_msg=f"{case}: {key}")


def test_entries_a_failed_point_leaves_are_nan_on_the_gpu_as_on_the_cpu(tmp_path):
    """A point stopped by its step cap leaves its later periods' records unwritten: NaN on the CPU
    (its caller fills them), and NaN on the GPU, whose kernel fills its outputs on the card
    (cuda.fill_nan) while the host's arrays hold anything (gpu_simulated.GARBAGE)."""
    cpu, gpu = _simulated(tmp_path, SMALL_MAP + "integration: {max_steps: 6000}\n", "rk45", "false", 1)
    assert (cpu["statuses"] != 0).all(), cpu["statuses"]  # Status.OK is 0
    assert np.isnan(cpu["records"]).any() and not np.isnan(cpu["records"]).all()
    for key in ("statuses", "summaries", "records"):
        np.testing.assert_array_equal(gpu[key], cpu[key], err_msg=key)


def _simulated_run(tmp_path, mode, config_text, *arguments):
    """gpu_simulated.py's ``mode`` (sweep, slots, job) on a config in numba's CUDA simulator: its JSON."""
    config = tmp_path / "gpu.yaml"
    config.write_text(textwrap.dedent(config_text))
    done = subprocess.run([sys.executable, str(HERE / "gpu_simulated.py"), mode, str(config), *arguments],
                          capture_output=True,
                          text=True, env=dict(os.environ, NUMBA_ENABLE_CUDASIM="1"), timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_the_job_on_the_gpu_hands_every_chunk_over_once_in_order_with_the_cpu_s_values(tmp_path):
    """On a GPU run_sweep launches the next chunk before it finishes the last (the host's diagnostics
    and writing overlap the card's work): every point is handed to on_chunk exactly once, the chunks
    in the order they were cut, growing from two points, and each point's values are the CPU's bit
    for bit (rk45)."""
    result = _simulated_run(tmp_path, "sweep",
                            BASIN_MAP.replace("[5.0, 20.0, 30.0]", "[5.0, 12.0, 20.0, 25.0, 30.0, 35.0]"))
    handed = result["cuda"]["handed"]
    sizes = [len(chunk) for chunk in handed]
    assert sizes[:2] == [2, 2] and max(sizes) > 2 and len(handed) >= 4, sizes
    flat = [index for chunk in handed for index in chunk]
    assert sorted(flat) == list(range(24))
    # cut in order: the same sequence as the CPU's run of the grid's shuffled lines
    assert flat == [index for chunk in result["cpu"]["handed"] for index in chunk]
    assert result["cuda"]["values"] == result["cpu"]["values"]
    assert set(result["cpu"]["values"]["status"].values()) == {0.0}


def test_on_the_gpu_the_solver_errors_tight_run_starts_beside_the_grid_and_gives_the_cpus_estimate(tmp_path):
    """execution/job.py's SolverErrorSample: on a GPU the tight run of R_solver_err's sample starts
    once the grid's first lines are written (after the first chunk, with chunks left to run), not
    as a launch of its own at the end; the file's estimate is the CPU run's, bit for bit, whose
    tight run still starts at the end."""
    result = _simulated_run(tmp_path, "job", "model: effective\n" + SMALL_MAP.replace(
        "[5.0, 20.0, 30.0]", "[5.0, 10.0, 15.0, 20.0, 25.0, 30.0]"), str(tmp_path))
    gpu, cpu = result["cuda"], result["cpu"]
    assert len(gpu["started_after"]) == 1 and 1 <= gpu["started_after"][0] < gpu["chunks"], gpu
    assert cpu["started_after"] == [cpu["chunks"]], cpu
    assert gpu["attributes"]["R_solver_err_points"] > 0, gpu
    assert gpu["attributes"] == cpu["attributes"]


def test_launches_in_flight_keep_their_slots_and_give_fresh_arrays_values(tmp_path):
    """DeviceLines keeps a launch's device arrays for the next (an allocation between two launches
    keeps CUDA from running them at once): two launches in flight hold two slots; a larger chunk
    replaces a slot's arrays, a smaller one uses their first rows; every chunk's outputs are those
    of fresh arrays and of the CPU, bit for bit."""
    result = _simulated_run(tmp_path, "slots", SMALL_MAP.replace("[3.5, 4.0]", "[3.5, 4.0, 4.5]"))
    assert result["slots_in_flight"] == 2 and result["slots"] == 2
    assert result["reallocated"] == [True, False]  # 6 lines fit in no slot; 1 line fits in the first
    assert [len(chunk["kept"]["statuses"]) for chunk in result["chunks"]] == [4, 2, 6, 1]
    for k, chunk in enumerate(result["chunks"]):
        assert chunk["kept"] == chunk["fresh"] == chunk["cpu"], k
        assert {status for row in chunk["kept"]["statuses"] for status in row} == {0}


def test_dop853_on_the_gpu_agrees_with_the_cpu_to_the_tolerance(tmp_path):
    """The GPU's dop853 calls cos at every stage (no 68 kB rotation table per thread), so its steps
    are not the CPU's: where the orbit is periodic in both runs, R agrees to the tolerance's level
    and the period is the same; statuses agree everywhere."""
    from vrsweep.analysis.diagnostics import detect_period

    cpu, gpu = _simulated(tmp_path, SMALL_MAP + "integration: {rtol: 1.0e-10, atol: 1.0e-12}\n", "dop853", "false",
                          1, transient_periods=100)
    np.testing.assert_array_equal(gpu["statuses"], cpu["statuses"])

    def periods(records):
        strobe = records[:, 0, :, :]
        return detect_period(strobe[:, :, kernel.REC_X], strobe[:, :, kernel.REC_V], 8, 1e-6)

    period_cpu, period_gpu = periods(cpu["records"]), periods(gpu["records"])
    periodic = (period_cpu > 0) & (period_gpu > 0)
    assert periodic.sum() >= 3, (period_cpu, period_gpu)
    np.testing.assert_array_equal(period_gpu[periodic], period_cpu[periodic])
    r_cpu = cpu["summaries"][:, 0, kernel.SUM_R][periodic]
    r_gpu = gpu["summaries"][:, 0, kernel.SUM_R][periodic]
    # Two converged runs of an 8th-order method at rtol 1e-10: R (a Fourier component ~1e-3 of x
    # at large g) agrees to 1e-6 relative (on an H100, 2000 periodic points at rtol 1e-9: 1e-7 at most).
    np.testing.assert_allclose(r_gpu, r_cpu, rtol=1e-6)
    assert not np.array_equal(r_gpu, r_cpu)  # the two really differ in their steps


def _ptxas():
    from cuda.pathfinder import find_nvidia_binary_utility

    return find_nvidia_binary_utility("ptxas")


@pytest.mark.parametrize("method, options", [("rk45", {}), ("rk45", {"local_coefficients": True}),
                                             ("rk45", {"hold": 8}), ("dop853", {})],
                         ids=["default", "local coefficients", "branches held", "dop853"])
def test_the_line_kernel_compiles_for_an_h100_and_assembles(tmp_path, method, options):
    """compile_ptx for sm_90 without a GPU (vrsweep.numerics.cuda.compile_for), then ptxas: the
    resource report names the kernel; its local memory is the work arrays' and little more: at
    most 768 bytes (rk45: 608 since 0.6.7, with one impact-test bracket of the method's size;
    1,056 with two of the largest). A change that brings a larger workspace into a thread fails
    here: the impact test's stack of pieces took 8.1 kB, and dop853's rotation table, 68 kB, must
    never come into a thread. The coefficients' copy (cuda.LOCAL_COEFFICIENTS) is 0.5 kB more.
    With the branches held (cuda.HOLD_LANES), the step and its branches are apart in the loop's
    passes, and the kernel needs 216 registers and spills none (0.6.8): a change that brings
    spills back fails here. The default kernel spills none either (254 registers): in 0.7.7 a
    rejected step froze a smooth model's mode at 0 (rhs.no_switches), the frozen branches stayed
    alive in the paper's kernel, and it spilled 8 bytes. dop853's kernel spills none since 0.7.11
    (250 registers; 280/396 bytes of spills when the dense output was called at four places)."""
    from vrsweep.numerics import cuda

    ptx = cuda.compile_for(method, False, *rhs.paper_functions(False), compute_capability=(9, 0), **options)
    assert ".target sm_90" in ptx
    assert "vote.sync" in ptx  # the warp's lanes gathered at every pass (gather_warp)
    if options.get("hold"):
        assert "vote.sync.ballot" in ptx  # the lanes waiting, counted
    ptxas = _ptxas()
    if ptxas is None:
        pytest.skip("ptxas is not installed (cuda-toolkit[nvcc])")
    source = tmp_path / "lines.ptx"
    source.write_text(ptx)
    done = subprocess.run([ptxas, "-arch=sm_90", "-v", str(source), "-o", str(tmp_path / "lines.cubin")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    report = done.stderr + done.stdout
    entry = report[report.index("Compiling entry function"):]
    frame = int(re.search(r"(\d+) bytes stack frame", entry).group(1))
    registers = int(re.search(r"Used (\d+) registers", entry).group(1))
    assert registers <= 255
    copy = 8 * cuda.LOCAL_COEFFICIENTS_SIZE if options.get("local_coefficients") else 0
    assert frame <= 768 + copy, entry[:2000]
    if options.get("hold") or not options:
        spills = [int(n) for n in re.search(r"(\d+) bytes spill stores, (\d+) bytes spill loads", entry).groups()]
        assert spills == [0, 0], entry[:2000]


def test_a_kernel_reading_a_local_copy_of_the_coefficients_refuses_a_wider_row():
    """cuda.LOCAL_COEFFICIENTS: the thread's copy holds LOCAL_COEFFICIENTS_SIZE values; a model with
    more is refused before anything reaches the device (and the default kernel reads any width)."""
    from vrsweep.numerics import cuda

    kernel_ = cuda.line_kernel("rk45", False, *rhs.paper_functions(False), local_coefficients=True)
    assert kernel_.local_coefficients is True
    assert cuda.line_kernel("rk45", False, *rhs.paper_functions(False)).local_coefficients is False
    n = 1
    wide = np.zeros((n, cuda.LOCAL_COEFFICIENTS_SIZE + 1))
    with pytest.raises(ValueError, match="LOCAL_COEFFICIENTS_SIZE"):
        cuda.DeviceLines(kernel_).launch(wide, np.zeros((n, 2)), np.zeros(16), np.zeros((n, 1), dtype=np.int64),
                                         np.empty((n, 1, 4, kernel.N_RECORD)), np.empty((n, 1, kernel.N_SUMMARY)),
                                         np.empty((n, 1), dtype=np.int8))


def test_the_warp_vote_is_on_but_for_the_effective_model():
    """cuda.GATHER_LANES_BY_MODEL: measured slower on the effective model's kernel (an H100), it is
    off there; on for the original model and for written ones. Choosing compiles nothing."""
    from vrsweep.config import parse_config
    from vrsweep.numerics.models import kernels_for

    assert kernels_for("original").gpu_lines("rk45").kernel.gather is True
    assert kernels_for("original").gpu_lines("dop853", True).kernel.gather is True
    assert kernels_for("effective").gpu_lines("dop853").kernel.gather is False
    written = parse_config((EXAMPLES / "impact_two_sided.yaml").read_text(), "impact_two_sided.yaml").model
    assert kernels_for(written).gpu_lines("rk45").kernel.gather is True


def test_the_gpu_kernels_are_files_that_numba_caches_one_per_kernel():
    """numba caches a kernel by its source file: an exec'd string cannot be cached (numba-cuda
    refuses it, "no locator available"). Each kernel's source is a module file in numba's cache
    folder, named by a digest of its text, so a kernel of another method, model, option or register
    cap is another file, and caching is on for every one of them (written models' too)."""
    from numba.cuda.dispatcher import CUDACache

    from vrsweep.config import parse_config
    from vrsweep.numerics import cuda, numba_cache
    from vrsweep.numerics.models import kernels_for

    if not numba_cache.enabled():
        pytest.skip("numba's cache is off here: the kernels' files go to a temporary folder, uncached")
    written = parse_config((EXAMPLES / "impact_two_sided.yaml").read_text(), "impact_two_sided.yaml").model
    kernels = [kernels_for("original").gpu_kernel("rk45"), kernels_for("original").gpu_kernel("dop853", True),
               kernels_for("effective").gpu_kernel("dop853"), kernels_for(written).gpu_kernel("rk45"),
               cuda.line_kernel("rk45", False, *rhs.paper_functions(False), max_registers=128)]
    files = [Path(k.py_func.__code__.co_filename) for k in kernels]
    assert len(set(files)) == len(files)
    for k, file in zip(kernels, files):
        assert file.is_file() and file.parent.parent == numba_cache.cache_dir()
        assert isinstance(k._cache, CUDACache)
    assert "max_registers: 128" in files[-1].read_text()
    # The same kernel asked for again is the same dispatcher (one compile per process).
    assert kernels_for("original").gpu_kernel("rk45") is kernels[0]


def test_the_compile_notice_looks_where_numba_cuda_keeps_the_kernel(monkeypatch):
    """`vrsweep run --device cuda` says the CUDA kernel compiles first unless numba's cache holds
    it: the hint looks for the index file at the path numba-cuda's own cache reads."""
    from vrsweep.numerics import cuda
    from vrsweep.numerics.models import kernels_for

    kernel_ = kernels_for("original").gpu_kernel("dop853")
    index = Path(kernel_._cache._cache_file._index_path)
    if index.exists():
        pytest.skip("this machine has compiled the kernel for a GPU")
    assert not kernels_for("original").is_cached("dop853", device="cuda")
    index.parent.mkdir(parents=True, exist_ok=True)
    index.touch()
    try:
        assert kernels_for("original").is_cached("dop853", device="cuda")
        monkeypatch.setattr(cuda, "CACHE_KERNELS", False)
        assert not kernels_for("original").is_cached("dop853", device="cuda")
    finally:
        index.unlink()


def test_a_kernel_the_cache_fails_on_compiles_without_it(monkeypatch):
    """cuda.ready_kernel: where loading or saving the cached kernel raises, the same source compiles
    without the cache (as up to 0.6.3), and the dispatcher launched says why; a compile that fails
    without the cache too is the run's error."""
    import pickle

    from vrsweep.numerics import cuda

    compiled = []

    class Uncached:
        def compile(self, signature):
            compiled.append(signature)

    class Cached:
        queue, gather, local_coefficients, hold = True, False, False, 0

        def compile(self, signature):
            raise pickle.PicklingError("cannot pickle the kernel's library")

        def without_cache(self):
            return Uncached()

    class Loaded:
        def bind(self):
            raise RuntimeError("CUDA_ERROR_INVALID_IMAGE")

    class Unloadable(Cached):
        def compile(self, signature):
            return Loaded()

    monkeypatch.setattr(cuda, "_READY", {})
    assert isinstance(cuda.ready_kernel(Unloadable()), Uncached)  # loaded from the cache, not loadable
    assert cuda.ready_kernel(Unloadable()).cache_failure == "RuntimeError: CUDA_ERROR_INVALID_IMAGE"
    compiled.clear()
    cached = Cached()
    ready = cuda.ready_kernel(cached)
    assert isinstance(ready, Uncached) and compiled == [cuda.kernel_signature()]
    assert ready.queue is True and ready.gather is False
    assert ready.cache_failure == "PicklingError: cannot pickle the kernel's library"
    assert cuda.ready_kernel(cached) is ready and len(compiled) == 1  # once per process

    class Broken(Cached):
        def without_cache(self):
            class Failing:
                def compile(self, signature):
                    raise RuntimeError("the kernel does not compile")
            return Failing()

    with pytest.raises(RuntimeError, match="does not compile"):
        cuda.ready_kernel(Broken())


@pytest.mark.parametrize("options", [["-q"], ["--dry-run"]])
def test_asking_for_the_gpu_where_there_is_none_is_one_line_and_exit_2(tmp_path, invoke, write_config, options):
    """One line, exit 2, no file; a dry run does not first announce a compile that never comes."""
    from numba import cuda as numba_cuda_target

    if numba_cuda_target.is_available():
        pytest.skip("this machine has a GPU")
    config = write_config(tmp_path, SMALL_MAP)
    result = invoke("run", config, "-o", tmp_path / "out.h5", "--device", "cuda", *options)
    assert result.exit_code == 2, result.output
    assert "integration.device: cuda:" in result.output
    assert len(result.output.strip().splitlines()) == 1, result.output
    assert not (tmp_path / "out.h5").exists()  # checked before anything is written


def test_integration_device_is_a_config_key(tmp_path, invoke, write_config):
    config = write_config(tmp_path, SMALL_MAP + "integration: {device: tpu}\n")
    result = invoke("validate", config)
    assert result.exit_code == 2
    assert "integration.device" in result.output and "cuda" in result.output


def test_the_default_device_leaves_the_config_text_as_before():
    from vrsweep.config import parse_config

    config = parse_config(textwrap.dedent(SMALL_MAP))
    assert config.integration.device == "cpu"
    assert "device" not in config.to_yaml()  # files written before the key keep their text (resume)
    assert "device: cuda" in parse_config(textwrap.dedent(SMALL_MAP) + "integration: {device: cuda}\n").to_yaml()


def test_a_gpu_failing_during_a_run_is_the_runs_failure_in_one_line(monkeypatch):
    """Out of device memory, a driver or launch error: RunFailed (exit 1), whose message the command
    completes with what was saved; the chunks written before stay (the job's writer, as on the CPU)."""
    from vrsweep.errors import RunFailed
    from vrsweep.execution import device

    class Failing:
        """A device whose chunk fails at its launch (copies, allocation) or at the wait (the kernel)."""

        def __init__(self, error, at):
            self.error, self.at = error, at

        def gpu_lines(self, method, lyapunov):
            failing = self

            class Launch:
                def wait(self):
                    raise failing.error

            class Lines:
                def launch(self, *arrays):
                    if failing.at == "launch":
                        raise failing.error
                    return Launch()

            return Lines()

    monkeypatch.setattr(device, "check_device", lambda name: None)
    for (error, words), at in itertools.product(
            ((MemoryError("cuMemAlloc results in CUDA_ERROR_OUT_OF_MEMORY"), "ran out of memory"),
             (RuntimeError("CUDA_ERROR_LAUNCH_FAILED\nmore lines"), "the GPU failed (RuntimeError: "
                                                                    "CUDA_ERROR_LAUNCH_FAILED)")),
            ("launch", "wait")):
        run_lines = device.gpu_lines(Failing(error, at), "rk45", False)
        with pytest.raises(RunFailed) as caught:
            run_lines()
        assert words in str(caught.value) and "\n" not in str(caught.value)
