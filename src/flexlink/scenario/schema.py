"""The scenario schema: every key of every kind of table, with its type, unit, default, bounds,
allowed values and documentation — the one source the loader reads and docs/scenario.md's
key tables are generated from (`schema_docs.py`).

A `Field` describes one key; a `Section` lists the keys of one kind of table in file order
(the order unknown-key hints list them). `read_fields` checks keys with the typed readers of
`Problems`; rules that involve several keys (EI or E, x within the link, ...) stay in the
readers (load.py, sensors.py, drives.py) and are described here in ``rule`` for the docs.
Allowed values of the model's choices come from its literal types, never a copy.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from ..model import (
    BASE_KINDS,
    CLOSURE_KINDS,
    INITIAL_STATES,
    LOAD_FRAMES,
    METHODS,
    MODE_SHAPES,
    MODELS,
    POINT_SENSOR_KINDS,
)
from ..motion.shapers import DEFAULT_TOLERABLE_VIBRATION, SHAPERS
from .errors import REQUIRED, Problems

# scalar kinds are read by `read_fields`; the others (arrays of tables, segments) by code
Kind = Literal["number", "integer", "string", "boolean", "pair", "numbers", "profiles",
               "history", "table", "tables", "strings", "vector", "matrix"]
_READERS: dict[str, Callable[..., Any]] = {
    "number": Problems.number, "integer": Problems.integer, "string": Problems.string,
    "boolean": Problems.boolean, "pair": Problems.pair,
}


@dataclass(frozen=True)
class Field:
    """One key: how it is read and checked, and how the docs describe it.

    ``default`` is `REQUIRED`, None (optional, absent from the resolved scenario) or the
    value; ``default_doc`` replaces the docs' default text when the reader sets the default
    (e.g. from another key). ``rule``: a further constraint checked in code, for the docs.
    ``notes``: what each allowed value means. ``by_model``: unit and bounds are checked by
    the motion constructors (with their messages); the reader only checks for a number.
    """

    key: str
    kind: Kind = "number"
    unit: str = ""
    default: Any = REQUIRED
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    nonzero: bool = False
    choices: tuple[str, ...] | None = None
    doc: str = ""
    notes: Mapping[str, str] = field(default_factory=dict)
    default_doc: str = ""
    rule: str = ""
    by_model: bool = False
    # the keyword arguments of this field's `Problems` reader, computed once (sweeps validate
    # thousands of scenarios): only those that differ from the reader's own defaults
    options: dict[str, Any] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "options", self._reader_options())

    def _reader_options(self) -> dict[str, Any]:
        """Unit, bounds or choices as the reader of ``kind`` takes them."""
        if self.by_model:
            return {}
        if self.kind == "number":
            given = {"unit": self.unit, "gt": self.gt, "ge": self.ge, "lt": self.lt,
                     "le": self.le, "nonzero": self.nonzero}
            return {k: v for k, v in given.items()
                    if v is not None and v is not False and v != ""}
        if self.kind == "integer":
            return {"ge": self.ge, "le": self.le}
        if self.kind == "string" and self.choices is not None:
            return {"choices": self.choices}
        if self.kind == "pair":
            return {"unit": self.unit}
        return {}


class Section:
    """The keys of one kind of table, in file order. ``label`` and ``doc`` describe a
    segment kind (a profile) in the docs' profile tables."""

    def __init__(self, name: str, fields: Iterable[Field], *, label: str = "",
                 doc: str = "") -> None:
        self.name = name
        self.fields = tuple(fields)
        self.label = label
        self.doc = doc
        self.keys = tuple(f.key for f in self.fields)
        self._by_key = {f.key: f for f in self.fields}

    def __getitem__(self, key: str) -> Field:
        return self._by_key[key]

    def pick(self, *keys: str) -> tuple[Field, ...]:
        """The fields of ``keys``, in that order (the order the reader checks them)."""
        return tuple(self._by_key[k] for k in keys)

    def __repr__(self) -> str:
        return f"Section({self.name!r}, keys={self.keys})"


_FIELD_DEFAULT: Any = object()


def read_field(table: Mapping[str, Any], f: Field, path: str, problems: Problems, *,
               default: Any = _FIELD_DEFAULT) -> Any:
    """The value of one scalar key (None if unusable, the problem recorded), checked as its
    field says; ``default`` overrides the field's when the reader computes it."""
    if default is _FIELD_DEFAULT:
        default = f.default
    if f.key not in table and default is not REQUIRED:
        return _fresh(default)
    return _READERS[f.kind](problems, table, f.key, path, default=default, **f.options)


def read_fields(table: Mapping[str, Any], fields: Iterable[Field], path: str,
                problems: Problems, defaults: Mapping[str, Any] | None = None
                ) -> dict[str, Any]:
    """{key: value} of scalar keys, read in order; unusable values are None.

    ``defaults`` override the fields' defaults by key (e.g. the scenario name).
    """
    out = {}
    for f in fields:  # read_field inlined: a call per key costs 4% of a scenario's load
        default = defaults.get(f.key, f.default) if defaults else f.default
        if f.key not in table and default is not REQUIRED:
            out[f.key] = _fresh(default)  # the common case, without a reader call
        else:
            out[f.key] = _READERS[f.kind](problems, table, f.key, path, default=default,
                                          **f.options)
    return out


