"""UF2 images for the RP2350: written from an ELF, and checked before a copy.

A UF2 file (Microsoft's format, https://github.com/microsoft/uf2) is a run
of 512-byte blocks, each self-describing: two start magics, flags, the flash
address its payload goes to, the payload size, its block number, the number
of blocks, the family id (flag 0x2000) and, last, an end magic. The
RP2350's boot ROM writes each block it is given to flash, and starts the
image once every block numbered 0..n-1 of one family has arrived
(RP2350 datasheet, section 5.5 "UF2 format details").

What this module writes is what picotool 2.2.0's ``uf2 convert`` writes
for a flash image (picotool ``elf2uf2/elf2uf2.cpp``), as the pico-sdk's
build does for the Pico 2: the ELF's loadable contents cut into 256-byte
pages at flash addresses from 0x10000000, family RP2350-ARM-S
(``0xe48bff59``); every 4 kB sector the image touches filled with zero
pages below the last page (the boot ROM erases a sector by block number);
and first an "absolute" block (family ``0xe48bff57``, 0x10ffff00, 256
bytes of 0xef, extension ``0x9957e304`` "ignore") that works around
erratum RP2350-E10 on A2 chips (pico-sdk ``tools/CMakeLists.txt``:
``--abs-block`` when ``PICO_RP2350_A2_SUPPORTED``, which the ``pico2``
board sets). Checked: for this repository's Pico 2 firmware ELF, picotool
2.2.0 (built from its tag, without USB) ``uf2 convert firmware.elf out.uf2
--family rp2350-arm-s --abs-block`` and :func:`from_elf` give the same
bytes (sha256 5bcd6dc0..., ``roboray-pico2.uf2`` before its rebuild with the
flight log's RAM, now fe2f5fea...), and ``picotool info -a``
reads its IMAGE_DEF (RP2350, Arm Secure) at 0x10000138.

:func:`check` refuses a UF2 the boot ROM would not start as an RP2350 Arm
image: wrong magics or family, payloads other than 256 bytes, block numbers
out of order or a count that disagrees, flash addresses outside the code
space, and no IMAGE_DEF. The RP2350 boot ROM starts an image only if a
block loop with an IMAGE_DEF lies in its first 4 kB (datasheet 5.9.5): a
block is the word 0xffffded3, items (the IMAGE_TYPE item 0x42 says
executable, Arm, RP2350), a LAST item 0xff with the items' size in words,
the offset of the next block, and the word 0xab123579; the blocks' offsets
must lead back to the first (pico-sdk ``boot/picobin.h``,
``pico_crt0/embedded_start_block.inc.S``).

Standard library only: ``build.sh`` runs it with the system Python::

    python3 tools/flash/uf2.py from-elf firmware.elf out.uf2
    python3 tools/flash/uf2.py check out.uf2
"""

from __future__ import annotations

import struct
import sys

MAGIC_START0 = 0x0A324655
MAGIC_START1 = 0x9E5D5157
MAGIC_END = 0x0AB16F30
FLAG_NOT_MAIN_FLASH = 0x00000001
FLAG_FAMILY_ID_PRESENT = 0x00002000
FLAG_EXTENSION_FLAGS_PRESENT = 0x00008000
EXTENSION_RP2_IGNORE_BLOCK = 0x9957E304

BLOCK_BYTES = 512
PAYLOAD_BYTES = 256
SECTOR_BYTES = 4096

#: Family ids (pico-sdk ``boot/uf2.h``).
RP2040_FAMILY_ID = 0xE48BFF56
ABSOLUTE_FAMILY_ID = 0xE48BFF57
DATA_FAMILY_ID = 0xE48BFF58
RP2350_ARM_S_FAMILY_ID = 0xE48BFF59
RP2350_RISCV_FAMILY_ID = 0xE48BFF5A
RP2350_ARM_NS_FAMILY_ID = 0xE48BFF5B
FAMILIES = {
    RP2040_FAMILY_ID: "RP2040",
    ABSOLUTE_FAMILY_ID: "absolute",
    DATA_FAMILY_ID: "data",
    RP2350_ARM_S_FAMILY_ID: "RP2350-ARM-S",
    RP2350_RISCV_FAMILY_ID: "RP2350-RISCV",
    RP2350_ARM_NS_FAMILY_ID: "RP2350-ARM-NS",
}

