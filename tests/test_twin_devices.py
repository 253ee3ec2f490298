"""The emulated sensors at register level: what a driver meets on the bus."""

from __future__ import annotations

import pytest

from roboray.sim import twin
from roboray.sim.twin.board import ms5837_device

pytestmark = pytest.mark.micropython

C = [0] + list(ms5837_device.DATASHEET_PROM)


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
        "from roboray.sim.twin.board import vclock, i2c_device\n"
        "from roboray.sim.twin.board.ms5837_device import MS5837Device, crc4\n"
        "from roboray.sim.twin.board.lsm6dsox_device import LSM6DSOXDevice\n"
        "from roboray.sim.twin.board.lis3mdl_device import LIS3MDLDevice\n"
        "i2c = machine.I2C(0, sda=machine.Pin(4), scl=machine.Pin(5))\n"
        "def adc():\n"
        "    b = i2c.readfrom_mem(0x76, 0x00, 3)\n"
        "    return (b[0] << 16) | (b[1] << 8) | b[2]\n"
        "def reg(addr, r, n=1):\n"
        "    return list(i2c.readfrom_mem(addr, r, n))\n"
        "def put(addr, r, v):\n"
        "    i2c.writeto_mem(addr, r, bytes([v]))\n"
    )
    return board


# ------------------------------------------------------------------ MS5837
def test_ms5837_prom_carries_the_datasheet_coefficients_and_a_valid_crc(mp):
    mp.exec("d = machine.twin.attach(0, MS5837Device())\n"
            "words = [int.from_bytes(i2c.readfrom_mem(0x76, 0xA0 + 2 * i, 2), 'big') for i in range(7)] + [0]")
    words = mp.eval("words")
    assert words[1:7] == C[1:]
    assert words[0] >> 12 == ms5837_device.crc4(words)
    mp.exec("d.corrupt_prom()\nw1 = int.from_bytes(i2c.readfrom_mem(0x76, 0xA2, 2), 'big')")
    assert mp.eval("w1") == C[1] ^ 1


@pytest.mark.parametrize("cmd, us", [(0x40, 600), (0x44, 2280), (0x48, 9040), (0x4A, 18080), (0x5A, 18080)])
def test_ms5837_conversion_takes_its_datasheet_time(mp, cmd, us):
    mp.exec("d = machine.twin.attach(0, MS5837Device())\ni2c.writeto(0x76, bytes([%d]))\n"
            "time.sleep_us(%d)\nearly = adc()" % (cmd, us - 1))
    assert mp.eval("early") == 0                     # read during the conversion: 0
    # (that read spoiled the conversion, as the datasheet warns: let it end)
    mp.exec("time.sleep_us(1)\nspoiled = adc()\n"
            "i2c.writeto(0x76, bytes([%d]))\ntime.sleep_us(%d)\nv = adc()" % (cmd, us))
    want = mp.eval("d.d1" if cmd < 0x50 else "d.d2")
    assert mp.eval("spoiled") not in (0, want)
    assert mp.eval("v") == want
    assert mp.eval("adc()") == 0                     # a second read of one result: 0


def test_ms5837_read_during_a_conversion_spoils_its_result(mp):
    mp.exec("d = machine.twin.attach(0, MS5837Device())\ni2c.writeto(0x76, b'\\x4a')\n"
            "time.sleep_ms(5)\nz = adc()\ntime.sleep_ms(20)\nv = adc()")
    assert mp.eval("z") == 0
    assert mp.eval("v != d.d1 and v != 0") is True


def test_ms5837_reset_reloads_the_prom_without_answering_for_2_8_ms(mp):
    mp.exec("machine.twin.attach(0, MS5837Device())\ni2c.writeto(0x76, b'\\x1e')")
    assert mp.eval("i2c.scan()") == []
    mp.exec("time.sleep_us(2800)")
    assert mp.eval("i2c.scan()") == [0x76]


