"""The settings of a slider's run on the nonlinear model: its default tolerance
(`model.settings.default_rtol`), Newton's stopping tolerance of the nonlinear forward path
(`gauss_forward.forward_newton_tol`) and the compiled residual's addresses looked up once per
record layout (`_gauss_numba.residual_model`)."""

from __future__ import annotations

import dataclasses

import numpy as np

from flexlink.model import (
    BangBang,
    Base,
    Cart,
    Chain,
    Link,
    PrismaticJoint,
    Scenario,
    SimulationSettings,
    TorqueDrive,
)
from flexlink.model.settings import (
    DEFAULT_RTOL,
    FORWARD_RTOL,
    NONLINEAR_SLIDER_RTOL,
)
from flexlink.results import Results
from flexlink.simulation.nonlinear_forward import nonlinear_forward_system
from flexlink.solvers import _gauss_numba
from flexlink.solvers.gauss_forward import (
    NEWTON_SHARE_OF_RTOL,
    NEWTON_TOL_FORWARD,
    forward_newton_tol,
)

BEAM = Link("beam", 0.8, 0.6, 12.0, tip_mass=0.2, thickness=0.01, modes=3)


def _slider(model: str = "nonlinear", base: Base | None = None, rtol: float | None = None
            ) -> Scenario:
    """A rigid link turned by a bang-bang moment carrying a block pushed along its axis,
    and on the block a flexible beam (Case 23's shape, shorter)."""
    return Scenario(
        Chain((Link("link", 0.5, 2.0, 1.0, modes=0), BEAM),
              (TorqueDrive(BangBang(0.6, 0.0, 0.2)),
               PrismaticJoint(TorqueDrive(BangBang(1.5, 0.0, 0.2), 0.1), 0.0, 0.0, mass=0.5))),
        settings=SimulationSettings(0.3, 0.01, model=model, rtol=rtol), base=base)


def test_a_slider_on_a_fixed_base_defaults_to_its_own_tolerance() -> None:
    assert _slider().settings.rtol == NONLINEAR_SLIDER_RTOL
    assert _slider(base=Base()).settings.rtol == NONLINEAR_SLIDER_RTOL
    assert _slider(rtol=1e-7).settings.rtol == 1e-7
    # a moving base keeps the nonlinear default; the first-order model its forward one
    free = Base(kind="free", mass=3.0, inertia=0.2)
    assert _slider(base=free).settings.rtol == DEFAULT_RTOL["nonlinear"]
    assert _slider("first_order").settings.rtol == FORWARD_RTOL


def test_newton_stops_at_a_share_of_rtol_only_without_base_coordinates() -> None:
    fixed = nonlinear_forward_system(_slider())
    assert forward_newton_tol(fixed, 1e-4) == NEWTON_SHARE_OF_RTOL * 1e-4
    assert forward_newton_tol(fixed, 1e-9) == NEWTON_TOL_FORWARD
    pinned = nonlinear_forward_system(_slider(base=Base(kind="pinned", inertia=0.2)))
    assert forward_newton_tol(pinned, 1e-4) == NEWTON_TOL_FORWARD
    cart = nonlinear_forward_system(_slider(base=Base("cart", mass=1.0, cart=Cart())))
    assert forward_newton_tol(cart, 1e-4) == NEWTON_SHARE_OF_RTOL * 1e-4


def _loose_and_tight(scenario: Scenario) -> tuple[Results, Results]:
    """The run with Newton at its default share of rtol, and the same run with every step's
    Newton to NEWTON_TOL_FORWARD."""
    from flexlink import simulate
    from flexlink.solvers import gauss_forward

    loose = simulate(scenario, shapes=False)
    share = gauss_forward.NEWTON_SHARE_OF_RTOL
    try:
        gauss_forward.NEWTON_SHARE_OF_RTOL = 0.0  # every step to NEWTON_TOL_FORWARD
        tight = simulate(dataclasses.replace(scenario), shapes=False)
    finally:
        gauss_forward.NEWTON_SHARE_OF_RTOL = share
    return loose, tight


def test_a_cart_run_on_the_looser_newton_keeps_its_momentum_and_channels() -> None:
    """On a free cart Newton at a thousandth of rtol: the momentum along the rail (zero,
    from rest) drifts by less than 3× that of the run whose Newton stops at
    NEWTON_TOL_FORWARD and than 3e-8 of the cart's peak momentum (measured 6e-9 against
    5e-9), and every channel is within 1e-2 · rtol of that run (measured ≤ 9e-9)."""
    scenario = _slider(base=Base("cart", mass=1.0, cart=Cart()), rtol=1e-5)
    loose, tight = _loose_and_tight(scenario)
    assert loose.metadata["newton_iterations"] < tight.metadata["newton_iterations"]
    peak = np.abs(np.asarray(loose["cart_velocity"])).max() * 1.0  # the cart's 1 kg
    drift = np.abs(np.asarray(loose["momentum_x"])).max()
    assert drift < min(3.0 * np.abs(np.asarray(tight["momentum_x"])).max(), 3e-8 * peak)
    for name in ("joint1_angle", "joint1_rate", "joint2_position", "joint2_velocity",
                 "cart_position", "cart_velocity"):
        ref = np.asarray(tight[name])
        gap = np.abs(np.asarray(loose[name]) - ref).max() / np.abs(ref).max()
        assert gap < 1e-2 * 1e-5, (name, gap)


def test_the_compiled_residual_is_looked_up_once_per_record_layout() -> None:
    system = nonlinear_forward_system(_slider())
    d = system.kernel_data()
    first = _gauss_numba.residual_model(d)
    size = len(_gauss_numba._MODELS)
    again = _gauss_numba.residual_model(nonlinear_forward_system(_slider()).kernel_data())
    assert len(_gauss_numba._MODELS) == size
    assert again[0] == first[0] and again[2] == first[2]
    # the address numba's own typeof finds for this record
    trampoline, _ = _gauss_numba._address_of(_gauss_numba._TRAMPOLINES[type(d)], (d,))
    assert first[0] == trampoline


def test_a_run_on_the_looser_newton_matches_a_tight_one() -> None:
    """Newton at a thousandth of rtol changes the slider's run by far less than rtol."""
    scenario = _slider()
    loose, tight = _loose_and_tight(scenario)
    for name in ("joint1_angle", "joint1_rate", "joint2_position", "joint2_velocity"):
        ref = np.asarray(tight[name])
        gap = np.abs(np.asarray(loose[name]) - ref).max() / np.abs(ref).max()
        assert gap < 0.1 * NONLINEAR_SLIDER_RTOL, (name, gap)
