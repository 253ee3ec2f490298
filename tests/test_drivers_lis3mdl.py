"""LIS3MDL driver against the emulated chip on the real MicroPython."""

from __future__ import annotations

import pytest

from roboray.firmware.drivers.health import ERR_BUS, ERR_FROZEN, ERR_STALE, FROZEN_SAMPLES
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
        "from roboray.sim.twin.board import vclock, i2c_device\n"
        "from roboray.sim.twin.board.lis3mdl_device import LIS3MDLDevice\n"
        "from roboray.sim.twin.board.lsm6dsox_device import LSM6DSOXDevice\n"
        "from roboray.firmware.drivers.lis3mdl import LIS3MDL\n"
        "i2c = machine.I2C(0, sda=machine.Pin(4), scl=machine.Pin(5))\n"
        "dev = machine.twin.attach(0, LIS3MDLDevice())\n"
        "def step(n=1, dt=10000):\n"
        "    ok = 0\n"
        "    for _ in range(n):\n"
        "        vclock.advance(dt)\n"
        "        ok += drv.read()\n"
        "    return ok\n"
    )
    return board


def test_configures_ultra_high_performance_155_hz_4_gauss(mp):
    mp.exec("drv = LIS3MDL(i2c)")
    assert mp.eval("[dev.regs[r] for r in (0x20, 0x21, 0x22, 0x23, 0x24)]") == [0xE2, 0x00, 0x00, 0x0C, 0x40]
    assert mp.eval("dev._period_us()") == 6452  # 155 Hz


def test_reads_the_field_in_gauss_at_every_100_hz_cycle(mp):
    # a live part: its own noise moves the counts (a frozen one is a fault)
    mp.exec("drv = LIS3MDL(i2c)\ndev.set_noise(2)\ndev.set_field(0.21, -0.05, 0.43)\ndev.set_temperature(18.0)")
    assert mp.eval("step(200)") == 200  # 155 Hz: every 10 ms cycle finds a new sample
    for got, want in zip(mp.eval("list(drv.mag_gauss)"), (0.21, -0.05, 0.43)):
        assert abs(got - want) <= 2.5 / 6842 + 1e-7
    assert mp.eval("drv.temp_c[0]") == pytest.approx(18.0, abs=0.125)
    # 155 Hz read at 100 Hz: some samples are overwritten unread, and say so
    assert 0 < mp.eval("drv.overruns") < 200
    assert mp.eval("drv.health.errors") == 0


def test_reading_slower_than_the_chip_counts_overruns(mp):
    mp.exec("drv = LIS3MDL(i2c)\nstep(5, 20000)")
    assert mp.eval("drv.overruns") == 5
    assert mp.eval("drv.health.errors") == 0


def test_a_read_allocates_only_its_floats(mp):
    mp.exec("drv = LIS3MDL(i2c)\nstep()\ndev.set_temperature(30.0)")
    # counts only; a new temperature boxes two floats
    assert mp.alloc_bytes("vclock.advance(10000); drv.read()") <= 2 * 16
    assert mp.alloc_bytes("vclock.advance(10000); drv.read()") == 0


def test_absent_or_wrong_part_is_named_by_address(mp):
    mp.exec("machine.twin.detach(0, 0x1C)")
    with pytest.raises(Exception, match=r"OSError: LIS3MDL at I2C address 0x1C: no answer"):
        mp.exec("LIS3MDL(i2c)")
    mp.exec("machine.twin.attach(0, LSM6DSOXDevice(address=0x1C))")
    with pytest.raises(Exception, match=r"WHO_AM_I is 0x6C, expected 0x3D"):
        mp.exec("LIS3MDL(i2c)")


def test_nack_then_recovery(mp):
    mp.exec("drv = LIS3MDL(i2c)\nstep(3)\ndev.set_fault(i2c_device.FAULT_NACK)\nstep(12)")
    assert mp.eval("drv.health.last_error") == ERR_BUS
    assert mp.eval("drv.health.healthy()") is False
    mp.exec("dev.set_fault(i2c_device.FAULT_NONE)\nstep(2)")
    assert mp.eval("drv.health.healthy()") is True


def test_power_dip_is_recovered_by_reconfiguring(mp):
    mp.exec("drv = LIS3MDL(i2c)\nstep(3)\ndev.power_on()\nstep(10)")
    assert mp.eval("drv.health.counts[%d]" % ERR_STALE) == 10
    assert mp.eval("drv.reconfigurations") == 1
    assert mp.eval("step(2)") == 2


def test_frozen_counts_are_caught(mp):
    mp.exec("drv = LIS3MDL(i2c)\ndev.set_noise(2)\ndev.set_field(0.21, -0.05, 0.43)")
    assert mp.eval("step(50)") == 50
    mp.exec("dev.set_fault(i2c_device.FAULT_STICK)")
    assert mp.eval("step(80)") == FROZEN_SAMPLES - 1   # then frozen, reconfigurations or not
    assert mp.eval("drv.health.last_error") == ERR_FROZEN and mp.eval("drv.health.healthy()") is False
