"""Wing servos: angle to pulse on the emulated PWM, calibration, clamping."""

from __future__ import annotations

import math

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
        "import machine, math\n"
        "from roboray.firmware.boards import pico2\n"
        "from roboray.firmware.drivers.servo import Servo, Wings, PARAMS\n"
        "from roboray.shared.params import ParamTable\n"
        "t = machine.twin\n"
        "pwms = pico2.servo_pwms(machine)\n"
        "def pulses():\n"
        "    return [t.pulse_ns(p) for p in pico2.SERVO_PINS]\n"
    )
    return board


def test_pwm_runs_at_50_hz_on_the_profile_pins_with_no_pulse_yet(mp):
    assert mp.eval("[t.pwm_freq(p) for p in pico2.SERVO_PINS]") == [50] * 4
    assert mp.eval("pulses()") == [0, 0, 0, 0]


@pytest.mark.parametrize("deg, pulse_us", [(0, 1000), (45, 1500), (90, 2000), (30, 1333)])
def test_angle_maps_linearly_onto_the_calibrated_range(mp, deg, pulse_us):
    mp.exec("s = Servo(pwms[0])\nr = s.set_angle(math.radians(%r))" % deg)
    assert mp.eval("r") == pulse_us
    assert abs(mp.eval("t.pulse_ns(10)") - pulse_us * 1000) < 1000


def test_reversed_servo_and_trim(mp):
    mp.exec("s = Servo(pwms[1], 1100, 1900, trim_us=25, reversed=True)")
    assert mp.eval("s.set_angle(0.0)") == 1925
    assert mp.eval("s.set_angle(math.pi / 2)") == 1125
    assert mp.eval("t.pulse_ns(11)") == 1125000


def test_commands_are_clamped_and_nan_keeps_the_last_pulse(mp):
    mp.exec("s = Servo(pwms[2])")
    assert mp.eval("s.set_angle(-1.0)") == 1000
    assert mp.eval("s.set_angle(3.0)") == 2000
    assert mp.eval("s.clamped") == 2
    assert mp.eval("s.set_angle(float('nan'))") == 2000
    assert mp.eval("s.invalid") == 1
    # a trim past the servo's limit cannot push the pulse beyond 2500 us
    mp.exec("s.calibrate(2000, 2500, trim_us=300)")
    assert mp.eval("s.set_angle(math.pi / 2)") == 2500


def test_a_repeated_command_keeps_its_pulse_and_its_counts(mp):
    mp.exec("s = Servo(pwms[3])\nfor a in (0.5, 0.5, 2.0, 2.0, float('nan'), 0.5, 0.5):\n    s.set_angle(a)")
    assert mp.eval("[s.pulse_us, s.clamped, s.invalid]") == [1318, 2, 1]   # clamped each time it was asked
    assert mp.eval("t.pulse_ns(13)") == 1318309
    mp.exec("s.calibrate(1200, 2000)\ns.set_angle(0.5)")                   # the same angle, a new calibration
    assert mp.eval("[s.pulse_us, t.pulse_ns(13) // 1000]") == [1454, 1454]
    mp.exec("s.off()\ns.set_angle(0.5)")                                   # the pulse comes back after off()
    assert mp.eval("[s.pulse_us, t.pulse_ns(13) // 1000]") == [1454, 1454]


@pytest.mark.parametrize("args, message", [
    ("400, 2000", "min_us 400 outside 500..2500"),
    ("1500, 1500", "no travel"),
    ("1000, 2000, 900", "trim_us 900"),
])
def test_bad_calibration_is_refused_by_name(mp, args, message):
    with pytest.raises(Exception, match=message):
        mp.exec("Servo(pwms[0], %s)" % args)


def test_wings_take_calibration_from_parameters_and_hold_safe(mp):
    mp.exec("p = ParamTable(PARAMS)\np.set_by_name('SERVO3_REVERSED', 1)\np.set_by_name('SERVO2_MAX', 1800)\n"
            "w = Wings([Servo(x) for x in pwms], safe=math.radians(45))\nw.configure(p)\nw.hold_safe()")
    assert mp.eval("list(w.pulse_us)") == [1500, 1400, 1500, 1500]
    mp.exec("w.command[2] = 0.0\nw.update()")
    assert mp.eval("pulses()[2]") == 2000000  # reversed: flat is the MAX end
    mp.exec("w.off()")
    assert mp.eval("pulses()") == [0, 0, 0, 0]


def test_an_update_of_four_servos_boxes_two_floats_each(mp):
    mp.exec("w = Wings([Servo(x) for x in pwms])\nw.command[1] = 0.5")
    assert mp.alloc_bytes("w.update()") <= 4 * 2 * 16
