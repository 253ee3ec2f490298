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
