"""The model: an immutable description of a planar chain, free of physics (SI, radians).

Links and joints (`chain`), sensors, settings, the base and drives of forward runs, input
histories, and the `Scenario` that holds them. Degrees only appear at the scenario/CLI edge,
which converts them once. Algorithms take a model and never mutate it.
"""

from .actuators import PiezoActuator
from .base import BASE_KINDS, LOAD_FRAMES, Base, BaseKind, BaseLoad, Cart
from .chain import MODE_SHAPES, Body, Chain, Link, ModeShapes
from .controllers import (
    CONTROLLER_KINDS,
    Controller,
    DiscreteLTI,
    FunctionController,
    PositivePositionFeedback,
    StrainRateFeedback,
)
from .histories import ZERO, BangBang, History, Step, Sum, Table
from .joints import (
    Drive,
    ElasticJoint,
    Joint,
    JointMotion,
    PositionServo,
    PrismaticJoint,
    Servo,
    TorqueDrive,
    VelocityServo,
    is_driven,
)
from .loops import CLOSURE_KINDS, Closure, ClosureKind
from .scenario import Scenario
from .sensors import POINT_SENSOR_KINDS, PiezoSensor, PointSensor, PointSensorKind, Sensor
from .settings import (
    INITIAL_STATES,
    METHODS,
    MODELS,
    InitialName,
    MethodName,
    ModelName,
    SimulationSettings,
)

__all__ = [
    "BASE_KINDS",
    "CLOSURE_KINDS",
    "CONTROLLER_KINDS",
    "INITIAL_STATES",
    "LOAD_FRAMES",
    "METHODS",
    "MODELS",
    "MODE_SHAPES",
    "POINT_SENSOR_KINDS",
    "ZERO",
    "BangBang",
    "Base",
    "BaseKind",
    "BaseLoad",
    "Body",
    "Cart",
    "Chain",
    "Closure",
    "ClosureKind",
    "Controller",
    "DiscreteLTI",
    "Drive",
    "ElasticJoint",
    "FunctionController",
    "History",
    "InitialName",
    "Joint",
    "JointMotion",
    "Link",
    "MethodName",
    "ModeShapes",
    "ModelName",
    "PiezoActuator",
    "PiezoSensor",
    "PointSensor",
    "PointSensorKind",
    "PositionServo",
    "PositivePositionFeedback",
    "PrismaticJoint",
    "Scenario",
    "Sensor",
    "Servo",
    "SimulationSettings",
    "Step",
    "StrainRateFeedback",
    "Sum",
    "Table",
    "TorqueDrive",
    "VelocityServo",
    "is_driven",
]
