"""A scenario: everything one simulation needs."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from .actuators import PiezoActuator
from .base import Base
from .chain import Chain
from .controllers import Controller
from .joints import PrismaticJoint, is_driven
from .loops import Closure
from .sensors import Sensor
from .settings import SimulationSettings, default_rtol


@dataclass(frozen=True)
class Scenario:
    """The chain, its sensors, the settings, and optionally the base it hangs on."""

    chain: Chain
    sensors: tuple[Sensor, ...] = ()
    settings: SimulationSettings = field(
        default_factory=lambda: SimulationSettings(t_end=1.0, dt_out=1e-3)
    )
    name: str = "scenario"
    # None: the chain hangs on a fixed hub at the origin. A Base makes the hub free or
    # pinned, carries applied loads and lets several branches start on it.
    base: Base | None = None
    # piezo patches driven by a voltage (open loop, or by a controller)
    actuators: tuple[PiezoActuator, ...] = ()
    # sampled feedback loops from sensors to actuators (model/controllers.py)
    controllers: tuple[Controller, ...] = ()
    # joints that close loops of the tree (model/loops.py): four-bars, slider-cranks
    closures: tuple[Closure, ...] = ()

    def __post_init__(self) -> None:
        if self.settings.rtol is None:  # the default of the run's model and path
            object.__setattr__(self, "settings", replace(
                self.settings, rtol=default_rtol(self.settings.model, self.is_forward,
                                                 bool(self.closures),
                                                 self.slides_on_fixed_base)))
        if self.base is not None and self.base.cart is not None:
            self.base.cart.check_travel(self.settings.t_end)
        for k, joint in enumerate(self.chain.joints):
            if isinstance(joint, PrismaticJoint):
                from .prismatic import check_slider

                check_slider(self, k)

    @property
    def slides_on_fixed_base(self) -> bool:
        """True if a slider is in the chain, the base does not move and no controller runs
        (the nonlinear model then integrates it by Gauss collocation: `default_rtol`)."""
        return (not self.controllers and (self.base is None or self.base.kind == "fixed")
                and any(isinstance(j, PrismaticJoint) for j in self.chain.joints))

    @property
    def is_forward(self) -> bool:
        """True if the base moves, branches start on it, or a joint is driven: the joint
        angles then follow from the equations of motion (forward dynamics); a slider in the
        chain runs there too (its travel is one more rigid coordinate: dynamics/prismatic.py)."""
        return self.base is not None or any(is_driven(j) or isinstance(j, PrismaticJoint)
                                            for j in self.chain.joints)
