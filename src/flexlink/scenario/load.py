"""TOML scenario → validated, resolved dict → `Scenario`.

Every check runs before any computation and all problems are raised together in one
`ScenarioError`. The resolved dict (all defaults filled in, bending stiffness as EI, CSV
paths absolute) is what a run folder saves; loading it again gives an equal `Scenario`.
Angles stay in degrees here: the motion constructors take degrees and convert once.
"""

from __future__ import annotations

import math
import os
import tomllib
import warnings
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import replace
from pathlib import Path
from typing import Any

from .._version import package_version
from ..channels.catalogue import reserved_names
from ..model import (
    Body,
    Chain,
    JointMotion,
    Link,
    PiezoSensor,
    PointSensor,
    Scenario,
    SimulationSettings,
)
from ..model.basis import chosen_mode_shapes
from . import schema
from .actuators import build_actuator, read_actuators
from .cart import build_cart, read_cart
from .closures import build_closure, read_closures
from .controllers import build_controller, read_controllers
from .drives import build_base, build_drive, read_base, read_driven_joint
from .elastic import read_elastic_joint
from .errors import Problems, ScenarioError, describe
from .initial_rates import check_rates_on_forward_runs, read_modal_rates
from .prismatic import check_sliders, read_prismatic
from .schema import (
    BODIES,
    ELASTIC,
    JOINTS,
    LINKS,
    MAX_CONTROL_SAMPLES,
    MEASURED_ANGLES,
    SIMULATION,
    read_field,
    read_fields,
)
from .sensors import read_sensors

SECTIONS = ("simulation", "base", "links", "joints", "sensors", "flexlink_version",
            "actuators", "controllers", "closures")
# read by `flexlink compare` / `flexlink fit` (flexlink.experiment); `run` ignores them
EXPERIMENT_SECTIONS = ("measurement", "fit")
# the keys of each motion profile (flexlink.batch reads them to recognise sweep paths)
PROFILES: dict[str, tuple[str, ...]] = {name: s.keys for name, s in schema.PROFILES.items()}
# links: the section's dimensions are read before the bending stiffness, which needs them
_LINK_HEAD = LINKS.pick("name", "length", "mass_per_length", "width", "thickness")
_LINK_TAIL = LINKS.pick("tip_mass", "tip_inertia", "damping_ratio", "modes", "mode_shapes")
_RIGID_TAIL = LINKS.pick("tip_mass", "tip_inertia")
_BODY_KEYS = BODIES.pick("mass", "offset", "inertia")
_ELASTIC_ONLY = ("damping_ratio", "modes", "mode_shapes", "initial_modal_rates")


flexlink_version = package_version


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a TOML scenario file; CSV paths are relative to its folder."""
    if isinstance(path, Mapping):
        raise TypeError("load_scenario reads a TOML file: give its path; for a dict of "
                        "its tables use flexlink.scenario.scenario_from_dict(d)")
    path = Path(path)
    return scenario_from_dict(read_toml(path), base_dir=path.parent, name=path.stem,
                              source=str(path))


def as_scenario(scenario: Scenario | str | os.PathLike[str], what: str) -> Scenario:
    """``scenario`` itself, or the scenario file it names loaded (`load_scenario`); a
    TypeError naming ``what`` (the function called) for anything else."""
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, str | os.PathLike):
        return load_scenario(scenario)
    raise TypeError(f"{what}: expected a Scenario (flexlink.load_scenario(path)) or the path "
                    f"of a scenario file, got {type(scenario).__name__}")


def scenario_from_dict(d: Mapping[str, Any], base_dir: Path = Path("."), *,
                       name: str = "scenario", source: str | None = None) -> Scenario:
    """Validate a parsed scenario (as tomllib returns it) and build the `Scenario`.

    ``name`` is used when ``simulation.name`` is absent; ``source`` labels error messages.
    """
    base_dir = base_dir if isinstance(base_dir, Path) else Path(base_dir)  # Path() costs
    resolved, motions = _resolve(d, base_dir, name, source)
    scenario = _build(resolved, motions)
    # what field paths address (simulation/sensitivities.py); dataclasses.replace drops it
    object.__setattr__(scenario, "_origin", (d, base_dir, name, source))
    return scenario


def resolve_scenario_dict(path_or_dict: str | Path | Mapping[str, Any],
                          base_dir: Path = Path(".")) -> dict[str, Any]:
    """The fully resolved scenario (defaults filled in, flexlink version added) as a dict."""
    if isinstance(path_or_dict, Mapping):
        resolved, motions = _resolve(path_or_dict, Path(base_dir), "scenario", None)
    else:
        path = Path(path_or_dict)
        resolved, motions = _resolve(read_toml(path), path.parent, path.stem, str(path))
    _build(resolved, motions)  # states each link's basis (mode_shapes "auto") in `resolved`
    return resolved


def read_toml(path: Path) -> dict[str, Any]:
    """Parse a TOML file; a missing file or a syntax error becomes a ScenarioError."""
    try:
        return parse_toml(path.read_text(encoding="utf-8"), str(path))
    except FileNotFoundError:
        raise ScenarioError([f"file not found: {path}"], str(path)) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError([f"cannot read {path}: {exc}"], str(path)) from None


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """Parse TOML text; tomllib's message carries the line and column of a syntax error."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError([f"TOML syntax error: {exc}"], source) from None


