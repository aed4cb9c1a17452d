"""The sweep's lines on an NVIDIA GPU: kernel.py's loop compiled by numba-cuda, lines from a queue.

One numerics source for both targets. The CPU's lines (lines.py) and the GPU's call the same
``kernel._integrate`` with the same method and model functions; numba compiles them for the
CPU (njit, Python threads over lines) and, here, for CUDA: numba-cuda turns every njit function the loop
calls into a device function. The loop allocates nothing: its work arrays come from its caller,
which here are thread-local arrays of fixed size (cuda.local.array).

What differs on the GPU, and why:

- dop853 evaluates the forcing with the library's cosines at every stage (kernel.DOP853_RULES):
  the CPU's rotation table (rhs.dop853_rotation_scratch) is 68 kB per point, far more than a
  thread's registers; results agree with the CPU's dop853 to the tolerance, not bit for bit.
- The CUDA compiler fuses a * b + c into one rounding (FMA), so even rk45 differs from the CPU in
  the last bits: R agrees to ~1e-10 relative where the orbit is periodic (benchmarks/gpu.py).
- Samples, impact and sticking logs and monodromy matrices stay on the CPU (trajectories and
  continuation): a sweep's lines need none of them.

A kernel's source (the loop's call with the method's and model's functions) is written as a module
file into numba's cache folder, like a written model's (codegen.generated_module), so that
numba-cuda caches its compile: only a machine's first run compiles it.

Requires the optional extra ``vrsweep[cuda]`` (numba-cuda and the CUDA compiler libraries from
the package index); importing this module without it raises ImportError, which the execution layer
turns into one line for the user (execution/device.py). ``NUMBA_ENABLE_CUDASIM=1`` runs the same
kernels in numba's CUDA simulator, on the CPU, for tests.
"""

from __future__ import annotations

import functools
import hashlib
import math
import sys

import numba
import numpy as np
from numba import cuda

from vrsweep.numerics import codegen, kernel, numba_cache, numba_inline, rhs
from vrsweep.numerics.impact import bracket_size
from vrsweep.numerics.jit import kernel_jit
from vrsweep.numerics.lines import next_start
from vrsweep.numerics.state import N_STATE, N_STATE_WITH_TANGENTS

try:  # numba-cuda inlines with its own copy of numba's inliner (numba_inline.py)
    from numba.cuda.core import inline_closurecall as _cuda_inliner
except ImportError:  # a numba-cuda that inlines with numba's
    pass
else:
    numba_inline.share_scope_copies(_cuda_inliner)

