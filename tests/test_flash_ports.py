"""``--port auto`` picks the board from pyserial's real port descriptions."""

from __future__ import annotations

import pytest
from serial.tools.list_ports_common import ListPortInfo

from roboray.tools.flash.errors import NoBoardFound
from roboray.tools.flash.ports import RASPBERRY_PI_VID, pick


def port(device, vid=None, pid=None, product=None, serial_number=None):
    p = ListPortInfo(device, skip_link_detection=True)
    p.vid, p.pid, p.product, p.serial_number = vid, pid, product, serial_number
    return p


FTDI = port("/dev/ttyUSB0", 0x0403, 0x6015, "FT231X USB UART", "D30A1B2C")
PICO2 = port("/dev/ttyACM0", RASPBERRY_PI_VID, 0x0005, "Board in FS mode", "E6614C311B7A8F2A")
PICO2_B = port("/dev/ttyACM1", RASPBERRY_PI_VID, 0x0005, "Board in FS mode", "E6614C311B7A0001")
NO_USB = port("/dev/ttyS0")


def test_an_explicit_port_is_used_as_given():
    assert pick("/dev/pts/7", ports=[PICO2]) == "/dev/pts/7"


def test_the_one_raspberry_pi_port_is_picked_and_named(caplog):
    caplog.set_level("INFO", logger="roboray.flash")
    assert pick("auto", ports=[NO_USB, FTDI, PICO2]) == "/dev/ttyACM0"
    assert "using /dev/ttyACM0 Board in FS mode [2e8a:0005] serial E6614C311B7A8F2A" in caplog.text


def test_no_board_is_a_one_line_error():
    with pytest.raises(NoBoardFound) as info:
        pick("auto", ports=[NO_USB, FTDI])
    assert str(info.value).startswith("no board found: no serial port has the Raspberry Pi USB vendor id 2e8a")
    assert "\n" not in str(info.value)


def test_several_boards_are_listed_and_none_chosen():
    with pytest.raises(NoBoardFound) as info:
        pick("auto", ports=[PICO2_B, FTDI, PICO2])
    text = str(info.value)
    assert text.startswith("2 boards found, choose one with --port: /dev/ttyACM0 ")
    assert "/dev/ttyACM1 Board in FS mode [2e8a:0005] serial E6614C311B7A0001" in text
    assert "ttyUSB0" not in text and "\n" not in text
