"""The analytic side drawn over the numbers: the branches of the corrected first-order theory
(ERRATA 1-3) on a fine grid, and where the resonance wt2 = omega^2 (eq3.4) lies."""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D

from vrsweep.numerics.model import PARAMETER_NAMES
from vrsweep.plot.labels import parameter_symbol
from vrsweep.plot.selection import _limits


# --------------------------------------------------------------------------------------------
# Analytic side on a fine grid: branches and resonance positions
# --------------------------------------------------------------------------------------------


def _fine_parameters(parameters, axis, values):
    """Every parameter as an array over ``values`` of ``axis`` (others constant)."""
    fine = {name: np.full(values.shape, float(parameters[name])) for name in PARAMETER_NAMES}
    fine[axis] = values
    return fine


def analytic_branches(parameters, axis, values, gain=True):
    """Branches of the analytic response along ``axis``: list of (x, y, stable) polylines.

    The roots of the fixed-point cubic (theory.analytic_columns: corrected eq2.24/eq2.27, ERRATA
    1-3) come sorted by size, so a root's slot changes where roots appear or vanish in pairs at a
    fold; each branch is followed by continuity instead. y is A/c with ``gain`` (ERRATA 6), else A.
    """
    from vrsweep.analysis import theory

    fine = _fine_parameters(parameters, axis, values)
    columns = theory.analytic_columns(fine)
    # None where the fast force is no faster than the slow one (Omega <= omega): the effective
    # system is an average over it (theory.fast_force).
    roots = np.where(theory.fast_force(fine)[:, None], columns["A_theory"][0], np.nan)
    stable = columns["A_theory_stable"][0].astype(bool)
    if gain:
        with np.errstate(divide="ignore", invalid="ignore"):
            roots = roots / fine["c"][:, None]
    return _follow_branches(values, roots, stable)


def _follow_branches(x, roots, stable):
    """Join roots at neighbouring x into polylines, nearest to nearest (greedy by distance)."""
    finite = roots[np.isfinite(roots)]
    if finite.size == 0:
        return []
    jump_limit = 0.05 * (finite.max() - finite.min() + abs(finite).max())  # a fold, not a continuation
    active, finished = [], []
    for i in range(len(x)):
        present = [j for j in range(roots.shape[1]) if np.isfinite(roots[i, j])]
        pairs = sorted((abs(branch["y"][-1] - roots[i, j]), b, j)
                       for b, branch in enumerate(active) for j in present)
        matched_branches, matched_roots = set(), set()
        for distance, b, j in pairs:
            if b in matched_branches or j in matched_roots or distance > jump_limit:
                continue
            matched_branches.add(b)
            matched_roots.add(j)
            active[b]["x"].append(x[i])
            active[b]["y"].append(roots[i, j])
            active[b]["stable"].append(stable[i, j])
        still = [branch for b, branch in enumerate(active) if b in matched_branches]
        finished += [branch for b, branch in enumerate(active) if b not in matched_branches]
        still += [{"x": [x[i]], "y": [roots[i, j]], "stable": [stable[i, j]]}
                  for j in present if j not in matched_roots]
        active = still
    finished += active
    return [(np.array(b["x"]), np.array(b["y"]), np.array(b["stable"], dtype=bool)) for b in finished]


def _draw_branches(ax, branches, colour):
    """Stable runs solid, unstable runs dashed; each run shares its end point with the next."""
    for x, y, stable in branches:
        start = 0
        for end in range(1, len(x) + 1):
            if end == len(x) or stable[end] != stable[start]:
                stop = min(end + 1, len(x))
                (line,) = ax.plot(x[start:stop], y[start:stop], color=colour, lw=1.3,
                                  ls="-" if stable[start] else "--", zorder=2)
                line._vrsweep_context = True  # the theory, not data: a zoom fits the data (layout.fit_y_to_view)
                start = end


def resonance_positions(parameters, axis, values):
    """Where along ``axis`` the effective frequency meets the slow one, wt2 = omega^2 (eq3.4), and
    the fast force is fast (Omega > omega: ``theory.fast_force``; below, eq3.4 means nothing).

    For the g axis these are +-g_res; for other axes the root is found on the fine grid ``values``
    (linear interpolation between sign changes). Empty where the axis leaves wt2 - omega^2 one-signed.
    """
    return resonance_roots(parameters, axis, values)[0]


