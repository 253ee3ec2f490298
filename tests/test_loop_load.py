"""The main loop's load and its worst slot, from the scheduler to the ground.

The firmware on a wired emulated board (``sim/twin/bench.py``), with one
extra task that takes a set time of each slot (the virtual clock stands
still while code runs, so that task is all the work a slot does); what the
radio UART sent is read by pymavlink, as the ground station reads it.
"""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from roboray.shared.mavlink import messages  # noqa: E402
from roboray.sim import twin  # noqa: E402
from roboray.sim.twin import bench  # noqa: E402

PARAMS = "/tmp/loop_load_params.bin"
#: What carries SLOT_MAX: NAMED_VALUE_INT once the generated table has it.
SLOT_TYPE = "NAMED_VALUE_INT" if hasattr(messages, "MSG_NAMED_VALUE_INT") else "NAMED_VALUE_FLOAT"

#: A task that takes __work[0] us of each slot, __work[2] us in slot __work[1].
_WORK = """
__work = [4000, -1, 0]
def __busy():
    w = __work
    vclock.advance(w[2] if v.sched.slot == w[1] else w[0])
v.sched.add('busy', __busy, 10)
"""


@pytest.fixture(scope="module")
def board():
    mp = twin.interpreter()
    yield mp
    mp.close()


@pytest.fixture
def mp(board):
    twin.reset(board)
    board.exec("import os\ntry:\n    os.remove(%r)\nexcept OSError:\n    pass\n" % PARAMS)
    bench.build(board, PARAMS)
    board.exec(_WORK)
    return board


def sent(mp) -> list:
    """The loop's figures the radio sent since the last call: ("load", permille), ("SLOT_MAX", us)."""
    rx = mavlink.MAVLink(None)
    rx.robust_parsing = True
    out = []
    for m in rx.parse_buffer(bytearray(mp.eval("t.uart(0).take()"))) or []:
        if m.get_type() == "SYS_STATUS":
            out.append(("load", m.load))
        elif m.get_type() == SLOT_TYPE and m.name == "SLOT_MAX":
            out.append((m.name, m.value))
    return out


def test_sys_status_load_is_the_loop_load_and_slot_max_the_longest_slot_since_the_last_report(mp):
    mp.exec("v.sched.run(150)")    # 1.5 s of 4 ms in each 10 ms slot
    first = sent(mp)
    # the first report goes out in the first slots (one frame a slot, behind
    # the heartbeat and the attitude), the load still rising from 0
    assert first[0][0] == "load" and 0 < first[0][1] < 400 and first[1] == ("SLOT_MAX", 4000)
    # then the scheduler's load, smoothed over ~8 slots: 4 ms of 10 ms is 400
    # permille, as ArduPilot counts (its integer smoothing settles up to 7 below)
    load = mp.eval("v.sched.load_permille")
    assert 390 <= load <= 400
    assert first[2:] == [("load", load), ("SLOT_MAX", 4000)]
    # one slot of 9 ms: the next report shows it, the one after is back to 4 ms
    mp.exec("__work[1] = v.sched.slot + 20\n__work[2] = 9000\nv.sched.run(200)")
    assert [s for s in sent(mp) if s[0] == "SLOT_MAX"] == [("SLOT_MAX", 9000), ("SLOT_MAX", 4000)]
    assert mp.eval("v.sched.max_loop_us") == 9000   # (the scheduler's since boot)
    # a busier loop reads as a higher load
    mp.exec("__work[0] = 7500\nv.sched.run(100)")
    assert sent(mp)[-2:] == [("load", mp.eval("v.sched.load_permille")), ("SLOT_MAX", 7500)]
    assert 740 <= mp.eval("v.sched.load_permille") <= 750


def test_the_slot_figure_costs_the_link_no_heap_and_its_report_one_frame(mp):
    mp.exec("v.sched.run(150)\nep = v.link.ep\ns = v.sched\n"
            "def quiet(sched):\n"          # a link step with no stream due, so no telemetry filled
            "    v.reporter.sched = sched\n    ep._pending = 0\n"
            "    ep._wake = (ep.now_ms + 100000) & 0x3FFFFFFF\n")
    mp.exec("quiet(s)\ns.last_loop_us = 7000")
    sampling = mp.alloc_bytes("v.link.step()")
    assert mp.eval("ep.slot_max_us") == 7000
    mp.exec("quiet(None)")
    assert sampling == mp.alloc_bytes("v.link.step()")    # reading the slot time allocates nothing
    without = mp.alloc_bytes("ep.slot_max_us = -1; ep._send_stream(5)")
    with_slot = mp.alloc_bytes("ep.slot_max_us = 5000; ep._send_stream(5)")
    assert with_slot == without                           # the frame's view is made once per length
