"""Radio: the UART transport (its queue for what the UART has no room for), against the emulated UART line."""

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
        "from roboray.sim.twin.board import vclock\n"
        "from roboray.firmware.boards import pico2\n"
        "from roboray.firmware.drivers.radio import Radio\n"
        "line = machine.twin.uart(0)\n"
        "radio = Radio(pico2.uart(machine))\n"
        "buf = bytearray(256)\n"
        "def run(ms):\n"
        "    for _ in range(ms // 10):\n"
        "        vclock.advance(10000)\n"
        "        radio.service()\n"
    )
    return board


def test_bytes_arrive_at_the_line_rate_and_in_order(mp):
    data = bytes(range(200))
    mp.exec("line.feed(%r)" % data)
    # 57600 baud, 8N1: 5760 bytes/s, so 10 ms carries 57 bytes
    mp.exec("run(10)\nn1 = radio.read_into(buf)\nfirst = bytes(buf[:n1])")
    assert 55 <= mp.eval("n1") <= 58
    mp.exec("run(40)\nn2 = radio.read_into(buf)\nrest = bytes(buf[:n2])")
    assert mp.eval("first + rest") == data
    assert mp.eval("radio.read_into(buf)") == 0


def test_frames_go_out_whole_and_paced(mp):
    mp.exec("frame = bytes(range(100))\nn = radio.write(frame)\nrun(10)\nout1 = line.take()")
    assert mp.eval("n") == 100
    assert 55 <= len(mp.eval("out1")) <= 58
    mp.exec("run(20)\nout2 = line.take()")
    assert mp.eval("out1 + out2") == bytes(range(100))
    assert mp.eval("radio.tx_bytes") == 100


def test_a_frame_that_does_not_fit_the_queue_is_dropped_whole(mp):
    # the UART's own buffer takes 32 bytes, the radio's queue 128
    mp.exec("u = machine.UART(0, 57600, tx=machine.Pin(0), rx=machine.Pin(1), txbuf=32)\n"
            "r = Radio(u, tx_size=128)\n"
            "a = r.write(bytes(100))\nb = r.write(bytes(range(70)))")
    assert mp.eval("a") == 100
    assert mp.eval("r.queued()") == 68
    assert mp.eval("b") == 0
    assert mp.eval("[r.tx_dropped_frames, r.tx_dropped_bytes]") == [1, 70]
    mp.exec("for _ in range(10):\n    vclock.advance(10000)\n    r.service()\nout = line.take()")
    assert mp.eval("out") == bytes(100)  # never a piece of the dropped frame


def test_a_reader_takes_at_most_its_buffer_and_the_uart_keeps_the_rest(mp):
    data = bytes(range(200)) + bytes(range(100))
    mp.exec("r = Radio(pico2.uart(machine))\nline.feed(%r)\n"
            "vclock.advance(60000)\nr.service()\nsmall = bytearray(64)" % data)
    # 60 ms brought the 300 bytes to the 1024-byte UART buffer; a read takes 64
    assert mp.eval("r.available()") == 300
    assert mp.eval("r.read_into(small)") == 64
    assert mp.eval("bytes(small)") == data[:64]
    assert mp.eval("r.available()") == 236
    mp.exec("got = bytearray()\nwhile True:\n    n = r.read_into(small)\n    if not n:\n        break\n"
            "    got.extend(small[:n])")
    assert mp.eval("bytes(got)") == data[64:]
    assert mp.eval("[r.rx_bytes, line.rx_dropped]") == [300, 0]


def test_the_line_rate_is_known_for_pacing(mp):
    assert mp.eval("radio.bytes_per_s") == 5760
    assert mp.eval("Radio(pico2.uart(machine), baudrate=115200).bytes_per_s") == 11520


def test_service_read_and_write_allocate_nothing(mp):
    mp.exec("line.feed(bytes(500))\nframe = bytes(40)")
    assert mp.alloc_bytes("vclock.advance(10000); radio.service()") == 0
    assert mp.alloc_bytes("radio.read_into(buf)") == 0
    assert mp.alloc_bytes("radio.write(frame)") == 0
