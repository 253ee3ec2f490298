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
_numba = __import__("sys").modules.get("numba")
if _numba is not None:   # imported before us: tell it too (it reads the variable once)
    _numba.config.CACHE_DIR = _os.environ["NUMBA_CACHE_DIR"]
