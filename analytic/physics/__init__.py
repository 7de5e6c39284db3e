"""The exact physics: finite-H determinant, small k, half-space, large k, two bodies."""