def test_ms5837_inverse_gives_back_pressure_and_temperature_over_its_range(mp):
    # Whatever the twin sets, the datasheet formula on D1/D2 returns it to the
    # nearest code: 0.1 mbar and 0.01 C, across -20..85 C and 0..30 bar.
    cases = [(p, t) for t in (-20.0, -15.5, 0.0, 12.34, 19.99, 20.0, 40.0, 85.0)
             for p in (0.0, 101325.0, 250000.0, 1000000.0, 2999000.0)]
    mp.exec("d = MS5837Device()\nres = []\n"
            "for p, t in %r:\n    d.set(p, t)\n    res.append((d.d1, d.d2))" % (cases,))
    for (p, t), (d1, d2) in zip(cases, mp.eval("res")):
        got_p, got_t = ms5837_device.compensate(C, d1, d2)
        assert abs(got_p - p / 10) <= 0.5 + 1e-9, (p, t)
        assert abs(got_t - t * 100) <= 1, (p, t)


def test_ms5837_stick_freezes_conversions(mp):
    mp.exec("d = machine.twin.attach(0, MS5837Device())\nd.set(200000.0, 15.0)\nd1 = d.d1\n"
            "d.set_fault(i2c_device.FAULT_STICK)\nd.set(300000.0, 15.0)\n"
            "i2c.writeto(0x76, b'\\x4a')\ntime.sleep_ms(19)\nv = adc()")
    assert mp.eval("v == d1 and d.d1 != d1") is True


# ---------------------------------------------------------------- LSM6DSOX
def test_lsm6dsox_powers_up_off_and_samples_at_its_odr(mp):
    mp.exec("d = machine.twin.attach(0, LSM6DSOXDevice())\nd.set_accel(0.0, 0.0, 9.80665)\ntime.sleep_ms(50)")
    assert mp.eval("reg(0x6A, 0x0F)") == [0x6C]
    assert mp.eval("reg(0x6A, 0x1E, 16)") == [0] * 16   # ODR 0: nothing, ever
    mp.exec("put(0x6A, 0x10, 0x58)\ntime.sleep_us(4807)")
    assert mp.eval("reg(0x6A, 0x1E)") == [0]
    mp.exec("time.sleep_us(1)")
    assert mp.eval("reg(0x6A, 0x1E)") == [0x05]         # XLDA and TDA at 1/208 s
    az = mp.eval("reg(0x6A, 0x2C, 2)")
    assert az[0] | az[1] << 8 == round(1000 / 0.122)     # 1 g at 0.122 mg/LSB
    assert mp.eval("reg(0x6A, 0x1E)") == [0x04]         # reading the accel cleared XLDA


def test_lsm6dsox_auto_increment_follows_if_inc(mp):
    mp.exec("machine.twin.attach(0, LSM6DSOXDevice())\nput(0x6A, 0x12, 0x00)")
    assert mp.eval("reg(0x6A, 0x0F, 3)") == [0x6C, 0x6C, 0x6C]
    mp.exec("put(0x6A, 0x12, 0x04)")
    assert mp.eval("reg(0x6A, 0x0F, 2)") == [0x6C, 0x00]


def test_lsm6dsox_sw_reset_restores_defaults_and_read_only_registers_stay(mp):
    mp.exec("machine.twin.attach(0, LSM6DSOXDevice())\nput(0x6A, 0x10, 0x58)\nput(0x6A, 0x0F, 0x00)\n"
            "put(0x6A, 0x12, 0x45)")
    assert mp.eval("reg(0x6A, 0x0F)") == [0x6C]
    assert mp.eval("reg(0x6A, 0x10, 3)") == [0x00, 0x00, 0x04]


def test_lsm6dsox_full_scale_sets_the_counts(mp):
    mp.exec("d = machine.twin.attach(0, LSM6DSOXDevice())\nd.set_accel(9.80665, 0.0, 0.0)\n"
            "put(0x6A, 0x10, 0x50)\ntime.sleep_ms(5)\na2 = reg(0x6A, 0x28, 2)\n"
            "put(0x6A, 0x10, 0x5C)\ntime.sleep_ms(5)\na8 = reg(0x6A, 0x28, 2)")
    assert mp.eval("a2[0] | a2[1] << 8") == round(1000 / 0.061)
    assert mp.eval("a8[0] | a8[1] << 8") == round(1000 / 0.244)