def _fresh(default: Any) -> Any:
    """The value of a left-out key: its default; a pair (a tuple here) as a new list, as
    TOML arrays are read."""
    return [*map(float, default)] if isinstance(default, tuple) else default


# --- [simulation] ---------------------------------------------------------------------------

SIMULATION = Section("simulation", [
    Field("name", "string", default=None, default_doc="the file name without `.toml` "
          "(`\"scenario\"` from a dict)", rule="no `/` or `\\`",
          doc="names the run and its results folder"),
    Field("t_end", unit="s", gt=0, doc="end of the simulated time span"),
    Field("dt_out", unit="s", gt=0, rule="≤ `t_end`",
          doc="output samples are 0, dt_out, 2·dt_out, … up to and including t_end"),
    Field("geometric_stiffening", "boolean", default=True, notes={
        "true": "(**recommended**) the consistent linearisation with the axial (centrifugal) "
                "stiffening of every link, including the pull of outer links and tip masses",
        "false": "the paper's model, which keeps centrifugal softening only and diverges when "
                 "a link spins faster than its first frequency (docs/derivation.md §4, "
                 "docs/validation.md)"}),
    Field("rtol", default=None, gt=0, le=1e-2,
          default_doc="1e-6 (`first_order`), 1e-4 (`first_order` forward runs: driven joints, "
                      "moving base; `nonlinear` closed loops, `[[closures]]`, which run on the "
                      "same Radau IIA; `nonlinear` runs with a slider on a fixed base and no "
                      "controller), 1e-5 (`nonlinear` otherwise)",
          doc="error of the time integration relative to the peak displacements and "
              "velocities (the nonlinear model: of each step); each default keeps it at about "
              "a tenth of the model's own error or less (docs/nonlinear.md §4, "
              "docs/performance.md \"Tolerances of forward runs\"). The run's `rtol` and "
              "`error_estimate` attributes say what was asked for and what the integrator's "
              "estimate reached"),
    Field("atol", default=1e-12, gt=0, doc="absolute error floor of the time integration"),
    Field("method", "string", default="lawson", choices=METHODS, notes={
        "lawson": "fourth-order Lawson–Runge–Kutta on a tabulated state matrix, compiled; "
                  "falls back to Magnus for coefficients too rough to tabulate, say measured "
                  "angles (the run's `method` attribute says which ran)",
        "magnus": "fourth-order Magnus, vectorised numpy, no compiled code"},
        doc="both error-controlled by step halving; the others are scipy `solve_ivp` "
            "methods, for comparison (first-order models only)"),
    Field("model", "string", default="first_order", choices=MODELS, notes={
        "first_order": "the linearised models above (`geometric_stiffening` chooses the "
                       "paper's or the stiffened one)",
        "nonlinear": "large deflections and rotations of every link, exact kinematics with "
                     "the same assumed modes (docs/nonlinear.md); `geometric_stiffening` and "
                     "`method` are then ignored"}),
    Field("step", unit="s", default=None, gt=0, rule="`model = \"nonlinear\"` only",
          doc="nonlinear model only: fixed time step of its Gauss collocation solver, "
              "without error control. Without it each step is chosen so that its estimated "
              "error is within `rtol` of the peak coordinates and rates (docs/nonlinear.md §4)"),
    Field("gravity", "pair", unit="m/s²", default=(0.0, 0.0),
          doc="uniform gravity field [gx, gy] in the plane of motion, in the global (base "
              "plane) axes: `[0, -9.81]` for a vertical plane with y up; zero for the paper's "
              "horizontal arm. It acts on every link, tip mass, hub and base (docs/derivation.md "
              "§11); accelerometers read specific force (acceleration − g), as real ones "
              "do"),
    Field("initial", "string", default="rest", choices=INITIAL_STATES, notes={
        "rest": "every link undeformed and at rest at t = 0",
        "equilibrium": "the elastic coordinates, the joints held by servos and the links "
                       "on elastic joints start at rest in static equilibrium with the loads "
                       "at t = 0 (gravity, held joints): a run without motion then stays at "
                       "rest; a start no equilibrium exists for (a servo that cannot hold the "
                       "load within its torque_limit or saturation; a torque-driven or free "
                       "joint that the loads turn at t = 0, such as an arm standing off "
                       "upright on a free pin) is refused; the base may move (the equilibrium "
                       "is relative to it)"},
        doc="the state at t = 0"),
])

# --- [[links]] ------------------------------------------------------------------------------

