"""Solvers of the discrete eigenproblems: SLEPc, banded, certified spectra, continuation."""
