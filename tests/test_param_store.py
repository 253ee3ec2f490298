"""Parameter store: whole sets only, through power cuts at every step."""

from __future__ import annotations

import pytest

from roboray.firmware import param_store
from roboray.firmware.param_store import ParamStore
from roboray.shared.params import READ_ONLY, TYPE_INT32, TYPE_REAL32, TYPE_UINT8, ParamTable
from roboray.sim import twin

DECLS = (
    ("GAIN_P", TYPE_REAL32, 1.5, 0.0, 10.0),
    ("GAIN_I", TYPE_REAL32, 0.25, 0.0, 10.0),
    ("MODE", TYPE_UINT8, 2, 0, 5),
    ("BAUD", TYPE_INT32, 57600, 1200, 921600, READ_ONLY),
    ("COUNT", TYPE_INT32, -7, -100000, 100000),
)


def values(table):
    return [table.get(i) for i in range(table.count())]


def test_round_trip_keeps_every_value_exactly(tmp_path):
    path = str(tmp_path / "params.bin")
    a = ParamTable(DECLS)
    assert a.set_by_name("GAIN_P", 3.125) == 0
    assert a.set_by_name("COUNT", 99999) == 0
    ParamStore(a, path).save()
    b = ParamTable(DECLS)
    store = ParamStore(b, path)
    assert store.load() == "main"
    assert values(b) == values(a)
    assert store.loaded == 4 and store.unknown == 0 and store.rejected == 0  # BAUD is read-only: not saved
    assert store.describe() == "params: 4 loaded from %s" % path


def test_missing_file_keeps_defaults_and_says_so(tmp_path):
    t = ParamTable(DECLS)
    store = ParamStore(t, str(tmp_path / "params.bin"))
    assert store.load() == "defaults"
    assert store.problem == "missing"
    assert values(t) == values(ParamTable(DECLS))
    assert "defaults" in store.describe()


@pytest.mark.parametrize("damage, problem", [
    (lambda d: d[:-1], "checksum mismatch"),
    (lambda d: d[:20], "truncated"),
    (lambda d: d[:40] + bytes([d[40] ^ 1]) + d[41:], "checksum mismatch"),
    (lambda d: b"XXXX" + d[4:], "not a parameter file"),
])
def test_damaged_main_file_falls_back_to_the_previous_set(tmp_path, damage, problem):
    path = tmp_path / "params.bin"
    t = ParamTable(DECLS)
    t.set_by_name("GAIN_I", 0.5)
    store = ParamStore(t, str(path))
    store.save()                       # main: 0.5
    t.set_by_name("GAIN_I", 0.75)
    store.save()                       # main: 0.75, backup: 0.5
    path.write_bytes(damage(path.read_bytes()))
    fresh = ParamTable(DECLS)
    store = ParamStore(fresh, str(path))
    assert store.load() == "backup"
    assert store.problem.startswith(problem)
    assert fresh.get(fresh.index("GAIN_I")) == 0.5
    assert "params.bin.bak" in store.describe()


def test_unknown_and_refused_entries_are_counted_not_fatal(tmp_path):
    path = str(tmp_path / "params.bin")
    wide = DECLS + (("OLD_PARAM", TYPE_REAL32, 1.0, 0.0, 2.0),)
    t = ParamTable(wide)
    t.set_by_name("MODE", 5)
    ParamStore(t, path).save()
    narrow = ParamTable(tuple(d if d[0] != "MODE" else ("MODE", TYPE_UINT8, 2, 0, 3) for d in DECLS))
    store = ParamStore(narrow, path)
    assert store.load() == "main"
    assert (store.unknown, store.rejected) == (1, 1)
    assert narrow.get(narrow.index("MODE")) == 2.0  # refused value: default kept
    assert "1 unknown, 1 rejected" in store.describe()


def test_service_saves_only_when_the_table_changed(tmp_path):
    path = tmp_path / "params.bin"
    t = ParamTable(DECLS)
    store = ParamStore(t, str(path))
    store.load()
    assert store.service() is False and not path.exists()
    t.set_by_name("GAIN_P", 2.0)
    assert store.dirty() and store.service() is True
    assert store.service() is False and store.saves == 1


def test_file_format_is_what_the_docstring_says():
    t = ParamTable(DECLS[:1])
    data = param_store.encode(t)
    assert data[:5] == b"RRPS\x01" and data[5:7] == b"\x01\x00"
    assert data[7:15] == b"\x06GAIN_Pf"
    entries, why = param_store.decode(data)
    assert why is None and entries == [("GAIN_P", 1.5)]


