"""MS5837-30BA driver: exact small-integer compensation, and the driver
against the emulated chip on the real MicroPython (PROM, CRC, conversions,
timing, faults)."""

from __future__ import annotations

import random
import struct

import pytest

from roboray.firmware.drivers import ms5837
from roboray.firmware.drivers.health import ERR_BUS, ERR_NOT_READY, ERR_RANGE, OK
from roboray.sim import twin

DATASHEET_C = [0, 34982, 36352, 20328, 22354, 26646, 26146]
SMALL_INT = 1 << 30   # MicroPython small ints on the boards: |x| < 2**30


def reference(c, d1, d2):
    """The datasheet's int64 formula (first and second order, 30BA), floor division."""
    dt = d2 - c[5] * 2**8
    temp = 2000 + dt * c[6] // 2**23
    if temp < -4000 or temp > 8500:
        return ERR_RANGE, None, None
    off = c[2] * 2**16 + c[4] * dt // 2**7
    sens = c[1] * 2**15 + c[3] * dt // 2**8
    if temp < 2000:
        ti = 3 * dt**2 // 2**33
        offi = 3 * (temp - 2000) ** 2 // 2
        sensi = 5 * (temp - 2000) ** 2 // 2**3
        if temp < -1500:
            offi += 7 * (temp + 1500) ** 2
            sensi += 4 * (temp + 1500) ** 2
    else:
        ti = 2 * dt**2 // 2**37
        offi = (temp - 2000) ** 2 // 2**4
        sensi = 0
    p = (d1 * (sens - sensi) // 2**21 - (off - offi)) // 2**13
    if p < 0 or p > 400000:
        return ERR_RANGE, None, None
    return OK, p, temp - ti


class Bounded(int):
    """An int whose every arithmetic result must stay a MicroPython small int."""

    seen = 0

    def _wrap(self, r):
        if r is NotImplemented:
            return r
        Bounded.seen = max(Bounded.seen, abs(r))
        assert abs(r) < SMALL_INT, "intermediate %d needs a big integer" % r
        return Bounded(r)


def _binop(name):
    base = getattr(int, name)
    return lambda self, other: self._wrap(base(self, other))


for _name in ("__add__", "__radd__", "__sub__", "__rsub__", "__mul__", "__rmul__", "__and__",
              "__rand__", "__or__", "__ror__", "__rshift__", "__lshift__", "__floordiv__", "__mod__"):
    setattr(Bounded, _name, _binop(_name))
Bounded.__neg__ = lambda self: self._wrap(-int(self))


def test_datasheet_example_and_its_floor_division():
    out = [0, 0]
    assert ms5837.compensate(DATASHEET_C, 4958179, 6815414, out) == OK
    assert out == [39998, 1981]  # C-style truncation would give TEMP 1982
    # the datasheet's formula gives OFF = 2381323464; its example prints 2381326464, a typo
    dt = 6815414 - DATASHEET_C[5] * 256
    assert DATASHEET_C[2] * 2**16 + DATASHEET_C[4] * dt // 2**7 == 2381323464


def _cases(n, seed):
    rng = random.Random(seed)
    cases = [(DATASHEET_C, 4958179, 6815414)]
    corners = [0, 1, 0x7FFF, 0x8000, 0xFFFF]
    for _ in range(n):
        c = [0] + [rng.choice(corners) if rng.random() < 0.3 else rng.randint(1, 0xFFFF) for _ in range(6)]
        d1 = rng.choice([0, 1, 1 << 23, 0xFFFFFF]) if rng.random() < 0.3 else rng.randint(0, 0xFFFFFF)
        d2 = rng.choice([0, 1, 1 << 23, 0xFFFFFF]) if rng.random() < 0.3 else rng.randint(0, 0xFFFFFF)
        cases.append((c, d1, d2))
    # real sensors: datasheet PROM, every temperature branch, pressure across 0..30 bar
    c = DATASHEET_C
    for temp_dt in range(-2_000_000, 2_000_001, 40_000):
        d2 = c[5] * 256 + temp_dt
        for d1 in range(0, 1 << 24, 1 << 19):
            cases.append((c, d1, d2))
    return cases


def test_compensation_is_exact_and_never_needs_a_big_integer():
    Bounded.seen = 0
    in_range = 0
    for c, d1, d2 in _cases(3000, seed=1):
        want = reference(c, d1, d2)
        out = [None, None]
        got = ms5837.compensate([Bounded(x) for x in c], Bounded(d1), Bounded(d2), out)
        assert got == want[0], (c, d1, d2)
        if got == OK:
            in_range += 1
            assert out == [want[1], want[2]], (c, d1, d2)
    assert in_range > 1000          # the exact-result branch really ran
    assert Bounded.seen > 1 << 27   # and came near the bound it is tested against


def test_every_corner_of_the_input_space_stays_small():
    # All PROM words and conversions at their extremes (any chip, any reading).
    Bounded.seen = 0
    words = (1, 0x8000, 0xFFFF)
    conv = (0, 1 << 12, 0x800000, 0xFFFFFF)
    import itertools
    for c in itertools.product(words, repeat=6):
        for d1 in conv:
            for d2 in conv:
                out = [None, None]
                ms5837.compensate([0] + [Bounded(x) for x in c], Bounded(d1), Bounded(d2), out)


def test_crc4_is_the_datasheets_routine():
    def datasheet_crc4(n_prom):
        # literal transcription of the datasheet's C, unsigned int n_rem
        n_prom = list(n_prom)
        n_rem = 0
        n_prom[0] = n_prom[0] & 0x0FFF
        n_prom[7] = 0
        for cnt in range(16):
            if cnt % 2 == 1:
                n_rem ^= n_prom[cnt >> 1] & 0x00FF
            else:
                n_rem ^= n_prom[cnt >> 1] >> 8
            for _ in range(8):
                if n_rem & 0x8000:
                    n_rem = ((n_rem << 1) ^ 0x3000) & 0xFFFFFFFF
                else:
                    n_rem = (n_rem << 1) & 0xFFFFFFFF
        return (n_rem >> 12) & 0x000F

    from roboray.sim.twin.board import ms5837_device

    rng = random.Random(2)
    for _ in range(300):
        words = [rng.randint(0, 0xFFFF) for _ in range(8)]
        assert ms5837.crc4(words) == datasheet_crc4(words) == ms5837_device.crc4(words)
    prom = ms5837_device.prom_words(DATASHEET_C[1:])
    assert prom[0] >> 12 == datasheet_crc4(prom)
    assert (prom[0] >> 5) & 0x7F == 0x1A


# ------------------------------------------------------------ on MicroPython
@pytest.fixture(scope="module")
def board():
    mp = twin.interpreter()
    yield mp
    mp.close()


@pytest.fixture
def mp(board):
    twin.reset(board)
    board.exec(
        "import machine, time\n"
        "from array import array\n"
        "from roboray.sim.twin.board import vclock, i2c_device\n"
        "from roboray.sim.twin.board.ms5837_device import MS5837Device\n"
        "from roboray.firmware.drivers import ms5837, health\n"
        "i2c = machine.I2C(0, sda=machine.Pin(4), scl=machine.Pin(5))\n"
        "dev = MS5837Device()\n"
        "def tick(n=1):\n"
        "    fresh = 0\n"
        "    for _ in range(n):\n"
        "        vclock.advance(20000)\n"
        "        fresh += drv.update()\n"
        "    return fresh\n"
    )
    return board




@pytest.mark.micropython
def test_this_interpreter_has_the_boards_small_integers(mp):
    # Zero bytes below only proves "no big integer" if 2**30 is big here too.
    assert mp.alloc_bytes("x = a * b", "a = 1 << 20\nb = 1 << 10") > 0
    assert mp.alloc_bytes("x = a * b", "a = 1 << 20\nb = 1 << 9") == 0


@pytest.mark.micropython
def test_datasheet_example_on_micropython_allocates_nothing(mp):
    mp.exec("c = array('l', %r)\nout = array('l', [0, 0])" % DATASHEET_C)
    assert mp.eval("ms5837.compensate(c, 4958179, 6815414, out)") == OK
    assert mp.eval("list(out)") == [39998, 1981]
    assert mp.alloc_bytes("ms5837.compensate(c, 4958179, 6815414, out)") == 0


@pytest.mark.micropython
def test_micropython_agrees_with_the_reference_with_zero_heap_over_the_input_space(mp):
    cases = _cases(400, seed=3)[:900]
    flat = [x for c, d1, d2 in cases for x in (*c[1:], d1, d2)]
    mp.write_file("/tmp/ms5837_cases.bin", struct.pack("<%di" % len(flat), *flat))
    mp.exec(
        "cases = array('i', open('/tmp/ms5837_cases.bin', 'rb').read())\n"
        "res = array('l', [0] * %d)\n"
        "o = array('l', [0, 0])\n"
        "c = array('l', [0] * 7)\n"
        "def run_all():\n"
        "    for k in range(%d):\n"
        "        for j in range(6):\n"
        "            c[1 + j] = cases[8 * k + j]\n"
        "        e = ms5837.compensate(c, cases[8 * k + 6], cases[8 * k + 7], o)\n"
        "        res[3 * k] = e\n"
        "        res[3 * k + 1] = o[0]\n"
        "        res[3 * k + 2] = o[1]\n" % (3 * len(cases), len(cases))
    )
    assert mp.alloc_bytes("run_all()") == 0
    res = mp.eval("list(res)")
    exact = 0
    for k, (c, d1, d2) in enumerate(cases):
        err, p, temp = reference(c, d1, d2)
        assert res[3 * k] == err, (c, d1, d2)
        if err == OK:
            exact += 1
            assert res[3 * k + 1:3 * k + 3] == [p, temp], (c, d1, d2)
    assert exact > 150


@pytest.mark.micropython
def test_driver_reads_the_emulated_sensor_at_25_hz(mp):
    mp.exec("machine.twin.attach(0, dev)\ndev.set(250000.0, 12.34)\ndrv = ms5837.MS5837(i2c)")
    assert mp.eval("drv.version") == 0x1A
    assert mp.eval("list(drv.prom)") == list(__import__(
        "roboray.sim.twin.board.ms5837_device", fromlist=["x"]).prom_words(DATASHEET_C[1:]))
    fresh = mp.eval("tick(50)")  # one second of 20 ms ticks
    assert fresh == 24           # the first pair has no temperature yet
    assert abs(mp.eval("drv.pressure_pa") - 250000) <= 10
    assert abs(mp.eval("drv.temp_cc") - 1234) <= 1
    assert mp.eval("drv.health.healthy()") is True
    assert mp.eval("drv.health.errors") == 0
    # a new pressure reaches the driver within two ticks (40 ms)
    mp.exec("dev.set(260000.0, 12.34)")
    assert mp.eval("tick(2)") == 1
    assert abs(mp.eval("drv.pressure_pa") - 260000) <= 10
    assert mp.eval("dev.zero_reads") == 0
    assert mp.alloc_bytes("tick(1)") == 0


@pytest.mark.micropython
def test_called_early_the_driver_waits_instead_of_reading(mp):
    mp.exec("machine.twin.attach(0, dev)\ndrv = ms5837.MS5837(i2c)\ntick(4)\nn = dev.conversions")
    mp.exec("vclock.advance(5000)\nr = drv.update()")  # 5 ms into an 18 ms conversion
    assert mp.eval("r") is False
    assert mp.eval("dev.conversions == n and dev.zero_reads == 0") is True
    assert mp.eval("drv.health.errors") == 0


@pytest.mark.micropython
def test_conversion_read_too_early_is_an_error_then_recovers(mp):
    # A driver that believes conversions take 5 ms reads the chip too early:
    # the chip answers 0 and the driver must notice, not report 0 Pa.
    mp.exec("machine.twin.attach(0, dev)\ndev.set(200000.0, 20.0)\ndrv = ms5837.MS5837(i2c)\n"
            "tick(10)\np = drv.pressure_pa\ndrv.conversion_us = 5000\n"
            "vclock.advance(6000)\nr = drv.update()")
    assert mp.eval("r") is False
    assert mp.eval("dev.zero_reads") == 1
    assert mp.eval("drv.health.last_error") == ERR_NOT_READY
    assert mp.eval("drv.pressure_pa == p") is True
    mp.exec("drv.conversion_us = 18080\ntick(6)")
    assert mp.eval("drv.health.consecutive") == 0
    assert abs(mp.eval("drv.pressure_pa") - 200000) <= 10


@pytest.mark.micropython
def test_missing_sensor_is_named_by_address(mp):
    with pytest.raises(Exception) as info:
        mp.exec("ms5837.MS5837(i2c)")
    assert "OSError" in str(info.value)
    assert "0x76" in str(info.value) and "no answer" in str(info.value)


@pytest.mark.micropython
def test_prom_crc_mismatch_refuses_the_sensor(mp):
    mp.exec("machine.twin.attach(0, dev)\ndev.corrupt_prom()")
    with pytest.raises(Exception) as info:
        mp.exec("ms5837.MS5837(i2c)")
    text = str(info.value)
    assert "OSError" in text and "0x76" in text and "CRC mismatch" in text


@pytest.mark.micropython
def test_a_02ba_is_refused(mp):
    mp.exec("machine.twin.detach(0, 0x76)\nmachine.twin.attach(0, MS5837Device(version=0x15))")
    with pytest.raises(Exception) as info:
        mp.exec("ms5837.MS5837(i2c)")
    assert "02BA" in str(info.value)


@pytest.mark.micropython
def test_nack_at_runtime_is_a_bus_error_and_the_driver_recovers(mp):
    mp.exec("machine.twin.attach(0, dev)\ndev.set(150000.0, 18.0)\ndrv = ms5837.MS5837(i2c)\ntick(10)\n"
            "dev.set_fault(i2c_device.FAULT_NACK)\ntick(15)")
    assert mp.eval("drv.health.last_error") == ERR_BUS
    assert mp.eval("drv.health.counts[%d] >= 10" % ERR_BUS) is True
    assert mp.eval("drv.health.healthy()") is False   # 300 ms without a sample
    mp.exec("dev.set_fault(i2c_device.FAULT_NONE)\ntick(6)")
    assert mp.eval("drv.health.healthy()") is True
    assert abs(mp.eval("drv.pressure_pa") - 150000) <= 10


@pytest.mark.micropython
def test_garbage_is_caught_as_impossible_or_unready_values(mp):
    mp.exec("machine.twin.attach(0, dev)\ndrv = ms5837.MS5837(i2c)\ntick(10)\n"
            "dev.set_fault(i2c_device.FAULT_GARBAGE)\ntick(100)")
    assert mp.eval("drv.health.counts[%d] + drv.health.counts[%d]" % (ERR_RANGE, ERR_NOT_READY)) > 0
    # whatever got through is still a number the part could report
    assert 0 <= mp.eval("drv.pressure_pa") <= 4000000


@pytest.mark.micropython
def test_a_still_reading_is_not_a_failure(mp):
    # Resting on the bottom, or a stuck front end: the same value for
    # minutes is not a fault by itself (ArduSub's false depth errors).
    mp.exec("machine.twin.attach(0, dev)\ndev.set(180000.0, 10.0)\ndrv = ms5837.MS5837(i2c)\n"
            "dev.set_fault(i2c_device.FAULT_STICK)\ndev.set(190000.0, 11.0)\ntick(3000)")
    assert mp.eval("drv.health.healthy()") is True
    assert mp.eval("drv.health.errors") == 0
    assert abs(mp.eval("drv.pressure_pa") - 180000) <= 10
