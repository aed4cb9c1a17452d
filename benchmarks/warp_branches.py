"""What the loop's branches cost a warp whose lanes take each pass together: a model from the CPU.

    python benchmarks/warp_branches.py [--method rk45|dop853] [--points 64] [--warps 1056]
                                       [--measured FACTOR] [--out FILE.json]

On a GPU the warp vote (numerics/cuda.py) starts every pass of the loop (kernel._integrate) with
the warp's 32 lanes together; inside the pass a branch that any lane takes costs the whole warp
its time, while the lanes that do not take it wait. warp_passes.py bounded one branch this way
(the impact's Newton steps, since made passes of the loop); this does it for every costly branch of
a pass at once, on the
original model, gpu.py's map and settings, with the loop composed as the GPU's kernel composes it
(kernel.METHOD_PARTS: the library's cosines at every stage, no rotation table, with either method):

1. counts: a random sample of the map's points integrated in pure Python (NUMBA_DISABLE_JIT, one
   process per core), the kernel's own functions wrapped so that every pass of the loop records
   which kinds it took (KINDS): a dense output, the exact barrier test, an impact located or
   reached (its Newton steps are passes of their own, whose step is the pass's), a turning point's
   test and its root, a rejected step; with a sample of each kind's arguments.
2. costs: each kind's seconds per call on the CPU (numba, one thread), on those arguments; and the
   compiled kernel's seconds per pass on the same points, so that the pass's remaining work (the
   step's error and control, the records, the loop) is what the kinds leave of it.
3. the model: a pass of a warp of lanes on different points costs the rest plus every kind any of
   them takes (its rate r: 1 - (1 - r)^32 of the passes); a warp of one point's copies, the rest
   plus r of each. Printed: the ratio per pass, the share of lanes active per instruction it
   implies (what Nsight Compute's smsp__thread_inst_executed_per_inst_executed.ratio measures, /32),
   and a launch's time at several sizes, WARPS warps resident (an H100: 132 multiprocessors x 8
   warps of 255 registers), lanes taking points from the queue as they finish.

The CPU's costs stand in for the card's: the model says how much of gpu_divergence.py's factor
(one point per warp against 32) the union of branches explains if the card weighs the branches as
the CPU does; --measured FACTOR, the card's, gives the weight of the branches (relative to the
pass's rest, against the CPU's) at which it would explain all of it. A card's profile checks that
(benchmarks/README.md, "What the loop's branches cost a warp").
"""

from __future__ import annotations

import argparse
import heapq
import json
import os
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from gpu import INTEGRATION, X0, V0, coefficients_of, grid  # noqa: E402

WARP = 32
# The kinds a pass can take, and the function whose call marks it. A rejected step costs nothing
# beyond the pass's step (the pass ends there), the period's close next to nothing: counted, not
# costed.
# (None: the method's own function, wrapped where the loop is handed it.)
KINDS = {
    "dense": None,                              # the step's dense output (rk45: free of RHS)
    "find": ("kernel", "find_crossing"),        # the exact barrier test on it (Bernstein form)
    "impact": ("kernel", "locate_root"),        # the impact located on it (then Newton steps as passes)
    "restitution": ("kernel", "_restitution"),  # the impact reached: eq2.2 or the start of sticking
    "turn_test": ("records", "_inside_extremes"),  # a turning point: can it pass the extremes?
    "turn_root": ("records", "locate_root"),    # ... it can: locate it
    "reject": None,
    "period": ("kernel", "close_period"),
}
COSTED = ("dense", "find", "impact", "restitution", "turn_test", "turn_root")
BIT = {kind: 1 << i for i, kind in enumerate(KINDS)}
CAPTURED_CALLS = 200   # arguments kept per kind, for the costs
CAPTURE_SHARE = 0.05   # of the calls, at random
REPEAT = 2000          # calls timed per captured argument set
ROUNDS = 3             # every time is the best of ROUNDS (this machine's noise)


