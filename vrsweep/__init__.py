"""vrsweep: vibrational resonance sweeps of a vibro-impact Van der Pol-Duffing oscillator.

Implements Roy & Gupta, "Vibrational resonance in vibro-impact oscillator through fast
harmonic excitation", with the corrections listed in docs/errata.md.
"""

__version__ = "0.1.0"
