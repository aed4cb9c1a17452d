"""What a warp gains if its lanes hold their rare branches back and take them together: a model.

    python benchmarks/warp_defer.py [--method rk45|dop853] [--points 64] [--weights 1,5,10.7]
                                    [--hold 4,8,16,24] [--cache FILE.npz] [--out FILE.json]

warp_branches.py models a warp whose lanes take every pass together (the warp vote, cuda.py):
inside a pass, a rare branch any lane takes (the dense output, the exact barrier test, the
impact's location, its restitution, a turning point's test and root) costs the whole warp its time.
With the lanes on 32 different points, a warp pays the union of their branches at every pass.

Holding them back (cuda.py's HOLD_LANES, gpu_variants.py variant H): a lane whose accepted step
needs a rare branch keeps the step and waits; the warp's vote at the start of each pass releases
the waiting lanes together once HOLD of them wait (or every lane still integrating does), and
they take their branches in that pass while the others take their next step. Each lane computes
what it computed before, in the same order: only when, relative to the other lanes, changes.

This script replays the lanes' own passes, as warp_branches.py counted them (the same points,
settings and per-call CPU costs; its counts are pure Python, minutes), through one warp in steady
state (a lane that finishes a point takes another at random), and prints the time per lane-pass:
- with the vote, as the card runs now (every pass: the step, and the union of the lanes' branches);
- with the branches held, for each HOLD;
- with one point's copies in the warp (no divergence: the card's measured best);
at several weights w of the branches relative to the pass's rest (w = 1: as on this CPU; the
card's measured factor needs about 10.7 with rk45, warp_branches.py --measured 3.41).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import warp_branches  # noqa: E402
from warp_branches import BIT, COSTED, KINDS, WARP  # noqa: E402

# The kinds a lane holds back: every costed kind (they all come after the pass's step, in the
# accepted step's branches or in the last Newton step's).
HELD = sum(BIT[kind] for kind in COSTED)


@numba.njit(cache=False)
def steady_warp(masks, starts, lengths, kind_costs, rest, hold, warp_passes, seed):
    """(seconds a lane-pass, lanes active per instruction of 32) for one warp in steady state.

    masks (n,) uint16, every point's passes one after the other (point p: masks[starts[p]:
    starts[p] + lengths[p]]); kind_costs (16,) seconds of each bit's kind (0 for the uncosted);
    rest, a pass's step and the rest; hold: 0 runs every pass with the vote (the union of every
    lane's kinds), -1 a warp of one point's copies, H > 0 holds the rare kinds back until H lanes
    (or all) wait."""
    np.random.seed(seed)
    n_points = starts.shape[0]
    point = np.empty(WARP, np.int64)
    position = np.empty(WARP, np.int64)
    waiting = np.zeros(WARP, np.bool_)
    for lane in range(WARP):
        point[lane] = np.random.randint(n_points)
        position[lane] = np.random.randint(lengths[point[lane]])  # steady state: lanes out of phase
    seconds = 0.0
    done = 0  # the lanes' own passes completed
    own = 0.0  # what those passes cost a lane alone (for lanes active per instruction)
    for _ in range(warp_passes):
        if hold == -1:  # one point's copies: every lane takes the first lane's pass
            mask = masks[starts[point[0]] + position[0]]
            cost = rest
            for bit in range(16):
                if mask & (1 << bit):
                    cost += kind_costs[bit]
            seconds += cost
            own += WARP * cost
            done += WARP
            position[0] += 1
            if position[0] == lengths[point[0]]:
                point[0] = np.random.randint(n_points)
                position[0] = 0
            continue
        n_waiting = 0
        for lane in range(WARP):
            n_waiting += waiting[lane]
        release = hold > 0 and n_waiting >= min(hold, WARP)
        union = 0
        stepped = False
        for lane in range(WARP):
            mask = masks[starts[point[lane]] + position[lane]]
            if waiting[lane]:
                if not release:
                    continue
                union |= mask & HELD
                waiting[lane] = False
            else:
                stepped = True
                if hold > 0 and mask & HELD:
                    waiting[lane] = True  # the step is kept; its branches wait for the release
                    continue
                union |= mask
            # the lane's pass is complete
            alone = rest
            for bit in range(16):
                if mask & (1 << bit):
                    alone += kind_costs[bit]
            own += alone
            done += 1
            position[lane] += 1
            if position[lane] == lengths[point[lane]]:
                point[lane] = np.random.randint(n_points)
                position[lane] = 0
        cost = rest if stepped else 0.0
        for bit in range(16):
            if union & (1 << bit):
                cost += kind_costs[bit]
        seconds += cost
    return seconds / done, WARP * own / (WARP * seconds) if seconds > 0 else 0.0


def counts_and_costs(method, points, seed, cache):
    """warp_branches.py's pass masks and per-call costs, from `cache` (an .npz) where it holds them."""
    if cache and Path(cache).exists():
        with np.load(cache, allow_pickle=False) as data:
            passes = [data[f"p{i}"] for i in range(int(data["n_points"]))]
            costs = dict(zip(COSTED, data["costs"].tolist()))
            return passes, costs, float(data["per_pass"])
    began = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        passes, captured = warp_branches.count_in_parallel("original", method, seed, points, os.cpu_count() or 1,
                                                           folder)
    print(f"counted {points} points in pure Python ({time.perf_counter() - began:.0f} s)", flush=True)
    costs, per_pass = warp_branches.costs_on_cpu("original", method, seed, points, captured, passes)
    if cache:
        np.savez(cache, n_points=points, costs=np.array([costs[k] for k in COSTED]), per_pass=per_pass,
                 **{f"p{i}": p for i, p in enumerate(passes)})
    return passes, costs, per_pass


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--method", choices=("rk45", "dop853"), default="rk45")
    parser.add_argument("--points", type=int, default=64)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--weights", default="1,5,10.7")
    parser.add_argument("--hold", default="2,4,8,12,16,24,32")
    parser.add_argument("--warp-passes", type=int, default=2_000_000)
    parser.add_argument("--cache", help="an .npz keeping the counts and costs between runs")
    parser.add_argument("--out", help="a JSON file for the figures")
    args = parser.parse_args()
    passes, costs, per_pass = counts_and_costs(args.method, args.points, args.seed, args.cache)
    every = np.concatenate(passes)
    rates = {kind: float(np.mean((every & BIT[kind]) > 0)) for kind in KINDS}
    rest = per_pass - sum(rates[kind] * costs[kind] for kind in COSTED)
    held = float(np.mean((every & HELD) > 0))
    print(f"original, {args.method}: {args.points} points, {len(every):,} passes; a lane's passes with a rare "
          f"branch: {held:.4f}; the pass's rest {rest * 1e9:.0f} ns on this CPU")
    masks = every.astype(np.uint16)
    lengths = np.array([len(p) for p in passes], dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    holds = [int(h) for h in args.hold.split(",")]
    figures = {"method": args.method, "points": args.points, "rest_s": rest, "costs_s": costs, "held_rate": held,
               "weights": {}}
    for weight in (float(w) for w in args.weights.split(",")):
        kind_costs = np.zeros(16)
        for kind in COSTED:
            kind_costs[BIT[kind].bit_length() - 1] = weight * costs[kind]
        row = {}
        for hold in [0, -1] + holds:
            seconds, active = steady_warp(masks, starts, lengths, kind_costs, rest, hold, args.warp_passes,
                                          args.seed)
            row[hold] = (seconds, active)
        vote = row[0][0]
        print(f"w = {weight:g}: a lane-pass takes {vote * 1e9:.1f} ns with the vote (lanes active {row[0][1]:.1f}), "
              f"{row[-1][0] * 1e9:.1f} ns with one point's copies ({vote / row[-1][0]:.2f}x less)")
        for hold in holds:
            seconds, active = row[hold]
            print(f"   held until {hold:2d} lanes wait: {seconds * 1e9:6.1f} ns, {vote / seconds:.2f}x the vote's "
                  f"speed, lanes active {active:.1f}")
        figures["weights"][weight] = {str(h): {"s_lane_pass": s, "lanes_active": a} for h, (s, a) in row.items()}
    if args.out:
        Path(args.out).write_text(json.dumps(figures, indent=1))


if __name__ == "__main__":
    main()
