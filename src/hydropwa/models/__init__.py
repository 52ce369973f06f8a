"""The full-order and reduced models (the PWA model lives in :mod:`hydropwa.linearization`)."""

from ._models import FullOrderModel, Model, ReducedModel, as_model, pack_params

__all__ = ["FullOrderModel", "Model", "ReducedModel", "as_model", "pack_params"]