NAME_RULE = "unique; 1–64 letters, digits, `_`, `-`, `.`"
LINKS = Section("links", [
    Field("name", "string", rule=NAME_RULE, doc="names the link's output channels"),
    Field("length", unit="m", gt=0, doc="from the joint to the tip"),
    Field("mass_per_length", unit="kg/m", gt=0, doc="uniform along the link"),
    Field("EI", unit="N·m²", gt=0, default_doc="`EI` **or** `E` (neither with `rigid = true`)",
          rule="with `mass_per_length` and `length`, the highest mode below 10¹² rad/s",
          doc="bending stiffness in the plane of motion"),
    Field("E", unit="Pa", gt=0, default_doc="`EI` **or** `E`",
          doc="Young's modulus; then `width` and `thickness` are required and "
              "EI = E·width·thickness³/12"),
    Field("width", unit="m", gt=0, default=None, default_doc="optional unless `E` is given",
          doc="section size across the plane of motion"),
    Field("thickness", unit="m", gt=0, default=None,
          default_doc="optional unless `E` is given",
          doc="section depth *in* the bending plane; also the default for strain and piezo "
              "sensors on this link"),
    Field("tip_mass", unit="kg", ge=0, default=0.0, doc="point mass at x = length"),
    Field("tip_inertia", unit="kg·m²", ge=0, default=0.0,
          doc="rotary inertia of the tip body about the tip"),
    Field("bodies", "tables", default=None, default_doc="none",
          doc="rigid bodies fixed to sections of the link, `[[links.bodies]]` tables "
              "(below); a tip body with an offset centre of mass is one at `at = length`"),
    Field("damping_ratio", ge=0, lt=1, default=0.0, doc="modal damping ratio of every mode"),
    Field("modes", "integer", ge=1, le=20, default=4, doc="number of assumed modes"),
    Field("mode_shapes", "string", choices=MODE_SHAPES, default="auto", notes={
        "auto": "chosen from the chain: `pinned_pinned` for a link on a free joint whose tip "
                "a closure holds (`pinned_loaded` if its tip body has a rotary inertia), else `hub_loaded` for a link on a torque-driven joint or "
                "alone on a pinned base, else `outboard_loaded` for a link whose tip carries "
                "the next link, else `tip_loaded` for a link with a tip mass or tip inertia, "
                "else `clamped_free`; the resolved scenario states the choice",
        "clamped_free": "cantilever modes",
        "tip_loaded": "exact modes of a cantilever carrying the tip mass and tip inertia",
        "outboard_loaded": "modes of the cantilever whose tip body is its tip mass plus the "
                           "rest of the chain, rigid, as at t = 0; when a slider's line "
                           "passes through a section inside it (`line_at`), the exact modes "
                           "with that body at that section",
        "hub_loaded": "the natural modes of the link on its free hub (motor or base inertia) "
                      "with its tip body or what its tip carries, less their rigid rotation; "
                      "on a prescribed joint the loaded modes above",
        "pinned_pinned": "√2 sin(iπx/L) in the frame of the chord: a member on a free joint "
                         "whose far end a closed loop holds (a coupler, a connecting rod)",
        "pinned_loaded": "exact modes of that member carrying its tip body's rotary inertia "
                         "at the held end (`tip_inertia`, bodies at the tip)"},
        doc="cantilever modes have no curvature at the tip, so a link with a tip inertia or "
            "carrying a heavy outer link converges slowly (~1/N) with them; the loaded modes "
            "converge fast there. Every run reports the estimated error of its frequencies in "
            "the assumed modes (docs/modes.md)"),
    Field("initial_modal_rates", "vector", unit="m/s", default=None,
          default_doc="none: the link starts at rest",
          rule="one finite number per mode (`modes`); forward runs only",
          doc="the rates q̇_i(0) of the link's modal coordinates at t = 0, in its basis "
              "(`mode_shapes`, as resolved; docs/modes.md: w(x) = Σ φ_i(x) q_i, φ_i "
              "dimensionless): the link starts vibrating. For `pinned_pinned` modes "
              "φ_i = √2 sin(iπx/L), so an amplitude rate a_i of sin(iπx/L) is a_i/√2"),
    Field("rigid", "boolean", default=False, notes={
        "true": "no assumed modes: the link keeps its mass, tip mass and tip inertia and does "
                "not bend (its sensors read zero deflection, slope and strain); `EI`/`E` may "
                "be left out, `modes`, `damping_ratio` and `mode_shapes` must be",
        "false": "a flexible link with `modes` assumed modes"},
        doc="a link far stiffer than the rest costs as little as a rigid one: with "
            "prescribed joints, a link whose first frequency is far above what `dt_out` "
            "resolves and whose quasi-static deflection is below `rtol` of its length runs "
            "as rigid (the run's `rigid_links` attribute says which); a forward run names a "
            "link whose highest mode alone sets its step, advising `rigid = true` only where "
            "that moves no frequency the output shows by 1%, else fewer modes "
            "(`stiff_links_warning`, docs/modes.md)"),
])

BODIES = Section("links.bodies", [
    Field("at", unit="m", ge=0, default=None, default_doc="the link's `length` (its tip)",
          rule="≤ the link's length", doc="the section the body is fixed to, from the joint"),
    Field("mass", unit="kg", ge=0, default=0.0, doc="the body's mass"),
    Field("offset", "pair", unit="m, the section's frame", default=(0.0, 0.0),
          doc="its centre of mass from the section point, `[dx, dy]`: dx along the section's "
              "tangent, dy along its normal (it turns with the link's slope there)"),
    Field("inertia", unit="kg·m²", ge=0, default=0.0,
          doc="rotary inertia about its centre of mass"),
])

# --- [[joints]]: prescribed motion ----------------------------------------------------------

BASE_POINT = Field("base_point", "pair", unit="m, base frame", default=None,
                   doc="where the joint sits on the base: starts a new branch there instead "
                       "of on the previous link's tip")
JOINTS = Section("joints", [
    Field("motion", "profiles", default_doc="`motion`, `csv` or `drive`",
          doc="the joint angle: one or more profiles, below"),
    BASE_POINT,
])


