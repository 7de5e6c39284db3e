"""Computations of particular scenes on the exact spectrum."""