# ------------------------------------------------------------------ LIS3MDL
def test_lis3mdl_increments_only_with_bit_7_of_the_subaddress(mp):
    mp.exec("machine.twin.attach(0, LIS3MDLDevice())")
    assert mp.eval("reg(0x1C, 0x20, 3)") == [0x10, 0x10, 0x10]
    assert mp.eval("reg(0x1C, 0x20 | 0x80, 3)") == [0x10, 0x00, 0x03]


def test_lis3mdl_rates_modes_and_byte_order(mp):
    mp.exec("d = machine.twin.attach(0, LIS3MDLDevice())\nd.set_field(0.5, 0.0, 0.0)\n"
            "put(0x1C, 0x20, 0x1C)\nput(0x1C, 0x22, 0x00)\ntime.sleep_us(12499)")  # 80 Hz, continuous
    assert mp.eval("reg(0x1C, 0x27)") == [0x00]
    mp.exec("time.sleep_us(1)")
    assert mp.eval("reg(0x1C, 0x27)") == [0x0F]
    assert mp.eval("reg(0x1C, 0x28 | 0x80, 2)") == [3421 & 0xFF, 3421 >> 8]   # 0.5 G at 6842 LSB/G
    mp.exec("put(0x1C, 0x23, 0x02)\ntime.sleep_us(12500)")                     # BLE: big-endian
    assert mp.eval("reg(0x1C, 0x28 | 0x80, 2)") == [3421 >> 8, 3421 & 0xFF]
    mp.exec("time.sleep_us(25000)")                                          # two samples, none read
    assert mp.eval("reg(0x1C, 0x27)") == [0xFF]                              # overrun flagged
    mp.exec("put(0x1C, 0x22, 0x01)\ntime.sleep_us(12500)")                   # single conversion
    assert mp.eval("reg(0x1C, 0x22)") == [0x03]                              # then idle


def test_lis3mdl_soft_reset(mp):
    mp.exec("machine.twin.attach(0, LIS3MDLDevice())\nput(0x1C, 0x20, 0xE2)\nput(0x1C, 0x21, 0x04)")
    assert mp.eval("reg(0x1C, 0x20 | 0x80, 3)") == [0x10, 0x00, 0x03]


# ------------------------------------------------------------------- faults
def test_faults_nack_garbage_and_recovery(mp):
    mp.exec("d = machine.twin.attach(0, LSM6DSOXDevice())\nd.set_fault(i2c_device.FAULT_NACK)")
    assert mp.eval("i2c.scan()") == []
    mp.exec("d.set_fault(i2c_device.FAULT_GARBAGE)\ng1 = reg(0x6A, 0x0F, 8)\ng2 = reg(0x6A, 0x0F, 8)")
    assert mp.eval("g1 != g2 and len(set(g1)) > 4") is True
    mp.exec("d.set_fault(i2c_device.FAULT_NONE)")
    assert mp.eval("reg(0x6A, 0x0F)") == [0x6C]
    raises_unknown = "d.set_fault(9)"
    with pytest.raises(Exception, match="unknown fault"):
        mp.exec(raises_unknown)


def test_reading_an_emulated_device_allocates_nothing(mp):
    mp.exec("machine.twin.attach(0, LSM6DSOXDevice())\nmachine.twin.attach(0, MS5837Device())\n"
            "put(0x6A, 0x10, 0x58)\nbuf = bytearray(16)\nw = bytearray(2)\ncmd = bytearray(b'\\x4a')")
    assert mp.alloc_bytes("time.sleep_ms(5); i2c.readfrom_mem_into(0x6A, 0x1E, buf)") == 0
    assert mp.alloc_bytes("i2c.writeto(0x76, cmd); i2c.readfrom_mem_into(0x76, 0xA2, w)") == 0
    # with the part's own noise on, too (rigs at rest)
    mp.exec("machine.twin.devices(0)[0x6A].set_noise(3)")
    assert mp.alloc_bytes("time.sleep_ms(5); i2c.readfrom_mem_into(0x6A, 0x1E, buf)") == 0