# Threads per block: a block of 64 lets every multiprocessor hold several blocks of a kernel that
# needs about 250 registers a thread.
THREADS_PER_BLOCK = 64
# The launch's shape (benchmarks/README.md, "GPU", for what each choice measured):
# - QUEUE: threads take lines from a counter (cuda.atomic.add) until none is left, so a slow point
#   holds one thread, not its whole launch; the launch then has QUEUE_BLOCKS_PER_SM blocks per
#   multiprocessor (more than fit at once: the rest start as the first finish).
# - SORT: a chunk's lines are handed out in the order of their parameters (lexicographic), so the
#   threads of one warp integrate neighbouring points. Measured on an H100, this keeps a warp's
#   lanes no closer than scattered points do: adjacent points of a map fall out of step at their
#   first different step size (benchmarks/gpu_spacing.py: 0.93x to 0.96x against points 32 cells
#   apart). Kept: it costs a sort of the chunk.
# - MAX_REGISTERS: None leaves the compiler its choice (up to 255).
# - REUSE_DEVICE_ARRAYS: a launch's device arrays, stream and timing events are one of a few slots
#   kept between launches (one per launch in flight), not allocated anew: CUDA runs two kernels of
#   different streams at once only if no device allocation comes between their launches, so with
#   kept slots the next chunk's kernel fills the card while this one's slowest points finish (the
#   launch's tail). False: fresh arrays each launch, as up to 0.6.2 (benchmarks compare the two).
# - GATHER_LANES: the loop's every pass starts with a vote of the warp's lanes (gather_warp), a
#   barrier: lanes which drifted apart (an impact in one, a rejected step in another) take the next
#   step together rather than one after the other (on an H100: 1.71x on the original model).
#   GATHER_LANES_BY_MODEL: the paper's models whose kernels run without it, where the card measured
#   it slower (the effective model: 0.86x in one run on an H100).
# - CACHE_KERNELS: a kernel's source is a module file in numba's cache folder (codegen.generated_module)
#   and numba-cuda caches its compile there (cache=True): the first run on a machine compiles (20 to
#   65 s on an H100's host), later runs load it. Where loading or saving fails, the kernel compiles
#   as without a cache (ready_kernel). False: every process compiles, as up to 0.6.3.
# - LOCAL_COEFFICIENTS: a thread copies its point's coefficients (LOCAL_COEFFICIENTS_SIZE at most)
#   into its local memory before integrating, and the loop reads them there. In the launch's array
#   a warp's 32 lanes read 32 rows, a cache line each, for every coefficient a right-hand side
#   reads (about 9 an evaluation); the hardware interleaves local memory across a warp's lanes, so
#   there the same read takes two lines. Off until a card has measured it (gpu_variants.py, F).
# - HOLD_LANES: with GATHER_LANES, a lane whose step needs the loop's rare branches (the dense
#   output, the exact barrier test, an impact, a turning point) keeps the step and waits until
#   HOLD_LANES lanes of its warp wait (or all that still integrate), and they take their branches
#   in one pass (kernel._integrate's vote, _HOLD_WARP): the warp pays for a rare branch once for many
#   lanes, not at every pass one lane needs it. The same arithmetic per lane, bit for bit; only the
#   lanes' order in time changes. 0: off, until a card has measured it (gpu_variants.py, H: 8;
#   benchmarks/warp_defer.py predicts 1.0x to 1.65x on the original model, from the branches'
#   weight on the card).
QUEUE = True
QUEUE_BLOCKS_PER_SM = 16
SORT = True
MAX_REGISTERS = None
REUSE_DEVICE_ARRAYS = True
GATHER_LANES = True
GATHER_LANES_BY_MODEL = {"effective": False}
CACHE_KERNELS = True
LOCAL_COEFFICIENTS = False
LOCAL_COEFFICIENTS_SIZE = 64
HOLD_LANES = 0


# The kernel's source: thread-local arrays need sizes that are constants when numba compiles, so
# the method's and state's sizes are written into it (line_kernel) rather than read from variables.
_LINE_KERNEL = """
def run_lines(coefficients, initial_states, settings, lines, period_records, summaries, statuses, order, counter):
{simulator_prologue}    K = cuda.local.array(({k_rows}, {n_state}), float64)
    dense = cuda.local.array(({n_state}, {dense_order}), float64)
    vectors = cuda.local.array(({n_vectors}, {n_state}), float64)
    bracket = cuda.local.array({n_bracket}, float64)
    scratch = cuda.local.array(1, float64)  # the frozen mode (kernel._hold_mode); no_preparations reads none
    state = cuda.local.array(2, float64)
{local_coefficients}    # The observers a sweep does not use, as empty views (nothing is allocated for them).
    no_samples = scratch[:0]
    no_sample_values = vectors[:0, :2]
    no_impacts = vectors[:0, :3]
    no_sticks = vectors[:0, :2]
    no_monodromy = vectors[:0, :4]
    position = {first_position}
    while position < order.shape[0]:
        line = order[position]
        first = initial_states[line]
        state[0] = first[0]
        state[1] = first[1]
        for slot in range(lines.shape[1]):
            summary = summaries[line, slot]
            fill_nan(period_records[line, slot], summary)
{point}            status = _integrate(
                model_rhs, model_rhs, tangent, barrier_force, switch_signs, switch_saltation, sliding_surface,
                no_preparations, RULES,
                step, step_error, dense_output, accepted_factor, growth, rejected_factor, {tangents},
                (K, dense, vectors, bracket), scratch, point, state, settings, period_records[line, slot],
                summary, no_samples, no_sample_values, no_impacts, no_sticks, no_monodromy, gather_lanes)
            statuses[line, slot] = status
            next_start(status, summary, first, state)
        position = {next_position}
{wait_for_warp}"""
# Where a thread starts and what it does next: a line from the queue's counter, or one line each.
_POSITIONS = {
    True: ("cuda.atomic.add(counter, 0, 1)", "cuda.atomic.add(counter, 0, 1)"),
    False: ("cuda.grid(1)", "order.shape[0]"),
}


