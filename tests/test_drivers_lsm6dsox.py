"""LSM6DSOX driver against the emulated chip on the real MicroPython."""

from __future__ import annotations

import math

import pytest

from roboray.firmware.drivers.health import ERR_BUS, ERR_FROZEN, ERR_RANGE, ERR_STALE, FROZEN_SAMPLES
from roboray.sim import twin

pytestmark = pytest.mark.micropython

G = 9.80665
ACCEL_LSB = 0.122e-3 * G
GYRO_LSB = 17.50e-3 * math.pi / 180


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
        "from roboray.sim.twin.board.lsm6dsox_device import LSM6DSOXDevice\n"
        "from roboray.sim.twin.board.lis3mdl_device import LIS3MDLDevice\n"
        "from roboray.firmware.drivers.lsm6dsox import LSM6DSOX\n"
        "from roboray.firmware.drivers.health import FROZEN_SAMPLES\n"
        "i2c = machine.I2C(0, sda=machine.Pin(4), scl=machine.Pin(5))\n"
        "dev = machine.twin.attach(0, LSM6DSOXDevice())\n"
        "def step(n=1):\n"
        "    ok = 0\n"
        "    for _ in range(n):\n"
        "        vclock.advance(10000)\n"
        "        ok += drv.read()\n"
        "    return ok\n"
    )
    return board


def test_configures_the_chip_and_scales_to_si(mp):
    mp.exec("drv = LSM6DSOX(i2c)\n"
            "dev.set_accel(1.0, -2.0, 9.80665)\ndev.set_gyro(0.1, -0.2, 0.3)\ndev.set_temperature(31.5)")
    # 104 Hz, +-4 g, +-500 dps, BDU and IF_INC; both batched into the FIFO
    # at 104 Hz, the temperature at 1.6 Hz, continuous mode
    assert mp.eval("[dev.regs[0x10], dev.regs[0x11], dev.regs[0x12]]") == [0x48, 0x44, 0x44]
    assert mp.eval("[dev.regs[0x09], dev.regs[0x0A]]") == [0x44, 0x16]
    # 104 Hz against 100 Hz: one read in ~25 finds nothing yet; 0.7 s for a
    # temperature (batched at 1.6 Hz)
    assert mp.eval("step(70)") >= 67
    accel = mp.eval("list(drv.accel)")
    gyro = mp.eval("list(drv.gyro)")
    # within half a count, and the emulated part's own +-1 count (its noise
    # floor: a steady input never batches the same word twice)
    for got, want in zip(accel, (1.0, -2.0, G)):
        assert abs(got - want) <= 1.5 * ACCEL_LSB + 1e-6
    for got, want in zip(gyro, (0.1, -0.2, 0.3)):
        assert abs(got - want) <= 1.5 * GYRO_LSB + 1e-7
    assert mp.eval("drv.temp_c[0]") == pytest.approx(31.5, abs=1 / 256)
    assert mp.eval("drv.health.healthy()") is True


def test_full_scale_clips_at_4_g_and_500_dps(mp):
    # (the 17.50 mdps/LSB scale reaches 573 dps; 20 rad/s is beyond it)
    mp.exec("drv = LSM6DSOX(i2c)\ndev.set_accel(0.0, 50.0, -50.0)\ndev.set_gyro(20.0, 0.0, -20.0)\nstep()")
    assert mp.eval("list(drv.raw[1:])") == [32767, 0, -32768, 0, 32767, -32768]
    assert mp.eval("drv.accel[1]") == pytest.approx(32767 * ACCEL_LSB, rel=1e-6)


def test_reading_faster_than_the_batch_rate_finds_nothing_and_only_a_silence_is_stale(mp):
    # 104 Hz: a read 1 ms after one that emptied the FIFO finds nothing,
    # which is no error; a part that batches nothing for longer than
    # STALE_MS (a reset to power-down) is stale
    mp.exec("drv = LSM6DSOX(i2c)\nstep(3)\nvclock.advance(1000)\nr = drv.read()")
    assert mp.eval("r") is False
    assert mp.eval("drv.health.errors") == 0 and mp.eval("drv.health.healthy()") is True
    mp.exec("dev.power_on()\nstep(3)")
    assert mp.eval("drv.health.last_error") == ERR_STALE


