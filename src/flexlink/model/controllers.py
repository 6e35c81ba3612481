"""Feedback controllers from piezo (or other linear) sensors to piezo actuators (SI units).

Every controller is sampled at ``sample_rate`` (Hz) with a zero-order hold on its output:
it reads its input sensors at the sample instants (plus Gaussian noise of standard
deviation ``noise_std`` per input, then rounded to multiples of ``quantization``), updates
its state, and its outputs (V) are held until the next sample. The voltage an actuator
sees is its open-loop command (sampled at the same instants) plus every controller output
driving it, clipped to the actuator's ``limit``. Joint PID loops are servo drives
(model/joints.py), not controllers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PositivePositionFeedback:
    """PPF (Goh & Caughey 1985): a second-order filter on the sensor reading v,

        ξ̈ + 2 ζ_f ω_f ξ̇ + ω_f² ξ = ω_f² v,   V = gain · ξ   [V],

    ω_f = 2π frequency_hz. ``gain`` (V/V) > 0 is positive feedback for a collocated pair
    (same d31 sign)."""

    name: str
    sensor: str
    actuator: str
    frequency_hz: float
    damping: float
    gain: float
    sample_rate: float  # Hz
    noise_std: tuple[float, ...] = ()  # per input, in the input's unit; () = none
    quantization: tuple[float, ...] = ()  # per input; () or 0 = none
    noise_seed: int = 0

    @property
    def inputs(self) -> tuple[str, ...]:
        return (self.sensor,)

    @property
    def outputs(self) -> tuple[str, ...]:
        return (self.actuator,)


@dataclass(frozen=True)
class StrainRateFeedback:
    """SRF: V = −gain · dv/dt, the rate taken as the backward difference of consecutive
    samples, (v_k − v_{k−1}) · sample_rate. ``gain`` (V·s/V) > 0 damps a collocated pair."""

    name: str
    sensor: str
    actuator: str
    gain: float
    sample_rate: float  # Hz
    noise_std: tuple[float, ...] = ()
    quantization: tuple[float, ...] = ()
    noise_seed: int = 0

    @property
    def inputs(self) -> tuple[str, ...]:
        return (self.sensor,)

    @property
    def outputs(self) -> tuple[str, ...]:
        return (self.actuator,)


@dataclass(frozen=True)
class DiscreteLTI:
    """x_{k+1} = A x_k + B y_k, V_k = C x_k + D y_k at the sample instants; y the readings of
    ``inputs`` (sensor names, their units), V the voltages of ``outputs`` (actuator names).
    A (n, n), B (n, inputs), C (outputs, n), D (outputs, inputs); n may be 0 (a static
    gain D). Matrices are nested tuples of rows (hashable, comparable)."""

    name: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    A: tuple[tuple[float, ...], ...]  # rows; np.array(A) is the matrix
    B: tuple[tuple[float, ...], ...]
    C: tuple[tuple[float, ...], ...]
    D: tuple[tuple[float, ...], ...]
    sample_rate: float  # Hz
    noise_std: tuple[float, ...] = ()
    quantization: tuple[float, ...] = ()
    noise_seed: int = 0


@dataclass(frozen=True)
class FunctionController:
    """Any Python callable ``V = function(t, y)``: t the sample instant (s), y the readings of
    ``inputs`` (array), V the voltages of ``outputs`` (array of that length). Called once per
    sample in time order, in each integration pass (the error control runs two or more):
    a stateful callable must be an object whose state copy.deepcopy copies (a class with
    ``__call__``); a closure's or a global's state would carry over between passes."""

    name: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    function: Callable[[float, np.ndarray], np.ndarray]
    sample_rate: float  # Hz
    noise_std: tuple[float, ...] = ()
    quantization: tuple[float, ...] = ()
    noise_seed: int = 0


Controller = PositivePositionFeedback | StrainRateFeedback | DiscreteLTI | FunctionController
CONTROLLER_KINDS: tuple[str, ...] = ("ppf", "srf", "lti")