def _resolve(raw: Mapping[str, Any], base_dir: Path, default_name: str,
             source: str | None) -> tuple[dict[str, Any], list[JointMotion]]:
    p = Problems()
    if not isinstance(raw, Mapping):
        raise ScenarioError([f"expected a table of sections, got {describe(raw)}"], source)
    p.unknown_keys(raw, SECTIONS + EXPERIMENT_SECTIONS, "", noun="section")
    if "flexlink_version" in raw:  # informational, written into resolved scenarios
        p.string(raw, "flexlink_version", "scenario")
    simulation = _simulation(raw, p, default_name)
    links = [_once(lambda t=t, path=path: _link(t, path, p), given, (path,), p)  # type: ignore[misc]
             for path, t, given in p.given_tables(raw, "links", required=True)]
    link_names = [lk.get("name") for lk in links]
    p.check_names(link_names, "links")
    given_joints = p.given_tables(raw, "joints", required=True)
    joint_tables = [(path, table) for path, table, _ in given_joints]
    if links and joint_tables and len(joint_tables) != len(links):
        p.add(f"joints: expected one [[joints]] table per link ({len(links)}), "
              f"got {len(joint_tables)}")
    joints, motions = [], []
    t_end = simulation.get("t_end")
    for path, table, given in given_joints:
        joint, motion = _once(lambda table=table, path=path: _joint(table, path, base_dir,  # type: ignore[misc]
                                                                    t_end, p),
                              given, (path, base_dir, t_end), p)
        joints.append(joint)
        motions.append(motion)
    base = read_base(raw.get("base"), base_dir, p)
    if base is not None and base.get("type") == "cart" and "cart" in raw["base"]:
        base["cart"] = read_cart(raw["base"]["cart"], "base.cart", base_dir,
                                 simulation.get("t_end"), p)
    _check_massless_base(base, joints, simulation.get("model"), p)
    reserved = reserved_names([n for n in link_names if n], len(links))
    sensors = read_sensors(p.table_array(raw, "sensors", required=False), links, reserved, p)
    p.check_names([s.get("name") for s in sensors], "sensors")
    actuators = read_actuators(p.table_array(raw, "actuators", required=False), links, sensors,
                               base_dir, p)
    p.check_names([a.get("name") for a in actuators], "actuators")
    sensor_names = {s.get("name") for s in sensors}
    for i, a in enumerate(actuators):
        if a.get("name") in sensor_names:
            p.add(f"actuators[{i}].name {a['name']!r} is a sensor's name; choose another")
    controllers = read_controllers(p.table_array(raw, "controllers", required=False), sensors,
                                   actuators, p)
    _check_controller_names(controllers, actuators, reserved | {s.get("name") for s in sensors},
                            p)
    _check_controller_samples(controllers, simulation.get("t_end"), p)
    closures = read_closures(p.table_array(raw, "closures", required=False), links, joints,
                             simulation, reserved | set(link_names) | sensor_names
                             | {a.get("name") for a in actuators}, p)
    check_sliders(joint_tables, base, simulation, closures, controllers, p, links)
    check_rates_on_forward_runs(links, joints, base, p)
    if p:
        raise ScenarioError(p.messages, source)
    _warn_of_moves_after_the_end(joints, base, simulation["t_end"])
    resolved = {"flexlink_version": flexlink_version(), "simulation": simulation,
                "links": links, "joints": joints, "sensors": sensors}
    if base is not None:
        resolved["base"] = base
    if actuators:
        resolved["actuators"] = actuators
    if controllers:
        resolved["controllers"] = controllers
    if closures:
        resolved["closures"] = closures
    return resolved, [m for m in motions if m is not None]  # all built: no problems


