"""What a run computes once and reuses (a sweep's worker runs thousands of cases): each
shortcut gives the numbers, and the errors, of the work it saves."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from flexlink.dynamics import kinematics
from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.model import Chain, Link, PiezoActuator, Step
from flexlink.motion import Cycloidal, Harmonic, Hold, MeasuredMotion, Quintic, Sequence, Spinup
from flexlink.motion.shaped import shaped_move
from flexlink.scenario import load_scenario, paper_experiment_path
from flexlink.simulation.common import output_times
from flexlink.simulation.prescribed import prescribed_system
from flexlink.solvers.coefficient_table import resting_from_keys, tabulate
from flexlink.solvers.solution import Solution, all_finite

MOTIONS = [
    Cycloidal(0.0, 40.0, 0.3, 0.7),
    Quintic(10.0, -20.0, 0.2, 0.45),
    Harmonic(0.0, 30.0, 0.1, 0.8, cosine=(0.1,), sine=(0.05,)),
    Sequence((Hold(5.0), Cycloidal(5.0, 25.0, 0.2, 0.3), Quintic(25.0, 0.0, 0.6, 0.3))),
    Spinup(90.0, 0.25, 0.5),
    shaped_move("cycloidal", 0.0, 30.0, 0.1, 0.4, "zvd", [4.0]),
    MeasuredMotion.from_arrays(np.linspace(0.0, 1.2, 61),
                               20.0 * np.sin(np.linspace(0.0, 3.0, 61))),
]


@pytest.mark.parametrize("motion", MOTIONS, ids=lambda m: type(m).__name__)
def test_the_history_at_output_times_and_midpoints_equals_its_whole_evaluation(motion) -> None:
    links = (Link("a", 0.5, 2.0, 300.0, modes=1), Link("b", 0.4, 1.0, 200.0, modes=1))
    system = FirstOrderSystem(Chain(links, (motion, Cycloidal(0.0, 10.0, 0.05, 0.5))))
    t = output_times(1.0, 1e-3)
    interleaved = np.empty(2 * t.size - 1)
    interleaved[0::2] = t
    interleaved[1::2] = t[:-1] + 0.5 * np.diff(t)
    system.joint_history(t)  # the output times first, as a run asks
    kinematics._HISTORIES.clear()  # nothing remembered: the midpoints alone are evaluated
    mixed = system.joint_history(interleaved)
    kinematics._HISTORIES.clear()
    whole = kinematics.joint_history(system.chain.joints, interleaved)
    for a, b in ((mixed.angle, whole.angle), (mixed.rate, whole.rate),
                 (mixed.acceleration, whole.acceleration)):
        np.testing.assert_array_equal(a, b)
        assert not a.flags.writeable
    np.testing.assert_array_equal(mixed.distinct[1], whole.distinct[1])


def test_the_remembered_histories_keep_their_byte_count_after_a_clear(monkeypatch) -> None:
    monkeypatch.setattr(kinematics, "_HISTORY_BYTES_KEPT", 100_000)
    joints = (Cycloidal(0.0, 45.0, 0.1, 0.5),)
    for count in range(101, 1101, 50):  # 2.4–26 kB each
        kinematics.joint_history(joints, np.linspace(0.0, 1.0, count))
        held = sum(h.angle.base.nbytes for h in kinematics._HISTORIES.values())
        assert held <= 100_000
        assert kinematics._HELD == [len(kinematics._HISTORIES), held]
    kinematics._HISTORIES.clear()
    kinematics.joint_history(joints, np.linspace(0.0, 1.0, 3501))  # 84 kB
    kinematics.joint_history(joints, np.linspace(0.0, 1.0, 1001))  # 24 kB: over, drops one
    assert sum(h.angle.base.nbytes for h in kinematics._HISTORIES.values()) <= 100_000
    assert len(kinematics._HISTORIES) == 1


def test_a_scenario_s_catalogue_is_made_once_and_handed_out_as_a_new_list() -> None:
    from flexlink.channels.catalogue import _catalogue, catalogue

    scenario = load_scenario(paper_experiment_path())
    first = catalogue(scenario)
    assert first == _catalogue(scenario)
    first.pop()
    second = catalogue(scenario)
    assert second == _catalogue(scenario)
    assert all(a is b for a, b in zip(second, catalogue(scenario)))


def test_the_reserved_names_are_made_once_per_chain_shape_and_handed_out_as_a_new_set() -> None:
    from flexlink.channels.catalogue import _reserved_names, reserved_names

    first = reserved_names(["arm", "forearm"], 2)
    assert first == set(_reserved_names.__wrapped__(("arm", "forearm"), 2))
    assert {"arm_tip_X", "forearm_tip_Y", "joint2_angle", "time"} <= first
    first.add("mine")  # a caller's set is its own
    assert "mine" not in reserved_names(["arm", "forearm"], 2)
    assert reserved_names([["unhashable"]], 1) >= {"joint1_angle"}  # type: ignore[list-item]


def test_builds_that_reuse_the_tables_they_share_equal_builds_from_scratch() -> None:
    """Within reusing_tables, a link or joint table met again as the same object is
    resolved once: the scenarios equal their builds from scratch, a changed table is
    resolved anew, and a table with a problem reports it at every build."""
    from flexlink.scenario import ScenarioError
    from flexlink.scenario.fields import ScenarioFile
    from flexlink.scenario.load import reusing_tables
    from flexlink.simulation.sensitivities import scenario_file

    file = scenario_file(load_scenario(paper_experiment_path()))
    changes = [{}, {("links", 1, "thickness"): 1.1e-3}, {("links", 0, "EI"): 2.0},
               {("joints", 1, "motion", 0, "to_deg"): 35.0}, {}]
    scratch = [file.build(c) for c in changes]
    with reusing_tables():
        reused = [file.build(c) for c in changes]
    assert reused == scratch
    assert reused[1].chain.links[1] != reused[0].chain.links[1]
    assert reused[3].chain.joints[1] != reused[0].chain.joints[1]
    bad = ScenarioFile(file.with_values({("links", 0, "mass_per_length"): -1.0}),
                       file.base_dir, file.name, file.source)
    with reusing_tables():
        for _ in range(2):  # the same tables each time
            with pytest.raises(ScenarioError, match=r"links\[0\]\.mass_per_length"):
                bad.build()
        assert file.build() == scratch[0]


def test_an_array_of_tables_hands_out_each_copy_with_the_table_it_copies() -> None:
    """One filter pairs each [[links]] / [[joints]] table's copy with the table as given (the
    key of its reuse): past an entry that is not a table, the pairs stay aligned."""
    from flexlink.scenario.errors import Problems

    first, third = {"length": 1.0}, {"length": 2.0}
    p = Problems()
    found = p.given_tables({"links": [first, 5, third]}, "links", required=True)
    assert [(path, given) for path, _, given in found] == [("links[0]", first),
                                                          ("links[2]", third)]
    assert all(copy == given and copy is not given for _, copy, given in found)
    assert [g is t for (_, _, g), t in zip(found, (first, third))] == [True, True]
    assert len(p.messages) == 1 and p.messages[0].startswith("links[1]: expected a table")
    assert Problems().table_array({"links": [first, 5, third]}, "links", required=True) == \
        [(path, copy) for path, copy, _ in found]


def test_an_inner_reusing_tables_keeps_the_outer_ones_resolutions(monkeypatch) -> None:
    """A build inside a second reusing_tables (the stencils' inside the run's) resolves
    no link table the outer one resolved already."""
    from flexlink.scenario import load
    from flexlink.simulation.sensitivities import scenario_file

    file = scenario_file(load_scenario(paper_experiment_path()))
    resolved = []
    link = load._link
    monkeypatch.setattr(load, "_link", lambda *a: resolved.append(a[1]) or link(*a))
    with load.reusing_tables():
        nominal = file.build()
        with load.reusing_tables():
            moved = file.build({("links", 1, "thickness"): 1.1e-3})
    assert resolved == ["links[0]", "links[1]", "links[1]"]
    assert nominal == file.build() and moved == file.build({("links", 1, "thickness"): 1.1e-3})


def test_quasi_rigid_links_are_remembered_for_the_output_times_asked_for() -> None:
    from flexlink.simulation import rigid

    scenario = load_scenario(paper_experiment_path())
    fine = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    assert rigid.quasi_rigid_links(scenario, fine) == rigid._quasi_rigid_links(scenario, fine)
    coarse = fine[::50]
    assert rigid.quasi_rigid_links(scenario, coarse) == rigid._quasi_rigid_links(scenario,
                                                                                 coarse)
    kept = scenario.__dict__["_quasi_rigid"]
    np.testing.assert_array_equal(kept[0], coarse)


@pytest.mark.parametrize(("t_end", "dt_out"), [(5.0, 1e-3), (1.0, 0.3), (0.7, 0.1),
                                               (2.0, 2e-6), (1e-3, 1e-4), (3.0, 0.7)])
def test_output_times_end_as_with_numpy_s_isclose(t_end: float, dt_out: float) -> None:
    count = int(np.floor(t_end / dt_out + 1e-9))
    t = np.arange(count + 1) * dt_out
    expected = t if np.isclose(t[-1], t_end) else np.append(t, t_end)
    np.testing.assert_array_equal(output_times(t_end, dt_out), expected)


def test_all_finite_finds_a_non_finite_entry_in_a_column_slice_and_allows_overflow() -> None:
    states = np.random.default_rng(1).normal(size=(501, 17))
    assert all_finite(states[:, :8]) and all_finite(states[:, 8:16])
    for bad in (np.nan, np.inf, -np.inf):
        broken = states.copy()
        broken[250, 3] = bad
        assert not all_finite(broken[:, :8])
        assert all_finite(broken[:, 8:16])
        assert not all_finite(broken[:, 3])  # 1-D: element-wise
    big = np.full((4, 3), 1e308)  # finite entries whose row sums overflow
    assert all_finite(big)
    assert all_finite(np.zeros((5, 0)))
    q = states[:, :8].copy()
    q[7, 2] = np.nan
    with pytest.raises(Exception, match="coordinates are not finite"):
        Solution(np.arange(501.0), q, states[:, :8], states[:, :8], "test")


def test_a_worker_keeps_one_blas_thread_for_good() -> None:
    code = textwrap.dedent("""
        from contextlib import nullcontext
        from threadpoolctl import threadpool_info
        from flexlink.batch.worker import init_local_worker
        from flexlink.solvers.threads import single_threaded
        assert not isinstance(single_threaded(), nullcontext)
        init_local_worker()
        assert isinstance(single_threaded(), nullcontext)
        assert all(lib["num_threads"] == 1 for lib in threadpool_info())
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=False)
    assert done.returncode == 0, done.stderr


