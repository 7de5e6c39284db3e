"""The discretised models: the 1D cross-section, layers, the PML, the 2D strip."""
