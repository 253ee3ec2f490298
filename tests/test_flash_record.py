"""flash_record: one record on flash, whole or not at all, through power cuts at every step."""

from __future__ import annotations

import pytest

from roboray.firmware import flash_record
from roboray.firmware.flash_record import FlashRecord
from roboray.sim import twin


def test_round_trip_and_a_missing_record(tmp_path):
    path = str(tmp_path / "key.bin")
    r = FlashRecord(path)
    assert r.load() is None and r.source == "none" and r.problem == "missing"
    r.save(b"\x00\x01hello")
    r2 = FlashRecord(path)
    assert r2.load() == b"\x00\x01hello" and r2.source == "main" and r2.problem is None
    r2.save(b"")
    assert FlashRecord(path).load() == b""


def test_a_save_announces_its_stall_first(tmp_path):
    told = []
    r = FlashRecord(str(tmp_path / "r.bin"))
    r.expect_delay = told.append
    r.save(b"x")
    assert told == [flash_record.SAVE_STALL_MS] and r.saves == 1


def test_oversized_payload_is_refused_before_flash_is_touched(tmp_path):
    r = FlashRecord(str(tmp_path / "r.bin"))
    with pytest.raises(ValueError, match="data"):
        r.save(bytes(flash_record.MAX_PAYLOAD + 1))
    assert not (tmp_path / "r.bin.tmp").exists()


@pytest.mark.parametrize("damage, problem", [
    (lambda d: d[:-1], "length"),
    (lambda d: d[:20], "truncated"),
    (lambda d: d[:9] + bytes([d[9] ^ 1]) + d[10:], "checksum mismatch"),
    (lambda d: b"XXXX" + d[4:], "not a record file"),
    (lambda d: d[:4] + b"\x07" + d[5:], "format 7"),
])
def test_a_damaged_main_file_falls_back_to_the_previous_record(tmp_path, damage, problem):
    path = tmp_path / "r.bin"
    r = FlashRecord(str(path))
    r.save(b"first record")
    r.save(b"second record")
    path.write_bytes(damage(path.read_bytes()))
    r = FlashRecord(str(path))
    assert r.load() == b"first record"
    assert r.source == "backup" and r.problem.startswith(problem)


def test_file_format_is_what_the_docstring_says():
    image = flash_record.encode(b"ab")
    assert image[:7] == b"RRFR\x01\x02\x00" and image[7:9] == b"ab" and len(image) == 9 + 32
    assert flash_record.decode(image) == (b"ab", None)


# ------------------------------------------------------------ power cuts
@pytest.fixture(scope="module")
def mp():
    m = twin.interpreter()
    m.exec(
        "import os\n"
        "from roboray.firmware.flash_record import FlashRecord\n"
        "from roboray.firmware.param_store import Files\n"
        "from roboray.sim.twin.board.powercut import PowerCutFiles, PowerCut\n"
        "PATH = '/flash/rec.bin'\n"
        "OLD = b'old record ' * 20\n"
        "NEW = b'the new one' * 30\n"
        "try:\n    os.mkdir('/flash')\nexcept OSError:\n    pass\n"
        "def wipe():\n"
        "    for n in os.listdir('/flash'):\n"
        "        os.remove('/flash/' + n)\n"
        "def boot():\n"
        "    r = FlashRecord(PATH)\n"
        "    d = r.load()\n"
        "    return r.source, 'old' if d == OLD else 'new' if d == NEW else 'none' if d is None else 'MIXED'\n"
        "def cut_save(k, prepare):\n"
        "    wipe()\n"
        "    prepare()\n"
        "    r = FlashRecord(PATH, PowerCutFiles(Files(), k))\n"
        "    try:\n"
        "        r.save(NEW)\n"
        "        return 'done', r.fs.steps\n"
        "    except PowerCut:\n"
        "        return 'cut', r.fs.steps\n"
        "def with_old():\n"
        "    FlashRecord(PATH).save(OLD)\n"
        "    FlashRecord(PATH).save(OLD)\n"
        "def nothing():\n"
        "    pass\n"
    )
    yield m
    m.close()


def _every_step(mp, prepare):
    mp.exec("outcome, steps = cut_save(0, %s)" % prepare)
    assert mp.eval("outcome") == "done"
    steps = mp.eval("steps")
    results = []
    for k in range(1, steps + 1):
        mp.exec("outcome, _ = cut_save(%d, %s)\nres = boot()" % (k, prepare))
        assert mp.eval("outcome") == "cut"
        results.append(tuple(mp.eval("list(res)")))
    return steps, results


@pytest.mark.micropython
def test_a_power_cut_at_every_step_of_a_save_leaves_the_old_or_the_new_record(mp):
    steps, results = _every_step(mp, "with_old")
    assert steps == 6  # open, write, close (then the read-back), remove .bak, rename main, rename tmp
    assert all(which in ("old", "new") for _, which in results), results
    whiches = [which for _, which in results]
    assert whiches[0] == "old" and whiches[-1] == "new"
    assert ("tmp", "new") in results       # the half-done rename is finished at boot
    assert mp.eval("boot()") == ["main", "new"]


@pytest.mark.micropython
def test_a_power_cut_during_the_first_save_leaves_nothing_or_the_new_record(mp):
    _, results = _every_step(mp, "nothing")
    assert all(which in ("none", "new") for _, which in results), results
    assert results[0] == ("none", "none") and results[-1][1] == "new"


@pytest.mark.micropython
def test_a_power_cut_while_boot_finishes_an_interrupted_save(mp):
    mp.exec(
        "def cut_boot(k):\n"
        "    wipe()\n"
        "    FlashRecord(PATH).save(OLD)\n"
        "    r = FlashRecord(PATH, PowerCutFiles(Files(), 5))\n"   # cut after main went to .bak
        "    try:\n        r.save(NEW)\n    except PowerCut:\n        pass\n"
        "    b = FlashRecord(PATH, PowerCutFiles(Files(), k))\n"
        "    try:\n        b.load()\n        return 'done'\n    except PowerCut:\n        return 'cut'\n"
    )
    assert mp.eval("cut_boot(0)") == "done"
    assert mp.eval("boot()") == ["main", "new"]
    assert mp.eval("cut_boot(1)") == "cut"
    assert mp.eval("boot()") == ["tmp", "new"]
    assert mp.eval("boot()") == ["main", "new"]