# ------------------------------------------------------------ power cuts
@pytest.fixture(scope="module")
def mp():
    m = twin.interpreter()
    m.exec(
        "import os\n"
        "from roboray.firmware.param_store import ParamStore, Files\n"
        "from roboray.shared.params import ParamTable, TYPE_REAL32, TYPE_UINT8, TYPE_INT32\n"
        "from roboray.sim.twin.board.powercut import PowerCutFiles, PowerCut\n"
        "DECLS = %r\n"
        "PATH = '/flash/params.bin'\n"
        "try:\n    os.mkdir('/flash')\nexcept OSError:\n    pass\n"
        "def wipe():\n"
        "    for n in os.listdir('/flash'):\n"
        "        os.remove('/flash/' + n)\n"
        "def table(gain, count):\n"
        "    t = ParamTable(DECLS)\n"
        "    t.set_by_name('GAIN_P', gain)\n"
        "    t.set_by_name('COUNT', count)\n"
        "    return t\n"
        "def vals(t):\n"
        "    return [t.get(i) for i in range(t.count())]\n"
        "OLD = vals(table(1.0, 1))\n"
        "NEW = vals(table(9.0, -9))\n"
        "def boot():\n"
        "    t = ParamTable(DECLS)\n"
        "    s = ParamStore(t, PATH)\n"
        "    s.load()\n"
        "    v = vals(t)\n"
        "    return s.source, 'old' if v == OLD else 'new' if v == NEW else 'defaults' if v == vals(ParamTable(DECLS)) else 'MIXED'\n"
        "def cut_save(k, prepare):\n"
        "    wipe()\n"
        "    prepare()\n"
        "    s = ParamStore(table(9.0, -9), PATH, PowerCutFiles(Files(), k))\n"
        "    try:\n"
        "        s.save()\n"
        "        return 'done', s.fs.steps\n"
        "    except PowerCut:\n"
        "        return 'cut', s.fs.steps\n"
        % (DECLS,)
    )
    yield m
    m.close()


def _every_step(mp, prepare):
    """Cut the power at each step of a save; what the next boot loads each time."""
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
def test_a_power_cut_at_every_step_of_a_save_leaves_the_old_or_the_new_set(mp):
    mp.exec("def with_old():\n    ParamStore(table(1.0, 1), PATH).save()\n"
            "    ParamStore(table(1.0, 1), PATH).save()\n")  # main and backup both hold the old set
    steps, results = _every_step(mp, "with_old")
    assert steps == 6  # open, write, close (then the read-back), remove .bak, rename main, rename tmp
    assert all(which in ("old", "new") for _, which in results), results
    whiches = [which for _, which in results]
    assert whiches[0] == "old" and whiches[-1] == "new"   # both outcomes really happen
    assert ("tmp", "new") in results                        # the half-done rename is finished at boot


@pytest.mark.micropython
def test_a_power_cut_during_the_first_save_leaves_defaults_or_the_new_set(mp):
    mp.exec("def nothing():\n    pass\n")
    _, results = _every_step(mp, "nothing")
    assert all(which in ("defaults", "new") for _, which in results), results


@pytest.mark.micropython
def test_a_power_cut_while_boot_finishes_an_interrupted_save(mp):
    # First a save cut after main went to .bak (only .tmp holds the new set),
    # then a boot whose repair is itself cut at each step: still whole sets.
    mp.exec(
        "def cut_boot(k):\n"
        "    wipe()\n"
        "    ParamStore(table(1.0, 1), PATH).save()\n"
        "    s = ParamStore(table(9.0, -9), PATH, PowerCutFiles(Files(), 5))\n"
        "    try:\n        s.save()\n    except PowerCut:\n        pass\n"
        "    b = ParamStore(ParamTable(DECLS), PATH, PowerCutFiles(Files(), k))\n"
        "    try:\n        b.load()\n        return 'done'\n    except PowerCut:\n        return 'cut'\n"
    )
    assert mp.eval("cut_boot(0)") == "done"
    assert mp.eval("boot()") == ["main", "new"]
    assert mp.eval("cut_boot(1)") == "cut"   # the repair is one rename: cut before it
    assert mp.eval("boot()") == ["tmp", "new"]
    assert mp.eval("boot()") == ["main", "new"]


@pytest.mark.micropython
def test_a_save_that_reads_back_wrong_is_refused_and_keeps_the_old_set(mp):
    mp.exec(
        "class BadFlash(Files):\n"
        "    def open(self, path, mode):\n"
        "        f = Files.open(self, path, mode)\n"
        "        if 'r' in mode and path.endswith('.tmp'):\n"
        "            data = f.read()\n"
        "            f.close()\n"
        "            import io\n"
        "            return io.BytesIO(data[:-3] + b'bad')\n"
        "        return f\n"
        "wipe()\n"
        "ParamStore(table(1.0, 1), PATH).save()\n"
        "t = table(1.0, 1)\n"
        "s = ParamStore(t, PATH, BadFlash())\n"
        "t.set_by_name('GAIN_P', 9.0)\n"
        "ok = s.service()\n"
    )
    assert mp.eval("ok") is False
    assert "read back different" in mp.eval("s.last_error")
    assert mp.eval("s.save_errors") == 1
    assert mp.eval("boot()") == ["main", "old"]


def test_a_save_waits_while_the_vehicle_may_not_write_and_says_so_once(tmp_path):
    # A change mid-dive takes effect in RAM at once; its flash save (a
    # 150 ms stall) waits until may_write() allows it, as the flight log's
    # flushes wait for the vehicle to be disarmed or still on the bottom.
    t = ParamTable(DECLS)
    store = ParamStore(t, str(tmp_path / "params.bin"))
    store.load()
    allowed = [False]
    holds = []
    store.may_write = lambda: allowed[0]
    store.on_hold = holds.append
    for value in (0.5, 0.75, 1.0):
        assert t.set_by_name("GAIN_I", value) == 0
        assert store.service() is False
    assert t.get(t.index("GAIN_I")) == 1.0                 # in force already
    assert store.saves == 0 and store.held and holds == [True]   # told once, not per change
    assert not (tmp_path / "params.bin").exists()
    allowed[0] = True
    assert store.service() is True
    assert store.saves == 1 and not store.held and holds == [True, False]
    b = ParamTable(DECLS)
    ParamStore(b, str(tmp_path / "params.bin")).load()
    assert b.get(b.index("GAIN_I")) == 1.0                  # the last value, saved once
    assert store.service() is False and holds == [True, False]
