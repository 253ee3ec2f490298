"""The MicroPython interpreter the tests run board code on, and its helpers."""

from __future__ import annotations

import math

import pytest

from roboray.tools.micropython import (
    MicroPython,
    MicroPythonError,
    assert_close_f32,
    check_same,
    differences,
)


def test_interpreter_is_real_micropython(micropython):
    micropython.exec("import sys")
    assert micropython.eval("sys.implementation.name") == "micropython"
    assert micropython.version.startswith("1.29")


def test_board_module_is_installed_under_package_path(micropython):
    assert micropython.eval("__import__('roboray.shared.quat').shared.quat.__name__") == "roboray.shared.quat"
    micropython.exec("import roboray.shared.quat as quat")
    assert micropython.eval("quat.__file__") == "/lib/roboray/shared/quat.py"


def test_board_module_runs_the_same_on_both(micropython):
    micropython.exec(
        "import math\nfrom array import array\nimport roboray.shared.quat as quat\n"
        "def spin(wx, wy, wz, dt, n):\n"
        "    q = array('f', [1.0, 0.0, 0.0, 0.0])\n"
        "    for _ in range(n):\n"
        "        quat.integrate(q, wx, wy, wz, dt)\n"
        "    e = array('f', [0.0, 0.0, 0.0])\n"
        "    quat.to_euler(e, q)\n"
        "    return [list(q), list(e)]\n"
    )
    from array import array

    import roboray.shared.quat as quat

    q = array("f", [1.0, 0.0, 0.0, 0.0])
    for _ in range(100):
        quat.integrate(q, 0.0, 0.0, 0.5, 0.01)
    e = array("f", [0.0, 0.0, 0.0])
    quat.to_euler(e, q)
    on_mp = micropython.eval("spin(0.0, 0.0, 0.5, 0.01, 100)")
    assert_close_f32([list(q), list(e)], on_mp)
    # half a radian of yaw after 1 s at 0.5 rad/s: the module really ran
    assert on_mp[1][2] == pytest.approx(0.5, abs=1e-5)


def test_check_same_calls_a_board_function_on_both(micropython):
    result = check_same(micropython, "roboray.shared.quat:tilt", [math.cos(0.2), math.sin(0.2), 0.0, 0.0])
    assert result == pytest.approx(0.4, abs=1e-6)


def test_micropython_exception_carries_its_traceback(micropython):
    micropython.exec("def boom(x):\n    raise ValueError('bad value %d' % x)\n")
    with pytest.raises(MicroPythonError) as info:
        micropython.exec("boom(7)")
    assert info.value.type_name == "ValueError"
    assert "bad value 7" in info.value.traceback
    assert "in boom" in info.value.traceback


def test_cross_interpreter_helper_catches_a_real_difference():
    # 1e-4 relative is far beyond float32 rounding: must be reported
    assert differences([1.0, 2.0, {"a": 3.0}], [1.0, 2.0002, {"a": 3.0}])
    with pytest.raises(AssertionError, match=r"result\[1\]"):
        assert_close_f32([1.0, 2.0], [1.0, 2.0002])
    # a float32 rounding difference is not
    assert_close_f32([0.1], [float.fromhex("0x1.99999ap-4")])
    assert differences([1.0], [1.0, 2.0]) == ["result: length 1 != 2"]
    assert differences(float("nan"), 1.0)


def test_allocation_helper_reports_zero_for_array_writes(micropython):
    setup = (
        "from array import array\n"
        "buf = array('i', [0] * 16)\n"
        "def fill(b, k):\n"
        "    for i in range(16):\n"
        "        b[i] = i * k + 3\n"
    )
    assert micropython.alloc_bytes("fill(buf, 5)", setup) == 0
    assert micropython.eval("list(buf)")[15] == 15 * 5 + 3


def test_allocation_helper_sees_a_list_being_built(micropython):
    setup = "def build(n):\n    return [i for i in range(n)]\n"
    assert micropython.alloc_bytes("build(16)", setup) >= 16 * 4


def test_hostlink_reaches_the_python_side():
    seen = []

    def answer(text: str) -> str:
        seen.append(text)
        return text.upper()

    with MicroPython(on_request=answer) as mp:
        mp.exec("import hostlink")
        assert mp.eval("[hostlink.request('step %d' % i) for i in range(3)]") == ["STEP 0", "STEP 1", "STEP 2"]
    assert seen == ["step 0", "step 1", "step 2"]


def test_hostlink_answers_ahead_as_the_twin_pipelines():
    # answer k is sent on request k-1 (the first with the code): request k
    # reads it; None sends nothing, so the answers stay one ahead
    seen = []

    def answer(text: str):
        seen.append(text)
        k = int(text.split()[1])
        return None if k == 2 else "for %d" % (k + 1)

    with MicroPython(on_request=answer) as mp:
        mp.exec("import hostlink")
        out = mp.exec("print([hostlink.request('step %d' % i) for i in range(3)])", replies=["for 0"])
        assert out.strip() == "['for 0', 'for 1', 'for 2']"
        assert seen == ["step 0", "step 1", "step 2"]
        # an answer sent ahead that the code never asked for is dropped with
        # the code's end, not read as the next command
        assert mp.exec("print('next')", replies=["unread"]).strip() == "next"
        mp.on_request = lambda text: text.upper()
        assert mp.eval("hostlink.request('again')") == "AGAIN"


def test_files_round_trip(micropython):
    micropython.write_file("/tmp/data.bin", bytes(range(256)))
    assert micropython.read_file("/tmp/data.bin") == bytes(range(256))
    with pytest.raises(FileNotFoundError):
        micropython.read_file("/tmp/missing.bin")


def test_linecount_counts_lines_and_calls_per_function():
    from roboray.tools.micropython import linecount

    with MicroPython(variant="settrace") as mp:
        mp.exec("def add(n):\n    s = 0\n    for i in range(n):\n        s += i\n    return s\n")
        linecount.start(mp)
        mp.exec("add(10)\nadd(10)")
        counts = linecount.stop(mp)
        mp.exec("add(10)")   # stopped: not counted
        assert linecount.stop(mp) == counts
    lines, calls = counts["<stdin>:add"]
    assert calls == 2
    # the body's line events: at least s = 0, ten additions and the return, each call
    assert 2 * 12 <= lines <= 2 * 26
    s = linecount.summary(counts, per=2)
    assert s["top"][0] == {"function": "<stdin>:add", "lines": lines / 2, "calls": 1.0}


def test_linecount_needs_the_settrace_build(micropython):
    from roboray.tools.micropython import linecount

    with pytest.raises(RuntimeError, match="settrace"):
        linecount.start(micropython)


def test_board_code_boots_compiled_as_a_board_does(tmp_path, monkeypatch):
    # .mpy from mpy-cross (bytecode only), cached by content, tracebacks
    # naming the board path as the source's would
    monkeypatch.setenv("ROBORAY_CACHE", str(tmp_path))
    from roboray.tools.micropython.mpycache import compiled

    src = tmp_path / "boom.py"
    src.write_text("def f():\n    return 1 // 0\n")
    first = compiled(src, "/lib/boom.py")
    assert first[:1] == b"M" and compiled(src, "/lib/boom.py") == first
    assert len(list((tmp_path / "mpy").glob("*.mpy"))) == 1
    with MicroPython() as mp:
        mp.write_file("/lib/boom.mpy", first)
        with pytest.raises(MicroPythonError) as err:
            mp.exec("import boom\nboom.f()")
    assert 'File "/lib/boom.py", line 2, in f' in err.value.traceback
