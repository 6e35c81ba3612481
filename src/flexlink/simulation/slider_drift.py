"""A validity check of the first-order model for a force-driven or free slider on a flexible
parent (docs/prismatic_joints.md, "Limits of the first-order model").

The first-order slider row is the linearisation in the elastic coordinates: it leaves out the
products of two elastic quantities. Two of them grow with the square of the parent's
vibration frequency and keep one sign over a cycle, so a travel the drive does not hold
integrates them (vibratory conveying): the section's transverse elastic acceleration ẅ seen
along the line tilted by the section's slope φ (the block feels −cos α φ ẅ), and the
centripetal pull of the line's elastic rate φ̇ on the carried mass (+c φ̇², c its centre's
distance along the line from the section). Integrated twice from rest they give the travel the first-order run
misses; a run whose missed travel exceeds DRIFT_WARN_ABOVE of the travel's peak excursion
carries a warning. Prescribed travels and servos hold the travel; rigid parents have no φ.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..model import PrismaticJoint, TorqueDrive

# Missed travel (fraction of the travel's peak excursion) above which a run carries a warning.
DRIFT_WARN_ABOVE = 0.03
# Excursions below this fraction of the parent's length count as this much (a slider at rest).
SMALL_EXCURSION = 1e-3


def _twice_integrated(t: np.ndarray, a: np.ndarray) -> np.ndarray:
    """∬a dt dt from rest at t[0] (trapezoids on the output times)."""
    dt = np.diff(t)
    v = np.concatenate([[0.0], np.cumsum(0.5 * dt * (a[1:] + a[:-1]))])
    return np.concatenate([[0.0], np.cumsum(0.5 * dt * (v[1:] + v[:-1]))])


def _carried_centre(joint: PrismaticJoint, link: object) -> float:
    """Distance (m) along the line from the block to the centre of mass of the block and the
    link it carries (its rigid shape; the links beyond it not counted)."""
    mass = joint.mass + link.mass_per_length * link.length
    moment = link.mass_per_length * link.length ** 2 / 2
    for body in link.all_bodies():
        mass += body.mass
        moment += body.mass * body.at
    along = np.cos(joint.link_angle - joint.axis_angle)
    return float(along * moment / mass) if mass > 0.0 else 0.0


def slider_drift_metadata(system: object, t: np.ndarray, p: np.ndarray, z: np.ndarray,
                          zd: np.ndarray, zdd: np.ndarray) -> dict[str, Any]:
    """For the force-driven or free sliders on flexible parents of a forward ``system``
    (`dynamics.forward.ForwardSystem`): the largest estimated missed travel as a fraction of
    its slider's peak excursion (``slider_drift_vs_nonlinear``, with the joint), and a
    ``validity_warning`` above DRIFT_WARN_ABOVE. ``p`` (nt, rigid): the rigid states;
    ``z``, ``zd``, ``zdd`` (nt, n): the elastic coordinates and their rates. Empty where no
    such slider exists."""
    joints = system.chain.joints
    cuts = np.concatenate([[0], np.cumsum([d.n for d in system.modal])]).astype(int)
    worst: tuple[float, int, float] | None = None
    for k, joint in enumerate(joints):
        if not isinstance(joint, PrismaticJoint) or not isinstance(joint.drive, TorqueDrive):
            continue
        j = k - 1
        if j < 0 or system.modal[j].n == 0 or t.size < 3:
            continue
        hang = system.hang[j]
        coords = slice(cuts[j], cuts[j + 1])
        phi = z[:, coords] @ hang.slope
        phi_d = zd[:, coords] @ hang.slope
        w_dd = zdd[:, coords] @ hang.value
        s = p[:, system.n_base + k]
        lever = s + _carried_centre(joint, system.chain.links[k])
        missed = _twice_integrated(t, lever * phi_d ** 2 - joint.direction[0] * phi * w_dd)
        excursion = max(float(np.abs(s - s[0]).max()),
                        SMALL_EXCURSION * system.chain.links[j].length)
        ratio = float(np.abs(missed).max()) / excursion
        if worst is None or ratio > worst[0]:
            worst = (ratio, k, float(np.abs(missed).max()))
    if worst is None:
        return {}
    ratio, k, missed_peak = worst
    out: dict[str, Any] = {"slider_drift_vs_nonlinear": ratio, "slider_drift_joint": k + 1}
    if ratio > DRIFT_WARN_ABOVE:
        out["validity_warning"] = (
            f"the slider of joint {k + 1} rides on a vibrating flexible link: the first-order "
            f"model leaves out the vibration's one-sided push along its line, estimated at "
            f"{missed_peak:.3g} m of travel ({100 * ratio:.0f}% of the travel's peak "
            f"excursion, above {100 * DRIFT_WARN_ABOVE:.0f}%): model = \"nonlinear\" includes it")
    return out
