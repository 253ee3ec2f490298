"""``roboray-flash logs``: the board's flight logs copied over USB with the flashing transport
(mpremote's serial transport against the virtual board), checked by hash, the ones already here skipped."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from roboray.tools.micropython.virtual_board import VirtualBoard


def flash(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "roboray.tools.flash.cli", *args], capture_output=True,
                          text=True, timeout=180, cwd=cwd)


def test_logs_are_copied_whole_then_skipped_and_a_missing_number_is_named(tmp_path):
    fs = tmp_path / "fs"
    (fs / "logs").mkdir(parents=True)
    logs = {
        "00000001.BIN": bytes(range(256)) * 40 + b"\xa3\x95",      # ~10 kB, not a multiple of a chunk
        "00000002.BIN": os.urandom(20_000),
    }
    for name, data in logs.items():
        (fs / "logs" / name).write_bytes(data)
    (fs / "logs" / "LASTLOG.TXT").write_text("2\r\n")
    out = tmp_path / "here"
    with VirtualBoard(fs_dir=fs) as vb:
        r = flash("logs", "--port", vb.device, "--out", str(out), "--json")
        assert r.returncode == 0, r.stderr
        rep = json.loads(r.stdout)
        assert rep["copied"] == sorted(logs) and rep["skipped"] == [] and rep["bytes"] == 30_242
        for name, data in logs.items():
            assert (out / name).read_bytes() == data
        assert not list(out.glob("*.part"))
        again = json.loads(flash("logs", "--port", vb.device, "--out", str(out), "--json").stdout)
        assert again["copied"] == [] and again["skipped"] == sorted(logs)
        r = flash("logs", "7", "--port", vb.device, "--out", str(out))
        assert r.returncode == 1 and "not on the board: 00000007.BIN" in r.stderr
        assert "Traceback" not in r.stderr