#: Flash, as the RP2350 maps it (XIP), and the E10 workaround block's place.
FLASH_START = 0x10000000
FLASH_WINDOW_END = 0x11000000
ABS_BLOCK_ADDR = FLASH_WINDOW_END - PAYLOAD_BYTES
#: A Pico 2's 4 MB flash; of it RoboRay's build keeps the first 768 kB for
#: code (then the 256 kB ROMFS partition and the 3 MB file system), so an
#: image that reaches further would overwrite the board's files.
CODE_END = FLASH_START + 768 * 1024

# Picobin blocks (pico-sdk boot/picobin.h).
BLOCK_MARKER_START = 0xFFFFDED3
BLOCK_MARKER_END = 0xAB123579
ITEM_IMAGE_TYPE = 0x42
ITEM_LAST = 0xFF
IMAGE_TYPE_EXE = 0x1
IMAGE_CPU_ARM = 0
IMAGE_CHIP_RP2350 = 1

_HEADER = struct.Struct("<8I")


class Uf2Error(ValueError):
    """The file is no UF2 an RP2350 would start; the message says why."""


# ------------------------------------------------------------------ writing
def _block(flags: int, addr: int, block_no: int, num_blocks: int, family: int, payload: bytes,
           extension: int | None = None) -> bytes:
    data = payload.ljust(PAYLOAD_BYTES, b"\0")
    if extension is not None:
        data += struct.pack("<I", extension)
    return (_HEADER.pack(MAGIC_START0, MAGIC_START1, flags, addr, PAYLOAD_BYTES, block_no, num_blocks, family)
            + data.ljust(476, b"\0") + struct.pack("<I", MAGIC_END))


def absolute_block(addr: int = ABS_BLOCK_ADDR) -> bytes:
    """picotool's RP2350-E10 block: a UF2 "file" of its own (block 0 of 2)
    the boot ROM ignores, so the image's own blocks start a fresh download."""
    return _block(FLAG_FAMILY_ID_PRESENT | FLAG_EXTENSION_FLAGS_PRESENT, addr, 0, 2, ABSOLUTE_FAMILY_ID,
                  b"\xef" * PAYLOAD_BYTES, EXTENSION_RP2_IGNORE_BLOCK)


def elf_flash_pages(elf: bytes) -> dict[int, bytearray]:
    """The 256-byte flash pages an ELF's loadable segments fill, by address.

    Contents are taken at the segments' load (physical) addresses, which
    must lie in flash: a flash image's initialised RAM data is copied there
    from flash by its start-up code. Space a segment does not fill (BSS) is
    not written.
    """
    if elf[:4] != b"\x7fELF" or elf[4] != 1 or elf[5] != 1:
        raise Uf2Error("not a 32-bit little-endian ELF file")
    phoff, = struct.unpack_from("<I", elf, 0x1C)
    phentsize, phnum = struct.unpack_from("<HH", elf, 0x2A)
    pages: dict[int, bytearray] = {}
    for i in range(phnum):
        p_type, off, _vaddr, paddr, filesz, memsz = struct.unpack_from("<6I", elf, phoff + i * phentsize)
        size = min(filesz, memsz)
        if p_type != 1 or not size:  # PT_LOAD with contents
            continue
        if not (FLASH_START <= paddr and paddr + size <= FLASH_WINDOW_END):
            raise Uf2Error("segment at 0x%08x..0x%08x is not in flash: not a flash image" % (paddr, paddr + size))
        addr, pos, end = paddr, off, off + size
        while pos < end:
            base = addr & ~(PAYLOAD_BYTES - 1)
            n = min(end - pos, base + PAYLOAD_BYTES - addr)
            page = pages.setdefault(base, bytearray(PAYLOAD_BYTES))
            page[addr - base:addr - base + n] = elf[pos:pos + n]
            addr += n
            pos += n
    if not pages:
        raise Uf2Error("the ELF file has nothing to put in flash")
    return pages


