"""Where a sweep runs: integration.device (``cpu``, or ``cuda``: an NVIDIA GPU, docs/gpu.md).

The GPU's kernels are numerics/cuda.py's; this module decides whether they can run here, says in
one line why not, and turns a failure of the device during a run into the run's failure after the
chunks finished so far were saved (``--resume`` computes the rest, on the GPU or, with
``integration.device`` changed, nowhere else: a file's points come from one device).
"""

from __future__ import annotations

from vrsweep.errors import RunFailed, UsageError

INSTALL_HINT = 'pip install "vrsweep[cuda]"'


def cuda_problem() -> str | None:
    """Why a sweep cannot run on a CUDA GPU here, or None if it can: numba-cuda missing, no driver,
    no GPU (numba's CUDA simulator, NUMBA_ENABLE_CUDASIM=1, counts as a GPU: tests)."""
    import numba

    # numerics/cuda.py builds the GPU's kernels from the CPU kernel's compiled functions (their
    # py_func), which NUMBA_DISABLE_JIT=1 leaves as plain functions: importing it was a traceback.
    if numba.config.DISABLE_JIT:
        return ("NUMBA_DISABLE_JIT=1 turns numba's compiler off, and the GPU's kernel is compiled by it: "
                "unset it, or run on the cpu")
    try:
        from numba import cuda
    except ImportError as error:  # numba without its CUDA target
        return f"numba's CUDA target is not installed ({error}); install the extra: {INSTALL_HINT}"
    try:
        import numba_cuda  # noqa: F401 - the maintained CUDA target, which the extra installs
    except ImportError:
        return f"numba-cuda is not installed; install the extra: {INSTALL_HINT}"
    try:
        if cuda.is_available():
            return None
    except Exception as error:  # noqa: BLE001 -- numba-cuda raises several kinds; all mean "no GPU"
        return f"no usable CUDA GPU ({str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__})"
    return "no CUDA GPU or driver was found on this machine"


def check_device(device: str) -> None:
    """UsageError (exit 2), before anything is written, when integration.device cannot run here."""
    if device != "cuda":
        return
    problem = cuda_problem()
    if problem is not None:
        raise UsageError(f"integration.device: cuda: {problem}")


def gpu_memory_bytes() -> int:
    """The smaller of the card's memory and what the host allows a run (estimate.memory_allowance),
    in bytes: what a GPU's chunks are sized within (chunks.max_chunk_lines). The host's alone where
    the card does not say (numba's CUDA simulator)."""
    from vrsweep.execution.estimate import memory_allowance

    host = memory_allowance()[0]
    try:
        from numba import cuda

        _free, total = cuda.current_context().get_memory_info()
        return min(host, int(total))
    except Exception:  # noqa: BLE001 -- no figure from the card: the host's bound still holds
        return host


def gpu_lines(kernels, method: str, lyapunov: bool):
    """kernels.gpu_lines(method, lyapunov), with a device failure reported as RunFailed (whose
    message the command completes: the chunks finished so far are saved, --resume continues)."""
    check_device("cuda")
    return _ReportedLines(kernels.gpu_lines(method, lyapunov))


class _ReportedLines:
    """numerics/cuda.DeviceLines with its failures, at launch or at the wait, as RunFailed."""

    def __init__(self, lines):
        self.lines = lines

    def __call__(self, *arrays):
        self.launch(*arrays).wait()

    def launch(self, *arrays):
        return _ReportedLaunch(_reported(self.lines.launch, *arrays))


class _ReportedLaunch:
    def __init__(self, launch):
        self.launch = launch

    def wait(self):
        return _reported(self.launch.wait)


def _reported(call, *arguments):
    try:
        return call(*arguments)
    except (KeyboardInterrupt, SystemExit):
        raise
    except MemoryError as error:
        raise RunFailed(f"the GPU ran out of memory for a chunk ({error})") from error
    except Exception as error:  # noqa: BLE001 -- driver, compiler and launch errors alike
        first_line = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise RunFailed(f"the GPU failed ({type(error).__name__}: {first_line})") from error