# The point's coefficients: its row of the launch's array, or with LOCAL_COEFFICIENTS the thread's
# copy of it (only a copy: a choice between the two would leave the compiler a pointer into either
# memory, and every read a generic load; DeviceLines refuses a wider row than the copy holds).
_POINT = """\
            point = coefficients[lines[line, slot]]
"""
_LOCAL_COEFFICIENTS = """\
    local_point = cuda.local.array({size}, float64)
"""
_LOCAL_POINT = """\
            row = coefficients[lines[line, slot]]
            for k in range(row.shape[0]):
                local_point[k] = row[k]
            point = local_point[:row.shape[0]]
"""


# With gather_warp: a lane with no line left answers its warp's votes until no lane integrates.
_WAIT_FOR_WARP = """\
    while cuda.any_sync(WARP_LANES, False):
        pass
"""
# With _HOLD_WARP's gather_lanes: the same, answering its two ballots ("waiting", "integrating")
# in their order.
_WAIT_FOR_HOLDING_WARP = """\
    while True:
        cuda.ballot_sync(WARP_LANES, False)
        if cuda.ballot_sync(WARP_LANES, False) == 0:
            break
"""
# _HOLD_WARP, written into the kernel's module: its threshold is part of the source (and so of the
# kernel's name in numba's cache), not a global that numba would freeze unseen.
_HOLD_WARP = """import numba
from vrsweep.numerics.kernel import HOLD, RELEASE
HOLD_LANES = {hold}


@numba.njit
def gather_lanes(waiting):
    \"\"\"kernel._integrate's gather_lanes with HOLD_LANES (cuda.py): the warp's lanes gathered, and
    the waiting ones released together once HOLD_LANES of them wait or no other lane integrates.\"\"\"
    n_waiting = cuda.popc(cuda.ballot_sync(WARP_LANES, waiting))
    n_integrating = cuda.popc(cuda.ballot_sync(WARP_LANES, True))
    return RELEASE if n_waiting >= HOLD_LANES or n_waiting == n_integrating else HOLD
"""


# In numba's CUDA simulator (tests) the kernel runs as Python, its arrays wrapped in the
# simulator's own types: these are unwrapped to the numpy arrays beneath, so that the loop runs as
# numba's CPU compile of the same source (the GPU's compile is tested by compiling it to PTX).
_SIMULATOR_PROLOGUE = """\
    coefficients, initial_states, settings, lines, period_records, summaries, statuses, order, counter = [
        argument._item._ary for argument in (coefficients, initial_states, settings, lines, period_records,
                                             summaries, statuses, order, counter)]
"""


# The kernel's arguments that are only its outputs: period_records, summaries, statuses.
OUTPUT_ARGUMENTS = (4, 5, 6)


# A warp's 32 lanes (THREADS_PER_BLOCK is a multiple of 32, so every lane of a warp exists).
WARP_LANES = 0xFFFFFFFF


@numba.njit
def gather_warp(waiting):
    """kernel._integrate's gather_lanes on the GPU: a vote of the warp's lanes ("I am still
    integrating"), a barrier after which they run together. A lane between two lines comes to the
    next line's loop; a lane with no line left waits in the kernel's last loop, whose vote answers
    these until every lane of its warp has none (no lane of the warp exits before: a warp vote
    must not name an exited lane). Nothing is held back (kernel.APART)."""
    cuda.any_sync(WARP_LANES, True)
    return kernel.APART


