"""The root machinery: contour counts, Newton, continuation, spectra, tracking."""
