"""Package forms."""
