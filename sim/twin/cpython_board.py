"""The twin's board on CPython: ``--interpreter cpython``.

``python -m roboray.sim.twin.cpython_board FD_IN FD_OUT CONFIG_JSON BUILD_INFO`` runs
the same board-side code as the MicroPython interpreter does
(``board/lockstep.py`` and the firmware under it), with ``time`` and
``machine`` replaced in ``sys.modules`` before anything imports them, and a
``hostlink`` module whose ``request(text)`` writes one line to ``FD_OUT`` and
returns the line read back from ``FD_IN`` (the parent's answer), and
``BUILD_INFO`` as ``roboray.firmware.build_info`` (what a build writes). The
firmware's own output goes to this process's stdout, the protocol never
does. Objects that exist before the firmware starts are frozen out of
the garbage collector (``gc.freeze``), so the collection the scheduler
runs every slot costs what it costs on a board, not a walk of CPython's
whole heap. The parent is ``runner.CPythonBoard``.
"""

from __future__ import annotations

import json
import os
import sys
import types


def _hostlink(fd_in: int, fd_out: int) -> types.ModuleType:
    reader = os.fdopen(fd_in, "rb")
    module = types.ModuleType("hostlink")

    def request(text: str) -> str:
        data = (text + "\n").encode()
        view = memoryview(data)
        while view:
            n = os.write(fd_out, view)
            view = view[n:]
        line = reader.readline()
        if not line:
            raise SystemExit(0)  # the twin went away: nothing left to simulate
        return line[:-1].decode()

    module.request = request  # type: ignore[attr-defined]
    return module


def main(argv: list[str]) -> int:
    fd_in, fd_out, config = int(argv[1]), int(argv[2]), json.loads(argv[3])
    sys.modules["hostlink"] = _hostlink(fd_in, fd_out)
    info = types.ModuleType("roboray.firmware.build_info")
    exec(argv[4], info.__dict__)
    sys.modules[info.__name__] = info
    from roboray.sim.twin.board import vclock

    sys.modules["time"] = vclock  # type: ignore[assignment]
    from roboray.sim.twin.board import machine

    sys.modules["machine"] = machine  # type: ignore[assignment]
    import gc

    from roboray.firmware import app  # noqa: F401 - imported before the freeze
    from roboray.sim.twin.board import lockstep

    # The scheduler collects once a slot, cheap on a board's small heap; on
    # CPython a full collection walks every object of every module. Frozen
    # objects are left out, so a slot's collection sees the firmware's own.
    gc.collect()
    gc.freeze()
    lockstep.run(**config)
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv))
