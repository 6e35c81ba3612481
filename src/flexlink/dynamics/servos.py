"""Servo laws: the motor torque of a servo-driven joint from its error (SI units, radians)."""

from __future__ import annotations

import numpy as np

from ..model import Servo, VelocityServo


def servo_torque(servo: Servo, t: np.ndarray, angle: np.ndarray, rate: np.ndarray,
                 integral: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Motor torque (N·m) and the rate of the integral state (rad) of a servo at times t (s),
    joint angle (rad), rate (rad/s) and integral of the error (rad·s), all of one shape."""
    if isinstance(servo, VelocityServo):
        error, raw, volts = _pid(servo, t, angle, rate, integral)
        command = servo.rate_per_volt * volts
        # Conditional integration: no wind-up while the command is saturated.
        integral_rate = np.where((volts == raw) & servo.integrator, error, 0.0)
    else:
        error = servo.reference.evaluate(np.asarray(t, dtype=float))[0] - angle
        command = np.clip(servo.bandwidth * error, -servo.rate_limit, servo.rate_limit)
        integral_rate = np.zeros_like(error)
    torque = np.clip(servo.loop_gain * (command - rate), -servo.torque_limit, servo.torque_limit)
    return torque, integral_rate


def command_volts(servo: VelocityServo, t: np.ndarray, angle: np.ndarray, rate: np.ndarray,
                  integral: np.ndarray) -> np.ndarray:
    """The PID's saturated command (V) of a velocity servo."""
    return _pid(servo, t, angle, rate, integral)[2]


def _pid(servo: VelocityServo, t: np.ndarray, angle: np.ndarray, rate: np.ndarray,
         integral: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Error (rad), raw PID output and saturated command (V)."""
    ref, ref_rate, _ = servo.reference.evaluate(np.asarray(t, dtype=float))
    error = ref - angle
    raw = servo.P * error + servo.I * integral + servo.D * (ref_rate - rate)
    return error, raw, np.clip(raw, -servo.saturation, servo.saturation)