def _profile_key(key: str, unit: str, **bounds: Any) -> Field:
    """A profile key: read as a number; the motion constructor checks unit and bounds."""
    return Field(key, unit=unit, by_model=True, **bounds)


_START = _profile_key("start", "s", ge=0)
_DURATION = _profile_key("duration", "s", gt=0)
_MOVE = (_profile_key("from_deg", "deg"), _profile_key("to_deg", "deg"), _START, _DURATION)
PROFILES: dict[str, Section] = {
    "cycloidal": Section("cycloidal", _MOVE, label='`"cycloidal"`',
                         doc="rest-to-rest move with zero acceleration at both ends; holds "
                             "`from_deg` before `start` and `to_deg` after"),
    "quintic": Section("quintic", _MOVE, label='`"quintic"`',
                       doc="rest-to-rest quintic polynomial (zero rate and acceleration at "
                           "both ends)"),
    "spinup": Section("spinup", [_profile_key("to_rate_deg_s", "deg/s"), _START, _DURATION,
                                 _profile_key("from_deg", "deg", default=0.0)],
                      label='`"spinup"`', doc="spin-up to a constant rate (Kane, Ryan & "
                                              "Banerjee 1987), then constant rate"),
    "hold": Section("hold", [_profile_key("angle_deg", "deg")], label='`"hold"`',
                    doc="constant angle"),
    # input shaping and optimised moves (docs/shaping.md)
    "shaped": Section("shaped", [
        Field("shaped", "string", choices=("cycloidal", "quintic"),
              doc="the profile that is shaped, with the move keys below"),
        *_MOVE,
        Field("shaper", "string", choices=SHAPERS, notes={
            "zv": "zero vibration at each target mode (2 impulses per mode, +½ period)",
            "zvd": "zero vibration and zero slope (3 impulses per mode, +1 period)",
            "ei": "extra-insensitive: `tolerable_vibration` at the target, zero on either "
                  "side (3 impulses per mode, ≈ +1 period)"},
            doc="the input shaper"),
        Field("frequencies_hz", "vector", unit="Hz", rule="each > 0",
              doc="natural frequencies of the target modes (one shaper per mode, "
                  "convolved)"),
        Field("damping", "vector", default=None, default_doc="0 for every mode",
              rule="each in [0, 1); one per frequency, or one for all",
              doc="damping ratios of the target modes"),
        Field("tolerable_vibration", default=DEFAULT_TOLERABLE_VIBRATION, gt=0, lt=1,
              doc="EI only: residual vibration allowed at the target frequency (fraction)"),
    ], label='`"shaped"`', doc="a cycloidal or quintic move convolved with an input shaper; "
                               "ends the shaper's length after `start + duration`"),
    "harmonic": Section("harmonic", [
        *_MOVE,
        Field("cosine", "vector", default=(), rule="a_2, a_3, …",
              doc="coefficients of cos 2πτ − cos 2πkτ in the normalised rate"),
        Field("sine", "vector", default=(), rule="b_2, b_3, …",
              doc="coefficients of sin 2πkτ − k sin 2πτ in the normalised rate"),
    ], label='`"harmonic"`', doc="the cycloid plus harmonics that keep zero rate and "
                                 "acceleration at both ends (what `flexlink optimize` "
                                 "writes, docs/shaping.md)"),
}
PROFILE = Field("profile", "string", choices=tuple(PROFILES))

MEASURED_ANGLES = Section("measured_angles", [
    Field("csv", "string", doc="path of a CSV file with a header row, relative to the "
                               "scenario file's folder"),
    Field("time_column", "string", default="t",
          doc="column of times in s, strictly increasing; must cover 0 … `t_end`"),
    Field("angle_column", "string", default="angle", doc="column of joint angles in deg"),
    Field("lowpass_hz", unit="Hz", gt=0, default=None, default_doc="none (no filtering)",
          rule="below the Nyquist frequency of the samples",
          doc="zero-phase Butterworth low-pass filter (the paper filtered its potentiometer "
              "signal at 30 Hz)"),
])

# --- [[sensors]] ----------------------------------------------------------------------------

SENSORS = Section("sensors", [
    Field("name", "string", rule=f"{NAME_RULE}; not `t`, `time` or an automatic channel name "
                                 "(below)",
          doc="names the sensor's output channel"),
    Field("kind", "string", choices=(*POINT_SENSOR_KINDS, "piezo"),
          doc="a point sensor or a piezo patch, below"),
    Field("link", "string", rule="the `name` of a link", doc="the link the sensor is on"),
])
POINT_SENSORS = Section("point_sensors", [
    Field("x", unit="m", ge=0, rule="≤ the link's length", doc="measured from the link's joint"),
    Field("thickness", unit="m", gt=0, default=None,
          default_doc="strain only; default: the link's `thickness` (required if the link "
                      "has none)", doc="host beam thickness"),
])
PIEZO = Section("piezo", [
    Field("x_start", unit="m", ge=0, rule="< `x_end`", doc="where the patch starts"),
    Field("x_end", unit="m", gt=0, rule="≤ the link's length", doc="where the patch ends"),
    Field("width", unit="m", gt=0, doc="patch width"),
    Field("E_p", unit="Pa", gt=0, doc="Young's modulus of the patch"),
    Field("d31", unit="m/V", nonzero=True, rule="either sign",
          doc="piezoelectric strain constant"),
    Field("thickness", unit="m", gt=0, default=None,
          default_doc="the link's `thickness`", doc="host beam thickness"),
    Field("capacitance", unit="F", gt=0, doc="charge amplifier capacitance C_c"),
])

