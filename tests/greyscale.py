"""What a greyscale page keeps of a colour: its CIE L* (sRGB, D65), computed here from the standard's
formula and not by vrsweep's plot/palettes.py, so that the figure tests check the palettes against
an independent reckoning."""

import numpy as np


def lightness(colour):
    """CIE L* of a matplotlib colour, 0 (black) to 100 (white)."""
    from matplotlib.colors import to_rgb

    rgb = np.array(to_rgb(colour))
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    y = float(linear @ [0.2126, 0.7152, 0.0722])
    return 116.0 * np.cbrt(y) - 16.0 if y > 0.008856 else 903.3 * y