# Within `reusing_tables`: each [[links]] and [[joints]] table's resolution, by the table's
# identity (and what else it reads), with the table itself to check that identity.
_REUSED: ContextVar[dict[tuple[Any, ...], tuple[Any, Any]] | None] = ContextVar(
    "_REUSED", default=None)


@contextmanager
def reusing_tables() -> Iterator[None]:
    """Within it, scenario builds resolve a [[links]] or [[joints]] table that they share
    as the same object once: many builds of one file that differ in a value or two (a
    sensitivity's stencil: `ScenarioFile.with_values` copies only the tables on a changed
    path and shares the others). For a stretch of builds during which no table is changed
    in place. Within another, the outer one's resolutions serve."""
    token = _REUSED.set({} if _REUSED.get() is None else _REUSED.get())
    try:
        yield
    finally:
        _REUSED.reset(token)


def _once(read: Callable[[], Any], table: object, key: tuple[Any, ...], p: Problems) -> Any:
    """``read()``, the resolution of ``table`` (as given in the file's dict), or within
    `reusing_tables` a copy of its
    earlier one (a link's dict or a joint's (dict, motion); top-level copies, as building
    the scenario sets a link's chosen "mode_shapes" in its dict). A table with problems is
    not kept: they are reported each time."""
    kept = _REUSED.get()
    if kept is None:
        return read()
    found = kept.get((id(table), *key))
    if found is None or found[0] is not table:
        before = len(p.messages)
        out = read()
        if len(p.messages) > before:
            return out
        found = kept[(id(table), *key)] = (table, out)
    out = found[1]
    return dict(out) if isinstance(out, dict) else (dict(out[0]), out[1])


def _simulation(raw: Mapping[str, Any], p: Problems, default_name: str) -> dict[str, Any]:
    table = raw.get("simulation")
    if not isinstance(table, Mapping):
        p.add("missing section [simulation] (t_end and dt_out are required)" if table is None
              else f"simulation: expected a table [simulation], got {describe(table)}")
        return {}
    path = "simulation"
    p.unknown_keys(table, SIMULATION.keys, path)
    out = read_fields(table, SIMULATION.fields, path, p, defaults={"name": default_name})
    if out["t_end"] is not None and out["dt_out"] is not None and out["dt_out"] > out["t_end"]:
        p.add(f"simulation.dt_out must be <= simulation.t_end ({out['t_end']!r} s), "
              f"got {out['dt_out']!r}")
    if out.get("step") is not None and out["model"] == "first_order":
        p.add("simulation.step: a fixed step is the nonlinear model's; the first-order model "
              "controls its steps by rtol. Leave step out, or set model = \"nonlinear\"")
    name = out.get("name")
    if isinstance(name, str) and ("/" in name or "\\" in name):
        p.add(f"simulation.name {name!r} names the run's files and folders: no '/' or '\\' "
              "(give e.g. " + repr(name.replace("/", "-").replace("\\", "-").strip(".-"))
              + ")")
    # unusable values are reported (no resolved scenario then); an unset step stays absent
    return {k: v for k, v in out.items() if v is not None}


def _link(table: dict[str, Any], path: str, p: Problems) -> dict[str, Any]:
    p.unknown_keys(table, LINKS.keys, path)
    out = read_fields(table, _LINK_HEAD, path, p)
    if read_field(table, LINKS["rigid"], path, p):
        out.update(_rigid_link(table, path, out, p))
    else:
        out["EI"] = _bending_stiffness(table, path, out["width"], out["thickness"], p)
        out.update(read_fields(table, _LINK_TAIL, path, p))
        out["initial_modal_rates"] = read_modal_rates(table, path, out.get("modes"), p)
        _check_frequencies(out, table, path, p)
    _check_inertia(out, path, p)
    bodies = _bodies(table, path, out.get("length"), p)
    if bodies:
        out["bodies"] = bodies
    # in the schema's key order (the resolved file's), without E and unusable values
    return {k: out[k] for k in LINKS.keys if out.get(k) is not None}


