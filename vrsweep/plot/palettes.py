"""Categorical colours that stay apart on a greyscale page, and the lightness that decides it.

A journal figure is often read printed in grey, or by a reader who cannot tell red from green:
what keeps two categories apart then is their lightness alone, CIE L* (0 black, 100 white). Two
colours closer than LIGHTNESS_STEP in L* print as one grey. tab10's orange and green (L* 67 and
58) or blue and red (48 and 47) did: a basin plot of four attractors printed as two greys.

Every categorical palette that fills areas (basins, integer maps, status, kinds of motion) takes
its colours from here, and tests/test_figures.py checks every pair of each, with the greys it is
drawn beside ('no value' NO_VALUE_GREY, 'not computed' NOT_COMPUTED_GREY, black), for
LIGHTNESS_STEP.
"""

from __future__ import annotations

import numpy as np

LIGHTNESS_STEP = 8.0  # CIE L*: two colours closer than this are one grey on a greyscale page

# Paul Tol's colours (personal.sron.nl/~pault), chosen in turn so that each, with the ones before
# it and the greys below, is at least LIGHTNESS_STEP from every other in L*: dark blue 29, light
# orange 67, red 46, teal 57, light cyan 77, navy 16 (L* of the greys: 38 and 87; black 0). The
# first two, the commonest case (two attractors, two periods), are 38 apart.
QUALITATIVE = ("#004488", "#EE8866", "#CC3311", "#009988", "#66CCEE", "#222255")

NO_VALUE_GREY = "0.35"       # L* 38: a value that means none ('no period', 'failed')
NOT_COMPUTED_GREY = "0.85"   # L* 87: a point not computed (a map's background)

# How each point's integration ended: ok in teal, the failures darker or lighter than it, each a
# colour of its own (they used tab10's green, orange, red, purple, brown: red 47 and purple 52,
# green 58 and orange 67 were pairs of one grey).
STATUS_COLOURS = {"not_computed": NOT_COMPUTED_GREY, "ok": "#009988", "max_steps": "#EE8866",
                  "diverged": "#CC3311", "chatter_limit": "#66CCEE", "step_too_small": "#004488",
                  "non_finite": "#000000", "sliding": "#551133"}  # sliding: L* 18, between black and 29

# The curves of one figure (a response, --var, impacts, lambda_1 or bifurcation figure with a legend,
# up to labels.MAX_CURVES of them), in turn: each two at least LIGHTNESS_STEP apart in L* (48, 67, 58,
# 39, 77, 28, 16, 0), so that none repeats another's grey. tab10 in turn repeated them from the
# fourth curve on: its red, blue and purple are L* 47, 48 and 52. The first three are tab10's, as
# before (one to three curves look as they did); the rest fill the gaps in lightness, in hues of
# their own (magenta, light cyan, brown, navy, black).
LINE_COLOURS = ("tab:blue", "tab:orange", "tab:green", "#993388", "#66CCEE", "#663333", "#222255", "#000000")

SEQUENTIAL = "viridis"  # more categories than QUALITATIVE and EXTRA hold: in order, lighter and lighter

# Curves over one parameter coloured by its value (a response figure of many Omega), from dark to
# light. viridis' top is pale yellow, unreadable as a thin line on white: the scale stops at 90 %
# (L* 15 to 84). The curves are coloured by rank, at equal steps of the scale, so that neighbours
# are as far apart in grey as the scale allows; at most MAX_SCALE_CURVES of them keep every two
# neighbours LIGHTNESS_STEP apart. Sixteen at equal steps were 4 to 5 apart in L*: neighbouring
# curves printed in one grey (and colouring by value put two close values in one colour).
CURVE_SCALE = "viridis"
CURVE_SCALE_TOP = 0.9


def lightness(colour) -> float:
    """CIE L* of a matplotlib colour: what a greyscale page keeps of it (sRGB, D65)."""
    from matplotlib.colors import to_rgb

    rgb = np.array(to_rgb(colour))
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    luminance = float(linear @ [0.2126, 0.7152, 0.0722])
    return 116.0 * np.cbrt(luminance) - 16.0 if luminance > 216.0 / 24389.0 else luminance * 24389.0 / 27.0


# Beyond six categories no palette keeps them apart in grey: Paul Tol's muted colours, of hues
# QUALITATIVE does not use, tell the rarer ones apart in colour (callers give QUALITATIVE to the
# largest categories: a basin plot's labels run by basin size, an integer map orders by cells).
EXTRA = ("#AA4499", "#999933", "#DDCC77", "#117733", "#882255", "#88CCEE")


MAX_CATEGORIES = len(QUALITATIVE) + len(EXTRA)  # categories a palette keeps apart; an integer map bins beyond


def categorical(count) -> list:
    """``count`` colours for categories: QUALITATIVE's first ``count`` (apart in lightness), then
    EXTRA's (apart in hue), then, for more than both hold (MAX_CATEGORIES), SEQUENTIAL from dark to
    light (an integer map bins its values to MAX_CATEGORIES instead: sweeps.discrete_scale). A
    sequential scale for seven or more (viridis) drew periods 1 and 3 of a map of eight periods
    in two dark purples, and period 3 on the grey of 'no period'."""
    from matplotlib import colormaps

    named = QUALITATIVE + EXTRA
    if count <= len(named):
        return list(named[:count])
    return [tuple(colour) for colour in colormaps[SEQUENTIAL](np.linspace(0.0, 1.0, count))]


def contrasting(colour) -> str:
    """The casing for a line of ``colour`` drawn over cells of any colour: black around a light
    line, white around a dark one, so that core and casing differ by at least 50 in L* and
    one of them stands out against any cell (white vanished over yellow, dark red over navy)."""
    return "black" if lightness(colour) >= 50.0 else "white"


CASING = 1.6  # points of casing beyond a line's width (0.8 a side)


def cased(colour, width):
    """Path effects that draw a line of ``colour`` and ``width`` over a map with a casing in the
    contrasting colour (``contrasting``) under it: every line and mark drawn over cells, whose
    colours run from dark to light, takes them (the legend's sample too)."""
    from matplotlib.patheffects import Normal, Stroke

    return [Stroke(linewidth=width + CASING, foreground=contrasting(colour)), Normal()]


def scale_colours(count) -> list:
    """``count`` colours of CURVE_SCALE at equal steps from its bottom to CURVE_SCALE_TOP, dark to light."""
    from matplotlib import colormaps

    steps = np.linspace(0.0, CURVE_SCALE_TOP, count) if count > 1 else np.zeros(1)
    return [tuple(colour) for colour in colormaps[CURVE_SCALE](steps)]


def most_scale_curves() -> int:
    """The most curves ``scale_colours`` keeps with every two neighbours LIGHTNESS_STEP apart in L*
    (MAX_SCALE_CURVES; tests/test_figures.py checks the two agree)."""
    count = 2
    while min(np.diff([lightness(colour) for colour in scale_colours(count + 1)])) >= LIGHTNESS_STEP:
        count += 1
    return count


MAX_SCALE_CURVES = 9  # most_scale_curves() of viridis up to 0.9 (not computed here: no matplotlib on import)