def _packed_whole(system) -> object:
    from flexlink.dynamics.forward_kernel import pack
    from flexlink.dynamics.prescribed_kernel import forward_view

    return pack(forward_view(system))


@pytest.mark.parametrize("change", [{"EI": 310.0}, {"damping_ratio": 0.045},
                                    {"EI": 150.0, "damping_ratio": 0.0}])
def test_data_repacked_for_a_new_stiffness_equal_those_packed_whole(change) -> None:
    import dataclasses

    from flexlink.dynamics import prescribed_kernel
    from flexlink.dynamics.prescribed_kernel import forward_data

    scenario = load_scenario(paper_experiment_path())
    chain = scenario.chain
    prescribed_kernel._PACKED.clear()
    sibling = forward_data(FirstOrderSystem(chain))  # packed whole, kept
    links = (dataclasses.replace(chain.links[0], **change), *chain.links[1:])
    system = FirstOrderSystem(dataclasses.replace(chain, links=links))
    data = forward_data(system)
    assert data.mass is sibling.mass and data.stiffness is not sibling.stiffness  # re-stiffened
    assert len(prescribed_kernel._PACKED) == 1  # one entry per chain but for its stiffness
    whole = _packed_whole(system)
    assert data._fields == whole._fields
    for name, a, b in zip(data._fields, data, whole):
        np.testing.assert_array_equal(a, b, err_msg=name)
        assert np.asarray(a).dtype == np.asarray(b).dtype, name


