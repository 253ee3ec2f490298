"""Parameter documentation (``shared/param_meta.py``): one entry for each
declared parameter, nothing else, and none of it on the board's heap."""

from __future__ import annotations

import ast

from roboray.firmware.app import PARAMS
from roboray.shared.param_meta import META, UNITS
from roboray.tools.boardcheck import board_files


def test_every_declared_parameter_has_metadata_and_every_entry_is_declared():
    declared = [d[0] for d in PARAMS]
    assert declared and len(declared) == len(set(declared))       # each once
    assert sorted(META) == sorted(declared)


def test_metadata_is_complete_and_consistent_with_the_declarations():
    decls = {d[0]: d for d in PARAMS}
    for name, (display, unit, description, values, user) in META.items():
        assert display and description.endswith("."), name
        assert unit == "" or unit in UNITS, (name, unit)
        assert user in ("Standard", "Advanced"), name
        lo, hi = decls[name][3], decls[name][4]
        codes = [code for code, _ in values]
        assert codes == sorted(set(codes)), name
        assert all(lo <= code <= hi and code == int(code) for code in codes), (name, codes)
        assert all(label for _, label in values), name
    # a parameter that takes codes lists each one its range allows (failsafe actions: 0..3)
    assert [c for c, _ in META["FS_GCS_ENABLE"][3]] == [0, 1, 2, 3]


def test_board_code_never_imports_the_metadata():
    importers = []
    for path in board_files():
        if path.name == "param_meta.py":
            continue
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [(node.module or "") + "." + a.name for a in node.names]
            if any("param_meta" in n for n in names):
                importers.append(str(path))
    assert importers == []
