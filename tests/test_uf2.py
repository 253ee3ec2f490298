"""The UF2 writer and checker (tools/flash/uf2.py) on the committed RoboRay
image for the Pico 2 and on damaged copies of it, and the recipe's record."""

from __future__ import annotations

import hashlib
import json
import struct
from pathlib import Path

import pytest

from roboray.tools.flash import uf2
from roboray.tools.flash.firmware import IDENTITY, IMAGE, IMAGE_DIR

BLOCK = uf2.BLOCK_BYTES


@pytest.fixture(scope="module")
def image() -> bytes:
    return IMAGE.read_bytes()


def blocks(data: bytes) -> list[bytearray]:
    return [bytearray(data[i:i + BLOCK]) for i in range(0, len(data), BLOCK)]


def join(bs: list[bytearray]) -> bytes:
    return b"".join(bytes(b) for b in bs)


def put(b: bytearray, offset: int, value: int) -> bytearray:
    struct.pack_into("<I", b, offset, value)
    return b


def test_committed_image_is_an_rp2350_arm_image(image):
    r = uf2.check(image)
    assert r["absolute_block"] is True
    assert r["blocks"] == len(image) // BLOCK - 1
    assert r["flash_start"] == 0x10000000 and r["flash_end"] <= uf2.CODE_END
    # IMAGE_TYPE: executable (1), secure (2 << 4), Arm (0 << 8), RP2350 (1 << 12)
    assert r["image_def"] == 0x1 | 0x20 | 0x1000
    first = blocks(image)[1]
    assert struct.unpack_from("<I", first, 28)[0] == uf2.RP2350_ARM_S_FAMILY_ID == 0xE48BFF59


def test_committed_image_matches_its_checksum_and_identity(image):
    sha = hashlib.sha256(image).hexdigest()
    assert (IMAGE_DIR / "roboray-pico2.uf2.sha256").read_text().split() == [sha, "roboray-pico2.uf2"]
    ident = json.loads(IDENTITY.read_text())
    assert ident["sha256"] == sha and ident["build"] == "ROBORAY_PICO2"
    assert ident["machine"] == "RoboRay Pico 2 with RP2350"
    assert (ident["obj_repr"], ident["float_bits"], ident["word_bits"]) == ("C", 32, 32)
    # The image holds, as the C strings the board prints, what it will say
    # about itself (os.uname().version and .machine, sys.implementation._build).
    flash = b"".join(b[32:288] for b in blocks(image)[1:])
    assert "(GNU " in ident["version"]  # rp2's MICROPY_BUILD_TYPE, part of os.uname().version
    for text in (ident["version"], ident["machine"], ident["build"]):
        assert text.encode() + b"\0" in flash, text
    build_txt = (IMAGE_DIR / "BUILD.txt").read_text()
    assert sha in build_txt and "964803ab744297c82a9fc3cd0c71c6cf60eec6d2" in build_txt


def test_absolute_block_is_picotools(image):
    b = blocks(image)[0]
    magic0, magic1, flags, addr, size, no, count, family = struct.unpack_from("<8I", b)
    assert (flags, addr, size, no, count, family) == (0xA000, 0x10FFFF00, 256, 0, 2, uf2.ABSOLUTE_FAMILY_ID)
    assert bytes(b[32:288]) == b"\xef" * 256
    assert struct.unpack_from("<I", b, 288)[0] == uf2.EXTENSION_RP2_IGNORE_BLOCK


@pytest.mark.parametrize("damage, message", [
    (lambda bs: bs[:-1], "blocks of the"),                                            # truncated
    (lambda bs: bs[:5] + bs[6:], "block number"),                                      # one lost
    (lambda bs: bs[:3] + [bs[4], bs[3]] + bs[5:], "block number"),                     # out of order
    (lambda bs: bs[:2] + [put(bs[2], 0, 0)] + bs[3:], "bad UF2 magic"),                # magic
    (lambda bs: bs[:2] + [put(bs[2], 508, 0)] + bs[3:], "bad UF2 magic"),              # end magic
    (lambda bs: bs[:2] + [put(bs[2], 28, uf2.RP2040_FAMILY_ID)] + bs[3:], "RP2040"),   # family
    (lambda bs: bs[:2] + [put(bs[2], 16, 476)] + bs[3:], "payload of 476"),            # payload
    (lambda bs: bs[:2] + [put(bs[2], 12, 0x10200000)] + bs[3:], "outside the code space"),
    (lambda bs: bs[:2] + [put(bs[2], 12, 0x20000000)] + bs[3:], "outside the code space"),
    (lambda bs: bs[:2] + [put(bs[2], 12, 0x10000080)] + bs[3:], "not 256-byte aligned"),
    (lambda bs: bs[:2] + [put(bs[2], 24, 7)] + bs[3:], "says 7 blocks"),
], ids=["truncated", "lost-block", "swapped", "magic", "end-magic", "family", "payload", "address",
        "ram-address", "unaligned", "count"])
def test_damaged_copies_are_refused(image, damage, message):
    with pytest.raises(uf2.Uf2Error, match=message):
        uf2.check(join(damage(blocks(image))))


def image_def_block(bs: list[bytearray]) -> tuple[int, int]:
    """(index, offset) of the block with the start of the IMAGE_DEF in the first 4 kB."""
    for i, b in enumerate(bs[1:17], 1):
        for off in range(32, 288, 4):
            if struct.unpack_from("<I", b, off)[0] == uf2.BLOCK_MARKER_START:
                return i, off
    raise AssertionError("no IMAGE_DEF in the committed image")


