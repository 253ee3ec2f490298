"""RoboRay MicroPython on the host (``tools/roboray_micropython/host/``,
``tools/micropython/roboray_host.py``): the twin's default interpreter.

The committed binary is what the recipe built (its sha256), it is the
board's configuration (floats in the object word, single precision, 32-bit
words: a float costs no heap), it has what the twin uses (``hostlink`` over
pipes, the modules the firmware imports), and it flies the firmware.
"""

from __future__ import annotations

import hashlib
import json
import struct
import subprocess

import pytest

from roboray.tools.micropython import roboray_host

pytestmark = pytest.mark.skipif(not roboray_host.available(),
                                reason="RoboRay MicroPython's host build runs on Linux on x86")


def mp(code: str) -> str:
    proc = subprocess.run(roboray_host.command("-c", code), capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout


def test_the_binary_is_the_one_its_recipe_recorded():
    digest = hashlib.sha256(roboray_host.BINARY.read_bytes()).hexdigest()
    recorded = (roboray_host.HOST_DIR / "micropython-roboray.sha256").read_text().split()
    assert recorded == [digest, "micropython-roboray"]
    build_txt = (roboray_host.HOST_DIR / "BUILD.txt").read_text()
    assert "sha256: " + digest in build_txt
    # the pinned sdist, the same as the emulated RP2350's image
    emu_recipe = (roboray_host.HOST_DIR.parent.parent / "rp2350_emu" / "build.sh").read_text()
    sdist_sha = next(line.split("=")[1] for line in emu_recipe.splitlines() if line.startswith("MP_SHA256="))
    assert sdist_sha in build_txt
    # static: runs where no 32-bit C library is installed
    assert roboray_host.BINARY.read_bytes()[:5] == b"\x7fELF\x01"    # ELF, 32-bit


def test_it_is_the_boards_configuration():
    assert roboray_host.interpreter_build() == {"name": "roboray-unix", "version": roboray_host.version(),
                                                "obj_repr": "C", "float_bits": 32, "word_bits": 32}
    assert roboray_host.version().startswith("1.")
    # a float result costs no heap; a small int is 31 bits (2**30 boxes)
    out = mp("import gc\n"
             "def f(v, k):\n"
             "    a = gc.mem_alloc()\n"
             "    w = v * 3.0 + 1.0\n"
             "    w = w / v - 0.25\n"
             "    a1 = gc.mem_alloc()\n"
             "    n = k << 30\n"
             "    return a1 - a, gc.mem_alloc() - a1\n"
             "f(1.5, 1)\nprint(f(1.5, 1))\n")
    floats, bigint = json.loads(out.replace("(", "[").replace(")", "]"))
    assert floats == 0 and bigint > 0


def test_its_floats_are_30_bits():
    """Not float32 bit for bit: the two lowest mantissa bits are the
    object's tag (``float30``)."""
    out = mp("import struct\nprint(struct.pack('<f', 1 / 3).hex(), struct.pack('<f', 0.1).hex(), 1.0 + 1e-7 == 1.0)\n")
    third, tenth, tiny = out.split()
    assert (third, tenth) == (struct.pack("<f", roboray_host.float30(1 / 3)).hex(),
                              struct.pack("<f", roboray_host.float30(0.1)).hex())
    assert third == "aaaaaa3e" != struct.pack("<f", 1 / 3).hex()
    assert tiny == "True"    # 2**-21 apart near 1, single's 2**-23 lost
    assert roboray_host.float30(0.5) == 0.5 and roboray_host.float30(-2.0) == -2.0


def test_it_has_what_the_twin_and_the_firmware_use():
    out = mp("import sys, gc, json, struct, hashlib, binascii, os, select, time, math, array, micropython, io\n"
             "print(hashlib.sha256(b'abc').digest().hex(), binascii.hexlify(b'\\x01\\xff').decode(),\n"
             "      json.dumps({'a': [1, 2.5]}), os.getcwd() != '', hasattr(select, 'poll'),\n"
             "      struct.calcsize('<fIh'))\n"
             "@micropython.viper\n"
             "def add(a: int, b: int) -> int:\n"
             "    return a + b\n"
             "print(add(2, 3))\n")
    first, second = out.splitlines()
    assert first.split(" ", 2)[:2] == [hashlib.sha256(b"abc").hexdigest(), "01ff"]
    assert first.endswith('{"a": [1, 2.5]} True True 10')
    assert second == "5"


def test_a_bad_interpreter_choice_for_the_emulated_board_is_refused():
    from roboray.sim.twin.runner import Options, Twin

    with pytest.raises(ValueError, match="--emu-build"):
        Twin(Options(interpreter="roboray-unix", emu_build="stock"))
    with pytest.raises(ValueError, match="--emu-build"):
        Twin(Options(interpreter="rp2350-emu", emu_build="nope"))


def test_the_default_twin_flies_on_it_and_allocates_little():
    """The twin's default: a drop flown on the host build; the firmware's
    tasks allocate a few bytes a slot (floats boxed: kilobytes), counted
    when asked (``count_heap``, as ``bench board`` does)."""
    import numpy as np

    from roboray.sim.twin.board import boardtime
    from roboray.sim.twin.runner import Options, Twin

    twin = Twin(Options(scenario="passive-drop", depth=3.0, duration=10.0, count_heap=True))
    r = twin.run()
    assert r["interpreter"].startswith("roboray-unix ")
    assert r["interpreter_build"]["obj_repr"] == "C"
    assert r["task_errors"] == 0 and r["resets"] == 0
    kind, mode, us = twin.times.records()
    alloc = us[kind == boardtime.ALLOC]
    slots = us[kind == boardtime.SLOT]
    assert len(alloc) == len(slots) > 500
    assert float(np.mean(alloc)) < 1000


def test_sil_json_says_which_build_flew(capsys):
    from roboray.sim.cli import main

    assert main(["sil", "--json", "--depth", "2", "--duration", "3"]) in (0, None)
    r = json.loads(capsys.readouterr().out)
    assert r["interpreter_build"] == {"name": "roboray-unix", "version": roboray_host.version(), "obj_repr": "C",
                                      "float_bits": 32, "word_bits": 32}


def test_an_emulated_board_build_without_the_emulated_board_is_one_line(capsys):
    from roboray.sim.cli import main

    try:
        code = main(["sil", "--emu-build", "stock", "--duration", "1"])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert "--emu-build chooses the emulated RP2350's MicroPython: add --interpreter rp2350-emu" in err