# In numba's CUDA simulator the kernel runs as Python and calls the loop from there, so numba
# compiles kernel._integrate as an entry point of its own for the functions passed to it. Cached,
# each process would add an entry that never hits (a key with function arguments names those
# functions' objects, new in every process) to one index, and numba fails to save an index that
# names more functions than it keeps alive ("underlying object has vanished": seen in a second run
# of tests/test_gpu.py). Elsewhere the loop is inlined into its callers, never an entry point.
simulated_integrate = kernel_jit(kernel._integrate.py_func, cache=False)
_WHERE = {simulated_integrate: (__name__, "simulated_integrate")}


@numba.njit
def fill_nan(records, summary):
    """A point's outputs before its integration: NaN where the kernel writes nothing (the periods
    after a failure), as the CPU's callers fill them (execution/sweep.py). Filled on the card, the
    outputs need no copy from the host: a GPU's chunk of 131,072 points holds 1.8 GB of records."""
    for row in range(records.shape[0]):
        for j in range(records.shape[1]):
            records[row, j] = math.nan
    for j in range(summary.shape[0]):
        summary[j] = math.nan


def line_kernel(method, tangents, model_rhs, tangent, barrier_force, switch_signs, switch_saltation, sliding_surface,
                queue=None,
                max_registers=None, gather=None, local_coefficients=None, hold=None):
    """The CUDA kernel that runs lines with ``method`` for a model's functions (kernel._integrate's
    rhs, tangent, barrier_force, switch_signs, switch_saltation and sliding_surface; model_rhs with the tangent vectors when
    ``tangents``).

    kernel[blocks, THREADS_PER_BLOCK](coefficients, initial_states, settings, lines,
    period_records, summaries, statuses, order, counter): lines.run_lines_rk45's arguments, then
    order (n_lines,), the lines in the order they are handed out, and counter (1,) int64, zero, the
    queue's (queue: QUEUE by default; gather: GATHER_LANES; local_coefficients: LOCAL_COEFFICIENTS;
    hold: HOLD_LANES, with gather only). Compiled on its first launch, once per process.
    """
    return _line_kernel(method, bool(tangents), model_rhs, tangent, barrier_force, switch_signs, switch_saltation,
                        sliding_surface, bool(QUEUE if queue is None else queue),
                        MAX_REGISTERS if max_registers is None else max_registers,
                        bool(GATHER_LANES if gather is None else gather),
                        bool(LOCAL_COEFFICIENTS if local_coefficients is None else local_coefficients),
                        int(HOLD_LANES if hold is None else hold))


