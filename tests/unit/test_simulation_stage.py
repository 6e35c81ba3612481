"""The simulation stage's contract: one path per scenario, every path returns the channels of
the catalogue, integrators return a Solution, and the stages import only the stages below."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import numpy as np
import pytest

import flexlink
from flexlink.channels import Channel, ChannelKind
from flexlink.channels.catalogue import catalogue
from flexlink.errors import SimulationError
from flexlink.model import METHODS, Base, TorqueDrive
from flexlink.model.histories import Step
from flexlink.scenario import scenario_from_dict
from flexlink.simulation import PATHS, model_path, path_function, simulate
from flexlink.simulation.common import PathRun, assemble_results
from flexlink.solvers import PRESCRIBED_METHODS, Solution
from tests.unit.test_scenario import minimal

PACKAGE = Path(flexlink.__file__).parent


def _short(**simulation: object) -> flexlink.Scenario:
    d = minimal()
    d["simulation"].update(t_end=0.05, dt_out=0.01, **simulation)
    return scenario_from_dict(d)


def _driven(scenario: flexlink.Scenario) -> flexlink.Scenario:
    drives = tuple(TorqueDrive(Step(0.01)) for _ in scenario.chain.joints)
    chain = dataclasses.replace(scenario.chain, joints=drives)
    return dataclasses.replace(scenario, chain=chain, base=Base("pinned", inertia=0.1))


def test_every_method_has_an_integrator() -> None:
    assert set(PRESCRIBED_METHODS) == set(METHODS)


def test_each_scenario_takes_one_path() -> None:
    assert model_path(_short()) == "prescribed"
    assert model_path(_short(model="nonlinear")) == "nonlinear"
    assert model_path(_driven(_short())) == "forward"
    assert model_path(_driven(_short(model="nonlinear"))) == "nonlinear_forward"
    assert set(PATHS) == {"prescribed", "nonlinear", "forward", "nonlinear_forward",
                          "closed_loop"}
    assert all(callable(path_function(name)) for name in PATHS)


def test_a_prescribed_run_imports_no_other_path() -> None:
    import subprocess
    import sys

    code = ("import sys; from flexlink import simulate, load_paper_experiment; "
            "simulate(load_paper_experiment()); "
            "print(sorted(m for m in sys.modules if m.startswith('flexlink.simulation.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    for other in ("forward", "nonlinear", "nonlinear_forward", "closed_loop"):
        assert f"'flexlink.simulation.{other}'" not in out


@pytest.mark.parametrize("make", [lambda: _short(), lambda: _short(model="nonlinear"),
                                  lambda: _driven(_short(geometric_stiffening=True)),
                                  lambda: _driven(_short(model="nonlinear", step=1e-3))],
                         ids=["prescribed", "nonlinear", "forward", "nonlinear_forward"])
def test_every_path_returns_the_catalogue(make) -> None:
    scenario = make()
    results = simulate(scenario)
    assert list(results.channels.values()) == catalogue(scenario)
    assert results.names_of(ChannelKind.SENSOR) == [s.name for s in scenario.sensors]
    assert results.metadata["method"] and results.metadata["wall_time_s"] > 0


def test_a_path_that_strays_from_the_catalogue_is_refused() -> None:
    scenario = _short()
    t = np.linspace(0.0, 0.05, 6)
    zeros = np.zeros((t.size, 1))
    values = {c.name: np.zeros_like(t) for c in catalogue(scenario)}
    run = PathRun(Solution(t, zeros, zeros, zeros, "test"), {**values, "extra": t})
    with pytest.raises(AssertionError, match="outside the catalogue: extra"):
        assemble_results(scenario, run, 0.0)
    del values["tip"]
    with pytest.raises(KeyError, match="tip"):
        assemble_results(scenario, PathRun(run.solution, values), 0.0)


def test_a_solution_is_finite() -> None:
    t = np.zeros(2)
    q = np.array([[0.0], [np.nan]])
    with pytest.raises(SimulationError, match="coordinates are not finite"):
        Solution(t, q, np.zeros_like(q), np.zeros_like(q), "test")


def test_channel_records_are_frozen_and_typed() -> None:
    channel = Channel("a", ChannelKind.SENSOR, "m", "deflection")
    with pytest.raises(dataclasses.FrozenInstanceError):
        channel.name = "b"  # type: ignore[misc]
    assert ChannelKind("joint") is ChannelKind.JOINT


def _imports(path: Path) -> set[str]:
    """flexlink sub-packages (or top-level modules) a module imports, anywhere in it."""
    module = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    package = module.rsplit(".", 1)[0] if path.name != "__init__.py" else module
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
                targets = [name] if node.module else [f"{name}.{a.name}" for a in node.names]
            else:
                targets = [node.module or ""]
        elif isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        else:
            continue
        found |= {t.split(".")[1] for t in targets if t.startswith("flexlink.")}
    return found


def _stage(path: Path) -> str:
    return path.relative_to(PACKAGE).parts[0].removesuffix(".py")


def test_the_stages_import_no_circle() -> None:
    """Sub-packages and top-level modules form a graph without cycles (an import that climbs
    back up to a stage that imports this one would close a circle)."""
    graph: dict[str, set[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        stage = _stage(path)
        graph.setdefault(stage, set()).update(_imports(path) - {stage})
    visiting: list[str] = []
    done: set[str] = set()

    def visit(node: str) -> None:
        if node in done:
            return
        assert node not in visiting, f"import circle: {' -> '.join(visiting + [node])}"
        visiting.append(node)
        for target in sorted(graph.get(node, ())):
            visit(target)
        visiting.pop()
        done.add(node)

    for stage in sorted(graph):
        if stage not in ("__init__", "__main__"):  # the package's lazy exports sit on top
            visit(stage)


def _module_imports(path: Path) -> set[str]:
    """Dotted flexlink modules a module imports anywhere in it (type-checking imports too):
    ``from . import plotting`` names the module ``…plotting``, ``from .x import y`` the
    module ``…x``, or ``…x.y`` where that is a module itself."""
    module = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    package = module.rsplit(".", 1)[0] if path.name != "__init__.py" else module
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1])
                name = f"{base}.{node.module}" if node.module else base
            else:
                name = node.module or ""
            for alias in node.names:
                sub = f"{name}.{alias.name}"
                found.add(sub if _is_module(sub) else name)
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
    return {f.removesuffix(".__init__") for f in found if f.startswith("flexlink")}


def _is_module(dotted: str) -> bool:
    path = PACKAGE.parent.joinpath(*dotted.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def test_no_module_imports_a_circle() -> None:
    """No circle between modules either (inside a stage), lazy imports included: a module
    that a package's ``__init__`` imports may not import that package back."""
    graph = {}
    for path in PACKAGE.rglob("*.py"):
        name = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        graph[name.removesuffix(".__init__")] = _module_imports(path)
    graph.pop("flexlink", None)  # the package's lazy exports sit on top of everything
    done: set[str] = set()

    def visit(node: str, trail: list[str]) -> None:
        if node in done or node not in graph:
            return
        assert node not in trail, f"import circle: {' -> '.join(trail[trail.index(node):] + [node])}"
        for target in sorted(graph[node]):
            if target != node:
                visit(target, trail + [node])
        done.add(node)

    for name in sorted(graph):
        visit(name, [])


