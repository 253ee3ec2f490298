"""A virtual clock with the board's ``time`` API: simulated time, in lockstep.

The twin puts this module into ``sys.modules['time']`` before it imports the
firmware (MicroPython's built-in ``time`` cannot be shadowed by a file, but a
``sys.modules`` entry wins), so the firmware's own ``import time`` gets it and
runs unchanged. Time stands still while code runs and moves only when the
firmware sleeps (or the twin calls ``advance``): a run is deterministic and
goes as fast as the computer allows.

Firmware side, as on an rp2 board: ``ticks_us``, ``ticks_ms``, ``ticks_cpu``,
``ticks_diff``, ``ticks_add``, ``sleep``, ``sleep_ms``, ``sleep_us``,
``time``, ``time_ns``, ``gmtime``, ``localtime``, ``mktime``. Ticks wrap at
2**30 as MicroPython's do on the boards, so wrap-around bugs show up here too
(``reset(start_us=...)`` starts the clock just before a wrap).

Twin side:

- ``set_hook(fn)``: ``fn(dt_us)`` is called every time simulated time moves
  forward, after it moved (``ticks_us()`` inside the hook is already the new
  time). The lockstep twin steps the dynamics there and feeds the emulated
  devices; a hook may raise (the emulated watchdog does, to reset the board).
- ``advance(dt_us)``: move time forward from outside the firmware.
- ``set_tick_cost_us(n)``: every ``ticks_us``/``ticks_ms``/``ticks_cpu`` call
  also advances time by ``n`` us, so a loop that polls the clock without
  sleeping still makes progress (0, the default, is free code).
- ``set_cpu(fn)``: the board's compute time: ``fn()`` returns the
  microseconds of work the board's CPU has done so far (wrapping at 2**30);
  every clock reading first moves time on by the work done since the last
  one, so code takes time as on the chip (``boardtime.py``: the emulated
  RP2350's instruction count, or the calibrated model). None: code is free;
- ``elapsed_us()``: simulated time since ``reset``, not wrapped;
- ``wall_us()``: the host's real clock in microseconds (wrapping as its
  ticks do), for the twin's measurements of its own speed;
- ``now_us`` and ``tick_cost_us``: the state behind ``ticks_us()``, for the
  emulated peripherals, which read the clock on every transfer: ``now_us if
  not tick_cost_us else ticks_us()`` is ``ticks_us()`` without the cost of a
  Python call (read them as ``vclock.now_us``: they are rebound as time moves).

On MicroPython, ``ticks_diff`` and ``ticks_add`` are the interpreter's own
(native, and the same arithmetic when its ticks also wrap at 2**30, which
the import checks); on CPython they are written out here, with rp2's check
that an interval fits in half the period (``OverflowError``).

Everything here is small-integer arithmetic: nothing allocates on a 31-bit
small-int build except ``time`` and ``time_ns`` (whose values exceed 2**30,
as on the board) and ``elapsed_us`` after about 18 minutes.
"""

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

import time as _host_time  # the real module, kept for calendar conversions

_TICKS_PERIOD = const(0x40000000)
_TICKS_MAX = const(0x3FFFFFFF)
_TICKS_HALF = const(0x20000000)
_US_PER_S = const(1000000)
#: Longest single step: sleeps longer than this are cut into steps so no
#: product leaves the small integers (the hook sees each step).
_MAX_STEP_US = const(1000000)

#: ``time.time()`` at ``reset()``: 2021-01-01 00:00:00 UTC, where an rp2
#: board's clock starts when nothing set it.
EPOCH_S = 1609459200

now_us = 0       # ticks_us, wrapped at 2**30
_ms = 0          # ticks_ms, wrapped at 2**30
_ms_frac = 0     # microseconds into the current millisecond
_epoch = EPOCH_S  # time.time() at reset (above 2**30: kept out of the step)
_s_frac = 0      # microseconds into the current second
_elapsed_s = 0   # whole seconds since reset
_hook = None
tick_cost_us = 0
_cpu = None      # the board's compute clock (set_cpu), or None: code is free
_cpu_last = 0    # its reading when time last caught up with it