def test_data_of_links_that_differ_in_more_than_stiffness_are_packed_whole() -> None:
    import dataclasses

    from flexlink.dynamics import prescribed_kernel
    from flexlink.dynamics.prescribed_kernel import forward_data

    chain = load_scenario(paper_experiment_path()).chain
    prescribed_kernel._PACKED.clear()
    sibling = forward_data(FirstOrderSystem(chain))
    links = (dataclasses.replace(chain.links[0], EI=200.0, tip_mass=chain.links[0].tip_mass
                                 + 0.01), *chain.links[1:])
    system = FirstOrderSystem(dataclasses.replace(chain, links=links))
    data = forward_data(system)
    assert data.mass is not sibling.mass  # packed whole
    assert any(entry[1] is data for entry in prescribed_kernel._PACKED.values())
    for name, a, b in zip(data._fields, data, _packed_whole(system)):
        np.testing.assert_array_equal(a, b, err_msg=name)


def test_scenarios_equal_but_for_their_sensors_as_their_copies_without_sensors_compare() -> None:
    import dataclasses

    from flexlink.batch.runner import equal_but_sensors

    paper = load_scenario(paper_experiment_path())
    moved = dataclasses.replace(paper.sensors[0], x=paper.sensors[0].x - 0.1)
    other_sensors = dataclasses.replace(paper, sensors=(moved, *paper.sensors[1:]))
    links = (dataclasses.replace(paper.chain.links[0], EI=250.0), *paper.chain.links[1:])
    stiffer = dataclasses.replace(paper, chain=dataclasses.replace(paper.chain, links=links))
    longer = dataclasses.replace(paper, settings=dataclasses.replace(paper.settings, rtol=1e-7))
    motion = MeasuredMotion.from_arrays(np.linspace(0.0, 6.0, 61), np.linspace(0.0, 30.0, 61))
    measured = dataclasses.replace(paper, chain=dataclasses.replace(
        paper.chain, joints=(motion, *paper.chain.joints[1:])))
    measured_again = dataclasses.replace(measured, sensors=())
    for a, b, equal in [(paper, other_sensors, True), (paper, paper, True),
                        (paper, stiffer, False), (paper, longer, False),
                        (measured, measured_again, True), (measured, paper, False)]:
        assert equal_but_sensors(a, b) is equal
        assert equal_but_sensors(b, a) is equal