def _rigid_link(table: dict[str, Any], path: str, head: dict[str, Any],
                p: Problems) -> dict[str, Any]:
    """The keys of a rigid link (rigid = true): its tip body; a bending stiffness if given
    (unused, kept so that rigid = false restores the link); no modal keys."""
    for key in _ELASTIC_ONLY:
        if key in table:
            p.add(f"{path}.{key}: a rigid link (rigid = true) has no modes; leave out '{key}' "
                  "or set rigid = false")
    out = read_fields(table, _RIGID_TAIL, path, p)
    if "EI" in table or "E" in table:
        out["EI"] = _bending_stiffness(table, path, head["width"], head["thickness"], p)
    return {**out, "rigid": True}


def _bodies(table: Mapping[str, Any], path: str, length: float | None,
            p: Problems) -> list[dict[str, Any]]:
    """The link's [[links.bodies]] (`model.Body`), each read and checked by its keys."""
    raw = table.get("bodies", [])
    if not isinstance(raw, list):
        p.add(f"{path}.bodies: expected an array of tables [[links.bodies]], got "
              f"{describe(raw)}")
        return []
    out = []
    for i, entry in enumerate(raw):
        where = f"{path}.bodies[{i}]"
        if not isinstance(entry, Mapping):
            p.add(f"{where}: expected a table, got {describe(entry)}")
            continue
        p.unknown_keys(entry, BODIES.keys, where)
        at = read_field(entry, BODIES["at"], where, p, default=length)
        body = {"at": at, **read_fields(entry, _BODY_KEYS, where, p)}
        if at is not None and length is not None and at > length:
            p.add(f"{where}.at = {at!r} m is beyond the link's tip (length = {length!r} m); "
                  "give 0 <= at <= length")
        if body["mass"] == 0.0 and body["inertia"] == 0.0:
            p.add(f"{where}: a body needs a mass or an inertia (both are 0); give mass (kg) "
                  "or inertia (kg·m²), or leave the table out")
        out.append(body)
    return out


MAX_FREQUENCY = 1e12  # rad/s: far above any beam's modes, far below a float's overflow


def _check_frequencies(link: dict[str, Any], table: Mapping[str, Any], path: str,
                       p: Problems) -> None:
    """The highest assumed mode's frequency ((n − ½)π/L)² √(EI/m) (rad/s, bare cantilever;
    a tip body only lowers it) must be below MAX_FREQUENCY: beyond, the solver's matrices
    overflow or its steps vanish. Computed in logarithms, which cannot overflow."""
    EI, m, L, n = (link.get(k) for k in ("EI", "mass_per_length", "length", "modes"))
    if None in (EI, m, L, n):
        return
    log_omega = (2 * math.log((n - 0.5) * math.pi) - 2 * math.log(L)
                 + 0.5 * (math.log(EI) - math.log(m)))
    if log_omega > math.log(MAX_FREQUENCY):
        given = "E" if "E" in table else "EI"
        p.add(f"{path}: {given} (EI = {EI:.3g} N·m²), mass_per_length = {m:.3g} kg/m and "
              f"length = {L:.3g} m give mode {n} a frequency of "
              f"10^{log_omega / math.log(10):.0f} rad/s (at most {MAX_FREQUENCY:.0e}): not a "
              "physical beam; check these values, or for a link that does not bend set "
              "rigid = true")


MAX_INERTIA = 1e100  # kg·m²: products of two such terms stay finite in the solver


def _check_inertia(link: dict[str, Any], path: str, p: Problems) -> None:
    """The link's inertia about its joint, m L³/3 + m_t L² + J_t (kg·m², logarithms of the
    terms), must stay below MAX_INERTIA, or the equations overflow."""
    m, L = link.get("mass_per_length"), link.get("length")
    if m is None or L is None:
        return
    terms = {"mass_per_length": math.log(m) + 3 * math.log(L) - math.log(3)}
    if link.get("tip_mass"):
        terms["tip_mass"] = math.log(link["tip_mass"]) + 2 * math.log(L)
    if link.get("tip_inertia"):
        terms["tip_inertia"] = math.log(link["tip_inertia"])
    key, worst = max(terms.items(), key=lambda item: item[1])
    if worst > math.log(MAX_INERTIA):
        p.add(f"{path}: length = {L:.3g} m and {key} = {link[key]:.3g} give an inertia about "
              f"the joint of 10^{worst / math.log(10):.0f} kg·m² (at most {MAX_INERTIA:.0e}): "
              "check these values and their units")