def reset(start_us=0, epoch_s=EPOCH_S):
    """Back to a fresh board: ticks at ``start_us``, wall clock at ``epoch_s``."""
    global now_us, _ms, _ms_frac, _epoch, _s_frac, _elapsed_s
    now_us = start_us & _TICKS_MAX
    _ms = (start_us // 1000) & _TICKS_MAX
    _ms_frac = start_us % 1000
    _epoch = epoch_s
    _s_frac = 0
    _elapsed_s = 0


def set_hook(fn):
    """Install ``fn(dt_us)``, called after every advance of time (None removes it)."""
    global _hook
    _hook = fn


def set_cpu(fn):
    """Charge the board's compute time: ``fn()`` -> work done so far, us
    (wrapping at 2**30); None: code costs no time."""
    global _cpu, _cpu_last
    _cpu = fn
    _cpu_last = fn() if fn is not None else 0


def catch_up():
    """Move time on by the board's work since the last reading (``set_cpu``)."""
    global _cpu_last
    if _cpu is None:
        return
    b = _cpu()
    d = (b - _cpu_last) & _TICKS_MAX
    if d:
        _cpu_last = b   # first: the hook may read the clock again
        sleep_us(d)


def set_tick_cost_us(us):
    """Time every clock reading costs (0: readings are free)."""
    global tick_cost_us
    if us < 0:
        raise ValueError("tick cost must be >= 0 us, got %d" % us)
    tick_cost_us = us


def advance(dt_us):
    """Move simulated time forward by ``dt_us`` (>= 0) and run the hook."""
    if dt_us < 0:
        raise ValueError("time cannot go back: advance(%d)" % dt_us)
    sleep_us(dt_us)


def elapsed_us():
    """Simulated microseconds since ``reset()`` (a big integer after ~18 min)."""
    return _elapsed_s * _US_PER_S + _s_frac


def _perf_counter_us():
    return (_host_time.perf_counter_ns() // 1000) & _TICKS_MAX


#: The host's real clock, us (MicroPython's ticks_us, or CPython's
#: perf_counter wrapped the same way): the twin's stopwatch.
wall_us = getattr(_host_time, "ticks_us", _perf_counter_us)


# ----------------------------------------------------------- board's API
def ticks_us():
    if _cpu is not None:
        catch_up()
    if tick_cost_us:
        advance(tick_cost_us)
    return now_us


def ticks_ms():
    if _cpu is not None:
        catch_up()
    if tick_cost_us:
        advance(tick_cost_us)
    return _ms


def ticks_cpu():
    if _cpu is not None:
        catch_up()
    if tick_cost_us:
        advance(tick_cost_us)
    return now_us


def _ticks_diff(a, b):
    return ((a - b + _TICKS_HALF) & _TICKS_MAX) - _TICKS_HALF


def _ticks_add(t, delta):
    if not -_TICKS_HALF < delta < _TICKS_HALF:
        raise OverflowError("ticks interval overflow")
    return (t + delta) & _TICKS_MAX


# The firmware calls these dozens of times a 20 ms frame; the interpreter's
# own are native calls, several times cheaper than Python functions.
ticks_diff = _ticks_diff
ticks_add = _ticks_add
if hasattr(_host_time, "ticks_add"):
    if _host_time.ticks_add(_TICKS_MAX, 1) == 0 and _host_time.ticks_diff(0, _TICKS_MAX) == 1:
        ticks_diff = _host_time.ticks_diff
        ticks_add = _host_time.ticks_add


def sleep_us(us):
    # advance() and the firmware's sleeps: the step written out here, one
    # Python call a sleep (the scheduler sleeps once a slot).
    global now_us, _ms, _ms_frac, _s_frac, _elapsed_s
    while us > 0:
        dt = us if us < _MAX_STEP_US else _MAX_STEP_US
        us -= dt
        now_us = (now_us + dt) & _TICKS_MAX
        f = _ms_frac + dt
        _ms = (_ms + f // 1000) & _TICKS_MAX
        _ms_frac = f % 1000
        f = _s_frac + dt
        _elapsed_s += f // _US_PER_S
        _s_frac = f % _US_PER_S
        if _hook is not None:
            _hook(dt)


def sleep_ms(ms):
    while ms > 1000:
        sleep_us(_MAX_STEP_US)
        ms -= 1000
    if ms > 0:
        sleep_us(ms * 1000)


def sleep(seconds):
    whole = int(seconds)
    sleep_ms(whole * 1000)
    advance(int((seconds - whole) * _US_PER_S))


def time():
    return _epoch + _elapsed_s


def time_ns():
    return (_epoch + _elapsed_s) * 1000000000 + _s_frac * 1000


def gmtime(secs=None):
    return _host_time.gmtime(time() if secs is None else secs)


def localtime(secs=None):
    return _host_time.localtime(time() if secs is None else secs)


def mktime(t):
    return _host_time.mktime(t)