def test_a_chain_packed_before_gets_the_data_remembered_for_it() -> None:
    from flexlink.dynamics import prescribed_kernel
    from flexlink.dynamics.prescribed_kernel import forward_data

    chain = load_scenario(paper_experiment_path()).chain
    prescribed_kernel._PACKED.clear()
    data = forward_data(FirstOrderSystem(chain))
    again = FirstOrderSystem(chain)
    assert forward_data(again) is data
    for name, a, b in zip(data._fields, data, _packed_whole(again)):
        np.testing.assert_array_equal(a, b, err_msg=name)


# a joint that moves there and back within one output interval of 1 ms (0.8002–0.8008 s):
# alike at both ends of [0.800, 0.801] s, not in its middle
THERE_AND_BACK = Sequence((Cycloidal(0.0, 10.0, 0.8002, 0.0003),
                           Cycloidal(10.0, 0.0, 0.8005, 0.0003)))


@pytest.mark.parametrize("motion", [*MOTIONS, THERE_AND_BACK, Hold(3.0)],
                         ids=lambda m: type(m).__name__)
@pytest.mark.parametrize("with_patch", [False, True], ids=["joints", "patch"])
def test_resting_intervals_are_those_the_keys_of_every_middle_tell(motion, with_patch) -> None:
    links = (Link("a", 0.5, 2.0, 300.0, modes=1), Link("b", 0.4, 1.0, 200.0, modes=1))
    patch = PiezoActuator("patch", 1, 0.01, 0.04, 0.025, 30.33e9, 265e-12, 0.001,
                          voltage=Step(50.0, 0.7))
    chain = Chain(links, (motion, Cycloidal(0.0, 10.0, 0.05, 0.5)))
    t = output_times(1.0, 1e-3)
    system = FirstOrderSystem(chain, actuators=(patch,) if with_patch else ())
    system.joint_history(t)  # the output times first, as a run asks
    resting = system.resting_intervals(t)
    if with_patch:  # voltages are part of the keys: the table asks them
        assert resting is None
        return
    kinematics._HISTORIES.clear()
    expected = resting_from_keys(t, FirstOrderSystem(chain, actuators=system.actuators)
                                 .coefficient_keys)
    np.testing.assert_array_equal(resting, expected)
    assert not resting.all()  # the second joint moves from 0.05 to 0.55 s
    if motion is THERE_AND_BACK:  # the ends alike, the middle not
        assert resting[799] and not resting[800] and resting[801]


def test_a_lawson_table_from_resting_intervals_equals_the_one_from_keys() -> None:
    scenario = load_scenario(paper_experiment_path())
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    system = prescribed_system(scenario, t)
    rows, breaks = system.state_rows, system.breakpoints()
    fast = tabulate(rows, t, system.coefficient_keys, 1e-4, breaks=breaks,
                    resting=system.resting_intervals)
    keyed = tabulate(rows, t, system.coefficient_keys, 1e-4, breaks=breaks)
    assert fast.static.any() and not fast.static.all()
    for field in dataclasses.fields(keyed):
        np.testing.assert_array_equal(getattr(fast, field.name), getattr(keyed, field.name))
