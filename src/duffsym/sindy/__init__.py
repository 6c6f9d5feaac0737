"""SINDy cross-check of the recovered nonlinear terms (pysindy)."""