def test_missing_or_foreign_image_def_is_refused(image):
    bs = blocks(image)
    i, off = image_def_block(bs)
    gone = [bytearray(b) for b in bs]
    put(gone[i], off, 0)
    with pytest.raises(uf2.Uf2Error, match="no IMAGE_DEF"):
        uf2.check(join(gone))
    riscv = [bytearray(b) for b in bs]
    word = struct.unpack_from("<I", riscv[i], off + 4)[0]
    assert word & 0xFF == uf2.ITEM_IMAGE_TYPE
    put(riscv[i], off + 4, word | (1 << 24))  # CPU field: RISC-V
    with pytest.raises(uf2.Uf2Error, match="not an executable for the RP2350's Arm cores"):
        uf2.check(join(riscv))
    broken = [bytearray(b) for b in bs]
    put(broken[i], off + 12, 0x100)  # the link after the LAST item, to where no block is
    with pytest.raises(uf2.Uf2Error, match="leads to 0x10000238, where there is no block"):
        uf2.check(join(broken))


def test_not_a_uf2():
    with pytest.raises(uf2.Uf2Error, match="empty"):
        uf2.check(b"")
    with pytest.raises(uf2.Uf2Error, match="whole number"):
        uf2.check(b"\0" * 700)
    with pytest.raises(uf2.Uf2Error, match="bad UF2 magic"):
        uf2.check(b"\0" * 1024)


def elf(segments: list[tuple[int, bytes]], bss: int = 0) -> bytes:
    """A 32-bit little-endian Arm ELF with one PT_LOAD a segment (paddr = vaddr),
    the last followed by ``bss`` bytes of memory it does not fill."""
    ph_off, n = 52, len(segments)
    data_off = ph_off + 32 * n
    header = (b"\x7fELF\x01\x01\x01" + b"\0" * 9
              + struct.pack("<HHIIIIIHHHHHH", 2, 40, 1, segments[0][0] | 1, ph_off, 0, 0x5000200, 52, 32, n, 40, 0, 0))
    phs, body = b"", b""
    for k, (addr, content) in enumerate(segments):
        memsz = len(content) + (bss if k == n - 1 else 0)
        phs += struct.pack("<8I", 1, data_off + len(body), addr, addr, len(content), memsz, 5, 4)
        body += content
    return header + phs + body


def picobin_block() -> bytes:
    """The pico-sdk's embedded start block (crt0, RP2350 Arm secure): a loop of one."""
    return struct.pack("<IBBHBHBII", uf2.BLOCK_MARKER_START, uf2.ITEM_IMAGE_TYPE, 1, 0x1021,
                       uf2.ITEM_LAST, 1, 0, 0, uf2.BLOCK_MARKER_END)


def test_from_elf_lays_pages_out_as_picotool():
    code = bytes(range(256)) * 2 + picobin_block()  # block at 0x10000200
    data = b"\xaa" * 300
    out = uf2.from_elf(elf([(0x10000000, code), (0x10003100, data)], bss=4096))
    r = uf2.check(out)
    assert r["absolute_block"] and r["image_def"] == 0x1021
    bs = blocks(out)[1:]
    addrs = [struct.unpack_from("<I", b, 12)[0] for b in bs]
    # The sectors touched (0x10000000, 0x10003000) get every page below the
    # last one, zeros where the ELF has nothing (the ROM erases by block
    # number); untouched sectors get none.
    assert addrs == [0x10000000 + 256 * k for k in range(16)] + [0x10003000, 0x10003100, 0x10003200]
    assert [struct.unpack_from("<II", b, 20) for b in bs] == [(k, len(bs)) for k in range(len(bs))]
    page = {a: bytes(b[32:288]) for a, b in zip(addrs, bs)}
    assert page[0x10000000] == bytes(range(256)) and page[0x10000F00] == b"\0" * 256
    assert page[0x10003100] == b"\xaa" * 256 and page[0x10003200] == b"\xaa" * 44 + b"\0" * 212


def test_from_elf_refuses_what_is_not_a_flash_image():
    with pytest.raises(uf2.Uf2Error, match="not in flash"):
        uf2.from_elf(elf([(0x20000000, b"\1" * 64)]))
    with pytest.raises(uf2.Uf2Error, match="ELF"):
        uf2.from_elf(b"MZ" + b"\0" * 100)


def test_recipe_and_board_config_are_committed():
    here = Path(IMAGE_DIR)
    recipe = (here / "build.sh").read_text()
    for pin in ("964803ab744297c82a9fc3cd0c71c6cf60eec6d2", "a1438dff1d38bd9c65dbd693f0e5db4b9ae91779",
                "SOURCE_DATE_EPOCH", "-ffile-prefix-map"):
        assert pin in recipe
    board_h = (here / "board" / "ROBORAY_PICO2" / "mpconfigboard.h").read_text()
    assert '#include "mpconfig_roboray.h"' in board_h


def test_image_was_built_from_the_committed_configuration():
    """The three builds share mpconfig_roboray.h; the UF2 records the one it
    was compiled with, so a change there that the Pico 2 image lacks shows."""
    header = Path(IMAGE_DIR).parent / "mpconfig_roboray.h"
    sha = hashlib.sha256(header.read_bytes()).hexdigest()
    assert "mpconfig_roboray.h" in (IMAGE_DIR / "BUILD.txt").read_text()
    assert sha in (IMAGE_DIR / "BUILD.txt").read_text(), (
        "tools/roboray_micropython/mpconfig_roboray.h changed since the Pico 2 UF2 was built: "
        "rebuild it with tools/roboray_micropython/pico2/build.sh")