def integrate(method, coefficients, settings, gather_lanes, parts=None):
    """One point through kernel._integrate, composed as the GPU's line kernel composes it."""
    from vrsweep.numerics import kernel, rhs
    from vrsweep.numerics.impact import bracket_size
    from vrsweep.numerics.state import N_STATE

    rules, step, error, dense_output, accepted, growth, rejected, k_rows, dense_order = (
        parts or kernel.METHOD_PARTS[method])
    period_records = np.full((INTEGRATION["measure_periods"], kernel.N_RECORD), np.nan)
    summary = np.full(kernel.N_SUMMARY, np.nan)
    return kernel._integrate(
        rhs.oscillator_rhs, rhs.oscillator_rhs, rhs.oscillator_tangent, rhs.force_at_barrier, rhs.no_switches,
        rhs.no_saltation, rhs.no_sliding,
        rhs.no_preparations, rules, step, error, dense_output, accepted, growth, rejected, False,
        (np.empty((k_rows, N_STATE)), np.empty((N_STATE, dense_order)), np.empty((kernel.N_VECTORS, N_STATE)),
         np.empty(bracket_size(dense_order))), np.empty(1), coefficients, np.array([X0, V0]), settings,
        period_records, summary, np.empty(0), np.empty((0, 2)), np.empty((0, 3)), np.empty((0, 2)),
        np.empty((0, 4)), gather_lanes)


# --- 1. counts, in pure Python -------------------------------------------------------------------

def count(model, method, seed, first, n_points, out):
    """Per pass bit masks of KINDS for points [first, first + n_points) of the sample."""
    from vrsweep.numerics import kernel, records
    from vrsweep.numerics.models import kernels_for
    from vrsweep.numerics.trajectory import settings_vector

    modules = {"kernel": kernel, "records": records}
    state = {"flags": 0, "passes": [], "inside": 0}
    captured = {kind: [] for kind in KINDS}
    rng = np.random.default_rng(seed + first)

    def wrapped(kind, original):
        def counting(*arguments):
            if state["inside"]:  # a call from inside another kind's
                return original(*arguments)
            state["flags"] |= BIT[kind]
            if len(captured[kind]) < CAPTURED_CALLS and rng.random() < CAPTURE_SHARE:
                captured[kind].append([a.copy() if isinstance(a, np.ndarray) else (None if callable(a) else a)
                                       for a in arguments])
            state["inside"] += 1
            try:
                return original(*arguments)
            finally:
                state["inside"] -= 1
        return counting

    def next_pass(waiting=False):  # kernel._integrate's gather_lanes, called at the start of every pass
        state["passes"].append(state["flags"])
        state["flags"] = 0
        return kernel.APART  # (nothing held: each pass's branches follow its step, as counted)

    for kind, where in KINDS.items():
        if where is not None:
            module, name = where
            setattr(modules[module], name, wrapped(kind, getattr(modules[module], name)))
    parts = list(kernel.METHOD_PARTS[method])
    parts[3] = wrapped("dense", parts[3])
    parts[6] = wrapped("reject", parts[6])

    kernels = kernels_for(model)
    points = sample(seed, first + n_points)[first:]
    coefficients = coefficients_of(kernels, points)
    settings = settings_vector(**INTEGRATION)
    sequences = {}
    for i in range(n_points):
        state["passes"], state["flags"] = [], 0
        integrate(method, coefficients[i], settings, next_pass, parts)
        next_pass()
        sequences[f"p{first + i}"] = np.array(state["passes"][1:], dtype=np.uint16)
    np.savez(out, **sequences)
    with open(out + ".pkl", "wb") as file:
        pickle.dump(captured, file)


def sample(seed, n_points):
    points = grid(1_000_000)
    return points[np.random.default_rng(seed).choice(len(points), n_points, replace=False)]


def count_in_parallel(model, method, seed, n_points, processes, folder):
    """count() in `processes` pure-Python processes; (the points' pass masks, captured arguments)."""
    shares = np.array_split(np.arange(n_points), processes)
    environment = dict(os.environ, NUMBA_DISABLE_JIT="1")
    jobs = []
    for k, share in enumerate(s for s in shares if len(s)):
        out = str(Path(folder) / f"count{k}")
        command = [sys.executable, __file__, "--count", model, method, str(seed), str(share[0]), str(len(share)),
                   out]
        jobs.append((subprocess.Popen(command, env=environment), out))
    sequences, captured = {}, {kind: [] for kind in KINDS}
    for job, out in jobs:
        if job.wait() != 0:
            raise SystemExit(f"counting failed ({out})")
        with np.load(out + ".npz") as data:
            sequences.update({name: data[name] for name in data.files})
        with open(out + ".pkl", "rb") as file:
            for kind, calls in pickle.load(file).items():
                captured[kind] += calls
    return [sequences[f"p{i}"] for i in range(n_points)], captured