@functools.lru_cache(maxsize=None)  # (line_kernel's defaults resolved first: one compile per kernel)
def _line_kernel(method, tangents, model_rhs, tangent, barrier_force, switch_signs, switch_saltation, sliding_surface,
                 queue,
                 max_registers, gather, local_coefficients, hold):
    (rules, step, step_error, dense_output, accepted_factor, growth, rejected_factor, k_rows,
     dense_order) = kernel.METHOD_PARTS[method]  # (the library's cosines, no rotation table)
    first_position, next_position = _POSITIONS[queue]
    # (the simulator runs the loop as a CPU compile, where a warp vote has no meaning)
    gather = gather and not numba.config.ENABLE_CUDASIM
    hold = hold if gather else 0  # (a lane waits at the warp's vote: without the vote nothing is held)
    wait_for_warp = (_WAIT_FOR_HOLDING_WARP if hold else _WAIT_FOR_WARP) if gather else ""
    body = _LINE_KERNEL.format(
        k_rows=k_rows, n_state=N_STATE_WITH_TANGENTS if tangents else N_STATE, dense_order=dense_order,
        n_vectors=kernel.N_VECTORS, n_bracket=bracket_size(dense_order), tangents=bool(tangents),
        simulator_prologue=_SIMULATOR_PROLOGUE if numba.config.ENABLE_CUDASIM else "",
        first_position=first_position, next_position=next_position, wait_for_warp=wait_for_warp,
        local_coefficients=_LOCAL_COEFFICIENTS.format(size=LOCAL_COEFFICIENTS_SIZE) if local_coefficients else "",
        point=_LOCAL_POINT if local_coefficients else _POINT)
    functions = {
        "_integrate": simulated_integrate if numba.config.ENABLE_CUDASIM else kernel._integrate,
        "next_start": next_start, "no_preparations": rhs.no_preparations, "switch_signs": switch_signs,
        "switch_saltation": switch_saltation, "sliding_surface": sliding_surface,
        "step": step, "step_error": step_error, "dense_output": dense_output, "accepted_factor": accepted_factor,
        "growth": growth, "rejected_factor": rejected_factor, "model_rhs": model_rhs, "tangent": tangent,
        "barrier_force": barrier_force,
    }
    if not hold:
        functions["gather_lanes"] = gather_warp if gather else kernel.lanes_apart
    # (max_registers changes the compile, not the source: the header names it, so that it is part of
    # the file's name and numba's cache never hands one cap's kernel to another)
    text = _KERNEL_MODULE.format(
        method=method, max_registers=max_registers, imports="".join(
            _import_line(alias, function) for alias, function in functions.items()),
        rules=repr(tuple(rules)), warp_lanes=WARP_LANES, body=body,
        hold_warp=_HOLD_WARP.format(hold=hold) if hold else "")
    name = f"vrsweep_cuda_lines_{hashlib.sha1(text.encode()).hexdigest()[:16]}"
    module = codegen.generated_module(name, lambda: text)
    # (numba's CUDA simulator has no registers to cap)
    options = {"max_registers": max_registers} if max_registers and not numba.config.ENABLE_CUDASIM else {}
    compiled = cuda.jit(cache=CACHE_KERNELS and numba_cache.enabled(), **options)(module.run_lines)
    compiled.queue, compiled.gather, compiled.local_coefficients, compiled.hold = queue, gather, local_coefficients, hold
    compiled.without_cache = lambda: cuda.jit(**options)(module.run_lines)
    return compiled


# The launch's choices a line kernel carries (_line_kernel sets them; DeviceLines reads them).
KERNEL_CHOICES = ("queue", "gather", "local_coefficients", "hold")


def kernel_signature():
    """The line kernel's argument types: a launch's arrays (DeviceLines.launch), C-contiguous."""
    from numba import types as nb

    return (nb.float64[:, ::1], nb.float64[:, ::1], nb.float64[::1], nb.int64[:, ::1],
            nb.float64[:, :, :, ::1], nb.float64[:, :, ::1], nb.int8[:, ::1], nb.int64[::1], nb.int64[::1])


_READY = {}  # kernel -> the dispatcher ready_kernel returned for it (kernels live as long as the process)


def ready_kernel(kernel_):
    """kernel_ compiled for kernel_signature() in this process, loaded from numba's cache where it
    holds it: the dispatcher to launch. Where the cache fails (a file it cannot read, a kernel it
    cannot save, a loaded kernel the card cannot load), the same source compiles without it, as
    every process did up to 0.6.3: slower, never wrong; the returned dispatcher's ``cache_failure``
    then says why. A compile error of the kernel itself is raised (by the second compile). Once per
    kernel and process."""
    if numba.config.ENABLE_CUDASIM:  # (the simulator compiles nothing)
        return kernel_
    ready = _READY.get(kernel_)
    if ready is None:
        try:
            # (bound here, not at the first launch: a cached module the card cannot load falls back too)
            kernel_.compile(kernel_signature()).bind()
            ready = kernel_
        except Exception as error:  # noqa: BLE001 -- numba-cuda's cache raises many kinds
            ready = kernel_.without_cache()
            for name in KERNEL_CHOICES:
                setattr(ready, name, getattr(kernel_, name))
            ready.compile(kernel_signature())
            ready.cache_failure = f"{type(error).__name__}: {error}"
        _READY[kernel_] = ready
    return ready


def is_cached(kernel_) -> bool:
    """Whether numba's cache holds a compile of the kernel (a hint, as numba_cache.is_compiled: the
    run's notice that the kernel compiles first). The simulator's kernels compile nothing for a GPU."""
    if numba.config.ENABLE_CUDASIM:
        return True
    return bool(CACHE_KERNELS) and numba_cache.is_compiled(kernel_)


