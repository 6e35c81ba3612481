"""Assumed modes of a clamped flexible link and their modal integrals."""

from flexlink.modes.integrals import ModalData, modal_data
from flexlink.modes.shapes import (
    ModeShapes,
    clamped_free_modes,
    mode_shapes_for,
    tip_loaded_modes,
)

__all__ = [
    "ModeShapes",
    "clamped_free_modes",
    "tip_loaded_modes",
    "mode_shapes_for",
    "ModalData",
    "modal_data",
]
