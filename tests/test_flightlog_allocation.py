"""The log task allocates nothing armed on RoboRay's MicroPython (issue 29
item 2): the firmware built on its wired board (as ``roboray-sim bench
board`` builds it) on the host build of RoboRay MicroPython, armed and
logging, each call measured between two ``gc.mem_alloc()`` readings with the
collector off: two seconds of calls from the arming on (every record of the
50-call cycle, the ring in the RAM the build keeps), with a position fix and
a failsafe raised and cleared among them. A flush to flash (at rest, inside its announced
stall) opens the log's file, which allocates: not a flight call."""

from __future__ import annotations

import os
import subprocess
import tempfile
from pathlib import Path

import pytest

from roboray.sim import twin
from roboray.sim.twin import bench
from roboray.tools.micropython import roboray_host

pytestmark = pytest.mark.skipif(not roboray_host.available(),
                                reason="RoboRay MicroPython's host build runs on Linux on x86")

CALLS = 100


def test_the_log_task_allocates_nothing_a_call_armed_on_roboray_micropython():
    d = Path(tempfile.mkdtemp())
    from roboray.sim.twin.runner import install_board_lib
    lib = install_board_lib(d / "lib")
    code = (twin.PRELUDE + bench.SETUP + bench.BUILD % str(d / "params.bin") + "v.sched.run(400)\n"
            "print('KEPT', v.log.ram is not None)\n"
            "for i in range(200):\n"      # still on deck: the next dive's log prepared
            "    vclock.advance(20000)\n"
            "    v.log_step()\n"
            "print('PREPARED', v.log.prepared() > 0, v.log._hdr, v.log.chunks)\n"
            "v.modes.arm(True)\n"
            "ep = v.link.ep\n"
            "t = v.telemetry\n"
            "def _call(i):\n"
            "    if i == 30:\n"
            "        ep.fix_count += 1\n"          # a position fix arrived: a FIX record
            "        ep.fix_time_us = vclock.ticks_us()\n"
            "    if i == 40 or i == 70:\n"
            "        t.failsafe_flags ^= 4\n"      # raised, then cleared: ERR records
            "    v.log_step()\n"
            "got = []\n"
            "for i in range(%d):\n"
            "    vclock.advance(20000)\n"
            "    gc.collect()\n"
            "    gc.disable()\n"
            "    a = gc.mem_alloc()\n"
            "    _call(i)\n"
            "    got.append(gc.mem_alloc() - a)\n"
            "    gc.enable()\n"
            "print('ALLOC', ' '.join(str(x) for x in got))\n"
            "print('LOGGING', v.log.logging, v.log._hdr, v.log._parm)\n"
            "print('PENDING', v.log.w.pending(), v.log.chunks)\n" % CALLS)
    proc = subprocess.run(roboray_host.command("-X", "heapsize=900000", "-c", code),
                          env=dict(os.environ, MICROPYPATH=str(lib)), capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    out = {line.split()[0]: line.split()[1:] for line in proc.stdout.splitlines() if line[:1].isupper() and " " in line}
    assert out["KEPT"] == ["True"]
    assert out["PREPARED"][:2] == ["True", "-1"]     # so the first call measured is the arming's
    assert out["LOGGING"] == ["True", "-1", "-1"]
    alloc = [int(x) for x in out["ALLOC"]]
    assert len(alloc) == CALLS and alloc == [0] * CALLS
    pending, chunks = (int(x) for x in out["PENDING"])
    assert pending > 3_000 and chunks == int(out["PREPARED"][2])     # armed off the bottom: all of it went to the ring