# --- [base] and its loads -------------------------------------------------------------------

BASE = Section("base", [
    Field("type", "string", choices=BASE_KINDS, notes={
        "free": "moves and turns in the plane",
        "pinned": "turns about its fixed reference point",
        "fixed": "does not move; only useful to start several branches",
        "cart": "slides along a straight rail fixed in the ground, at a constant attitude "
                "(`[base.cart]`, below)"}),
    # 0 is allowed: the first link is then the free body itself (a flexible beam in flight)
    Field("mass", unit="kg", ge=0, default=None, default_doc="required for free and cart",
          doc="mass of the rigid base; 0 (with `inertia = 0`) makes the first link itself "
              "the free body, its root the reference point (then no driven joint on the "
              "base, and no `loads` with the nonlinear model)"),
    Field("inertia", unit="kg·m² (about the reference point)", ge=0, default=None,
          default_doc="required for free/pinned",
          doc="the centre of mass of a free base is its reference point"),
    Field("position", "pair", unit="m", default=(0.0, 0.0), rule="`[0, 0]` if pinned",
          doc="initial reference point; of a cart: the rail's point where its travel is 0"),
    Field("attitude_deg", unit="deg", default=0.0, rule="0 for a fixed base",
          doc="initial attitude (a cart's, constant)"),
    Field("velocity", "pair", unit="m/s", default=(0.0, 0.0),
          rule="`[0, 0]` if pinned or a cart", doc="initial velocity"),
    Field("rate_deg_s", unit="deg/s", default=0.0, rule="0 for a fixed base or a cart",
          doc="initial angular rate"),
    Field("cart", "table", default=None, default_doc="required for a cart",
          rule="only with `type = \"cart\"`",
          doc="the rail and the cart's drive, a `[base.cart]` table (below)"),
    Field("loads", "tables", default=None, default_doc="none", rule="not on a fixed base",
          doc="applied loads, `[[base.loads]]` tables (below)"),
])
_ONE_OF_THREE = "none; give at least one of `force_x`, `force_y`, `moment`"
LOADS = Section("base.loads", [
    Field("force_x", "history", unit="N", default=None, default_doc=_ONE_OF_THREE,
          doc="force history (segments, below)"),
    Field("force_y", "history", unit="N", default=None, default_doc=_ONE_OF_THREE,
          doc="force history (segments, below)"),
    Field("moment", "history", unit="N·m", default=None, default_doc=_ONE_OF_THREE,
          doc="moment history"),
    Field("point", "pair", unit="m, body frame", default=(0.0, 0.0),
          doc="where the force acts on the base, from the reference point"),
    Field("frame", "string", choices=LOAD_FRAMES, default="inertial",
          doc="the axes of `force_x`, `force_y`"),
])

CART_DRIVES = ("free", "force", "prescribed", "servo")
_DRIVE_ONLY = "only with drive = {}"
CART = Section("base.cart", [
    Field("rail_angle_deg", unit="deg", default=0.0,
          doc="direction of the rail from the global X axis; the travel s is measured along "
              "it from `base.position`"),
    Field("travel", "pair", unit="m", default=None, default_doc="unlimited",
          rule="lower < upper",
          doc="allowed range of s: a prescribed travel, a servo's reference or a start outside it is "
              "refused; a run whose cart leaves it ends with an error (never clipped)"),
    Field("drive", "string", choices=CART_DRIVES, default="free", notes={
        "free": "no force along the rail (base loads only)",
        "force": "a force history along the rail (`force`)",
        "prescribed": "the travel follows `motion`",
        "servo": "a servo law on the travel follows `reference` (`servo`)"},
        doc="what moves the cart along its rail"),
    Field("initial_position", unit="m", default=0.0,
          rule=_DRIVE_ONLY.format("free or force"), doc="travel s at t = 0"),
    Field("initial_velocity", unit="m/s", default=0.0,
          rule=_DRIVE_ONLY.format("free or force"), doc="speed along the rail at t = 0"),
    Field("force", "history", unit="N", default=None, default_doc="required for force",
          rule=_DRIVE_ONLY.format("force"),
          doc="force along the rail on the cart (segments, as base loads)"),
    Field("motion", "profiles", default=None, default_doc="required for prescribed",
          rule=_DRIVE_ONLY.format("prescribed"),
          doc="an array of travel profiles (below), in m"),
    Field("servo", "string", choices=("position", "velocity_pid"), default=None,
          default_doc="required for servo", notes={
              "position": "v = clip(ω_b e, ±v_max), F = K_v (v − ṡ)",
              "velocity_pid": "V = sat(P e + D ė), v = k_v V, F = K_v (v − ṡ)"},
          rule=_DRIVE_ONLY.format("servo"), doc="e = reference − s; the joints' servo laws "
                                                "on the travel, without an integral"),
    Field("reference", "profiles", default=None, default_doc="required for servo",
          rule=_DRIVE_ONLY.format("servo"),
          doc="an array of travel profiles (below), in m; the cart starts on it"),
    Field("bandwidth", unit="1/s", gt=0, default=None, default_doc="required",
          rule="servo = \"position\" only", doc="ω_b"),
    Field("rate_limit", unit="m/s", gt=0, default=None, default_doc="required",
          rule="servo = \"position\" only", doc="v_max"),
    Field("P", unit="V/m", ge=0, default=None, default_doc="required",
          rule="servo = \"velocity_pid\" only", doc="proportional gain"),
    Field("I", unit="V/(m·s)", ge=0, default=0.0, rule="servo = \"velocity_pid\" only",
          doc="integral gain (an integral state, with no wind-up while the command saturates)"),
    Field("D", unit="V·s/m", ge=0, default=0.0, rule="servo = \"velocity_pid\" only",
          doc="derivative gain"),
    Field("saturation_V", unit="V", gt=0, default=10.0, rule="servo = \"velocity_pid\" only",
          doc="command limit"),
    Field("rate_per_volt", unit="m/s per V", gt=0, default=None, default_doc="required",
          rule="servo = \"velocity_pid\" only", doc="k_v, commanded speed per volt"),
    Field("loop_gain", unit="N·s/m", gt=0, default=None, default_doc="required",
          rule=_DRIVE_ONLY.format("servo"), doc="K_v, the velocity loop"),
    Field("force_limit", unit="N", gt=0, default=None, default_doc="none",
          rule=_DRIVE_ONLY.format("servo"), doc="the servo's force limit"),
])
_TRAVEL_MOVE = (Field("from", unit="m", doc="travel held before `start`"),
                Field("to", unit="m", doc="travel reached at `start + duration`, then held"),
                Field("start", unit="s", ge=0, default=0.0),
                Field("duration", unit="s", gt=0))
