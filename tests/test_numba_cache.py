"""numba's cache of the dynamics kernels: one folder per source, not per checkout.

Every clone and every install used to compile the kernels again (about
30 s on two cores) into a folder of its own; the folder is now named by
the kernels' sources (sim/numba_cache.py).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from roboray.sim import numba_cache

SIM = Path(numba_cache.__file__).resolve().parent


def _copy(to: Path) -> Path:
    shutil.copytree(SIM, to, ignore=shutil.ignore_patterns("__pycache__"))
    return to


def test_two_checkouts_of_one_source_share_a_folder_and_a_change_gets_its_own(tmp_path):
    a, b = _copy(tmp_path / "a" / "sim"), _copy(tmp_path / "b" / "sim")
    for rel in ("kernels.py", "twin/world.py"):
        assert numba_cache.folder_name(str(a / rel), str(a)) == numba_cache.folder_name(str(b / rel), str(b))
    assert numba_cache.folder_name(str(a / "kernels.py"), str(a)).startswith("roboray.sim.kernels-")
    # world's kernels freeze dynamics' constants: a change there is a change of
    # world's kernels, while kernels.py (which imports nothing of ours) keeps its folder
    dyn = b / "dynamics.py"
    dyn.write_text(dyn.read_text() + "\n# changed\n")
    numba_cache.sources_hash.cache_clear()
    assert numba_cache.folder_name(str(a / "twin/world.py"), str(a)) != \
        numba_cache.folder_name(str(b / "twin/world.py"), str(b))
    assert numba_cache.folder_name(str(a / "kernels.py"), str(a)) == \
        numba_cache.folder_name(str(b / "kernels.py"), str(b))


def test_the_kernels_are_cached_in_the_folder_named_by_their_sources(tmp_path):
    # a process of its own: numba reads its configuration once, at import
    env = dict(os.environ)
    env.pop("NUMBA_CACHE_LOCATOR_CLASSES", None)
    env["ROBORAY_CACHE"] = str(tmp_path)
    env.pop("NUMBA_CACHE_DIR", None)
    code = ("from roboray.sim import kernels, numba_cache\n"
            "from roboray.sim.twin import world\n"
            "for f, m in ((kernels.rk4_one, kernels), (world._advance, world)):\n"
            "    print(f._cache._cache_path, numba_cache.folder_name(m.__file__))\n")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120,
                         check=True).stdout.split()
    assert len(out) == 4
    for path, name in zip(out[0::2], out[1::2]):
        assert path == str(tmp_path / "numba" / name)
