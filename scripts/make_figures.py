#!/usr/bin/env python3
"""Regenerate every figure of the paper into docs/figures/, from the configs in configs/.

    python scripts/make_figures.py            # from the repository root; about a minute on 2 cores

Each figure is the `vrsweep` commands a user would type (printed as they run), so any one of
them can be re-run, changed or extended by hand. Result files go to results/ (not committed);
the PNGs to docs/figures/ (committed, shown in the user guide).

Figures: quickstart (the README's and the guide's first figure: configs/quickstart.yaml, effective model, R
against g with the analytic response), fig1, fig2 (R against g, Omega = 4 and 5, with the
analytic response), their bifurcation diagrams (stroboscopic x against g: which R is trustworthy),
fig1_lyapunov (Fig. 1's sweep on a finer grid with the largest Lyapunov exponent under its
bifurcation diagram), fig_impact_no
(impacts per slow period, g = 5 and 20), fig3-fig5 (original above effective trajectories),
fig6 (effective system against the slow-flow reconstruction); and, not in the paper, the
hysteresis loop of configs/hysteresis_effective.yaml (continuation up and down) and the basins of
attraction of that bistable example at g = 23 (configs/basins_g23.yaml) and of four coexisting
orbits of the original model at g = 5 (configs/basins_g5_original.yaml); the map of R over g
and Omega (configs/map_g_Omega.yaml); bifurcation curves over an effective (g, Omega) map and an
original (g, Delta) map (curves_g_Omega_effective, curves_original: docs/bifurcation-curves.md);
three written models' figures (impact_linear_branch, impact_two_sided, bouncing_ball: docs/models.md).
"""

import argparse
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FIGURES = Path("docs/figures")
RESULTS = Path("results")
DPI = "110"  # ~100 kB per PNG, sharp enough for the README


class Bifurcation:
    """The ``--point`` of a branch file's bifurcation, named by its kind and where it lies (a value of
    the branch's parameter, to ``within``), found in the file when the command runs. An index
    written here picked whatever the branch listed there: a change in the branch (a graze located
    first, one bifurcation more) silently followed another point, or stopped the recipe."""

    def __init__(self, branch, kind, near, within=0.01):
        self.branch, self.kind, self.near, self.within = branch, kind, near, within

    def __str__(self):
        import h5py

        with h5py.File(self.branch, "r") as f:
            kinds = [k.decode() if isinstance(k, bytes) else str(k) for k in f["bifurcation_kind"][()]]
            places = [float(p) for p in f["bifurcation_parameter"][()]]
        found = [index for index, (kind, at) in enumerate(zip(kinds, places))
                 if kind == self.kind and abs(at - self.near) <= self.within]
        if len(found) != 1:
            listed = ", ".join(f"{index}: {kind} at {at:.6g}" for index, (kind, at) in enumerate(zip(kinds, places)))
            sys.exit(f"make_figures: {self.branch} has {len(found)} {self.kind} points within {self.within:g} of "
                     f"{self.near:g}, not one (it lists {listed or 'none'}); the recipe names the wrong point")
        return str(found[0])

    def __repr__(self):
        return f"{self.kind} near {self.near:g} of {self.branch}"


def resolve(words):
    """A command's words as text, each Bifurcation replaced by its index in its branch file (read now:
    the file is made by the commands before)."""
    return [str(word) for word in words]


# Maps whose curves are told apart by colour: a palette of a few dozen colours merged an orange curve into
# viridis' yellow and bands the colour bar, so these stay full-colour (~150 kB). So does the map of
# R: banded into eight colours, its continuous scale read as eight levels of R.
FULL_COLOUR = {"curves_g_Omega_effective", "curves_original", "map_g_Omega"}

