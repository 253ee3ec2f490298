"""The collector's marking order (``firmware/collector.py``): the firmware's
modules and instances leaves first, what holds a bound method last.

On the WebAssembly port with the firmware built on its wired board (as
``roboray-sim bench board`` builds it); the collection itself is counted on
the emulated RP2350 in ``tests/test_rp2350_gc.py``."""

from __future__ import annotations

import pytest

from roboray.sim import twin
from roboray.sim.twin import bench

pytestmark = pytest.mark.micropython


@pytest.fixture(scope="module")
def mp(tmp_path_factory):
    m = twin.interpreter()
    bench.build(m, str(tmp_path_factory.mktemp("collector") / "params.bin"))
    m.exec("app.vehicle = v\n"
           "from roboray.firmware import collector\n"
           "n = collector.prepare()\n"
           "order = []\n"
           "c = collector._first\n"
           "while c is not None:\n"
           "    order.append(c[1])\n"
           "    c = c[0]\n"
           "where = {}\n"
           "for k in range(len(order)):\n"
           "    where[id(order[k])] = k\n")
    yield m
    m.close()


def test_every_module_and_part_of_the_vehicle_is_in_the_chain_once(mp):
    assert mp.eval("n == len(order) == len(where)") is True
    for part in ("v", "v.nav", "v.nav.est", "v.nav.est.att", "v.link", "v.sched", "v.params"):
        assert mp.eval("id(%s) in where" % part) is True, part
    assert mp.eval("id(app) in where") is True
    # built-in modules are not on the heap: not in the chain
    mp.exec("import gc as _gc, math as _math")
    assert mp.eval("id(_gc) in where or id(_math) in where") is False


def test_an_instance_comes_after_what_it_holds(mp):
    # the estimator's filters before the estimator, the estimator before
    # the navigation that holds it (none of them holds a bound method)
    for inner, outer in (("v.nav.est.att", "v.nav.est"), ("v.nav.est.hor", "v.nav.est"),
                         ("v.nav.est", "v.nav"), ("v.params", "v.nav")):
        assert mp.eval("where[id(%s)] < where[id(%s)]" % (inner, outer)) is True, (inner, outer)


def test_what_holds_a_bound_method_comes_after_all_that_does_not(mp):
    # the scheduler holds its tasks' bound methods: after every object that
    # holds none, the navigation and the estimator among them; the vehicle,
    # which holds the scheduler, is in the same late part, before it
    assert mp.eval("where[id(v.sched)] > where[id(v.nav)] and where[id(v.sched)] > where[id(v.nav.est)]") is True
    assert mp.eval("where[id(v)] < where[id(v.sched)]") is True


def test_off_micropython_there_is_nothing_to_order():
    from roboray.firmware import collector
    assert collector.prepare() == 0 and collector._first is None


# ---------------------------------------------------------------- the build
# Which MicroPython the firmware runs on, said once at start
# (firmware/app.py build_loop).

def test_stock_micropython_boxes_floats_and_keeps_the_planned_collection(mp):
    # the WebAssembly port is stock MicroPython (MICROPY_OBJ_REPR_A)
    mp.exec("from roboray.firmware import collector")
    assert mp.eval("collector.floats_boxed()") is True
    assert mp.eval("v.floats_boxed") is True
    assert mp.eval("'gc' in v.sched.names") is True
    text = mp.eval("v.collection_text")
    assert text.startswith("MicroPython ") and text.endswith("floats boxed, GC every 300 ms")
    assert len(text) <= 50      # one STATUSTEXT


