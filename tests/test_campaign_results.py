"""A campaign's results file and the runner's bookkeeping (sim/campaign):
rows read back bit for bit, a resume takes what is there, a torn line is
redone, another campaign's file is refused; the same rows on this process
and on a pool of two."""

from __future__ import annotations

import csv
import math
import os

import numpy as np
import pytest

from roboray.sim.campaign import Campaign, InProcess, ProcessPool, ResultsError, ResultsFile, read_rows, run
from roboray.sim.campaign.results import header

COLUMNS = [("x", "float"), ("tiny", "float"), ("n", "int"), ("ok", "bool"), ("label", "str"), ("maybe", "float")]
CALLS: list = []


def draw_row(index: int) -> dict:
    """A task of the index alone: numbers a decimal round trip would spoil."""
    CALLS.append(index)
    rng = np.random.default_rng([11, index])
    x = float(rng.standard_normal()) / 3.0
    return {"x": x, "tiny": x * 1e-300, "n": index * 7, "ok": x > 0, "label": "run %d, \"quoted\"" % index,
            "maybe": None if index % 3 == 0 else 0.1 + 0.2 * index}


def campaign(tasks: int = 6, **params) -> Campaign:
    return Campaign("test", dict({"seed": 11}, **params), list(range(tasks)), draw_row, COLUMNS)


def rows_of(path) -> list:
    return read_rows(str(path))[1]


def test_rows_read_back_bit_for_bit_by_the_csv_module(tmp_path):
    path = tmp_path / "r.csv"
    out = run(campaign(), InProcess(), results=str(path))
    assert [r["n"] for r in out.rows] == [0, 7, 14, 21, 28, 35]
    back = rows_of(path)
    assert [r.pop("run") for r in back] == list(range(6))
    assert back == out.rows == [draw_row(i) for i in range(6)]   # floats equal, not close
    with open(path, newline="") as f:
        first = f.readline()
        assert first.startswith("# roboray-campaign ") and '"kind":"test"' in first and '"seed":11' in first
        plain = list(csv.DictReader(f))
    assert plain[0]["maybe"] == "" and plain[1]["ok"] in ("true", "false") and float(plain[2]["x"]) == out.rows[2]["x"]
    summary = tmp_path / "r.summary.json"
    assert not summary.exists()   # the command writes its summary, the runner only rows


def test_pandas_and_polars_read_it_when_installed(tmp_path):
    path = tmp_path / "r.csv"
    out = run(campaign(3), InProcess(), results=str(path))
    readers = 0
    try:
        import pandas
    except ImportError:
        pass
    else:
        frame = pandas.read_csv(path, comment="#")
        assert list(frame["x"]) == [r["x"] for r in out.rows]
        readers += 1
    try:
        import polars
    except ImportError:
        pass
    else:
        frame = polars.read_csv(path, comment_prefix="#")
        assert frame["x"].to_list() == [r["x"] for r in out.rows]
        readers += 1
    if not readers:
        pytest.skip("neither pandas nor polars is installed here: the csv module's reading is tested above")


