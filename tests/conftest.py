"""Fixtures every test can use.

``micropython``: one real MicroPython interpreter (the WebAssembly port under
Node.js) for the whole session, with the board packages copied into its file
system under /lib/roboray/..., as the flashing tool lays them out on a board.
Tests that use it are marked ``micropython`` automatically, so
``pytest -m micropython`` runs exactly those.
"""

from __future__ import annotations

import pytest

from roboray.tools.micropython import MicroPython, MicroPythonUnavailable


@pytest.fixture(scope="session")
def micropython():
    try:
        mp = MicroPython()
    except MicroPythonUnavailable as exc:
        pytest.fail(str(exc), pytrace=False)
    mp.install_board_code()
    yield mp
    mp.close()


def pytest_sessionstart(session):
    """Compile the dynamics kernels once, in the controlling process, before
    pytest-xdist starts its workers: numba caches them on disk, so the
    workers load them instead of each compiling them (about 30 s)."""
    if hasattr(session.config, "workerinput"):
        return  # an xdist worker: the controller has compiled them
    import numpy as np

    from roboray.sim.dynamics import Model
    from roboray.sim.simulate import simulate

    model = Model(None)
    x0 = model.state(velocity=(0.0, 0.0, 0.3))
    model.step(x0, x0[:, 13:17], 0.01)
    model.rhs(x0, x0[:, 13:17])
    simulate(model, x0, 0.02, dt=0.01)
    model.body_rhs(x0, np.zeros((1, 4)))


def pytest_xdist_auto_num_workers(config):
    """``-n auto``: two workers more than the cores. A dozen tests talk to the
    twin's radio at the pace of simulated time (57,600 baud, MAVProxy's own
    waits) and use a tenth of a core meanwhile; with one worker a core the
    suite left 40 % of two cores idle (CPU time 609 s over 511 s of wall
    time). The two more fill those waits."""
    import os

    return (os.cpu_count() or 1) + 2


def pytest_configure(config):
    """An xdist worker takes its share of the cores for numba's threads:
    with one worker a core (``-n auto``), a batch kernel on two threads in
    each worker had four threads on two cores, and every kernel call's
    threads waited on each other (``sim/identify``: ~80,000 calls a fit).
    The numbers do not depend on the thread count (``kernels._advance``,
    tests/test_dynamics_parallel.py); the tests that need threads set them."""
    workers = getattr(config, "workerinput", {}).get("workercount")
    if workers:
        import os

        import numba

        numba.set_num_threads(max(1, min(numba.config.NUMBA_NUM_THREADS, (os.cpu_count() or 1) // workers)))


def pytest_collection_modifyitems(config, items):
    for item in items:
        if "micropython" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.micropython)
