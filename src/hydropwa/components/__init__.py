"""Component physics shared by the full, reduced and PWA models (see :mod:`._physics`)."""

from . import _physics
from ._physics import *  # noqa: F403  (the public component functions, _physics.__all__)
from ._pwa import PiecewiseAffine

__all__ = ["PiecewiseAffine", *_physics.__all__]