COMMANDS = {
    # The README's first figure: configs/quickstart.yaml as a new user runs and plots it.
    "quickstart": [
        ["run", "configs/quickstart.yaml", "-o", "results/quickstart.h5", "--overwrite"],
        ["plot", "results/quickstart.h5", "-o", "docs/figures/quickstart.png"],
    ],
    "fig1": [
        ["run", "configs/fig1.yaml", "--overwrite"],
        ["plot", "results/fig1.h5", "--log", "-o", "docs/figures/fig1.png"],
        ["plot", "results/fig1.h5", "--kind", "bifurcation", "-o", "docs/figures/fig1_bifurcation.png"],
    ],
    "fig1_lyapunov": [
        ["run", "configs/fig1_lyapunov.yaml", "--overwrite"],
        ["plot", "results/fig1_lyapunov.h5", "--kind", "bifurcation+lyapunov",
         "-o", "docs/figures/fig1_lyapunov.png"],
    ],
    "fig2": [
        ["run", "configs/fig2.yaml", "--overwrite"],
        ["plot", "results/fig2.h5", "--log", "-o", "docs/figures/fig2.png"],
        ["plot", "results/fig2.h5", "--kind", "bifurcation", "-o", "docs/figures/fig2_bifurcation.png"],
    ],
    "fig_impact_no": [
        ["simulate", "configs/fig_impact_no.yaml", "--set", "g=5", "-o", "results/fig_impact_no_g5.h5", "--overwrite"],
        ["simulate", "configs/fig_impact_no.yaml", "--set", "g=20", "-o", "results/fig_impact_no_g20.h5", "--overwrite"],
        ["plot", "results/fig_impact_no_g5.h5", "results/fig_impact_no_g20.h5", "--kind", "impacts",
         "-o", "docs/figures/fig_impact_no.png"],
    ],
    "fig3": [
        ["simulate", "configs/fig3.yaml", "--compare", "effective", "--overwrite"],
        ["plot", "results/fig3.h5", "-o", "docs/figures/fig3.png"],
    ],
    "fig4": [
        ["simulate", "configs/fig4.yaml", "--compare", "effective", "--overwrite"],
        ["plot", "results/fig4.h5", "-o", "docs/figures/fig4.png"],
    ],
    "fig5": [
        ["simulate", "configs/fig5.yaml", "--compare", "effective", "--overwrite"],
        ["plot", "results/fig5.h5", "-o", "docs/figures/fig5.png"],
    ],
    "fig6": [
        ["simulate", "configs/fig6.yaml", "--overwrite"],
        ["plot", "results/fig6.h5", "--kind", "slowflow", "-o", "docs/figures/fig6.png"],
    ],
    # Not in the paper: hysteresis of the effective system found by continuation (issue 5).
    "hysteresis": [
        ["run", "configs/hysteresis_effective.yaml", "-o", "results/hysteresis_effective.h5", "--overwrite"],
        ["plot", "results/hysteresis_effective.h5", "-o", "docs/figures/hysteresis.png"],
    ],
    # Not in the paper: the same example followed by continuation, stable and unstable (issue 20).
    # Two branches: the one from rest (the small orbit, its fold, the unstable orbits beyond the
    # graze) and the stable impacting orbit the down-sweep follows, started from the down-sweep's
    # state at g = 23. Without the second the down-sweep's triangles sat by the dashed unstable
    # orbits (R within 2 % of theirs), as if the sweep had found unstable orbits.
    "continuation_hysteresis": [
        ["run", "configs/hysteresis_effective.yaml", "-o", "results/hysteresis_effective.h5", "--overwrite"],
        ["continue", "configs/continuation_hysteresis.yaml", "--overwrite"],
        ["continue", "configs/continuation_hysteresis.yaml", "--start", "results/hysteresis_effective.h5",
         "--at", "g=23", "--at", "direction=-1", "-o", "results/continuation_hysteresis_impacting.h5", "--overwrite"],
        ["plot", "results/continuation_hysteresis.h5", "results/continuation_hysteresis_impacting.h5",
         "results/hysteresis_effective.h5", "-o", "docs/figures/continuation_hysteresis.png"],
    ],
    # Not in the paper: the original model's periodic orbits along g over Fig. 1 (issue 20): three
    # starts of one config (the orbits of 2, 1 and 3 slow periods), over the Fig. 1 sweep.
    "continuation_fig1": [
        ["run", "configs/fig1.yaml", "--overwrite"],
        ["continue", "configs/fig1_continue.yaml", "--overwrite"],
        *[["continue", "configs/fig1_continue.yaml", "--set", f"continuation.from={start}",
           "--set", "continuation.max_step=0.05", "--set", "continuation.max_points=800",
           "-o", f"results/fig1_continue_{name}.h5", "--overwrite"] for name, start in (("p1", 30.0), ("p3", 12.0))],
        ["plot", "results/fig1_continue_p1.h5", "results/fig1_continue_p3.h5", "results/fig1_continue.h5",
         "results/fig1.h5", "-o", "docs/figures/continuation_fig1.png"],
    ],
    # Not in the paper: its period-doubling cascade at g = 17.833, between two of Fig. 1's points.
    "continuation_cascade": [
        ["run", "configs/fig1_cascade.yaml", "--overwrite"],
        ["continue", "configs/fig1_cascade.yaml", "-o", "results/fig1_cascade_branches.h5", "--overwrite"],
        ["plot", "results/fig1_cascade_branches.h5", "results/fig1_cascade.h5",
         "-o", "docs/figures/continuation_cascade.png"],
    ],
    # Not in the paper: basins of attraction of the bistable hysteresis example at g = 23 (issue 13).
    "basins_g23": [
        ["run", "configs/basins_g23.yaml", "-o", "results/basins_g23.h5", "--overwrite"],
        ["plot", "results/basins_g23.h5", "--kind", "basin", "-o", "docs/figures/basins_g23.png"],
    ],
    # Not in the paper: four coexisting orbits of the original model at g = 5 (issue 13).
    "basins_g5_original": [
        ["run", "configs/basins_g5_original.yaml", "-o", "results/basins_g5_original.h5", "--overwrite"],
        ["plot", "results/basins_g5_original.h5", "--kind", "basin", "-o", "docs/figures/basins_g5_original.png"],
    ],
    # Not in the paper: R over g and Omega (docs/maps.md).
    "map_g_Omega": [
        ["run", "configs/map_g_Omega.yaml", "--overwrite"],
        ["plot", "results/map_g_Omega.h5", "-o", "docs/figures/map_g_Omega.png"],
    ],
    # Not in the paper: bifurcation curves over maps (docs/bifurcation-curves.md). --point K is the
    # bifurcation's index in the branch file (vrsweep info lists them), found by its kind and place.
    "curves_g_Omega_effective": [
        ["run", "configs/curves_g_Omega_effective.yaml", "--overwrite"],
        ["continue", "configs/curves_branch_effective.yaml", "-o", "results/curves_branch_effective.h5",
         "--overwrite"],
        ["continue", "results/curves_branch_effective.h5", "--point",
         Bifurcation("results/curves_branch_effective.h5", "fold", 25.2675), "--along", "Omega", "--to", "3.5", "5.0",
         "-o", "results/curves_effective_fold.h5", "--overwrite"],
        ["continue", "results/curves_branch_effective.h5", "--point",
         Bifurcation("results/curves_branch_effective.h5", "grazing", 25.0849), "--along", "Omega", "--to", "3.5",
         "5.0", "-o", "results/curves_effective_grazing.h5", "--overwrite"],
        ["continue", "configs/curves_branch_effective_large.yaml", "-o", "results/curves_branch_effective_large.h5",
         "--overwrite"],
        ["continue", "results/curves_branch_effective_large.h5", "--point",
         Bifurcation("results/curves_branch_effective_large.h5", "period_doubling", 27.8371), "--along", "Omega",
         "--to", "3.5", "5.0", "-o", "results/curves_effective_period_doubling_large.h5", "--overwrite"],
        ["continue", "results/curves_branch_effective_large.h5", "--point",
         Bifurcation("results/curves_branch_effective_large.h5", "grazing", 29.5122), "--along", "Omega",
         "--to", "3.5", "5.0", "-o", "results/curves_effective_grazing_large.h5", "--overwrite"],
        ["plot", "results/curves_g_Omega_effective.h5", "results/curves_effective_fold.h5",
         "results/curves_effective_grazing.h5", "results/curves_effective_period_doubling_large.h5",
         "results/curves_effective_grazing_large.h5",
         "--var", "impacts_per_period", "-o", "docs/figures/curves_g_Omega_effective.png"],
    ],
    "curves_original": [
        ["run", "configs/curves_original.yaml", "--overwrite"],
        *[["continue", f"configs/curves_branch_original_{branch}.yaml", "-o",
           f"results/curves_branch_original_{branch}.h5", "--overwrite"] for branch in ("free", "p1", "p3", "p2")],
        # The free orbit's graze (g = 37.98): the branch crosses it onto impacting orbits, whose own
        # graze at a lower g (37.54) cannot be followed in two parameters. The period-1 fold (g =
        # 23.51): a graze at g = 22.74 (an impact reaching zero speed, which no curve follows) is
        # located before it. The period-3 fold at g = 6.24.
        *[["continue", f"results/curves_branch_original_{branch}.h5", "--point",
           Bifurcation(f"results/curves_branch_original_{branch}.h5", kind, near), "--along", "Delta",
           "--to", "1.0", "3.0", "-o", f"results/curves_original_{branch}.h5", "--overwrite"]
          for branch, kind, near in (("free", "grazing", 37.982), ("p1", "fold", 23.51), ("p3", "fold", 6.24))],
        # The period doubling of the orbit of two periods wanders in g: its range is all of the map's.
        ["continue", "results/curves_branch_original_p2.h5", "--point",
         Bifurcation("results/curves_branch_original_p2.h5", "period_doubling", 17.833051), "--along", "Delta",
         "--to", "1.0", "3.0", "--within", "0", "40", "-o", "results/curves_original_p2.h5", "--overwrite"],
        ["plot", "results/curves_original.h5", "results/curves_original_free.h5", "results/curves_original_p1.h5",
         "results/curves_original_p3.h5", "results/curves_original_p2.h5", "--var", "period",
         "-o", "docs/figures/curves_original.png"],
        ["plot", "results/curves_original.h5", "results/curves_original_free.h5", "results/curves_original_p1.h5",
         "results/curves_original_p3.h5", "results/curves_original_p2.h5", "--var", "impacts_per_period",
         "--vmax", "4", "-o", "docs/figures/curves_original_impacts.png"],
    ],
    # Not in the paper: written models (docs/models.md), from the shipped example configs.
    "impact_linear_branch": [
        ["continue", "configs/impact_linear.yaml", "-o", "results/impact_linear_branch.h5", "--overwrite"],
        ["plot", "results/impact_linear_branch.h5", "-o", "docs/figures/impact_linear_branch.png"],
    ],
    "impact_two_sided": [
        ["run", "configs/impact_two_sided.yaml", "-o", "results/impact_two_sided.h5", "--overwrite"],
        ["plot", "results/impact_two_sided.h5", "-o", "docs/figures/impact_two_sided.png"],
    ],
    "bouncing_ball": [
        ["run", "configs/bouncing_ball.yaml", "-o", "results/bouncing_ball.h5", "--overwrite"],
        ["plot", "results/bouncing_ball.h5", "--kind", "bifurcation", "-o", "docs/figures/bouncing_ball_bifurcation.png"],
        ["continue", "configs/bouncing_ball.yaml", "-o", "results/bouncing_ball_branch.h5", "--overwrite"],
        ["plot", "results/bouncing_ball_branch.h5", "-o", "docs/figures/bouncing_ball_branch.png"],
    ],
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1].strip(),
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("figures", nargs="*", metavar="FIGURE",
                        help=f"only these figures, of: {', '.join(COMMANDS)} (default: all)")
    args = parser.parse_args()
    unknown = [name for name in args.figures if name not in COMMANDS]
    if unknown:
        parser.error(f"unknown figure(s) {', '.join(unknown)}; choose from {', '.join(COMMANDS)}")
    os.chdir(ROOT)  # the configs' outputs and the commands' paths are relative to the repository
    FIGURES.mkdir(parents=True, exist_ok=True)
    RESULTS.mkdir(exist_ok=True)
    environment = dict(os.environ, MPLBACKEND="Agg")
    started = time.monotonic()
    for figure in args.figures or COMMANDS:
        for words in COMMANDS[figure]:
            words = resolve(words)
            if words[0] == "plot":
                words += ["--dpi", DPI]
            else:
                words += ["--quiet"]
            print("vrsweep " + shlex.join(words), flush=True)
            if subprocess.run([sys.executable, "-m", "vrsweep", *words], env=environment).returncode != 0:
                sys.exit(f"make_figures: the command above failed; {figure} not made")
            if words[0] == "plot" and figure not in FULL_COLOUR:
                shrink_png(Path(words[words.index("-o") + 1]))
    print(f"done in {time.monotonic() - started:.0f} s -> {FIGURES}/", flush=True)


PALETTE_COLOURS = 64


def shrink_png(path):
    """Re-save a PNG with a 64-colour palette (an octree's): 3-4 times smaller, every line's colour
    kept to a level or two of 255 (the dense trajectory figures would otherwise weigh ~600 kB each
    in the repository). A median cut to 32 colours spent them on the greys of antialiased text and
    moved a thin line's colour by up to 97 levels: the branch figure's red period drew dark brown,
    its light orange one brown, where the legend and the docs name the palette's colours."""
    from PIL import Image, PngImagePlugin

    with Image.open(path) as image:
        palette = image.convert("RGB").quantize(colors=PALETTE_COLOURS, method=Image.Quantize.FASTOCTREE,
                                                dither=Image.Dither.NONE)
        text = PngImagePlugin.PngInfo()  # the figure's description (vrsweep info FIGURE.png) stays
        for key, value in getattr(image, "text", {}).items():
            text.add_text(key, value)
    palette.save(path, optimize=True, pnginfo=text)


if __name__ == "__main__":
    main()