# The kernel's module, as written into numba's cache folder (codegen.generated_module).
_KERNEL_MODULE = '''"""Generated by vrsweep (vrsweep/numerics/cuda.py): the CUDA line kernel of {method}; do not edit.

max_registers: {max_registers}
"""
from numba import cuda, float64
{imports}
from vrsweep.numerics.cuda import fill_nan
RULES = {rules}
WARP_LANES = {warp_lanes}
{hold_warp}
{body}'''


def _import_line(alias, function):
    """``from module import name as alias`` for a module-level njit function (a generated model's
    module too: codegen registers it in sys.modules before its functions are handed here)."""
    module, name = _WHERE.get(function, (function.py_func.__module__, function.py_func.__name__))
    if getattr(sys.modules.get(module), name, None) is not function:
        raise ValueError(f"{alias}: {module}.{name} is not importable as the function handed to the kernel")
    return f"from {module} import {name} as {alias}\n"


class DeviceLines:
    """lines.run_lines_*'s call, run on the GPU: copies the chunk's inputs to the device, launches
    the kernel, and copies the outputs back into the caller's arrays (the same arrays the CPU
    fills, so everything after the kernel is the CPU's code; what they held before is overwritten,
    never read: the kernel fills its outputs itself). sort: SORT by default; reuse:
    REUSE_DEVICE_ARRAYS by default (the slots it keeps are freed with it)."""

    def __init__(self, kernel_, sort=None, reuse=None):
        self.kernel = kernel_
        self.sort = SORT if sort is None else sort
        self.reuse = REUSE_DEVICE_ARRAYS if reuse is None else reuse
        self.slots = []

    def order(self, coefficients, initial_states, lines):
        """The order the lines are handed out in: by their first point's parameters and start."""
        if not self.sort:
            return np.arange(lines.shape[0], dtype=np.int64)
        keys = np.concatenate([coefficients[lines[:, 0]], initial_states], axis=1)
        return np.lexsort(keys.T[::-1]).astype(np.int64)

    def blocks(self, n_lines):
        needed = math.ceil(n_lines / THREADS_PER_BLOCK)
        if not self.kernel.queue:
            return needed
        multiprocessors = getattr(cuda.get_current_device(), "MULTIPROCESSOR_COUNT", 1)
        return max(1, min(needed, QUEUE_BLOCKS_PER_SM * multiprocessors))

    def __call__(self, coefficients, initial_states, settings, lines, period_records, summaries, statuses):
        """Run the lines and wait for them: lines.run_lines_*'s call."""
        self.launch(coefficients, initial_states, settings, lines, period_records, summaries, statuses).wait()

    def launch(self, coefficients, initial_states, settings, lines, period_records, summaries, statuses):
        """Copy the chunk to the device and launch its kernel on its slot's stream, without waiting:
        the returned Launch's wait() fills the caller's arrays (C-contiguous, as LineRunner makes
        them) and returns the kernel's seconds. The host can meanwhile prepare or post-process
        another chunk, and the card run another launch (execution/sweep.py keeps one in flight)."""
        n_lines = lines.shape[0]
        if n_lines == 0:
            return Launch(None, ())
        if self.kernel.local_coefficients and coefficients.shape[1] > LOCAL_COEFFICIENTS_SIZE:
            raise ValueError(f"{coefficients.shape[1]} coefficients a point: the kernel's local copy holds "
                             f"{LOCAL_COEFFICIENTS_SIZE} (cuda.LOCAL_COEFFICIENTS_SIZE)")
        order = self.order(coefficients, initial_states, lines)
        self.kernel = ready_kernel(self.kernel)
        slot = self._free_slot()
        # (the outputs are not copied in: the kernel fills every entry, fill_nan where it computes none)
        hosts = (coefficients, initial_states, settings, lines, period_records, summaries, statuses, order,
                 np.zeros(1, dtype=np.int64))
        arguments = [slot.holding(k, np.ascontiguousarray(host), copy=k not in OUTPUT_ARGUMENTS)
                     for k, host in enumerate(hosts)]
        slot.began.record(slot.stream)
        self.kernel[self.blocks(n_lines), THREADS_PER_BLOCK, slot.stream](*arguments)
        slot.ended.record(slot.stream)
        copies = ((arguments[4], period_records), (arguments[5], summaries), (arguments[6], statuses))
        return Launch(slot, copies)

    def _free_slot(self):
        """A slot no launch in flight uses: a kept one (reuse), else a new one, kept if reuse."""
        for slot in self.slots:
            if not slot.busy:
                break
        else:
            slot = _Slot()
            if self.reuse:
                self.slots.append(slot)
        slot.busy = True
        return slot