def test_a_read_allocates_only_its_floats(mp):
    mp.exec("drv = LSM6DSOX(i2c)\nstep()")
    # counts only (accel and gyro are scaled when asked for); a new
    # temperature boxes two floats. The emulated part batches its words
    # first (its own float arithmetic is the twin's, not the driver's).
    # The emulated part's status read allocates (the twin's code, counted
    # alone and taken off).
    mp.exec("st = bytearray(2)")
    device = mp.alloc_bytes("i2c.readfrom_mem_into(0x6A, 0x3A, st)")
    for n in (1, 2, 5):   # one sample of each, and a stall's backlog
        mp.exec("vclock.advance(%d)\ndev._sync()" % (10000 * n))
        assert mp.alloc_bytes("drv.read()") - device <= 2 * 16, n


def test_absent_or_wrong_part_is_named_by_address(mp):
    mp.exec("machine.twin.detach(0, 0x6A)")
    with pytest.raises(Exception, match=r"OSError: LSM6DSOX at I2C address 0x6A: no answer"):
        mp.exec("LSM6DSOX(i2c)")
    mp.exec("machine.twin.attach(0, LIS3MDLDevice(address=0x6A))")
    with pytest.raises(Exception, match=r"WHO_AM_I is 0x3D, expected 0x6C"):
        mp.exec("LSM6DSOX(i2c)")


def test_nack_counts_bus_errors_and_health_drops_then_returns(mp):
    mp.exec("drv = LSM6DSOX(i2c)\nstep(5)\ndev.set_fault(i2c_device.FAULT_NACK)\nstep(8)")
    assert mp.eval("drv.health.last_error") == ERR_BUS
    assert mp.eval("drv.health.counts[%d]" % ERR_BUS) == 8
    assert mp.eval("drv.health.healthy()") is False
    mp.exec("dev.set_fault(i2c_device.FAULT_NONE)\nstep(2)")
    assert mp.eval("drv.health.healthy()") is True


def test_garbage_shows_as_impossible_values(mp):
    mp.exec("drv = LSM6DSOX(i2c)\nstep(5)\ndev.set_fault(i2c_device.FAULT_GARBAGE)\nstep(50)")
    assert mp.eval("drv.health.counts[%d]" % ERR_RANGE) > 30
    assert mp.eval("drv.health.healthy()") is False


def test_a_part_that_reset_itself_is_reconfigured(mp):
    # A supply dip resets the chip to power-down: no more samples, so reads go
    # stale; after ten the driver writes its configuration again.
    # (the first two reads after it are within STALE_MS of the last sample)
    mp.exec("drv = LSM6DSOX(i2c)\nstep(5)\ndev.power_on()\nstep(12)")
    assert mp.eval("drv.health.counts[%d]" % ERR_STALE) == 10
    assert mp.eval("drv.reconfigurations") == 1
    assert mp.eval("step(3)") == 3
    assert mp.eval("drv.health.healthy()") is True


def test_a_part_at_rest_is_live_and_a_frozen_one_is_caught_by_its_counts(mp):
    # At rest a live part's noise moves its counts every sample: five
    # seconds of the same input raise nothing. Frozen (still flagging new
    # samples), every count repeats: caught after FROZEN_SAMPLES reads.
    mp.exec("drv = LSM6DSOX(i2c)\ndev.set_noise(3)\ndev.set_accel(0.0, 0.0, 9.80665)")
    assert mp.eval("step(500)") == 500
    assert mp.eval("drv.health.errors") == 0
    mp.exec("dev.set_fault(i2c_device.FAULT_STICK)\ndev.set_accel(3.0, 0.0, 9.0)")
    assert mp.eval("step(FROZEN_SAMPLES - 1)") == FROZEN_SAMPLES - 1   # repeats 1 .. 19: still live
    assert mp.eval("drv.health.healthy()") is True
    # frozen, and a reconfiguration (every 10 failures) that resets the part
    # to zeros once does not make it live again
    # (the first sample after each reconfiguration is compared with nothing)
    assert mp.eval("step(60)") <= 6
    assert mp.eval("drv.reconfigurations") >= 5
    assert mp.eval("drv.health.last_error") == ERR_FROZEN
    assert mp.eval("drv.health.healthy()") is False
    assert abs(mp.eval("drv.accel[0]")) < 0.01     # the stuck part never showed the new input
    # a part that comes back moves its counts: live again after as many samples
    mp.exec("dev.set_fault(i2c_device.FAULT_NONE)")
    assert mp.eval("step(FROZEN_SAMPLES + 5)") == 6 and mp.eval("drv.health.healthy()") is True  # from the 20th