def _bending_stiffness(table: dict[str, Any], path: str, width: float | None,
                       thickness: float | None, p: Problems) -> float | None:
    """EI (N·m²): given, or E·width·thickness³/12 of a rectangular section."""
    if "EI" in table and "E" in table:
        p.add(f"{path}: give either EI (N·m²) or E (Pa) with width and thickness, not both")
    elif "EI" in table:
        return read_field(table, LINKS["EI"], path, p)
    elif "E" in table:
        modulus = read_field(table, LINKS["E"], path, p)
        for key in ("width", "thickness"):
            if key not in table:
                p.add(f"{path}: missing required key '{key}' (m, > 0; needed with E)")
        if modulus is not None and width is not None and thickness is not None:
            return modulus * width * thickness**3 / 12.0
    else:
        p.add(f"{path}: missing bending stiffness: give EI (N·m²), or E (Pa) with width "
              "and thickness (m)")
    return None


def _warn_of_moves_after_the_end(joints: list[dict[str, Any]], base: dict[str, Any] | None,
                                 t_end: float) -> None:
    """A warning for each joint or cart whose moves (its motion's or servo reference's
    profiles with a start) all start at or after t_end: the run shows it held at its start.
    Not refused: a run that ends before the move (the state it starts from) is a run one may
    want."""
    tables = [(f"joints[{k}]", "slider" if joint.get("type") == "prismatic" else "joint",
               joint) for k, joint in enumerate(joints)]
    if base is not None and isinstance(base.get("cart"), Mapping):
        tables.append(("base.cart", "cart", base["cart"]))
    for where, noun, table in tables:
        for key in ("motion", "reference"):
            profiles = table.get(key)
            starts = [(float(profile["start"]), i) for i, profile in enumerate(profiles)
                      if isinstance(profile, Mapping) and profile.get("start") is not None
                      ] if isinstance(profiles, list) else []
            if starts and min(starts)[0] >= t_end:
                start, i = min(starts)
                warnings.warn(f"{where}.{key}[{i}].start = {start:g} s is at or after "
                              f"simulation.t_end = {t_end:g} s: the {noun} does not move in "
                              "the run; start the move earlier or raise t_end", stacklevel=4)


def _joint(table: dict[str, Any], path: str, base_dir: Path, t_end: float | None,
           p: Problems) -> tuple[dict[str, Any], Any]:
    if table.get("type") == "prismatic":  # a slider (scenario/prismatic.py)
        return read_prismatic(table, path, base_dir, t_end, p)
    if "type" in table:  # its other keys would be read as a revolute joint's: one problem
        p.add(f"{path}.type must be \"prismatic\" (a slider), got {describe(table['type'])}; "
              "a revolute joint has no type: leave the key out")
        return {}, None
    if any(key in table for key in ELASTIC.keys):  # the rest of the table drives the motor
        return read_elastic_joint(table, path, p, lambda rest: _joint(rest, path, base_dir,
                                                                      t_end, p))
    if "drive" in table:
        return _driven_joint(table, path, base_dir, p)
    if "base_point" in table:  # a prescribed joint may start a branch on the base too
        rest = {k: v for k, v in table.items() if k != "base_point"}
        entry, motion = _joint(rest, path, base_dir, t_end, p)
        pair = read_field(table, JOINTS["base_point"], path, p)
        return ({**entry, "base_point": pair} if pair is not None else entry), motion
    if "motion" in table and "csv" in table:
        p.add(f"{path}: give either 'motion' (profiles) or 'csv' (measured angles), not both")
        return {}, None
    if "csv" in table:
        return _csv_joint(table, path, base_dir, t_end, p)
    if "motion" not in table:
        p.add(f"{path}: missing 'motion' (an array of profiles) or 'csv' (measured angles)")
        p.unknown_keys(table, ("motion", *MEASURED_ANGLES.keys), path)
        return {}, None
    p.unknown_keys(table, ("motion",), path)  # base_point is taken out above
    resolved, motion = _motion(table["motion"], f"{path}.motion", p)
    return {"motion": resolved}, motion


