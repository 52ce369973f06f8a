"""The full-order and reduced models (the PWA model lives in :mod:`hydropwa.linearization`)."""

from ._models import (
    MODEL_NAMES,
    REDUCED_FORMS,
    FullLinesModel,
    FullOrderModel,
    Model,
    ReducedModel,
    as_model,
    machine_model,
    pack_params,
)

__all__ = [
    "FullLinesModel",
    "FullOrderModel",
    "MODEL_NAMES",
    "Model",
    "REDUCED_FORMS",
    "ReducedModel",
    "as_model",
    "machine_model",
    "pack_params",
]