def _roboray(code):
    """``code`` run on RoboRay MicroPython's host build, the firmware built
    on its wired board as bench board builds it; its output."""
    import os
    import subprocess
    import tempfile
    from pathlib import Path

    from roboray.sim.twin.runner import install_board_lib
    from roboray.tools.micropython import roboray_host

    d = Path(tempfile.mkdtemp())
    lib = install_board_lib(d / "lib")
    src = twin.PRELUDE + bench.SETUP + bench.BUILD % str(d / "params.bin") + code
    proc = subprocess.run(roboray_host.command("-X", "heapsize=600000", "-c", src),
                          env=dict(os.environ, MICROPYPATH=str(lib)), capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    return proc.stdout.strip().splitlines()


def test_roboray_build_has_no_collection_task_and_says_so():
    from roboray.tools.micropython import roboray_host
    if not roboray_host.available():
        pytest.skip("RoboRay MicroPython's host build runs on Linux on x86")
    out = _roboray("from roboray.firmware import collector\n"
                   "print(collector.floats_boxed(), v.floats_boxed, 'gc' in v.sched.names)\n"
                   "print(v.collection_text)\n"
                   "print(v.collections.free)\n")
    assert out[-3] == "False False False"
    assert out[-2].startswith("RoboRay MicroPython 1.") and out[-2].endswith(": no GC in flight")
    assert len(out[-2]) <= 50      # one STATUSTEXT
    # the heap free after the start-up collection: most of a Pico 2's
    assert int(out[-1]) > 100000


def test_roboray_build_collects_at_rest_and_not_in_flight():
    # the firmware on RoboRay's host build, its loop run disarmed (at rest:
    # once half the heap's estimate is used, the free heap read again), then
    # armed and moving (no collection: the estimate is far from low), then
    # with the estimate forced low in flight: one collection, told on the
    # link and in the log
    from roboray.tools.micropython import roboray_host
    if not roboray_host.available():
        pytest.skip("RoboRay MicroPython's host build runs on Linux on x86")
    out = _roboray("from roboray.firmware import collector\n"
                   "c = v.collections\n"
                   "c.free = 200 * collector.SLOT_BYTES\n"
                   "v.sched.run(250)\n"
                   "print(c.count, c.low, c.free > 100000)\n"
                   "v.log.resting = lambda: False\n"
                   "n = c.count\n"
                   "v.sched.run(300)\n"
                   "print(c.count - n, c.low)\n"
                   "texts = []\n"
                   "v.link.ep.on_text = texts.append\n"
                   "c.free = 200 * collector.SLOT_BYTES\n"
                   "v.sched.run(60)\n"
                   "print(c.count - n, c.low, texts)\n")
    assert out[-3] == "1 0 True"
    assert out[-2] == "0 0"
    assert out[-1] == "1 1 [b'Heap low: collected in flight']"


def test_the_policy_never_collects_in_flight_until_the_heap_is_low():
    from roboray.firmware import collector
    free = 4 * collector.REST_SLOTS * collector.SLOT_BYTES    # half of it lasts past REST_SLOTS
    c = collector.Collections(free, slot=100)
    low = 100 + (free - free // 4) // collector.SLOT_BYTES      # the first slot the estimate is low
    # flying (not resting): nothing up to the low mark, flash write or not
    for slot in (101, 100 + collector.REST_SLOTS, low - 1):
        assert c.due(slot, False, False) == 0 and c.due(slot, False, True) == 0
    assert c.due(low, False, False) == 2
    c.done(low, -1, True)
    assert (c.count, c.low, c.last, c.free) == (1, 1, low, free)
    # at rest: in a flash write's slot once REST_SLOTS have passed, else
    # once half the free heap may be used
    s = c.last
    assert c.due(s + collector.REST_SLOTS - 1, True, True) == 0
    assert c.due(s + collector.REST_SLOTS, True, False) == 0
    assert c.due(s + collector.REST_SLOTS, True, True) == 1
    half = s + (free // 2) // collector.SLOT_BYTES
    assert c.due(half - 1, True, False) == 0 and c.due(half, True, False) == 1
    c.done(s + 1, 64 * collector.SLOT_BYTES, False)
    assert c.free == 64 * collector.SLOT_BYTES and c.low == 1
    assert c.due(s + 1 + 31, True, False) == 0 and c.due(s + 1 + 32, True, False) == 1


def test_the_policy_check_allocates_nothing_on_micropython(mp):
    mp.exec("from roboray.firmware import collector\n"
            "_c = collector.Collections(300000, 0)\n")
    assert mp.alloc_bytes("_c.due(50, False, False); _c.due(2000, True, True)") == 0