def _driven_joint(table: dict[str, Any], path: str, base_dir: Path,
                  p: Problems) -> tuple[dict[str, Any], Any]:
    """A joint whose angle follows from the dynamics (scenario/drives.py)."""
    before = len(p.messages)
    reference: list[JointMotion | None] = []

    def motion_reader(value: Any, where: str) -> tuple[Any, JointMotion | None]:
        resolved, motion = _motion(value, where, p)
        reference.append(motion)
        return resolved, motion

    entry = read_driven_joint(table, path, base_dir, p, motion_reader)
    if len(p.messages) > before:
        return entry, None
    return entry, build_drive(entry, reference[0] if reference else None)


def _motion(segments: Any, path: str, p: Problems) -> tuple[Any, JointMotion | None]:
    """An array of motion profiles (one JointMotion, or a Sequence of them)."""
    if not isinstance(segments, list) or not segments:
        p.add(f"{path}: expected a non-empty array of profiles, e.g. "
              f"[{{profile = \"hold\", angle_deg = 0.0}}], got {describe(segments)}")
        return [], None
    from .. import motion as motion_module

    resolved, built = [], []
    for i, segment in enumerate(segments):
        entry, obj = _segment(segment, f"{path}[{i}]", motion_module, p)
        resolved.append(entry)
        built.append(obj)
    segments = [obj for obj in built if obj is not None]
    if len(segments) < len(built):
        return resolved, None
    if len(segments) == 1:
        return resolved, segments[0]
    try:
        return resolved, motion_module.Sequence(tuple(segments))
    except ValueError as exc:
        message = str(exc)  # names the segment as "motion[i]"
        head = path.rsplit(".", 1)[0]
        p.add(f"{head}.{message}" if message.startswith("motion[") else f"{path}: {message}")
        return resolved, None


def _segment(segment: Any, path: str, motion_module: Any,
             p: Problems) -> tuple[dict[str, Any], JointMotion | None]:
    if not isinstance(segment, Mapping):
        p.add(f"{path}: expected a table like {{profile = \"hold\", angle_deg = 0.0}}, "
              f"got {describe(segment)}")
        return {}, None
    if "csv" in segment and "profile" not in segment and ".motion[" in path:
        joint = path.split(".motion[")[0]
        p.add(f"{path}: measured angles are not a motion segment: give csv (and "
              f"time_column, angle_column, lowpass_hz) on {joint} itself, in place of its "
              "motion")
        return dict(segment), None
    profile = read_field(segment, schema.PROFILE, path, p)
    if profile is None:
        return dict(segment), None
    before = len(p.messages)
    section = schema.PROFILES[profile]
    p.unknown_keys(segment, ("profile", *section.keys), path)
    values = read_fields(segment, [f for f in section.fields if f.kind != "vector"], path, p)
    values.update(_number_arrays(segment, section, path, p))
    entry = {"profile": profile, **values}
    if len(p.messages) > before:  # unknown or missing keys, or wrong types
        return entry, None
    cls = (motion_module.shaped.shaped_move if profile == "shaped"
           else getattr(motion_module, profile.capitalize()))
    try:
        return entry, cls(**values)
    except ValueError as exc:
        label = "Shaped: " if profile == "shaped" else f"{cls.__name__}: "
        message = str(exc)  # "Cycloidal: duration must be …"
        p.add(f"{path}.{message.removeprefix(label)}" if message.startswith(label)
              else f"{path}: {message}")
        return entry, None