# ------------------------------------------- what the fast paths must keep
_REF_S16 = (
    "def ref_s16(x):\n"
    "    v = int(x + 0.5) if x >= 0 else -int(-x + 0.5)\n"
    "    return max(-32768, min(32767, v))\n"
    "def s16(lo, hi):\n"
    "    v = lo | hi << 8\n"
    "    return v - 65536 if v & 0x8000 else v\n"
)


def _awkward_values(lsb_expr, n=30):
    # halves of a code (either sign), zeros of both signs, saturation, noise
    import random
    rnd = random.Random(7)
    vals = ["0.0", "-0.0", "1e9", "-1e9", "%s * 32767.5" % lsb_expr, "-%s * 32768.5" % lsb_expr]
    vals += ["%s * %r" % (lsb_expr, k + 0.5) for k in (-3, -2, -1, 0, 1, 2, 100)]
    vals += [repr(rnd.uniform(-40.0, 40.0)) for _ in range(n)]
    return vals


def test_lsm6dsox_outputs_round_half_away_from_zero_and_clip(mp):
    mp.exec(_REF_S16 + "d = machine.twin.attach(0, LSM6DSOXDevice())\nput(0x6A, 0x10, 0x58)\n"
            "put(0x6A, 0x11, 0x54)\nbad = []\n")
    for fs_xl, fs_g in ((0x58, 0x54), (0x5C, 0x5E), (0x50, 0x56)):
        mp.exec("put(0x6A, 0x10, %d)\nput(0x6A, 0x11, %d)" % (fs_xl, fs_g))
        vals = _awkward_values("d.accel_lsb()")
        mp.exec("vals = [%s]\n" % ", ".join(vals) +
                "for i in range(len(vals)):\n"
                "    m = [vals[(i + k) % len(vals)] for k in range(6)]\n"
                "    d.set_motion(*m)\n"
                "    time.sleep_ms(5)\n"
                "    r = reg(0x6A, 0x22, 12)\n"
                "    got = [s16(r[2 * k], r[2 * k + 1]) for k in range(6)]\n"
                "    want = [ref_s16(m[3 + k] / d.gyro_lsb()) for k in range(3)]\n"
                "    want += [ref_s16(m[k] / d.accel_lsb()) for k in range(3)]\n"
                "    if got != want:\n"
                "        bad.append((m, got, want))\n")
    assert mp.eval("bad") == []
    # set_accel, set_gyro and set_temperature keep what the other set
    mp.exec("d.set_motion(1.0, -2.0, 9.0, 0.1, -0.2, 0.3)\nd.set_gyro(0.5, 0.0, -0.5)\nd.set_temperature(30.0)\n"
            "time.sleep_ms(5)\nr = reg(0x6A, 0x20, 14)\n"
            "got = [s16(r[2 * k], r[2 * k + 1]) for k in range(7)]")
    assert mp.eval("got == [ref_s16(5.0 * 256)] + [ref_s16(v / d.gyro_lsb()) for v in (0.5, 0.0, -0.5)]"
                   " + [ref_s16(v / d.accel_lsb()) for v in (1.0, -2.0, 9.0)]") is True


def test_lis3mdl_outputs_round_half_away_from_zero_and_clip_in_both_byte_orders(mp):
    mp.exec(_REF_S16 + "d = machine.twin.attach(0, LIS3MDLDevice())\nput(0x1C, 0x20, 0x9C)\n"
            "put(0x1C, 0x22, 0x00)\nbad = []\n")
    for fs in (0x00, 0x20, 0x60):
        vals = _awkward_values("(1 / d.lsb_per_gauss())")
        mp.exec("put(0x1C, 0x21, %d)\nvals = [%s]\n" % (fs, ", ".join(vals)) +
                "for i in range(len(vals)):\n"
                "    b = [vals[(i + k) % len(vals)] for k in range(3)]\n"
                "    d.set_field(*b)\n"
                "    want = [ref_s16(v * d.lsb_per_gauss()) for v in b]\n"
                "    for ble in (0x00, 0x02):\n"
                "        put(0x1C, 0x23, ble)\n"
                "        time.sleep_ms(13)\n"
                "        r = reg(0x1C, 0x28 | 0x80, 6)\n"
                "        if ble:\n"
                "            r = [r[k ^ 1] for k in range(6)]\n"
                "        got = [s16(r[2 * k], r[2 * k + 1]) for k in range(3)]\n"
                "        if got != want:\n"
                "            bad.append((b, ble, got, want))\n")
    assert mp.eval("bad") == []
    mp.exec("put(0x1C, 0x23, 0x00)\nd.set_temperature(31.0)\ntime.sleep_ms(13)\nr = reg(0x1C, 0x2E | 0x80, 2)")
    assert mp.eval("s16(r[0], r[1])") == 48


