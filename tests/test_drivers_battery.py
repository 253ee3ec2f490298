"""Battery voltage: divider, 12-bit ADC, low-pass filter, rails."""

from __future__ import annotations

import pytest

from roboray.firmware.drivers.health import ERR_RANGE
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
        "from roboray.firmware.drivers.battery import Battery\n"
        "t = machine.twin\n"
        "bat = Battery(pico2.battery_adc(machine), divider=3.0, period_s=0.1, tau_s=1.0)\n"
    )
    return board


def test_reads_the_pack_through_the_divider(mp):
    mp.exec("t.set_adc_volts(0, 7.4 / 3.0)\nok = bat.update()")
    assert mp.eval("ok") is True
    # 12-bit ADC on 3.3 V, times 3: one count is 2.4 mV at the pack
    assert mp.eval("bat.volts[0]") == pytest.approx(7.4, abs=0.003)


def test_filter_follows_a_sag_with_its_time_constant(mp):
    mp.exec("t.set_adc_volts(0, 8.0 / 3.0)\nbat.update()\nt.set_adc_volts(0, 7.0 / 3.0)\n"
            "for _ in range(10):\n    bat.update()\n")
    # 1 s at tau = 1 s: 1 - (1 - 1/11)**10 = 61 % of the step
    assert mp.eval("bat.volts[0]") == pytest.approx(8.0 - 0.614, abs=0.01)
    assert mp.eval("bat.raw_volts[0]") == pytest.approx(7.0, abs=0.003)


def test_an_adc_at_a_rail_is_an_impossible_reading(mp):
    assert mp.eval("bat.update()") is False          # nothing connected: 0
    mp.exec("t.set_adc_u16(0, 65535)")
    assert mp.eval("bat.update()") is False
    assert mp.eval("bat.health.counts[%d]" % ERR_RANGE) == 2
    assert mp.eval("bat.health.healthy()") is False


def test_divider_is_validated(mp):
    with pytest.raises(Exception, match="divider must be > 0"):
        mp.exec("bat.set_divider(0.0)")
    mp.exec("bat.set_divider(4.0)\nt.set_adc_volts(0, 2.0)\nbat.update()")
    assert mp.eval("bat.volts[0]") == pytest.approx(8.0, abs=0.004)
