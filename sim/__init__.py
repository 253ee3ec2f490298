"""Dynamics model, analyses and the software-in-the-loop twin (CPython, numpy)."""

import os as _os

# numba caches its compiled kernels (``cache=True``, sim/kernels.py and
# sim/twin/world.py) beside their modules unless told otherwise: inside an
# installed package those files outlive ``pip uninstall`` and make the
# package's folders namespace packages that shadow a later editable install.
# They go to the user's cache instead, the root tools/micropython/install.py
# installs the interpreter under. Here, because every module of this package
# that imports numba is imported after this one, and numba reads the
# variable when it is first imported.
_os.environ.setdefault("NUMBA_CACHE_DIR", _os.path.join(
    _os.environ.get("ROBORAY_CACHE") or _os.path.join(
        _os.environ.get("XDG_CACHE_HOME") or _os.path.expanduser("~/.cache"), "roboray"),
    "numba"))
# In it, a folder named by the kernels' sources, not by where they sit: a
# fresh clone or another install of the same source loads them instead of
# compiling them again (sim/numba_cache.py).
_os.environ.setdefault("NUMBA_CACHE_LOCATOR_CLASSES", ",".join([
    "roboray.sim.numba_cache.SourcesLocator", "UserProvidedCacheLocator", "InTreeCacheLocator",
    "UserWideCacheLocator", "IPythonCacheLocator", "ZipCacheLocator"]))
_numba = __import__("sys").modules.get("numba")
if _numba is not None:   # imported before us: tell it too (it reads the variables once)
    _numba.config.CACHE_DIR = _os.environ["NUMBA_CACHE_DIR"]
    _numba.config.CACHE_LOCATOR_CLASSES = _os.environ["NUMBA_CACHE_LOCATOR_CLASSES"]