def _number_arrays(segment: Mapping[str, Any], section: schema.Section, path: str,
                   p: Problems) -> dict[str, list[float]]:
    """The array keys of a profile (shaper modes, harmonic coefficients), checked element by
    element: {key: list of floats}; a default fills a missing key (damping: 0 per mode)."""
    out: dict[str, list[float]] = {}
    for f in section.fields:
        if f.kind != "vector":
            continue
        value = segment.get(f.key)
        if value is None:
            if f.default is schema.REQUIRED:
                p.add(f"{path}: missing required key '{f.key}' (an array of numbers, {f.unit})")
            elif f.default is not None:
                out[f.key] = [float(x) for x in f.default]
            continue
        if not isinstance(value, list) or not all(
                isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
                for x in value):
            p.add(f"{path}.{f.key}: expected an array of finite numbers, got {describe(value)}")
            continue
        out[f.key] = [float(x) for x in value]
    freqs, damping = out.get("frequencies_hz"), out.get("damping")
    if freqs is not None:
        if not freqs:
            p.add(f"{path}.frequencies_hz: give at least one target frequency (Hz)")
        for i, x in enumerate(freqs):
            if x <= 0.0:
                p.add(f"{path}.frequencies_hz[{i}] must be > 0 Hz, got {x!r}")
    if damping is not None:
        for i, x in enumerate(damping):
            if not 0.0 <= x < 1.0:
                p.add(f"{path}.damping[{i}] must be in [0, 1) (a damping ratio), got {x!r}")
        if freqs and len(damping) not in (1, len(freqs)):
            p.add(f"{path}.damping: give one damping ratio per frequency ({len(freqs)}) or "
                  f"one for all, got {len(damping)}")
    elif freqs and "damping" in section.keys:
        out["damping"] = [0.0] * len(freqs)
    return out


def _csv_joint(table: dict[str, Any], path: str, base_dir: Path, t_end: float | None,
               p: Problems) -> tuple[dict[str, Any], JointMotion | None]:
    before = len(p.messages)
    p.unknown_keys(table, MEASURED_ANGLES.keys, path)
    entry = read_fields(table, MEASURED_ANGLES.fields, path, p)
    if entry["csv"] is not None:
        entry["csv"] = str((base_dir / entry["csv"]).resolve())
    entry = {k: v for k, v in entry.items() if v is not None}
    if len(p.messages) > before:
        return entry, None
    if not Path(entry["csv"]).is_file():
        p.add(f"{path}.csv: file not found: {entry['csv']} (paths are relative to the "
              "scenario file's folder)")
        return entry, None
    from ..motion import MeasuredMotion

    try:
        motion = MeasuredMotion.from_csv(Path(entry["csv"]), time_column=entry["time_column"],
                                         angle_column=entry["angle_column"],
                                         lowpass_hz=entry.get("lowpass_hz"))
    except (ValueError, OSError) as exc:
        p.add(f"{path}.csv: {exc}")
        return entry, None
    first, last = motion.time_range
    if t_end is not None and (first > 1e-9 or last < t_end - 1e-9):
        p.add(f"{path}.csv: the measured angles cover {first:g} s to {last:g} s; the "
              f"simulation needs 0 s to simulation.t_end = {t_end:g} s")
    return entry, motion


def _link_model(entry: dict[str, Any]) -> Link:
    """The `Link` of a resolved [[links]] entry; a rigid link has no modes (and, if no EI
    was given, an infinite one)."""
    fields = {k: v for k, v in entry.items() if k not in ("width", "rigid")}
    if "bodies" in fields:
        fields["bodies"] = tuple(Body(b["at"], b["mass"], tuple(b["offset"]), b["inertia"])
                                 for b in fields["bodies"])
    if "initial_modal_rates" in fields:
        fields["initial_modal_rates"] = tuple(fields["initial_modal_rates"])
    if entry.get("rigid"):
        fields.update(modes=0, EI=fields.get("EI", math.inf))
    return Link(**fields)


def _build(resolved: dict[str, Any], motions: list[JointMotion]) -> Scenario:
    sim = resolved["simulation"]
    settings = SimulationSettings(t_end=sim["t_end"], dt_out=sim["dt_out"],
                                  geometric_stiffening=sim["geometric_stiffening"],
                                  rtol=sim.get("rtol"), atol=sim["atol"], method=sim["method"],
                                  model=sim["model"], step=sim.get("step"),
                                  gravity=tuple(sim["gravity"]), initial=sim["initial"])
    links = tuple(_link_model(lk) for lk in resolved["links"])
    index = {link.name: i for i, link in enumerate(links)}
    sensors: list[PointSensor | PiezoSensor] = []
    for s in resolved["sensors"]:
        fields = {k: v for k, v in s.items() if k not in ("kind", "link")}
        if s["kind"] == "piezo":
            sensors.append(PiezoSensor(link=index[s["link"]], **fields))
        else:
            sensors.append(PointSensor(kind=s["kind"], link=index[s["link"]], **fields))
    chain = Chain(links=links, joints=tuple(motions))
    entry = resolved.get("base")
    cart = build_cart(entry["cart"]) if entry is not None and "cart" in entry else None
    base = build_base(entry, resolved["joints"], cart)
    closures = tuple(build_closure(c, index) for c in resolved.get("closures", ()))
    chain = _with_chosen_bases(chain, base, resolved["links"], closures)
    actuators = tuple(build_actuator(a, index) for a in resolved.get("actuators", ()))
    controllers = tuple(build_controller(c) for c in resolved.get("controllers", ()))
    return Scenario(chain=chain, sensors=tuple(sensors), settings=settings, name=sim["name"],
                    base=base, actuators=actuators, controllers=controllers,
                    closures=closures)