CART_PROFILES: dict[str, Section] = {
    "cycloidal": Section("cycloidal", _TRAVEL_MOVE, label='`"cycloidal"`',
                         doc="rest-to-rest cycloidal move (as the joints' profile)"),
    "quintic": Section("quintic", _TRAVEL_MOVE, label='`"quintic"`',
                       doc="rest-to-rest quintic move"),
    "hold": Section("hold", [Field("position", unit="m")], label='`"hold"`',
                    doc="constant travel"),
}
CART_PROFILE = Field("profile", "string", choices=tuple(CART_PROFILES))

_AMPLITUDE = Field("amplitude", doc="in the unit of the history")
_FROM = Field("start", unit="s", ge=0, default=0.0)
HISTORIES: dict[str, Section] = {
    "bang_bang": Section("bang_bang", [_AMPLITUDE, _FROM, Field("duration", unit="s", gt=0)],
                         label='`"bang_bang"`', doc="+amplitude for the first half, "
                                                   "−amplitude for the second"),
    "step": Section("step", [_AMPLITUDE, _FROM, Field("duration", unit="s", gt=0, default=None,
                                                      default_doc="∞")],
                    label='`"step"`', doc="amplitude from `start` for `duration`"),
    "table": Section("table", [Field("t", "numbers", unit="s", rule="increasing"),
                               Field("values", "numbers")],
                     label='`"table"`', doc="linear between the samples, held outside"),
}
HISTORY_PROFILE = Field("profile", "string", choices=tuple(HISTORIES))
HISTORY_CSV = Section("history_csv", [
    Field("csv", "string"),
    Field("time_column", "string", default="t"),
    Field("column", "string"),
], label='`csv = "…"` (no `profile`)',
    doc="a column of a CSV file (path relative to the scenario file's folder), linear, held "
        "outside; for example the `joint1_torque` column of another run's `results.csv`")

# --- driven [[joints]] ----------------------------------------------------------------------

DRIVE = Field("drive", "string", choices=("torque", "servo", "free"), notes={
    "torque": "a torque history drives the joint", "servo": "a servo follows `reference`",
    "free": "no torque: the joint turns freely (a passive joint of a closed loop); keys "
            "`initial_angle_deg`, `initial_rate_deg_s`, `motor_inertia`, `base_point`"},
    doc="`joint<k>_torque` is the motor's torque")
SERVO = Field("servo", "string", choices=("velocity_pid", "position"), notes={
    "velocity_pid": "V = sat(P e + I∫e + D ė), Ω = k_v V, τ = K_v(Ω − β̇)",
    "position": "Ω = clip(ω_b e, ±Ω_max), τ = K_v(Ω − β̇) (small RC servos)"},
    doc="e = reference − angle, β̇ the joint rate")
MOTOR_INERTIA = Field("motor_inertia", unit="kg·m²", ge=0, default=0.0,
                      doc="rotor inertia reflected to the joint")
TORQUE = Section("torque", [
    DRIVE,
    Field("torque", "history", unit="N·m",
          doc="torque history on link k, reaction on its parent (segments, as base loads)"),
    Field("initial_angle_deg", unit="deg", default=0.0, doc="initial joint angle"),
    Field("initial_rate_deg_s", unit="deg/s", default=0.0, doc="initial joint rate"),
    MOTOR_INERTIA,
    BASE_POINT,
])


