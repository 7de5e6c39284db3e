"""The computations of particular scenes (no file I/O; the scenes write)."""
