"""``gc`` for the twin on MicroPython's unix port: ``collect()`` collects at
every ``EVERY``-th call.

The firmware collects once a 10 ms slot (``firmware/scheduler.py``). On the
unix port that is a real mark and sweep of the firmware's ~220 kB of live
objects: 250 us with a 512 kB heap, 790 us with 16 MB (measured), more than
the rest of a slot's work there. In the twin, time does not pass while code
runs (``vclock``), so a collection changes nothing the firmware sees; only
the twin's speed. Collecting every hundredth call (once a simulated second)
keeps the garbage bounded (a slot leaves a few kilobytes: the estimator's
boxed floats) at a negligible cost. The WebAssembly port needs no such
thing: its collector frees nothing while a run is in progress (measured:
garbage made and collected inside one ``exec`` stays allocated until the
next), so ``gc.collect()`` there costs ~2 us.

Installed as ``sys.modules['gc']`` before the firmware is imported
(``runner.MicroPythonUnixBoard``); everything but ``collect`` is the real
module's.
"""

import gc as _gc

EVERY = 100

_calls = 0


def collect():
    global _calls
    _calls += 1
    if _calls >= EVERY:
        _calls = 0
        _gc.collect()


mem_alloc = _gc.mem_alloc
mem_free = _gc.mem_free
enable = _gc.enable
disable = _gc.disable
isenabled = _gc.isenabled
threshold = _gc.threshold