def _servo(name: str, loop_gain: float, own: Iterable[Field]) -> Section:
    """A servo's keys: the common ones, whose loop gain default depends on the servo, and its
    own."""
    return Section(name, [
        DRIVE,
        SERVO,
        Field("reference", "profiles",
              doc="an array of motion profiles, as `motion`; the servo starts on it (angle "
                  "and rate at t = 0)"),
        Field("loop_gain", unit="N·m·s/rad", gt=0, default=loop_gain,
              doc="K_v, the velocity loop"),
        Field("torque_limit", unit="N·m", gt=0, default=None,
              doc="the servo motor's torque limit (servo drives only: a torque drive applies its "
                  "torque history as given); none: unlimited"),
        MOTOR_INERTIA,
        BASE_POINT,
        *own,
    ])


VELOCITY_PID = _servo("velocity_pid", 50.0, [
    Field("P", unit="V/rad", ge=0, doc="proportional gain on the error e = reference − angle "
                                      "(radians)"),
    Field("I", unit="V/(rad·s)", ge=0, default=0.0, doc="integral gain"),
    Field("D", unit="V·s/rad", ge=0, default=0.0, doc="derivative gain"),
    Field("saturation_V", unit="V", gt=0, default=10.0, doc="command limit"),
    Field("rate_per_volt_deg_s", unit="deg/s per V", gt=0,
          doc="k_v, the amplifier's commanded joint rate per volt"),
])
POSITION = _servo("position", 5.0, [
    Field("bandwidth", unit="rad/s", gt=0, doc="ω_b"),
    Field("rate_limit_deg_s", unit="deg/s", gt=0, doc="Ω_max"),
])

# --- elastic [[joints]]: a motor rotor on a torsional spring (scenario/elastic.py) ----------

ELASTIC = Section("elastic", [
    Field("spring_stiffness", unit="N·m/rad", gt=0,
          doc="k: makes the joint elastic; the joint's motion, torque or servo then turns "
              "the motor (its angles, rates and torques are the motor shaft's, "
              "`motor_inertia` the rotor's about its axis) and the spring turns the link"),
    Field("spring_damping", unit="N·m·s/rad", ge=0, default=0.0,
          doc="c: τ_s = k (θ_m/N − β) + c (θ̇_m/N − β̇) on the link, −τ_s/N on the motor"),
    Field("gear_ratio", nonzero=True, default=1.0,
          doc="N, motor turns per link turn (the link starts on θ_m/N, the spring relaxed)"),
])

PRISMATIC = Section("prismatic", [
    Field("type", "string", choices=("prismatic",),
          doc="makes the joint a slider: link k rides on a block along a line through a "
              "point of link k − 1 (`line_at`, its tip by default), carried with that "
              "section's deflection and slope; the travel s (m) from that point along the "
              "line is the joint's coordinate; the other keys are a cart's (`travel`, "
              "`drive`, `motion`, `force`, `servo` …: `[base.cart]`, without "
              "`rail_angle_deg`)"),
    Field("line_at", unit="m", ge=0, default=None,
          default_doc="the parent link's `length` (its tip)",
          rule="≤ the parent link's length",
          doc="the parent's section the line passes through, from the parent's joint along "
              "its undeformed axis"),
    Field("axis_angle_deg", unit="deg", default=0.0,
          doc="direction of the line from the parent link's section at `line_at` (0: along "
              "the parent)"),
    Field("link_angle_deg", unit="deg", default=0.0,
          doc="direction of the carried link from the parent link's section at `line_at`, "
              "constant"),
    Field("mass", unit="kg", ge=0, default=0.0,
          doc="the block, a point mass at the carried link's root"),
])

# every table kind, by the name of its generated docs block
SECTIONS: dict[str, Section] = {s.name: s for s in (
    SIMULATION, LINKS, BODIES, JOINTS, *PROFILES.values(), MEASURED_ANGLES, SENSORS,
    POINT_SENSORS, PIEZO, BASE, LOADS, *HISTORIES.values(), HISTORY_CSV, TORQUE, VELOCITY_PID,
    POSITION, ELASTIC)}


# --- [[actuators]] --------------------------------------------------------------------------

ACTUATORS = Section("actuators", [
    Field("name", "string", rule=f"{NAME_RULE}; unique among sensors and actuators",
          doc="names the actuator (its channel is `<name>_voltage`)"),
    Field("kind", "string", choices=("piezo",),
          notes={"piezo": "a bonded PZT patch: a moment pair ±M at its ends, "
                          "M = w_p E_p d31 (t/2) V (docs/closed_loop.md)"}),
    Field("link", "string", default=None, default_doc="required, unless `collocated_with`",
          rule="the `name` of a link", doc="the link the patch is bonded on"),
    Field("collocated_with", "string", default=None,
          rule="the `name` of a piezo sensor",
          doc="copies `link`, `x_start`, `x_end`, `width`, `E_p`, `d31` and `thickness` from "
              "that sensor (a key given here too must agree)"),
    Field("x_start", unit="m", ge=0, default=None, default_doc="required, unless "
          "`collocated_with`", rule="< `x_end`", doc="where the patch starts"),
    Field("x_end", unit="m", gt=0, default=None, default_doc="required, unless "
          "`collocated_with`", rule="≤ the link's length", doc="where the patch ends"),
    Field("width", unit="m", gt=0, default=None, default_doc="required, unless "
          "`collocated_with`", doc="patch width"),
    Field("E_p", unit="Pa", gt=0, default=None, default_doc="required, unless "
          "`collocated_with`", doc="Young's modulus of the patch"),
    Field("d31", unit="m/V", nonzero=True, default=None, default_doc="required, unless "
          "`collocated_with`", rule="either sign", doc="piezoelectric strain constant"),
    Field("thickness", unit="m", gt=0, default=None,
          default_doc="the link's `thickness`", doc="host beam thickness"),
    Field("limit", unit="V", gt=0, default=None, default_doc="none (unlimited)",
          doc="amplifier saturation: the patch never sees more than ±limit"),
    Field("voltage", "history", unit="V", default=None, default_doc="none (0 V)",
          doc="open-loop voltage command (segments, as base loads); a controller's output "
              "adds to it (sampled with the controller's hold)"),
])

