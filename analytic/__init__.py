"""Package analytic."""