# --- 2. costs on the CPU ---------------------------------------------------------------------------

def costs_on_cpu(model, method, seed, n_points, captured, passes):
    """({kind: seconds a call}, the compiled kernel's seconds a pass) on this CPU, one thread.
    Each call is timed on its captured arguments; a call that would be the same every repetition
    gets a step size changed in its last bits, so that the compiler cannot take it out of the loop."""
    import numba

    from vrsweep.numerics import impact, kernel, records
    from vrsweep.numerics.models import kernels_for
    from vrsweep.numerics.trajectory import settings_vector

    dense_output = kernel.METHOD_PARTS[method][3]
    rhs = kernel.oscillator_rhs
    find_crossing, locate_root, inside_extremes = impact.find_crossing, impact.locate_root, records._inside_extremes
    restitute, force = kernel._restitution, kernel.force_at_barrier

    @numba.njit
    def time_dense(t, y, h, c, K, y_new, dense, stage, scratch, n_dynamic, n):
        total = 0
        for i in range(n):
            total += dense_output(rhs, t, y, h * (1.0 + 1e-16 * (i & 1)), c, K, y_new, dense, stage, scratch,
                                  n_dynamic)
        return total + dense[0, 0]

    @numba.njit
    def time_find(dense, y, y_new, h, delta, pushed, bracket, n):
        total = 0
        for i in range(n):
            total += find_crossing(dense, y, y_new, h * (1.0 + 1e-16 * (i & 1)), delta, pushed, bracket)
        return total

    @numba.njit
    def time_restitution(y, t, c, barrier, side, restitution, stick_velocity, n):
        total = 0.0
        f = np.empty_like(y)
        scratch = np.empty(1)
        for i in range(n):
            v_before, v_after, stuck, push = restitute(y, t * (1.0 + 1e-16 * (i & 1)), c, force, barrier, side,
                                                       restitution, stick_velocity)
            rhs(t, 0.0, -1, 0.0, y, c, f, scratch)  # the derivative after the rebound
            total += v_after + f[1]
        return total

    @numba.njit
    def time_turn_test(record, dense, y, h, n):
        total = 0
        for i in range(n):
            total += inside_extremes(record, dense, y, h * (1.0 + 1e-16 * (i & 1)))
        return total

    @numba.njit
    def time_turn_root(dense, y, h, component, level, low, high, n):
        total = 0.0
        for i in range(n):
            total += locate_root(dense, y, h * (1.0 + 1e-16 * (i & 1)), component, level, low, high)
        return total

    timers = {"dense": (time_dense, lambda a: a[1:11]), "find": (time_find, lambda a: a[:7]),
              "impact": (time_turn_root, lambda a: a[:7]),
              "restitution": (time_restitution, lambda a: (a[0], a[1], a[2], a[4], a[5], a[6], a[7])),
              "turn_test": (time_turn_test, lambda a: a[:4]),
              "turn_root": (time_turn_root, lambda a: a[:7])}
    costs = {}
    for kind, (timer, arguments_of) in timers.items():
        calls = captured[kind]
        if not calls:
            costs[kind] = 0.0
            continue
        timer(*arguments_of(calls[0]), 1)  # compile
        seconds = np.full(len(calls), np.inf)
        for _ in range(ROUNDS):
            for i, call in enumerate(calls):
                began = time.perf_counter()
                timer(*arguments_of(call), REPEAT)
                seconds[i] = min(seconds[i], (time.perf_counter() - began) / REPEAT)
        costs[kind] = float(np.mean(seconds))

    kernels = kernels_for(model)
    coefficients = coefficients_of(kernels, sample(seed, n_points))
    settings = settings_vector(**INTEGRATION)

    integrate(method, coefficients[0], settings, kernel.lanes_apart)  # compile
    timed = min(n_points, 16)
    per_pass = np.inf
    for _ in range(ROUNDS):
        began = time.perf_counter()
        for i in range(timed):
            integrate(method, coefficients[i], settings, kernel.lanes_apart)
        per_pass = min(per_pass, (time.perf_counter() - began) / sum(len(passes[i]) for i in range(timed)))
    return costs, per_pass