def from_elf(elf: bytes, family: int = RP2350_ARM_S_FAMILY_ID, abs_block: bool = True) -> bytes:
    """The UF2 of a flash image ELF, laid out as picotool 2.2.0 lays it out."""
    pages = elf_flash_pages(elf)
    last = max(pages)
    # Every sector touched gets all its pages below the last one (zeros).
    for sector in {a // SECTOR_BYTES for a in pages}:
        for a in range(sector * SECTOR_BYTES, (sector + 1) * SECTOR_BYTES, PAYLOAD_BYTES):
            if a < last:
                pages.setdefault(a, bytearray(PAYLOAD_BYTES))
    out = [absolute_block()] if abs_block and family != RP2040_FAMILY_ID else []
    addrs = sorted(pages)
    for n, a in enumerate(addrs):
        out.append(_block(FLAG_FAMILY_ID_PRESENT, a, n, len(addrs), family, bytes(pages[a])))
    return b"".join(out)


# ----------------------------------------------------------------- checking
def _is_absolute_block(b: tuple, payload: bytes, raw: bytes) -> bool:
    _m0, _m1, flags, _addr, size, block_no, num_blocks, family = b
    return (family == ABSOLUTE_FAMILY_ID and block_no == 0 and num_blocks == 2 and size == PAYLOAD_BYTES
            and flags & ~FLAG_EXTENSION_FLAGS_PRESENT == FLAG_FAMILY_ID_PRESENT
            and payload == b"\xef" * PAYLOAD_BYTES
            and (not flags & FLAG_EXTENSION_FLAGS_PRESENT
                 or struct.unpack_from("<I", raw, 32 + PAYLOAD_BYTES)[0] == EXTENSION_RP2_IGNORE_BLOCK))


def check(data: bytes, family: int = RP2350_ARM_S_FAMILY_ID, code_end: int = CODE_END) -> dict:
    """Check a UF2 for an RP2350 Arm flash image; its figures, or :class:`Uf2Error`.

    Returns ``blocks`` (of the image), ``absolute_block`` (the E10 block
    present), ``flash_start``/``flash_end`` (addresses written),
    ``image_bytes`` and ``image_def`` (the IMAGE_TYPE item's flags).
    """
    if not data:
        raise Uf2Error("empty file")
    if len(data) % BLOCK_BYTES:
        raise Uf2Error("%d bytes is not a whole number of 512-byte UF2 blocks" % len(data))
    image: dict[int, bytes] = {}
    absolute = False
    expected_count = None
    for i in range(len(data) // BLOCK_BYTES):
        raw = data[i * BLOCK_BYTES:(i + 1) * BLOCK_BYTES]
        b = _HEADER.unpack_from(raw)
        m0, m1, flags, addr, size, block_no, num_blocks, fam = b
        end, = struct.unpack_from("<I", raw, BLOCK_BYTES - 4)
        where = "block %d (file offset %d)" % (i, i * BLOCK_BYTES)
        if (m0, m1, end) != (MAGIC_START0, MAGIC_START1, MAGIC_END):
            raise Uf2Error("%s: bad UF2 magic: not a UF2 file, or a damaged one" % where)
        if size != PAYLOAD_BYTES:
            raise Uf2Error("%s: payload of %d bytes, the RP2350 takes 256" % (where, size))
        payload = raw[32:32 + PAYLOAD_BYTES]
        if not flags & FLAG_FAMILY_ID_PRESENT:
            raise Uf2Error("%s: no family id" % where)
        if i == 0 and _is_absolute_block(b, payload, raw):
            absolute = True
            continue
        if fam != family:
            raise Uf2Error("%s: family 0x%08x (%s), not 0x%08x (%s): an image for another chip"
                           % (where, fam, FAMILIES.get(fam, "unknown"), family, FAMILIES[family]))
        if flags & FLAG_NOT_MAIN_FLASH:
            raise Uf2Error("%s: marked not for main flash" % where)
        n = len(image)
        if expected_count is None:
            expected_count = num_blocks
        if num_blocks != expected_count:
            raise Uf2Error("%s: says %d blocks in all, block 0 said %d" % (where, num_blocks, expected_count))
        if block_no != n:
            raise Uf2Error("%s: block number %d, expected %d (blocks missing or out of order)" % (where, block_no, n))
        if addr % PAYLOAD_BYTES:
            raise Uf2Error("%s: flash address 0x%08x is not 256-byte aligned" % (where, addr))
        if not (FLASH_START <= addr and addr + PAYLOAD_BYTES <= code_end):
            raise Uf2Error("%s: flash address 0x%08x outside the code space 0x%08x..0x%08x"
                           % (where, addr, FLASH_START, code_end))
        if addr in image:
            raise Uf2Error("%s: flash address 0x%08x written twice" % (where, addr))
        image[addr] = payload
    if not image:
        raise Uf2Error("no image blocks")
    if len(image) != expected_count:
        raise Uf2Error("%d blocks of the %d the file announces: a truncated copy" % (len(image), expected_count))
    if FLASH_START not in image:
        raise Uf2Error("nothing at the start of flash (0x%08x): the boot ROM would not find the image"
                       % FLASH_START)
    image_def = _image_def(image)
    return {
        "blocks": len(image),
        "absolute_block": absolute,
        "flash_start": min(image),
        "flash_end": max(image) + PAYLOAD_BYTES,
        "image_bytes": len(image) * PAYLOAD_BYTES,
        "image_def": image_def,
    }


def _word(image: dict[int, bytes], addr: int) -> int | None:
    page = image.get(addr & ~(PAYLOAD_BYTES - 1))
    if page is None:
        return None
    return struct.unpack_from("<I", page, addr & (PAYLOAD_BYTES - 1))[0]


def _parse_block(image: dict[int, bytes], at: int) -> tuple[int | None, int]:
    """(IMAGE_TYPE flags or None, link) of the picobin block at ``at``; Uf2Error if malformed."""
    pos = at + 4
    image_type = None
    for _ in range(64):
        w = _word(image, pos)
        if w is None:
            raise Uf2Error("the metadata block at 0x%08x runs outside the image" % at)
        kind = w & 0xFF
        if kind == ITEM_LAST:
            words = (w >> 8) & 0xFFFF
            if words != (pos - at - 4) // 4:
                raise Uf2Error("the metadata block at 0x%08x: its last item counts %d words, the items are %d"
                               % (at, words, (pos - at - 4) // 4))
            link, marker = _word(image, pos + 4), _word(image, pos + 8)
            if marker != BLOCK_MARKER_END or link is None:
                raise Uf2Error("the metadata block at 0x%08x has no end marker" % at)
            return image_type, link
        size = ((w >> 8) & 0xFFFF) if kind & 0x80 else ((w >> 8) & 0xFF)
        if size == 0:
            raise Uf2Error("the metadata block at 0x%08x has an empty item" % at)
        if kind == ITEM_IMAGE_TYPE:
            image_type = w >> 16
        pos += 4 * size
    raise Uf2Error("the metadata block at 0x%08x has no last item" % at)


def _image_def(image: dict[int, bytes]) -> int:
    """The IMAGE_TYPE flags of the block loop in the first 4 kB; Uf2Error without one."""
    first = next((a for a in range(FLASH_START, FLASH_START + SECTOR_BYTES, 4)
                  if _word(image, a) == BLOCK_MARKER_START), None)
    if first is None:
        raise Uf2Error("no IMAGE_DEF: no metadata block (0xffffded3) in the first 4 kB, "
                       "the RP2350 boot ROM would not start this image")
    found = None
    at = first
    for _ in range(16):
        image_type, link = _parse_block(image, at)
        if image_type is not None and found is None:
            found = image_type
        at = (at + link) & 0xFFFFFFFF
        if at == first:
            break
        if _word(image, at) != BLOCK_MARKER_START:
            raise Uf2Error("the metadata block loop from 0x%08x leads to 0x%08x, where there is no block"
                           % (first, at))
    else:
        raise Uf2Error("the metadata blocks from 0x%08x do not loop back" % first)
    if found is None:
        raise Uf2Error("no IMAGE_DEF: the metadata blocks have no IMAGE_TYPE item")
    kind, cpu, chip = found & 0xF, (found >> 8) & 0x7, (found >> 12) & 0x7
    if kind != IMAGE_TYPE_EXE or cpu != IMAGE_CPU_ARM or chip != IMAGE_CHIP_RP2350:
        raise Uf2Error("the IMAGE_DEF (0x%04x) is not an executable for the RP2350's Arm cores" % found)
    return found


def main(argv: list[str]) -> int:
    if len(argv) == 3 and argv[0] == "from-elf":
        with open(argv[1], "rb") as f:
            uf2 = from_elf(f.read())
        check(uf2)
        with open(argv[2], "wb") as f:
            f.write(uf2)
        return 0
    if len(argv) == 2 and argv[0] == "check":
        with open(argv[1], "rb") as f:
            r = check(f.read())
        print("%s: %d blocks, flash 0x%08x..0x%08x, IMAGE_DEF 0x%04x%s" % (
            argv[1], r["blocks"], r["flash_start"], r["flash_end"], r["image_def"],
            ", RP2350-E10 absolute block" if r["absolute_block"] else ""))
        return 0
    sys.stderr.write("usage: uf2.py from-elf ELF UF2 | uf2.py check UF2\n")
    return 2


if __name__ == "__main__":
    try:
        raise SystemExit(main(sys.argv[1:]))
    except (Uf2Error, OSError) as exc:
        sys.stderr.write("uf2.py: %s\n" % exc)
        raise SystemExit(1)