def test_the_model_is_free_of_physics() -> None:
    """model/ imports nothing of flexlink but itself: a description, no algorithms."""
    for path in (PACKAGE / "model").glob("*.py"):
        assert _imports(path) <= {"model"}, path.name


def test_the_first_order_validity_is_reported() -> None:
    from flexlink.model import Link
    from flexlink.simulation.common import check_tip_deflection

    links = (Link("a", 1.0, 1.0, 1.0), Link("b", 0.5, 1.0, 1.0))
    t = np.linspace(0.0, 1.0, 3)
    fine = check_tip_deflection(links, t, np.array([[0.0, 0.0], [0.1, 0.05], [0.0, 0.0]]), True)
    assert fine["peak_tip_deflection_per_length"] == pytest.approx(0.1)
    assert "validity_warning" not in fine
    bent = check_tip_deflection(links, t, np.array([[0.0, 0.0], [0.1, 0.2], [0.0, 0.0]]), True)
    assert bent["peak_tip_deflection_per_length"] == pytest.approx(0.4)
    assert "the tip of b deflected 40% of its length" in bent["validity_warning"]
    assert 'model = "nonlinear"' in bent["validity_warning"]
    with pytest.raises(SimulationError, match="tip deflection of b exceeds its length .* at "
                                              "t = 0.5 s.*geometric_stiffening = true"):
        check_tip_deflection(links, t, np.array([[0.0, 0.0], [0.1, 0.6], [0.0, 0.0]]), False)


def test_shapes_are_computed_unless_declined() -> None:
    scenario = _short()
    assert [s.link for s in simulate(scenario).shapes] == ["a", "b"]
    assert simulate(scenario, shapes=False).shapes == []


@pytest.mark.parametrize(("field", "value", "message"), [
    ("t_end", -1.0, "simulation.t_end must be > 0, got -1.0"),
    ("dt_out", 2.0, "simulation.dt_out must be <= simulation.t_end"),
    ("rtol", 0.5, r"simulation.rtol must be in \(0, 0.01\]"),
    ("method", "rk4", "simulation.method must be one of 'magnus'"),
    ("model", "linear", "simulation.model must be one of 'first_order'"),
])
def test_settings_built_in_python_are_checked(field: str, value: object, message: str) -> None:
    """Regression: a negative t_end from Python ended in an IndexError inside output_times."""
    from flexlink.model import SimulationSettings

    with pytest.raises(ValueError, match=message):
        SimulationSettings(**{"t_end": 1.0, "dt_out": 0.01, field: value})


def test_shapes_are_computed_on_first_use_and_pickle_as_computed() -> None:
    import pickle

    from flexlink.channels.shapes import LazyShapes

    results = simulate(_short())
    assert isinstance(results.shapes, LazyShapes)
    assert results.shapes._compute is not None  # nothing computed by simulate itself
    tip = results.shapes[1].X[:, -1]
    np.testing.assert_allclose(tip, results["b_tip_X"], rtol=0, atol=1e-12)  # the tip
    copy = pickle.loads(pickle.dumps(results.shapes))
    assert [s.link for s in copy] == ["a", "b"]
    np.testing.assert_array_equal(copy[0].Y, results.shapes[0].Y)