def resonance_roots(parameters, axis, values):
    """(positions, cut): ``resonance_positions``, and whether a root of wt2 = omega^2 on the range
    was left out because Omega <= omega there (for the caption: the curve stops, and says why)."""
    from vrsweep.analysis import theory

    if axis == "g":
        g_res = float(theory.g_res(parameters["alpha"], parameters["omega0"], parameters["omega"],
                                   parameters["Omega"]))
        roots = [g for g in (-g_res, g_res) if values.min() <= g <= values.max()]
        if roots and not bool(theory.fast_force(parameters)):
            return [], True
        return roots, False
    fine = _fine_parameters(parameters, axis, values)
    detuning = theory.effective_frequency_squared(fine) - np.square(fine["omega"])
    fast = theory.fast_force(fine)
    positions, cut = [], False
    for i in np.flatnonzero(np.sign(detuning[:-1]) * np.sign(detuning[1:]) < 0):
        fraction = detuning[i] / (detuning[i] - detuning[i + 1])
        position = float(values[i] + fraction * (values[i + 1] - values[i]))
        if fast[i] and fast[i + 1]:
            positions.append(position)
        else:
            cut = True
    return positions, cut


RESONANCE_CUT = "no resonance (eq3.4) drawn where Ω ≤ ω: the effective system averages over a fast force"
THEORY_CUT = ("no analytic curve or resonance drawn where Ω ≤ ω: the effective system (eq2.10) averages over a "
              "fast force")


def _resonance_label(axis, position):
    if axis == "g":
        return f"$g_{{res}}$ = {position:.3f} (eq3.4)"
    return f"$\\tilde\\omega^2 = \\omega^2$ (eq3.4) at {parameter_symbol(axis)} = {position:.4g}"


def _draw_resonance_curve(ax, view, x_axis, y_axis):
    """The curve wt2 = omega^2 (eq3.4) in the plane of the two axes, e.g. g_res(Omega); none for a
    written model (the paper's theory is its own system's only: its nine parameters may be absent).
    White, in a dark casing: readable over any cell."""
    from vrsweep.analysis import theory

    if view.config is None or view.config.written:
        return None
    # As finely at every scale of a logarithmic axis (a geometric grid's, selection.map_mesh) as of a
    # linear one: on 400 linear steps its lowest decade had one or two.
    xs = (np.geomspace if ax.get_xscale() == "log" else np.linspace)(*_limits(view.axes[x_axis]), 400)
    ys = (np.geomspace if ax.get_yscale() == "log" else np.linspace)(*_limits(view.axes[y_axis]), 400)
    X, Y = np.meshgrid(xs, ys)
    mesh = {name: np.full(X.shape, float(value)) for name, value in view.parameters().items()}
    mesh[x_axis], mesh[y_axis] = X, Y
    detuning = theory.effective_frequency_squared(mesh) - np.square(mesh["omega"])
    # Only where the fast force is fast (Omega > omega, theory.fast_force): below, g_res(Omega) was
    # drawn on through Omega = 0.25 ... 0.5 of a geometric grid, where eq3.4 means nothing.
    fast = np.broadcast_to(theory.fast_force(mesh), detuning.shape)
    slow = ~fast & np.isfinite(detuning)
    cut = bool(slow.any()) and float(detuning[slow].min()) < 0.0 < float(detuning[slow].max())
    detuning = np.where(fast, detuning, np.nan)
    if not np.any(np.isfinite(detuning)) or not (np.nanmin(detuning) < 0.0 < np.nanmax(detuning)):
        return None
    from vrsweep.plot.palettes import cased

    # A white line alone vanished over white cells (lambda_1 near 0) and yellow ones (viridis' top,
    # light grey on a greyscale page): a dark casing keeps it on every scale.
    edge = cased("white", 1.6)
    contour = ax.contour(X, Y, detuning, levels=[0.0], colors="white", linewidths=1.6, linestyles="--")
    contour.set_gid("resonance")
    contour.set_path_effects(edge)
    # g_res(Omega) names the curve only in the (g, Omega) plane; over (Delta, alpha) it is Delta_res(alpha)
    name = "$g_{res}(\\Omega)$: " if {x_axis, y_axis} == {"g", "Omega"} else "resonance: "
    return Line2D([], [], color="white", ls="--", lw=1.6, path_effects=edge,
                  label=name + "$\\tilde\\omega^2 = \\omega^2$ (eq3.4)" + (", drawn where Ω > ω only" if cut else ""))


def barrier_positions(config, parameters) -> list[float]:
    """Where a written model's barriers are at ``parameters`` (name -> value)."""
    from vrsweep.numerics.written import header_values

    values = header_values(config.model, {name: parameters[name] for name in config.parameter_names})
    return [float(values[f"barriers.{index}.position"]) for index in range(len(config.model.barriers))]
