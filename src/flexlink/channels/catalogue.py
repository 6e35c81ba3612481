"""Which channels a run of a scenario produces: names, kinds, units and descriptions.

The one place where channel names are made. The channel computations of every model path
take their records from here and add only the values; the scenario loader (names a sensor
must not take), the measurement mapping and sweeps read the same records.

Order: sensors, base pose and rates (a cart's travel, speed and force), joint quantities (all
angles, then rates, torques, servo references and commands, elastic joints' motor angles,
motor rates and spring torques), momentum, tip positions.
"""

from __future__ import annotations

import functools

from ..model import (
    ZERO,
    Chain,
    ElasticJoint,
    PiezoSensor,
    PositionServo,
    PrismaticJoint,
    Scenario,
    Sensor,
    TorqueDrive,
    VelocityServo,
)
from ..model.joints import drive_side
from .record import SENSOR_UNITS, Channel, ChannelKind, Unit

JOINT_QUANTITIES = ("angle", "rate", "torque", "reference", "command", "motor_angle",
                    "motor_rate", "spring_torque")
# The torque channel of a free (undriven) revolute joint: no motor acts, so its value is the
# round-off of its equation's row; the joint figure leaves it out.
FREE_TORQUE = "free_torque"
# A slider's coordinate is a travel: its angle, rate and torque channels are these.
SLIDER_QUANTITIES = {"angle": "position", "rate": "velocity", "torque": "force"}
BASE_COORDINATES = {"free": ("x", "y", "attitude"), "pinned": ("attitude",), "fixed": (),
                    "cart": ()}
CART_QUANTITIES = ("position", "velocity", "force")
_BASE_UNITS = {"x": (Unit.METRE, Unit.METRE_PER_SECOND), "y": (Unit.METRE, Unit.METRE_PER_SECOND),
               "attitude": (Unit.RADIAN, Unit.RADIAN_PER_SECOND)}


def joint_name(k: int, quantity: str) -> str:
    """Channel name of a joint quantity, joint k counted from 0: ``joint1_angle``."""
    return f"joint{k + 1}_{quantity}"


def coordinate_name(joint: object, k: int, quantity: str) -> str:
    """joint_name of joint k's ``angle``, ``rate`` or ``torque``; a slider's (model.
    PrismaticJoint) are its ``position``, ``velocity`` and ``force``: ``joint2_position``."""
    if isinstance(joint, PrismaticJoint):
        quantity = SLIDER_QUANTITIES.get(quantity, quantity)
    return joint_name(k, quantity)


def tip_name(link: str, axis: str) -> str:
    """Channel name of a tip coordinate: ``link1_tip_X``."""
    return f"{link}_tip_{axis}"


def reserved_names(link_names: list[str], joints: int) -> set[str]:
    """Every automatic channel name a chain of these links could produce (and ``t``,
    ``time``): a sensor must not take one."""
    try:  # made once per chain shape: every scenario build asks (sweeps, sensitivities)
        return set(_reserved_names(tuple(link_names), joints))
    except TypeError:  # an unhashable name (a problem the scenario check reports)
        return set(_reserved_names.__wrapped__(tuple(link_names), joints))


@functools.lru_cache(maxsize=64)
def _reserved_names(link_names: tuple[str, ...], joints: int) -> frozenset[str]:
    names = {"t", "time", "momentum_x", "momentum_y", "angular_momentum"}
    names |= {joint_name(k, q) for k in range(joints)
              for q in (*JOINT_QUANTITIES, *SLIDER_QUANTITIES.values())}
    names |= {f"base_{c}{r}" for c in BASE_COORDINATES["free"] for r in ("", "_rate")}
    names |= {cart_name(q) for q in CART_QUANTITIES}
    names |= {tip_name(n, axis) for n in link_names for axis in "XY"}
    return frozenset(names)


def sensor_channel(sensor: Sensor, chain: Chain) -> Channel:
    link = chain.links[sensor.link].name
    if isinstance(sensor, PiezoSensor):
        return Channel(sensor.name, ChannelKind.SENSOR, SENSOR_UNITS["piezo"],
                       "PZT voltage, pin-force model (eq. 37)", "piezo", link)
    return Channel(sensor.name, ChannelKind.SENSOR, SENSOR_UNITS[sensor.kind],
                   f"{sensor.kind} at x = {sensor.x} m", sensor.kind, link)


def sensor_channels(scenario: Scenario) -> list[Channel]:
    return [sensor_channel(s, scenario.chain) for s in scenario.sensors]


def base_channels(kind: str) -> list[Channel]:
    """Pose and rates of a moving base (inertial, reference point)."""
    out = []
    for name in BASE_COORDINATES[kind]:
        unit, rate_unit = _BASE_UNITS[name]
        out.append(Channel(f"base_{name}", ChannelKind.BASE, unit,
                           f"base {name} (reference point, inertial)", name, "base"))
        out.append(Channel(f"base_{name}_rate", ChannelKind.BASE, rate_unit,
                           f"rate of base {name}", f"{name}_rate", "base"))
    return out


