"""Scenario keys of elastic joints (schema.ELASTIC): a joint table with ``spring_stiffness``
is an elastic joint whose other keys (a prescribed ``motion`` or ``csv``, ``drive = "torque"``
or ``"servo"``) describe its motor (model.ElasticJoint). Same contract as load.py: every
problem is collected in `Problems` before anything runs."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from ..model import ElasticJoint
from .errors import Problems
from .schema import ELASTIC, read_fields


def read_elastic_joint(table: Mapping[str, Any], path: str, p: Problems,
                       motor_reader: Callable[[dict[str, Any]], tuple[dict[str, Any], Any]]
                       ) -> tuple[dict[str, Any], ElasticJoint | None]:
    """The resolved table and the model of an elastic joint; ``motor_reader`` reads the
    rest of the table as a joint (the motor's drive) and returns its entry and model."""
    spring = read_fields(table, ELASTIC.fields, path, p)
    before = len(p.messages)
    entry, motor = motor_reader({k: v for k, v in table.items() if k not in ELASTIC.keys})
    if "drive" in entry and entry.get("motor_inertia") == 0.0:
        p.add(f"{path}.motor_inertia: an elastic joint's driven motor needs its rotor inertia "
              "> 0 (kg·m² about the motor axis; the spring alone cannot turn a rotor without "
              "inertia), or prescribe the motor angle with 'motion'")
    if motor is None or len(p.messages) > before or None in spring.values():
        return {**entry, **spring}, None
    return {**entry, **spring}, ElasticJoint(motor, spring["spring_stiffness"],
                                             spring["spring_damping"], spring["gear_ratio"])


__all__ = ["read_elastic_joint"]
