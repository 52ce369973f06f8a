"""Piecewise-affine linearization of the reduced model, Sec. IV of the paper."""