def test_register_reads_by_burst_wrap_and_repeat_read_the_registers(mp):
    # The cached bursts, the first reads, wrap-around and repeated registers
    # all read what the register file holds, and move the pointer as the chip.
    mp.exec("d = machine.twin.attach(0, LSM6DSOXDevice())\nput(0x6A, 0x10, 0x58)\nput(0x6A, 0x11, 0x54)\n"
            "d.set_motion(1.0, -2.0, 9.0, 0.1, -0.2, 0.3)\ntime.sleep_ms(5)\nreg(0x6A, 0x1E, 2)\n"
            "put(0x6A, 0x10, 0x00)\nput(0x6A, 0x11, 0x00)\n"      # a sample latched, then stopped
            "d.regs[0x7F] = 0xCD\nsnap = list(d.regs)")
    # (0x78-0x7E are the FIFO's output, tested with the FIFO; 0x7F wraps to 0x00)
    for first, n in ((0x22, 12), (0x22, 12), (0x28, 6), (0x7F, 3), (0x7F, 3), (0x0F, 1), (0x11, 2), (0x11, 2)):
        assert mp.eval("reg(0x6A, %d, %d)" % (first, n)) == [
            mp.eval("snap[%d]" % ((first + i) & 0x7F)) for i in range(n)], (first, n)
    assert mp.eval("snap[0x22:0x2E] != [0] * 12") is True
    mp.exec("b1 = bytearray(2)\nb2 = bytearray(2)\n"
            "i2c.readfrom_mem_into(0x6A, 0x0F, b1)\ni2c.readfrom_into(0x6A, b2)")
    assert mp.eval("[list(b1), list(b2)]") == [[0x6C, 0x00], [0x00, 0x04]]   # read on from 0x11
    mp.exec("put(0x6A, 0x12, 0x40)")                                        # IF_INC off
    assert mp.eval("reg(0x6A, 0x12, 3)") == [0x40, 0x40, 0x40]
    mp.exec("put(0x6A, 0x12, 0x44)")
    assert mp.eval("reg(0x6A, 0x12, 3)") == [0x44, 0x00, 0x00]


def test_a_device_that_does_not_answer_nacks_every_transfer(mp):
    mp.exec("imu = machine.twin.attach(0, LSM6DSOXDevice())\nmag = machine.twin.attach(0, LIS3MDLDevice())\n"
            "ms = machine.twin.attach(0, MS5837Device())\nb = bytearray(3)\n")
    calls = ("i2c.readfrom_mem_into(%d, 0x0F, b)", "i2c.readfrom_into(%d, b)", "i2c.readfrom_mem(%d, 0x0F, 2)",
             "i2c.readfrom(%d, 2)", "i2c.writeto(%d, b'\\x0f')", "i2c.writeto(%d, b'')",
             "i2c.writeto_mem(%d, 0x10, b'\\x00')", "i2c.writevto(%d, (b'\\x0f', b'\\x00'))")
    for dev, addr in (("imu", 0x6A), ("mag", 0x1C), ("ms", 0x76)):
        mp.exec("%s.set_fault(i2c_device.FAULT_NACK)\nn0 = %s.transfers" % (dev, dev))
        for call in calls:
            with pytest.raises(Exception, match=r"OSError: \[Errno 5\] EIO"):
                mp.exec(call % addr)
        assert mp.eval("%s.transfers == n0" % dev) is True
        mp.exec("%s.set_fault(i2c_device.FAULT_NONE)" % dev)
    assert mp.eval("i2c.scan()") == [0x1C, 0x6A, 0x76]
    mp.exec("i2c.writeto(0x76, b'\\x1e')")   # reset: the PROM reloads for 2.8 ms
    for call in calls:
        with pytest.raises(Exception, match=r"OSError: \[Errno 5\] EIO"):
            mp.exec(call % 0x76)
    mp.exec("time.sleep_us(2800)\ni2c.readfrom_mem_into(0x76, 0xA2, b)")
    assert mp.eval("list(b)") == [C[1] >> 8, C[1] & 0xFF, 0]


