"""The time-domain simulation with the nonlinear friction law."""
