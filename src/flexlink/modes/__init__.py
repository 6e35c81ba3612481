"""Assumed modes of a clamped flexible link and their modal integrals."""

from flexlink.modes.integrals import (
    ModalData,
    highest_frequency,
    modal_data,
    modal_data_for_stiffness,
    unit_stiffness_modal_data,
)
from flexlink.modes.shapes import (
    ModeShapes,
    clamped_free_modes,
    hub_loaded_modes,
    mode_shapes_for,
    tip_loaded_modes,
)

__all__ = [
    "ModalData",
    "ModeShapes",
    "clamped_free_modes",
    "highest_frequency",
    "hub_loaded_modes",
    "modal_data",
    "modal_data_for_stiffness",
    "mode_shapes_for",
    "tip_loaded_modes",
    "unit_stiffness_modal_data",
]