def cart_name(quantity: str) -> str:
    """Channel name of a cart quantity: ``cart_position``."""
    return f"cart_{quantity}"


def cart_channels(prescribed: bool) -> list[Channel]:
    """A cart's travel along its rail, its speed and the force its drive applies."""
    how = "the force its prescribed travel takes" if prescribed else "its drive's force"
    return [Channel(cart_name("position"), ChannelKind.BASE, Unit.METRE,
                    "cart travel along its rail from the base position", "position", "cart"),
            Channel(cart_name("velocity"), ChannelKind.BASE, Unit.METRE_PER_SECOND,
                    "cart speed along its rail", "velocity", "cart"),
            Channel(cart_name("force"), ChannelKind.BASE, Unit.NEWTON,
                    f"cart force along the rail: {how}",
                    "force", "cart")]


def joint_channels(scenario: Scenario, model: str) -> list[Channel]:
    """Joint angles and motor torques; forward runs add rates, servo references and commands.

    ``model`` names the equations the torques come from, for the descriptions."""
    joints = scenario.chain.joints
    forward = scenario.is_forward
    torque_source = "equations of motion" if forward else "inverse dynamics"
    out: dict[str, list[Channel]] = {q: [] for q in JOINT_QUANTITIES}
    for k, elastic in enumerate(joints):
        subject = f"joint{k + 1}"
        joint = drive_side(elastic)  # an elastic joint's servo is its motor's
        how = {TorqueDrive: "torque-driven", VelocityServo: "velocity servo",
               PositionServo: "position servo"}.get(type(joint), "prescribed")
        if isinstance(elastic, ElasticJoint):
            how = f"elastic, its motor {how}"
        if isinstance(elastic, PrismaticJoint):
            how = how.replace("torque-driven", "force-driven")
            out["angle"].append(Channel(
                joint_name(k, "position"), ChannelKind.JOINT, Unit.METRE,
                f"travel of slider {k + 1} along its line from its point on the parent ({how})",
                "position", subject))
            out["rate"].append(Channel(joint_name(k, "velocity"), ChannelKind.JOINT,
                                       Unit.METRE_PER_SECOND, f"speed of slider {k + 1}",
                                       "velocity", subject))
            out["torque"].append(Channel(
                joint_name(k, "force"), ChannelKind.JOINT, Unit.NEWTON,
                f"force of slider {k + 1}'s drive along its line ({torque_source}, "
                f"{model.replace('_', ' ')} model)", "force", subject))
            if isinstance(joint, VelocityServo | PositionServo):
                out["reference"].append(Channel(joint_name(k, "reference"), ChannelKind.JOINT,
                                                Unit.METRE, f"reference travel of slider "
                                                f"{k + 1}'s servo", "reference", subject))
            if isinstance(joint, VelocityServo):
                out["command"].append(Channel(joint_name(k, "command"), ChannelKind.JOINT,
                                              Unit.VOLT, f"servo command of slider {k + 1}",
                                              "command", subject))
            continue
        out["angle"].append(Channel(joint_name(k, "angle"), ChannelKind.JOINT, Unit.RADIAN,
                                    f"angle of joint {k + 1} ({how})", "angle", subject))
        if forward:
            out["rate"].append(Channel(joint_name(k, "rate"), ChannelKind.JOINT,
                                       Unit.RADIAN_PER_SECOND, f"rate of joint {k + 1}",
                                       "rate", subject))
        free = isinstance(elastic, TorqueDrive) and elastic.torque == ZERO
        out["torque"].append(Channel(joint_name(k, "torque"), ChannelKind.JOINT,
                                     Unit.NEWTON_METRE, f"motor torque of joint {k + 1} "
                                     f"({torque_source}, {model.replace('_', ' ')} model)"
                                     + ("; a free joint: zero to round-off" if free else ""),
                                     FREE_TORQUE if free else "torque", subject))
        if isinstance(joint, VelocityServo | PositionServo):
            out["reference"].append(Channel(joint_name(k, "reference"), ChannelKind.JOINT,
                                            Unit.RADIAN, f"reference angle of joint {k + 1}'s "
                                            "servo", "reference", subject))
        if isinstance(joint, VelocityServo):
            out["command"].append(Channel(joint_name(k, "command"), ChannelKind.JOINT,
                                          Unit.VOLT, f"servo command of joint {k + 1}",
                                          "command", subject))
        if isinstance(elastic, ElasticJoint):
            out["motor_angle"].append(Channel(
                joint_name(k, "motor_angle"), ChannelKind.JOINT, Unit.RADIAN,
                f"motor angle of joint {k + 1} (motor shaft, relative to the parent)",
                "motor_angle", subject))
            out["motor_rate"].append(Channel(
                joint_name(k, "motor_rate"), ChannelKind.JOINT, Unit.RADIAN_PER_SECOND,
                f"motor rate of joint {k + 1}", "motor_rate", subject))
            out["spring_torque"].append(Channel(
                joint_name(k, "spring_torque"), ChannelKind.JOINT, Unit.NEWTON_METRE,
                f"spring torque of joint {k + 1} on its link, k (θ_m/N − β) + c (θ̇_m/N − β̇)",
                "spring_torque", subject))
    return [c for q in JOINT_QUANTITIES for c in out[q]]


