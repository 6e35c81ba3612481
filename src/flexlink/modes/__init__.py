"""Assumed modes of a clamped flexible link and their modal integrals."""

from flexlink.modes.integrals import ModalData, highest_frequency, modal_data
from flexlink.modes.shapes import (
    ModeShapes,
    clamped_free_modes,
    mode_shapes_for,
    tip_loaded_modes,
)

__all__ = [
    "ModalData",
    "ModeShapes",
    "clamped_free_modes",
    "highest_frequency",
    "modal_data",
    "mode_shapes_for",
    "tip_loaded_modes",
]
