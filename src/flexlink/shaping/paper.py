"""The paper arm's judged manoeuvre: joint 1 0° → 90°, joint 2 90° → 170° in 1.2 s, within
chosen joint limits (the paper states none). Shared by the slow validation test, the
benchmark and the docs' figures, so that all three measure the same thing."""

from __future__ import annotations

from .optimize import Limits

DURATION_S = 1.2
# CHOSEN (the paper gives no limits): rate and acceleration a third and 2.5× above the
# cycloid's peaks (150°/s, 393°/s² for joint 1); torques about twice the cycloid's peaks
# (6.0 N·m at the AC servo of joint 1, 0.11 N·m at the RC servo of joint 2).
LIMITS = Limits(rate_deg_s=200.0, acceleration_deg_s2=1000.0, torque_Nm=(12.0, 0.25))
SEED = 0

__all__ = ["DURATION_S", "LIMITS", "SEED"]