def test_ms5837_adc_read_gives_the_same_bytes_whatever_the_buffer(mp):
    mp.exec("d = machine.twin.attach(0, MS5837Device())\nd.set(123456.0, 17.5)\nb3 = bytearray(3)\n"
            "b5 = bytearray(5)\n"
            "i2c.writeto(0x76, b'\\x4a')\ntime.sleep_ms(19)\ni2c.readfrom_mem_into(0x76, 0x00, b3)\n"
            "i2c.writeto(0x76, b'\\x4a')\ntime.sleep_ms(19)\ni2c.readfrom_mem_into(0x76, 0x00, b5)\n"
            "i2c.readfrom_mem_into(0x76, 0x00, b3)\nagain = list(b3)")
    d1 = mp.eval("d.d1")
    assert mp.eval("list(b5)") == [d1 >> 16, (d1 >> 8) & 0xFF, d1 & 0xFF, 0, 0]
    assert mp.eval("again") == [0, 0, 0]
    mp.exec("d.set_fault(i2c_device.FAULT_GARBAGE)\ni2c.writeto(0x76, b'\\x4a')\ntime.sleep_ms(19)\n"
            "i2c.readfrom_mem_into(0x76, 0x00, b3)\ng = list(b3)\nd.set_fault(i2c_device.FAULT_NONE)\n"
            "i2c.writeto(0x76, b'\\x4a')\ntime.sleep_ms(19)\ni2c.readfrom_mem_into(0x76, 0x00, b3)")
    assert mp.eval("g") != [d1 >> 16, (d1 >> 8) & 0xFF, d1 & 0xFF]
    assert mp.eval("list(b3)") == [d1 >> 16, (d1 >> 8) & 0xFF, d1 & 0xFF]


def test_reading_the_magnetometer_allocates_nothing(mp):
    mp.exec("machine.twin.attach(0, LIS3MDLDevice())\nput(0x1C, 0x20, 0xE2)\nput(0x1C, 0x22, 0x00)\n"
            "buf = bytearray(9)")
    assert mp.alloc_bytes("time.sleep_ms(7); i2c.readfrom_mem_into(0x1C, 0xA7, buf)") == 0
    assert mp.alloc_bytes("time.sleep_ms(7); i2c.readfrom_mem_into(0x1C, 0x27, buf)") == 0
    mp.exec("machine.twin.devices(0)[0x1C].set_noise(3)\nput(0x1C, 0x23, 0x02)")   # noise, big-endian
    assert mp.alloc_bytes("time.sleep_ms(7); i2c.readfrom_mem_into(0x1C, 0xA7, buf)") == 0


def test_a_parts_own_noise_moves_its_counts_around_the_input(mp):
    # set_noise: +-k counts on every output each sample, both byte orders
    mp.exec("d = machine.twin.attach(0, LIS3MDLDevice())\nput(0x1C, 0x20, 0xE2)\nput(0x1C, 0x22, 0x00)\n"
            "import struct\nd.set_field(0.5, -0.25, 0.0)\nd.set_noise(3)\nbuf = bytearray(6)\nseen = []\n"
            "for be in (0, 2):\n"
            "    put(0x1C, 0x23, be)\n"
            "    for _ in range(40):\n"
            "        time.sleep_ms(7)\n"
            "        i2c.readfrom_mem_into(0x1C, 0xA8, buf)\n"
            "        seen.append(struct.unpack('>hhh' if be else '<hhh', buf))\n")
    seen = mp.eval("seen")
    want = (3421, -1711, 0)    # 0.5 and -0.25 gauss at 6842 LSB/gauss, halves away from zero
    for axis in range(3):
        values = [s[axis] for s in seen]
        assert all(abs(v - want[axis]) <= 3 for v in values)
        assert len(set(values)) >= 4     # it moves


