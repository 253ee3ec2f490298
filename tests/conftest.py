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


def pytest_collection_modifyitems(config, items):
    for item in items:
        if "micropython" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.micropython)
