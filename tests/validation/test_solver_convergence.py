"""Step-size convergence of the Magnus integrator, shown rather than assumed: successive
halvings of the step shrink the change of the solution 16-fold (fourth order)."""

from __future__ import annotations

import itertools

import numpy as np

from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.motion import Cycloidal
from flexlink.simulation import output_times
from flexlink.solvers.magnus import _solve
from tests.helpers import chain_of, paper_links


def test_magnus_is_fourth_order() -> None:
    system = FirstOrderSystem(chain_of(paper_links(2), [Cycloidal(0.0, 90.0, 0.1, 1.0),
                                                        Cycloidal(90.0, 170.0, 0.1, 1.0)]), True)
    t = output_times(1.5, 0.02)
    runs = [_solve(system.matrices, system.n, t, substeps, None) for substeps in (2, 4, 8, 16)]
    changes = [np.abs(fine - coarse).max() for coarse, fine in itertools.pairwise(runs)]
    orders = np.log2(np.array(changes[:-1]) / np.array(changes[1:]))
    assert np.all((orders > 3.6) & (orders < 4.4)), orders