def test_a_resume_runs_only_what_is_missing_and_drops_a_torn_line(tmp_path):
    whole = tmp_path / "whole.csv"
    run(campaign(), InProcess(), results=str(whole))
    part = tmp_path / "part.csv"
    # a campaign stopped after runs 4, 1 and 0 (finishing order), the
    # power cut in the middle of run 3's line
    store = ResultsFile(str(part), header("test", {"seed": 11}, COLUMNS))
    store.open(6)
    for i in (4, 1, 0):
        store.append(i, draw_row(i))
    store.close()
    line3 = store._line(3, draw_row(3))
    with open(part, "a") as f:
        f.write(line3[:len(line3) // 2])
    notices: list = []
    CALLS.clear()
    out = run(campaign(), InProcess(), results=str(part), notice=notices.append,
              started=lambda total, present: notices.append((total, present)))
    assert sorted(CALLS) == [2, 3, 5]            # only the missing runs, the torn one among them
    assert (6, 3) in notices
    assert any("cut short" in n and "redone" in n for n in notices if isinstance(n, str)), notices
    assert out.stats["present"] == 3 and out.stats["ran"] == 3
    assert part.read_bytes() == whole.read_bytes()   # rewritten in index order: the same file
    CALLS.clear()
    again = run(campaign(), InProcess(), results=str(part))
    assert CALLS == [] and again.rows == out.rows and again.stats["ran"] == 0


def test_another_campaigns_file_is_refused_untouched(tmp_path):
    path = tmp_path / "r.csv"
    run(campaign(3), InProcess(), results=str(path))
    before = path.read_bytes()
    with pytest.raises(ResultsError, match=r"another test campaign \(seed 11 there, 12 here\)"):
        run(campaign(3, seed=12), InProcess(), results=str(path))
    with pytest.raises(ResultsError, match="holds a test campaign, not other"):
        run(Campaign("other", {"seed": 11}, [0], draw_row, COLUMNS), InProcess(), results=str(path))
    other = tmp_path / "notes.csv"
    other.write_text("a,b\n1,2\n")
    with pytest.raises(ResultsError, match="not a roboray campaign's results file"):
        run(campaign(3), InProcess(), results=str(other))
    assert path.read_bytes() == before and other.read_text() == "a,b\n1,2\n"


def test_a_damaged_line_in_the_middle_stops_the_resume(tmp_path):
    path = tmp_path / "r.csv"
    run(campaign(4), InProcess(), results=str(path))
    lines = path.read_text().splitlines(keepends=True)
    lines[3] = "1,not a number\n"
    path.write_text("".join(lines))
    with pytest.raises(ResultsError, match="line 4 is not a row of this campaign"):
        run(campaign(4), InProcess(), results=str(path))
    assert path.read_text() == "".join(lines)


def test_a_row_that_does_not_match_the_columns_is_a_bug_said_plainly(tmp_path):
    bad = Campaign("test", {}, [0], draw_row, COLUMNS[:-1])
    with pytest.raises(ValueError, match=r"unexpected \['maybe'\]"):
        run(bad, InProcess(), results=str(tmp_path / "r.csv"))


def test_parquet_from_its_journal(tmp_path):
    pytest.importorskip("pyarrow", reason="pyarrow is the optional 'parquet' extra; CSV is tested without it")
    path = tmp_path / "r.parquet"
    out = run(campaign(), InProcess(), results=str(path))
    assert not os.path.exists(str(path) + ".part")
    head, back = read_rows(str(path))
    assert head["kind"] == "test" and [r.pop("run") for r in back] == list(range(6))
    assert back == out.rows
    # a crash leaves the journal: the resume continues from it
    part = tmp_path / "p.parquet"
    store = ResultsFile(str(part), header("test", {"seed": 11}, COLUMNS))
    store.open(6)
    store.append(2, draw_row(2))
    store.close()
    assert not part.exists() and os.path.exists(str(part) + ".part")
    CALLS.clear()
    run(campaign(), InProcess(), results=str(part))
    assert sorted(CALLS) == [0, 1, 3, 4, 5] and read_rows(str(part))[1] == read_rows(str(path))[1]


def test_two_local_processes_give_the_rows_of_one(tmp_path):
    one = run(campaign(8), InProcess(), results=str(tmp_path / "one.csv"))
    with ProcessPool(2) as pool:
        assert len(pool.pids()) == 2
        two = run(campaign(8), pool, results=str(tmp_path / "two.csv"))
    assert two.rows == one.rows and two.stats["workers"] == 2
    assert (tmp_path / "one.csv").read_bytes() == (tmp_path / "two.csv").read_bytes()
    assert math.isfinite(two.stats["task_cpu_s"]) and two.stats["wall_s"] > 0
