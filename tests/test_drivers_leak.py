"""Leak probe: debounced, latched, on the emulated GPIO."""

from __future__ import annotations

import pytest

from roboray.sim import twin

pytestmark = pytest.mark.micropython


@pytest.fixture(scope="module")
def board():
    mp = twin.interpreter()
    yield mp
    mp.close()


@pytest.fixture
def mp(board):
    twin.reset(board)
    board.exec(
        "import machine\n"
        "from roboray.firmware.boards import pico2\n"
        "from roboray.firmware.drivers.leak import Leak\n"
        "t = machine.twin\n"
        "leak = Leak(pico2.leak_pin(machine), samples=3)\n"
        "def run(n):\n"
        "    for _ in range(n):\n"
        "        leak.update()\n"
    )
    return board


def test_unplugged_probe_reads_dry(mp):
    mp.exec("run(10)")
    assert mp.eval("[leak.wet, leak.detected]") == [False, False]


def test_a_splash_shorter_than_the_debounce_is_ignored(mp):
    mp.exec("t.set_pin(15, 1)\nrun(2)\nt.set_pin(15, 0)\nrun(5)")
    assert mp.eval("[leak.wet, leak.detected]") == [False, False]


def test_a_leak_is_debounced_then_latched(mp):
    mp.exec("t.set_pin(15, 1)\nrun(2)")
    assert mp.eval("leak.wet") is False
    mp.exec("run(1)")
    assert mp.eval("[leak.wet, leak.detected]") == [True, True]
    mp.exec("t.set_pin(15, 0)\nrun(5)")
    assert mp.eval("[leak.wet, leak.detected]") == [False, True]
    mp.exec("leak.clear()")
    assert mp.eval("leak.detected") is False


def test_active_low_probe(mp):
    mp.exec("t.set_pin(16, 1)\nlow = Leak(machine.Pin(16, machine.Pin.IN), active_high=False, samples=1)\n"
            "low.update()\nw1 = low.wet\nt.set_pin(16, 0)\nlow.update()")
    assert mp.eval("[w1, low.wet]") == [False, True]
    assert mp.alloc_bytes("low.update()") == 0
