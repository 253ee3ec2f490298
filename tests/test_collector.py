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


def test_roboray_build_is_told_apart_and_says_so():
    from roboray.tools.micropython import roboray_host
    if not roboray_host.available():
        pytest.skip("RoboRay MicroPython's host build runs on Linux on x86")
    out = _roboray("from roboray.firmware import collector\n"
                   "print(collector.floats_boxed(), v.floats_boxed, 'gc' in v.sched.names)\n"
                   "print(v.collection_text)\n")
    assert out[-2] == "False False True"
    assert out[-1].startswith("RoboRay MicroPython 1.") and out[-1].endswith(": GC every 300 ms")
    assert len(out[-1]) <= 50