# --- 3. the model ----------------------------------------------------------------------------------

def pass_cost(rest, rates, costs, lanes):
    """A warp pass's cost with `lanes` lanes on different points: the rest, and each kind any takes."""
    return rest + sum((1.0 - (1.0 - rates[kind]) ** lanes) * costs[kind] for kind in COSTED) if lanes else 0.0


def launch_times(lengths, n_points, warps, cost_of_lanes, one_point_cost, rng):
    """(32 points a warp, one point a warp, the lanes active per instruction with 32 points a warp):
    a launch's time, the time of its slowest warp; the lanes active, a lane's own work (a
    pass of one point's copies each) over the warp's, as the instructions of each count them.
    Every warp of 32 points advances a pass at cost_of_lanes(32) while its lanes all have points
    (the queue gives a lane the next point when it finishes one), then at cost_of_lanes(a) with
    the a lanes left; a warp of one point's copies takes 32 of the queue's lines at a time."""
    lanes = [(0.0, lane) for lane in range(WARP * warps)]
    for length in rng.choice(lengths, n_points):
        ends, lane = heapq.heappop(lanes)
        heapq.heappush(lanes, (ends + length, lane))
    ends = np.zeros(WARP * warps)
    for end, lane in lanes:
        ends[lane] = end
    slowest, issued, own = 0.0, 0.0, 0.0
    for warp in np.sort(ends.reshape(warps, WARP), axis=1):
        elapsed, before = 0.0, 0.0
        for finished, end in enumerate(warp):
            elapsed += (end - before) * cost_of_lanes(WARP - finished)
            own += (end - before) * (WARP - finished) * one_point_cost
            before = end
        slowest = max(slowest, elapsed)
        issued += elapsed
    warp_ends = [0.0] * warps
    for length in rng.choice(lengths, n_points // WARP):
        heapq.heappush(warp_ends, heapq.heappop(warp_ends) + length * one_point_cost)
    return slowest, max(warp_ends), own / issued


MEASURED_POINTS = 65536  # gpu_divergence.py's launches of 2,048 points x 32 copies


def branch_weight(measured, lengths, warps, rest, rates, costs, seed):
    """The factor w by which the branches' costs (not the pass's rest) must grow for the model's
    launch of MEASURED_POINTS to be `measured` times slower with 32 points per warp (bisection)."""
    def factor(w):
        heavier = {kind: w * cost for kind, cost in costs.items()}
        lone = rest + sum(rates[kind] * heavier[kind] for kind in COSTED)
        mixed, same, _ = launch_times(lengths, MEASURED_POINTS, warps,
                                      lambda lanes: pass_cost(rest, rates, heavier, lanes), lone,
                                      np.random.default_rng(seed))
        return mixed / same

    low, high = 0.0, 100.0
    if factor(high) < measured:
        return float("inf")
    for _ in range(40):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if factor(middle) < measured else (low, middle)
    return 0.5 * (low + high)


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--count":
        model, method, seed, first, n_points, out = sys.argv[2:8]
        return count(model, method, int(seed), int(first), int(n_points), out)
    parser = argparse.ArgumentParser()
    parser.add_argument("--method", choices=("rk45", "dop853"), default="rk45")
    parser.add_argument("--points", type=int, default=64)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--warps", type=int, default=1056, help="warps resident on the card (H100: 132 x 8)")
    parser.add_argument("--processes", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--measured", type=float,
                        help="the card's factor (one point per warp / 32) on a launch of MEASURED_POINTS: the "
                             "branches' weight, relative to the CPU's, at which the model gives it")
    parser.add_argument("--weight", type=float, default=1.0,
                        help="also print a point's time with the branches WEIGHT times as costly (a card's)")
    parser.add_argument("--out", help="a JSON file for the figures")
    args = parser.parse_args()
    model = "original"
    began = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        passes, captured = count_in_parallel(model, args.method, args.seed, args.points, args.processes, folder)
    print(f"{model}, {args.method}: {args.points} points of the map counted in pure Python "
          f"({time.perf_counter() - began:.0f} s), {sum(map(len, passes)):,} passes", flush=True)
    costs, per_pass = costs_on_cpu(model, args.method, args.seed, args.points, captured, passes)
    every = np.concatenate(passes)
    rates = {kind: float(np.mean((every & BIT[kind]) > 0)) for kind in KINDS}
    rest = per_pass - sum(rates[kind] * costs[kind] for kind in COSTED)
    print(f"the compiled kernel: {per_pass * 1e9:.0f} ns a pass on this CPU; of it, outside the kinds below: "
          f"{rest * 1e9:.0f} ns")
    print(f"{'kind':10s} {'passes':>8s} {'any of 32':>10s} {'ns a call':>10s} {'a lane':>8s} {'a warp':>8s}"
          "  (ns a pass)")
    for kind in KINDS:
        rate, cost = rates[kind], costs.get(kind, 0.0)
        anyone = 1.0 - (1.0 - rate) ** WARP
        print(f"{kind:10s} {rate:8.4f} {anyone:10.3f} {cost * 1e9:10.1f} {rate * cost * 1e9:8.1f} "
              f"{anyone * cost * 1e9:8.1f}")
    lone, together = per_pass, pass_cost(rest, rates, costs, WARP)
    print(f"a pass: one point per warp {lone * 1e9:.0f} ns, 32 points per warp {together * 1e9:.0f} ns: "
          f"{together / lone:.2f}x; lanes active per instruction {WARP * lone / together:.1f} of 32")
    lengths = np.array([len(p) for p in passes], dtype=float)
    rng = np.random.default_rng(args.seed)
    launches = {}
    for n_points in (2048, 65536, 262144, 1048576):
        mixed, same, active = launch_times(lengths, n_points, args.warps,
                                           lambda lanes: pass_cost(rest, rates, costs, lanes), lone, rng)
        launches[n_points] = {"mixed_seconds": mixed, "same_seconds": same, "lanes_active": active}
        print(f"a launch of {n_points:>9,} points on {args.warps} warps: 32 points a warp / one point a warp "
              f"{mixed / same:.2f}x, lanes active per instruction {active:.1f} of 32; a point takes "
              f"{mixed / n_points * 1e9:.0f} ns of the model's time")
    passes_a_point = len(every) / args.points
    heavier = {kind: args.weight * cost for kind, cost in costs.items()}
    at_weight = {"weight": args.weight, "passes_a_point": passes_a_point,
                 "mixed_ns_a_point": passes_a_point * pass_cost(rest, rates, heavier, WARP) * 1e9,
                 "same_ns_a_point": passes_a_point * pass_cost(rest, rates, heavier, 1) * 1e9}
    print(f"{passes_a_point:,.0f} passes a point; with the branches {args.weight:g}x as costly: a point takes "
          f"{at_weight['mixed_ns_a_point'] / 1e6:.3f} ms of warp passes with 32 points a warp, "
          f"{at_weight['same_ns_a_point'] / 1e6:.3f} ms with one")
    weight = None
    if args.measured:
        weight = branch_weight(args.measured, lengths, args.warps, rest, rates, costs, args.seed)
        print(f"the card's {args.measured:.2f}x on {MEASURED_POINTS:,} points: the model gives it with the branches "
              f"{weight:.1f}x as costly, relative to the pass's rest, as on this CPU")
    if args.out:
        Path(args.out).write_text(json.dumps({"weight": weight, "at_weight": at_weight, 
            "method": args.method, "points": args.points, "passes": int(len(every)), "rates": rates, "costs_s": costs,
            "per_pass_s": per_pass, "rest_s": rest, "pass_ratio": together / lone,
            "lanes_active": WARP * lone / together, "launches": launches}, indent=1))


if __name__ == "__main__":
    main()