def test_lsm6dsox_fifo_batches_tags_counts_and_overruns_as_the_datasheet_says(mp):
    # DS12814 sec. 9: FIFO_CTRL3 BDR_GY/BDR_XL 104 Hz, FIFO_CTRL4 continuous
    # (110); words of a tag (TAG_SENSOR in bits 7:3) and X, Y, Z; FIFO_STATUS1/2
    # DIFF_FIFO, FIFO_OVR_IA (6) and FIFO_OVR_LATCHED (3, cleared by the read)
    mp.exec("d = machine.twin.attach(0, LSM6DSOXDevice())\nput(0x6A, 0x10, 0x48)\nput(0x6A, 0x11, 0x44)\n"
            "put(0x6A, 0x09, 0x44)\nput(0x6A, 0x0A, 0x06)\n"
            "d.set_motion(1.0, -2.0, 9.0, 0.1, -0.2, 0.3)\ntime.sleep_ms(50)\nst = reg(0x6A, 0x3A, 2)")
    n = mp.eval("st[0] | (st[1] & 3) << 8")
    assert n == 10 and mp.eval("st[1] & 0x48") == 0     # 5 periods of 9.615 ms, gyroscope and accelerometer
    words = mp.eval("reg(0x6A, 0x78, 7 * %d)" % n)       # one burst: 0x7E wraps to 0x78
    tags = [words[7 * k] >> 3 for k in range(n)]
    assert tags == [0x01, 0x02] * 5
    s16 = lambda lo, hi: ((lo | hi << 8) ^ 0x8000) - 0x8000   # noqa: E731
    accel = [s16(words[7 * k + 1], words[7 * k + 2]) for k in range(n) if tags[k] == 0x02]
    assert all(abs(a - 1.0 / (0.122e-3 * 9.80665)) <= 1.5 for a in accel)
    assert mp.eval("reg(0x6A, 0x3A, 2)") == [0, 0]                       # read out
    # 3 s in continuous mode overruns the 512 words: the newest kept, the loss flagged once
    mp.exec("time.sleep_ms(3000)")
    st = mp.eval("reg(0x6A, 0x3A, 2)")
    assert (st[0] | (st[1] & 3) << 8) == 512 and st[1] & 0x48 == 0x48
    assert mp.eval("reg(0x6A, 0x3B, 1)")[0] & 0x08 == 0                   # latched bit cleared by the read


def test_lsm6dsox_fifo_words_are_the_mean_of_the_motion_over_their_period(mp):
    # The twin's world moves the input once a 10 ms step; the chip samples at
    # 104 Hz. A word is the mean over its own 9.615 ms, so the sum of the
    # words times the period is the motion's integral (what a stall's
    # backlog must give the estimator), whatever the phase of the two grids.
    mp.exec("d = machine.twin.attach(0, LSM6DSOXDevice())\nput(0x6A, 0x10, 0x48)\nput(0x6A, 0x11, 0x44)\n"
            "put(0x6A, 0x09, 0x04)\nput(0x6A, 0x0A, 0x06)\n"       # the accelerometer alone
            "lsb = d.accel_lsb()\nt0 = time.ticks_us()\nsteps = [0.0, 30.0, -10.0, 0.0, 5.0, 0.0, 0.0, 0.0]\n"
            "for a in steps:\n"
            "    d.set_motion(a, 0.0, 9.80665, 0.0, 0.0, 0.0)\n"
            "    time.sleep_ms(10)\n"
            "d.set_motion(0.0, 0.0, 9.80665, 0.0, 0.0, 0.0)\n"
            "st = reg(0x6A, 0x3A, 2)\nn = st[0]\nw = reg(0x6A, 0x78, 7 * n)\n"
            "xs = [(((w[7 * k + 1] | w[7 * k + 2] << 8) ^ 0x8000) - 0x8000) * lsb for k in range(n)]\n")
    n = mp.eval("n")
    assert n == 8          # 80 ms at 9.615 ms a word
    integral = mp.eval("sum(xs) * 9615e-6")
    # the motion's integral over the words' span: 0.3 - 0.1 + 0.05 = 0.25 m/s
    assert integral == pytest.approx(0.25, abs=0.002)
