"""The firmware's collection on the emulated RP2350: marked in the
collector's order (``firmware/collector.py``), its mark stack does not
overflow, so a collection costs one pass over the live heap and one sweep.

MicroPython's collector pushes every unmarked object a block points to onto
a 64-entry stack; when it is full it marks without scanning and, after the
roots, walks the whole allocation table and scans every marked block again.
That second pass costs as much as the first and more, so an overflowing
collection takes twice the instructions or more for the same heap: what
this test tells apart."""

from __future__ import annotations

import json
import re

import pytest

from roboray.sim import twin
from roboray.sim.twin import bench
from roboray.tools.micropython import rp2350_emu

pytestmark = pytest.mark.skipif(
    not rp2350_emu.available(),
    reason="qemu-system-arm (Debian package qemu-system-arm) is not installed: the emulated RP2350 cannot run")

_PROBE = """
import gc, json, emuboard
%(prelude)s
%(setup)s
%(build)s
v.sched.run(200)
from roboray.firmware import collector
def cost():
    v.sched.run(20)
    i0 = emuboard.insns()
    collector.collect()
    return emuboard.insns() - i0
out = {"unordered": cost()}
app.vehicle = v
out["chain"] = collector.prepare()
gc.collect()
out["ordered"] = cost()
out["ordered_again"] = cost()
out["live_bytes"] = gc.mem_alloc()
print("RESULT " + json.dumps(out))
"""


def test_a_collection_in_the_collectors_order_scans_the_heap_once(tmp_path):
    code = _PROBE % {"prelude": twin.PRELUDE,
                     "setup": bench.SETUP.replace("import gc, machine, time", "import machine, time"),
                     "build": bench.BUILD % "params.bin"}
    src = tmp_path / "romsrc"
    rp2350_emu.install_lib(src / "lib")
    status, out = rp2350_emu.run(code, cwd=tmp_path, heap_bytes=rp2350_emu.PICO2_HEAP + rp2350_emu.TWIN_HEAP,
                                 romfs=rp2350_emu.make_romfs(src), timeout=900)
    m = re.search(r"^RESULT (.*)$", out, re.M)
    assert status == 0 and m, out[-2000:]
    r = json.loads(m.group(1))
    words = r["live_bytes"] / 4
    assert r["chain"] > 50
    # in the order: well under the cost of a collection that overflows
    # (the firmware's natural order does: its objects are wide and
    # connected), and one pass (~14 instructions a live word to mark, ~18 a
    # block to sweep) rather than two
    assert r["ordered"] < 0.6 * r["unordered"]
    assert r["ordered"] / words < 30 and r["ordered_again"] / words < 30
    assert r["unordered"] / words > 40
