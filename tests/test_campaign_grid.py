"""The maps' and the envelope's grid as campaign tasks (sim/campaign/grid.py):
cut into tasks on two processes, the same figures as one batch here."""

from __future__ import annotations

import numpy as np

from roboray.sim.analysis import envelope, stability_map
from roboray.sim.campaign import InProcess, ProcessPool
from roboray.sim.campaign.grid import CHUNK, settler


def test_the_grid_on_two_processes_gives_the_one_batch_figures():
    assert settler(InProcess()) is envelope.settle_batch   # alone, the grid stays one batch
    with ProcessPool(2) as pool:
        settle = settler(pool)
        wings = np.array([[a, b, a, b] for a in (0.0, 30.0, 60.0, 90.0) for b in (10.0, 45.0, 80.0)])
        assert len(wings) > CHUNK            # more than one task
        here = envelope.settle_batch(None, wings, 4.0)
        there = settle(None, wings, 4.0)
        assert len(there) == len(here)
        for a, b in zip(here, there):
            assert (a is None) == (b is None)
            if a is not None:
                assert np.array_equal(a.V, b.V) and np.array_equal(a.gamma, b.gamma) and a.omega == b.omega
        one = stability_map.compute(step_deg=45.0, settle_s=4.0)
        two = stability_map.compute(step_deg=45.0, settle_s=4.0, settle=settle)
        assert repr(two) == repr(one)         # NaN where no trim, in the same cells
        e1 = envelope.search(step_deg=90.0, settle_s=4.0, refine=False)
        e2 = envelope.search(step_deg=90.0, settle_s=4.0, refine=False, settle=settle)
    for r in (e1, e2):
        r.pop("candidates")
    assert repr(e2) == repr(e1)