class _Slot:
    """A launch's place on the device: its stream, the events that time its kernel, and its arrays
    (k: the kernel's k-th argument), kept for the next launch that finds the slot free."""

    def __init__(self):
        self.stream = cuda.stream()
        self.began, self.ended = cuda.event(), cuda.event()
        self.arrays = []
        self.busy = False

    def holding(self, k, host, copy=True):
        """Device array k with host's values (copied on the slot's stream; with copy False only its
        shape and type): the slot's own, or its first rows, replaced where host needs more rows or
        another shape or type. Only a replacement allocates: the one point where this launch waits
        for those in flight."""
        if k == len(self.arrays):
            self.arrays.append(None)
        held = self.arrays[k]
        if (held is None or held.shape[1:] != host.shape[1:] or held.dtype != host.dtype
                or held.shape[0] < host.shape[0]):
            self.arrays[k] = None  # freed before its successor is allocated
            held = self.arrays[k] = cuda.device_array(host.shape, dtype=host.dtype, stream=self.stream)
        view = held if held.shape[0] == host.shape[0] else held[:host.shape[0]]
        if copy:
            view.copy_to_device(host, stream=self.stream)
        return view


class Launch:
    """A chunk's kernel in flight (DeviceLines.launch)."""

    def __init__(self, slot, copies):
        self.slot, self.copies = slot, copies

    def wait(self):
        """Copy the outputs into the host's arrays once the kernel is done, and free the launch's
        slot; the kernel's time on the device in seconds (None where the device does not time it:
        the simulator, or no lines)."""
        if self.slot is None:
            return None
        # (issued here, not at launch: a copy into pageable host memory holds the host until the
        # stream reaches it, which would make launch wait for the kernel)
        for device_array, host_array in self.copies:
            device_array.copy_to_host(host_array, stream=self.slot.stream)
        self.slot.stream.synchronize()
        milliseconds = self.slot.began.elapsed_time(self.slot.ended)
        self.slot.busy = False
        self.slot = self.copies = None
        return milliseconds / 1000.0 if milliseconds >= 0 else None


def compile_for(method, tangents, model_rhs, tangent, barrier_force, switch_signs, switch_saltation,
                sliding_surface, compute_capability=(9, 0), **options):
    """The line kernel's PTX for a GPU of ``compute_capability``, compiled on a machine that may have
    none (tests, and a look at the code before a GPU is at hand).

    numba-cuda compiles the njit functions the kernel calls for the current device's compute
    capability; without a device that lookup fails, so it is pointed at a stand-in for this one
    call. Returns the PTX text (ptxas -v reports its registers and local memory; a register cap,
    max_registers, is ptxas's -maxrregcount there).
    """
    import types
    from unittest import mock

    from numba.cuda import compile_ptx
    from numba.cuda import dispatcher as cuda_dispatcher

    kernel_ = line_kernel(method, tangents, model_rhs, tangent, barrier_force, switch_signs, switch_saltation,
                          sliding_surface, **options)
    stand_in = types.SimpleNamespace(compute_capability=tuple(compute_capability))
    with mock.patch.object(cuda_dispatcher, "get_current_device", lambda: stand_in):
        ptx, _ = compile_ptx(kernel_.py_func, kernel_signature(), cc=tuple(compute_capability))
    return ptx
