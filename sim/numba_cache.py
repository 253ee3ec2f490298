"""Where numba keeps this package's compiled kernels: a folder named by their sources.

numba caches a ``cache=True`` kernel under ``NUMBA_CACHE_DIR`` (the user's
cache: ``sim/__init__.py``) in a folder named by a hash of the *folder its
source file sits in*. Each clone, each virtual environment and each
``pip install`` put the same source in another folder, so each compiled
the kernels again (about 30 s on two cores, at every fresh clone's first
test session) and left 2-4 MB more in the cache: 66 folders, 145 MB on the
development machine (2026-12-05).

Here the folder is named by the module and a hash of its *sources*: the
module's file and every module of this package it imports, followed
through their imports (a kernel freezes the globals it reads, such as
``dynamics.POS``, as constants: a change there must compile it again, which
numba's own check, a hash of the kernel's file alone, does not see). Two
checkouts of one source share their kernels (numba 0.68 stamps a source
by a hash of its contents, not its time); a changed source gets a
folder of its own, so two versions in use at once (a clone under test
beside an edited working tree) never overwrite each other's. numba still
checks the file's hash, its own version and the CPU before it loads
anything.

``sim/__init__.py`` names ``SourcesLocator`` first in
``NUMBA_CACHE_LOCATOR_CLASSES`` (numba 0.62 and later read it; an older one
ignores it and caches as before); numba imports this module when the first
``@njit(cache=True)`` is applied, so importing ``roboray.sim`` does not
import numba. Kernels of other packages go on to numba's own locators.
"""

from __future__ import annotations

import ast
import hashlib
import os
from functools import lru_cache

from numba.core import config
from numba.core.caching import UserProvidedCacheLocator

_PACKAGE = "roboray.sim"
#: The package's folder: only kernels defined under it are placed here.
_ROOT = os.path.dirname(os.path.abspath(__file__))


def _module_file(name: str, root: str) -> str | None:
    """The source file of package module ``name`` (``roboray.sim.x.y``) under ``root``, if it exists."""
    if name != _PACKAGE and not name.startswith(_PACKAGE + "."):
        return None
    base = os.path.join(root, *name[len(_PACKAGE) + 1:].split(".")) if name != _PACKAGE else root
    for path in (base + ".py", os.path.join(base, "__init__.py")):
        if os.path.isfile(path):
            return path
    return None


def _imports(path: str, root: str) -> list[str]:
    """The package modules ``path`` (under ``root``) imports (absolute names, relative ones resolved)."""
    with open(path, "rb") as f:
        tree = ast.parse(f.read(), path)
    rel = os.path.relpath(path, root)[:-3].replace(os.sep, ".")
    here = [_PACKAGE] + [p for p in rel.split(".") if p != "__init__"]
    if not path.endswith("__init__.py"):
        here = here[:-1]    # a module's package
    names = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = here[:len(here) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            names.append(base)
            # ``from roboray.sim.sensors import depth``: depth may be a module
            names += [base + "." + a.name for a in node.names]
    return names


@lru_cache(maxsize=None)
def sources_hash(path: str, root: str = _ROOT) -> str:
    """SHA-1 of ``path`` and every package module it imports, transitively
    (``root``: the package's folder), each by its place in the package."""
    seen = {}
    todo = [os.path.abspath(path)]
    while todo:
        p = todo.pop()
        if p in seen:
            continue
        with open(p, "rb") as f:
            seen[p] = f.read()
        for name in _imports(p, root):
            q = _module_file(name, root)
            if q is not None and q not in seen:
                todo.append(q)
    h = hashlib.sha1()
    for p in sorted(seen):
        h.update(os.path.relpath(p, root).replace(os.sep, "/").encode() + b"\0")
        h.update(hashlib.sha1(seen[p]).digest())
    return h.hexdigest()


def folder_name(path: str, root: str = _ROOT) -> str:
    """The cache folder of the kernels in ``path``: ``roboray.sim.kernels-<hash>``."""
    path = os.path.abspath(path)
    rel = os.path.relpath(path, root)[:-3].replace(os.sep, ".")
    return "%s.%s-%s" % (_PACKAGE, rel, sources_hash(path, root)[:20])


def _inside(py_file: str) -> bool:
    p = os.path.abspath(py_file)
    return p.endswith(".py") and os.path.commonpath([p, _ROOT]) == _ROOT


class SourcesLocator(UserProvidedCacheLocator):
    """This package's kernels under ``NUMBA_CACHE_DIR``, in a folder named by their sources."""

    def __init__(self, py_func, py_file):
        UserProvidedCacheLocator.__init__(self, py_func, py_file)
        self._cache_path = os.path.join(config.CACHE_DIR, folder_name(py_file))

    @classmethod
    def from_function(cls, py_func, py_file):
        if not config.CACHE_DIR or not _inside(py_file):
            return None     # not ours: numba's next locator
        return super().from_function(py_func, py_file)