# --- [[controllers]] ------------------------------------------------------------------------

# Samples of one controller over a run: the closed loop steps at each (the held voltage
# changes there) and keeps its states per sample, about a kilobyte each.
MAX_CONTROL_SAMPLES = 1e6
CONTROLLERS = Section("controllers", [
    Field("name", "string", rule=NAME_RULE,
          doc="names the controller (channels `<name>_command`, `<name>_state<i>`)"),
    Field("kind", "string", choices=("ppf", "srf", "lti"), notes={
        "ppf": "positive position feedback: ξ̈ + 2ζ_f ω_f ξ̇ + ω_f² ξ = ω_f² v, V = gain·ξ",
        "srf": "strain-rate feedback: V = −gain · dv/dt (backward difference of samples)",
        "lti": "any discrete x⁺ = A x + B y, V = C x + D y at the samples"},
        doc="joint PID loops are servo drives of [[joints]], not controllers"),
    Field("sample_rate", unit="Hz", gt=0, doc="samples per second; output held in between "
          f"(at most {MAX_CONTROL_SAMPLES:.0e} samples over `t_end`)"),
    Field("noise_std", "vector", default=None, default_doc="none",
          rule="≥ 0, one per input", doc="Gaussian sensor noise (input units)"),
    Field("quantization", "vector", default=None, default_doc="none",
          rule="≥ 0, one per input", doc="readings rounded to multiples of this (0: none)"),
    Field("noise_seed", "integer", default=0, ge=0, le=2**31 - 1,
          doc="seed of the noise generator (runs are reproducible)"),
])
CONTROLLER_SISO = Section("controller_siso", [
    Field("sensor", "string", rule="a sensor's `name` (not acceleration)",
          doc="ppf, srf: the input"),
    Field("actuator", "string", rule="an actuator's `name`", doc="ppf, srf: the output"),
    Field("gain", gt=0, unit="V/V (ppf), V·s/V (srf)",
          doc="ppf, srf: > 0 is positive position feedback / rate damping for a collocated "
              "pair with d31 of one sign"),
])
PPF = Section("ppf", [
    Field("frequency_hz", unit="Hz", gt=0, doc="ppf: filter frequency (tune to the mode)"),
    Field("damping", gt=0, lt=10, doc="ppf: filter damping ratio ζ_f"),
])
LTI = Section("lti", [
    Field("inputs", "strings", rule="sensor names", doc="lti: the entries of y, in order"),
    Field("outputs", "strings", rule="actuator names", doc="lti: the entries of V, in order"),
    Field("A", "matrix", default=None, default_doc="none (no state)",
          rule="n × n", doc="lti: state matrix (arrays of rows)"),
    Field("B", "matrix", default=None, default_doc="none", rule="n × inputs", doc="lti"),
    Field("C", "matrix", default=None, default_doc="none", rule="outputs × n", doc="lti"),
    Field("D", "matrix", default=None, default_doc="zeros", rule="outputs × inputs",
          doc="lti: feed-through"),
])
SECTIONS.update({s.name: s for s in (ACTUATORS, CONTROLLERS, CONTROLLER_SISO, PPF, LTI)})

# --- [[closures]] ---------------------------------------------------------------------------

CLOSURES = Section("closures", [
    Field("name", "string", rule=f"{NAME_RULE}; unique, not a link's, sensor's or actuator's",
          doc="names the closure's force channels (`<name>_force_x`, `<name>_force_y`; "
              "slider: `<name>_normal_force`)"),
    Field("kind", "string", choices=CLOSURE_KINDS, default="revolute", notes={
        "revolute": "pins the point to a point of `to_link` or to the fixed point `ground`",
        "slider": "keeps the point on the fixed line through `ground` at `angle_deg`"}),
    Field("link", "string", rule="the `name` of a link", doc="the link the point is on"),
    Field("x", unit="m", ge=0, default=None, default_doc="the link's length (its tip)",
          rule="≤ the link's length", doc="the point, from the link's joint"),
    Field("to_link", "string", default=None, default_doc="none: the ground",
          rule="revolute only; the `name` of another link", doc="the other link"),
    Field("x_to", unit="m", ge=0, default=None, default_doc="`to_link`'s length (its tip)",
          rule="≤ `to_link`'s length", doc="the point on `to_link`, from its joint"),
    Field("ground", "pair", unit="m", default=None,
          default_doc="required for a revolute without `to_link`; `[0, 0]` for a slider",
          doc="revolute: the fixed pivot; slider: a point of the line"),
    Field("angle_deg", unit="deg", default=0.0, rule="slider only",
          doc="direction of the slider's line from the global X axis"),
])
SECTIONS[CLOSURES.name] = CLOSURES
