"""The figure of a branch file (vrsweep/plot/branches.py), checked through matplotlib's objects:
where the multipliers' lines are broken, what the legend explains at one journal column, where
the bifurcations' tags go, and what colour and style mean in each panel."""

import numpy as np
import pytest

from vrsweep import plot

COLUMN = (3.4, 2.6)
GRAZE = 24.25


def _spans(ax):
    """(low, high) of the horizontal extent of each line of ``ax`` with data (not legend proxies,
    not the unit circle's level, drawn in axes coordinates across)."""
    xs = [np.asarray(line.get_xdata(), dtype=float) for line in ax.get_lines() if line.get_transform() is ax.transData]
    return [(float(x.min()), float(x.max())) for x in xs if x.size > 1 and np.ptp(x) > 0]


@pytest.mark.parametrize("impacts_change", [True, False], ids=["impacts change", "graze record alone"])
def test_the_multipliers_are_not_joined_across_a_graze(tmp_path, impacts_change):
    from handmade import write_grazing_branch_file

    path = write_grazing_branch_file(tmp_path / "graze.h5", impacts_change=impacts_change)
    fig = plot.plot(path)
    top, bottom = fig.axes[:2]
    multipliers = _spans(bottom)
    assert multipliers, "the multipliers are drawn"
    assert not [span for span in multipliers if span[0] < GRAZE < span[1]], multipliers
    # Both sides are drawn: 22 to 24 free, 24.5 to 26 impacting, each multiplier.
    assert sorted(multipliers) == [(22.0, 24.0)] * 2 + [(24.5, 26.0)] * 2
    # R is continuous through the graze: the gain's line goes on across it.
    assert [span for span in _spans(top) if span[0] < GRAZE < span[1]]