def momentum_channels(model: str) -> list[Channel]:
    how = f"({model.replace('_', ' ')} model)"
    return [Channel("momentum_x", ChannelKind.MOMENTUM, Unit.NEWTON_SECOND,
                    f"linear momentum, X {how}", "momentum_x", "system"),
            Channel("momentum_y", ChannelKind.MOMENTUM, Unit.NEWTON_SECOND,
                    f"linear momentum, Y {how}", "momentum_y", "system"),
            Channel("angular_momentum", ChannelKind.MOMENTUM, Unit.NEWTON_METRE_SECOND,
                    f"angular momentum about the origin {how}", "angular_momentum", "system")]


def tip_channels(chain: Chain) -> list[Channel]:
    return [Channel(tip_name(link.name, axis), ChannelKind.TIP, Unit.METRE,
                    f"{axis} of the tip of {link.name}", axis, link.name)
            for link in chain.links for axis in "XY"]


def voltage_name(actuator: str) -> str:
    """Channel name of an actuator's applied voltage: ``pzt_a_voltage``."""
    return f"{actuator}_voltage"


def command_name(controller: str, output: int, outputs: int) -> str:
    """Channel name of a controller's command (V, held): ``ppf_command``, or with several
    outputs ``lqg_command1``, ``lqg_command2``, … (counted from 1)."""
    return f"{controller}_command" if outputs == 1 else f"{controller}_command{output + 1}"


def state_name(controller: str, index: int) -> str:
    """Channel name of a controller's state, counted from 1: ``ppf_state1``."""
    return f"{controller}_state{index + 1}"


def control_channels(scenario: Scenario) -> list[Channel]:
    """Actuator voltages, then per controller its commands and states (at the outputs: the
    values held since the last sample)."""
    from ..dynamics.controllers import controller_outputs, state_count

    out = [Channel(voltage_name(a.name), ChannelKind.CONTROLLER, Unit.VOLT,
                   f"voltage applied to piezo actuator {a.name} (after saturation)",
                   "voltage", a.name) for a in scenario.actuators]
    for c in scenario.controllers:
        outputs = controller_outputs(c)
        out += [Channel(command_name(c.name, j, len(outputs)), ChannelKind.CONTROLLER,
                        Unit.VOLT, f"command of controller {c.name} to {a} (before "
                        "saturation)", "command", c.name) for j, a in enumerate(outputs)]
        out += [Channel(state_name(c.name, i), ChannelKind.CONTROLLER, "1",
                        f"state {i + 1} of controller {c.name} (discrete)", "state", c.name)
                for i in range(state_count(c))]
    return out


def closure_name(closure: str, quantity: str) -> str:
    """A loop-closing joint's channel: force_x, force_y (revolute) or normal_force (slider)."""
    return f"{closure}_{quantity}"


def closure_channels(scenario: Scenario) -> list[Channel]:
    """The force each loop-closing joint applies to the point of its ``link`` (global axes;
    a slider's along the normal of its line)."""
    out = []
    for c in scenario.closures:
        quantities = (("force_x", "x"), ("force_y", "y")) if c.kind == "revolute" else (
            ("normal_force", "normal to the line"),)
        out += [Channel(closure_name(c.name, q), ChannelKind.CLOSURE, Unit.NEWTON,
                        f"force of closure {c.name} on link {scenario.chain.links[c.link].name}"
                        f" ({axis}, global axes)", q, c.name) for q, axis in quantities]
    return out


def catalogue(scenario: Scenario) -> list[Channel]:
    """Every channel a run of ``scenario`` produces, in the order of the results. Made once
    per scenario (a frozen object; a run and its checks ask for it several times)."""
    made = scenario.__dict__.get("_catalogue")
    if made is None:
        made = tuple(_catalogue(scenario))
        object.__setattr__(scenario, "_catalogue", made)
    return list(made)


def _catalogue(scenario: Scenario) -> list[Channel]:
    model = scenario.settings.model
    out = sensor_channels(scenario)
    base = scenario.base
    if base is not None:
        out += base_channels(base.kind)
        if base.cart is not None:
            out += cart_channels(base.cart.prescribed)
    out += joint_channels(scenario, model)
    if base is not None and base.kind != "fixed":
        out += momentum_channels(model)
    out += tip_channels(scenario.chain)
    out += closure_channels(scenario)
    if scenario.actuators or scenario.controllers:
        out += control_channels(scenario)
    return out