def _with_chosen_bases(chain: Chain, base: Any, entries: list[dict[str, Any]],
                       closures: tuple[Any, ...] = ()) -> Chain:
    """``chain`` with "auto" replaced by the basis it stands for (model.basis), which the
    resolved ``entries`` then state too (the resolved scenario names the basis that ran)."""
    kinds = chosen_mode_shapes(chain, base, closures)
    for entry, kind in zip(entries, kinds):
        if entry.get("mode_shapes") == "auto":
            entry["mode_shapes"] = kind
    return Chain(tuple(replace(link, mode_shapes=kind) if link.mode_shapes == "auto" else link
                       for link, kind in zip(chain.links, kinds)), chain.joints)


def _check_massless_base(base: dict[str, Any] | None, joints: list[dict[str, Any]],
                         model: str | None, p: Problems) -> None:
    """A free base of zero mass and inertia makes the first link the free body itself. A
    driven joint on it has no inertia to turn against (the base's attitude and the joint's
    angle turn the same bodies: a singular mass matrix), and the nonlinear model's step
    control does not converge on loads applied to it: refused, naming the fields."""
    if (base is None or base.get("type") != "free" or base.get("mass") != 0.0
            or base.get("inertia") != 0.0):
        return
    what = "base.mass = 0 and base.inertia = 0"
    for i, joint in enumerate(joints):
        if (i == 0 or "base_point" in joint) and ("drive" in joint or "spring_stiffness" in joint):
            p.add(f"{what} with joints[{i}] driven (drive = {joint.get('drive', 'spring')!r}) "
                  "on the base: "
                  "the joint's torque has no base inertia to act against; give base.mass "
                  f"and base.inertia > 0, or prescribe joints[{i}] (motion)")
    if model == "nonlinear" and base.get("loads"):
        p.add(f"{what} with base.loads: the nonlinear model does not converge on loads "
              "applied to a base without mass; give base.mass and base.inertia > 0, or "
              "model = \"first_order\"")


def _check_controller_samples(controllers: list[dict[str, Any]], t_end: float | None,
                              p: Problems) -> None:
    """Each controller's samples over the run, t_end × sample_rate, at most
    MAX_CONTROL_SAMPLES (checked before any array is made)."""
    if t_end is None:
        return
    for i, c in enumerate(controllers):
        rate = c.get("sample_rate")
        if rate is not None and t_end * rate > MAX_CONTROL_SAMPLES:
            p.add(f"controllers[{i}].sample_rate = {rate:g} Hz: {t_end * rate:.3g} samples "
                  f"over simulation.t_end = {t_end:g} s, more than the "
                  f"{MAX_CONTROL_SAMPLES:.0e} allowed; sample_rate = "
                  f"{MAX_CONTROL_SAMPLES / t_end:.3g} Hz or lower fits (or a shorter t_end)")


def _check_controller_names(controllers: list[dict[str, Any]], actuators: list[dict[str, Any]],
                            taken: set[Any], p: Problems) -> None:
    """Controller names are unique and their channels (`<name>_command`, `<name>_state<i>`)
    clash with no other channel."""
    p.check_names([c.get("name") for c in controllers], "controllers")
    taken = taken | {f"{a.get('name')}_voltage" for a in actuators}
    for i, c in enumerate(controllers):
        name = c.get("name")
        if name is not None and (name in taken or f"{name}_command" in taken):
            p.add(f"controllers[{i}].name {name!r} clashes with a sensor or channel name; "
                  "choose another")
