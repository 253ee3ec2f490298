"""The fixed-rate main loop: tasks at their periods, overruns counted.

The loop runs in slots of ``period_ms`` (10 ms, 100 Hz) on a fixed grid:
slot k starts at ``t0 + k * period``. Each task runs every ``n`` slots
(its period over the loop's) at a phase, so work can be spread (the depth
sensor on odd slots, control on even ones). Which tasks are due in a slot
is looked up in a table built when tasks are added (one entry a slot over
the periods' least common multiple, at most 1000 slots). A slot runs its
due tasks in the order they were added, then its collector (``collect``:
``gc.collect()`` by default, so a collection never lands in the middle of
a task; ``False``: none, when the application schedules the collection
as a task of its own), then feeds the watchdog if the loop is healthy,
then sleeps to the next slot.

A slot whose work ends after the next slot began is an overrun: the next
slot starts at once, late; slots that passed entirely are skipped (counted
in ``skipped``) and the slot counter jumps past them, so every task stays
on its wall-clock grid. The watchdog is fed only when no task raised in
this slot, fewer than ``overrun_limit`` slots in a row overran and
``health()`` (if given: the failsafes' veto) says yes; a loop that locks
up or limps stops feeding it and the board resets.

The clock is injected: the ``time`` module on the board, the twin's virtual
clock in simulation (its ``sleep_us`` is where simulated time moves).
Adding a task is one line: ``sched.add("control", ctrl.step, 20)``. A task
is called with no arguments; ``now_us``/``now_ms`` hold the slot's start.
A slot allocates nothing of its own; ``report()`` (a string) does.

A task about to stall the chip on purpose (a flash write: erasing a 4 kB
sector of the Pico 2's flash suspends execution for ~45 ms) says so first
with ``expect_delay_ms(ms)``, as ArduPilot's ``expect_delay_ms``: a slot
that ends late within what was announced is counted in ``stalls``, not as
an overrun, so neither the overrun failsafe nor the watchdog's hunger
takes a planned stall for a loop in trouble; the slots it spanned, and
the one it ended in, are counted in ``skipped``, and the loop resumes on
its grid at the next slot's start. That slot runs only the tasks due
every slot and on no budget (``deferred`` counts the others it passed
over, which wait for their next turn; one on a budget takes its next slot
if it fits there, as always): it also pays for the stall (the IMU's FIFO holds the
samples of the slots skipped, the radio's buffer their bytes), and with
the 50 Hz controller on top it overran on the emulated Pico 2 (nav 5 ms
after a collection's 40 ms, link 1.3 ms, control 3.2 ms). AP_Scheduler
likewise runs a task only if it fits the time left. A task that is a
planned stall itself (``add(..., stall_ms=)``: the collection) is
announced before each call, and its slot runs only it and the tasks due
every slot on no budget (nav): the others due then wait for their next
turn (``deferred`` counts them too). Nav stays in it: without it, the
step after the stall read one slot more of the IMU's FIFO and, with a
fix to fuse, took 10 ms on the emulated Pico 2 (an overrun). When another
stall skips the slot such a task was due in, it is owed and runs at the
end of the next slot that does not follow a stall and has its phase's
parity: a collection missed for a flash save's 100 ms let the heap fill
until an allocation in nav collected, unannounced and in no particular
order (62 ms, an overrun).

Timing costs one clock reading a task: a task's time runs from the reading
that ended the one before it (the slot's start for the first), so it
includes its share of the dispatch, a few microseconds; the collection is
timed from the last task's end, and its end is the slot's. Tick differences
are taken inline, modulo 2**30 as ``time.ticks_diff`` does on MicroPython
(its tick period, or a multiple of it), which saves a call each.
"""

import gc
from array import array

try:
    from micropython import const
except ImportError:  # CPython
    def const(x):
        return x

_MAX_TASKS = const(16)
_TICKS_MAX = const(0x3FFFFFFF)
_TICKS_HALF = const(0x20000000)
# The due-task table has one entry a slot over the tasks' common period;
# 1000 slots (10 s at 100 Hz) bounds it at 4 kB of references.
_MAX_PLAN_SLOTS = const(1000)


def _gcd(a, b):
    while b:
        a, b = b, a % b
    return a


class Scheduler:
    """Fixed-rate loop.

    Parameters
    ----------
    clock:
        Object with ``ticks_us``, ``ticks_ms``, ``ticks_diff``, ``ticks_add``
        and ``sleep_us`` (the ``time`` module).
    period_ms:
        Slot length: the fastest task's period.
    wdt:
        Watchdog (``machine.WDT``) to feed, or None.
    overrun_limit:
        Consecutive overrunning slots after which the watchdog goes hungry.
    health:
        Optional callable; the watchdog is fed only while it returns True.
    reset_cause:
        ``machine.reset_cause()`` at boot, kept for the reports.
    collect:
        The collector to run at the end of every slot (``gc.collect``);
        ``False``: none (the application collects in a task).
    """

    def __init__(self, clock, period_ms=10, wdt=None, overrun_limit=25, health=None, reset_cause=0,
                 collect=None):
        if period_ms < 1:
            raise ValueError("scheduler period_ms must be >= 1, got %r" % (period_ms,))
        self._clock = clock
        self.period_us = period_ms * 1000
        self.wdt = wdt
        self.overrun_limit = overrun_limit
        self.health = health
        self.reset_cause = reset_cause
        self._collect = gc.collect if collect is None else (collect or None)
        self.names = []
        self._fns = []
        self._every = array("H", [0] * _MAX_TASKS)
        self._phase = array("H", [0] * _MAX_TASKS)
        self._budget = array("l", [0] * _MAX_TASKS)
        self._stall_ms = array("H", [0] * _MAX_TASKS)
        self._held = bytearray(_MAX_TASKS)   # deferred in its last due slot
        # a planned-stall task due in a slot another stall skipped: run in
        # the next slot that is not the one after a stall
        self._owed = bytearray(_MAX_TASKS)
        self._owing = False
        # a task on a budget starts only if the slot's work then ends by
        # 90 % of the period: the 9 ms a 10 ms slot is held to (issue 15),
        # with the clock's own jitter and the sleep inside the rest
        self._limit_us = period_ms * 900
        #: Per task: runs, longest run (us), exceptions raised.
        self.runs = array("l", [0] * _MAX_TASKS)
        self.task_max_us = array("l", [0] * _MAX_TASKS)
        self.task_errors = array("l", [0] * _MAX_TASKS)
        self.last_errors = [None] * _MAX_TASKS
        self._n = 0
        # _plan[slot % _plan_slots]: the tasks due in that slot, in the order
        # added. Built by add(), so a slot neither tests every task's phase
        # (a modulo each) nor visits tasks that are not due.
        self._plan_slots = 1
        self._plan = [()]
        # per slot of the plan: task calls a planned stall's slot passes over
        self._passed = bytearray(1)
        self._planned = 0   # tasks in _plan: it is rebuilt when tasks were added
        self.slot = 0
        self.cycles = 0
        self.overruns = 0
        self.consecutive_overruns = 0
        self.stalls = 0
        self._expect_us = 0   # announced stall in this slot (expect_delay_ms)
        self._after_stall = False
        #: Task calls passed over in the slot after a planned stall.
        self.deferred = 0
        self.skipped = 0
        self.last_loop_us = 0
        self.max_loop_us = 0
        self.gc_us = 0
        self.gc_max_us = 0
        self.load_permille = 0
        self.wdt_feeds = 0
        self.wdt_withheld = 0
        self.now_us = 0
        self.now_ms = 0
        self._running = False
        self._deadline = 0
        self._end_us = 0

    def add(self, name, fn, period_ms, phase=0, budget_us=0, stall_ms=0):
        """Run ``fn()`` every ``period_ms`` (a multiple of the slot), ``phase`` slots in.

        ``budget_us``: what a call may take; a task with one waits for the
        next slot when the slot's time so far leaves it less (never twice
        in a row), as AP_Scheduler runs a task only if it fits.

        ``stall_ms``: the task is a planned stall of up to that long (the
        collection): each call is announced (``expect_delay_ms``), and its
        slot runs only it and the tasks due every slot and on no budget (as
        the slot after a stall does), the others due then waiting for their
        next turn."""
        if self._n >= _MAX_TASKS:
            raise ValueError("scheduler holds at most %d tasks" % _MAX_TASKS)
        every = period_ms * 1000 // self.period_us
        if every < 1 or every * self.period_us != period_ms * 1000:
            raise ValueError("task %s: period %r ms is not a multiple of the %d ms slot"
                             % (name, period_ms, self.period_us // 1000))
        if not 0 <= phase < every:
            raise ValueError("task %s: phase %r outside 0..%d" % (name, phase, every - 1))
        # the table repeats over the periods' least common multiple
        slots = self._plan_slots * every // _gcd(self._plan_slots, every)
        if slots > _MAX_PLAN_SLOTS:
            raise ValueError("task %s: task periods would repeat only every %d slots (at most %d)"
                             % (name, slots, _MAX_PLAN_SLOTS))
        i = self._n
        self._plan_slots = slots
        self.names.append(name)
        self._fns.append(fn)
        self._every[i] = every
        self._phase[i] = phase
        self._budget[i] = budget_us
        self._stall_ms[i] = stall_ms
        self._n = i + 1
        return i

    def _build_plan(self):
        # One tuple per distinct due set (a dict shares them), so the table
        # costs a reference a slot; built before the first slot after tasks
        # were added (at setup), so it may allocate.
        slots = self._plan_slots
        due = [[] for _ in range(slots)]
        for i in range(self._n):
            for k in range(self._phase[i], slots, self._every[i]):
                due[k].append(i)   # tasks in the order added
        shared = {}
        plan = []
        passed = bytearray(slots)
        stall = self._stall_ms
        every = self._every
        budget = self._budget
        for k in range(slots):
            d = due[k]
            if [i for i in d if stall[i]]:
                # a planned stall's slot: the stall, and the tasks due every
                # slot and on no budget before it, as in the slot after one
                kept = [i for i in d if stall[i] or (every[i] == 1 and not budget[i])]
                passed[k] = len(d) - len(kept)
                d = kept
            d = tuple(d)
            plan.append(shared.setdefault(d, d))
        self._plan = plan
        self._passed = passed
        self._planned = self._n

    def expect_delay_ms(self, ms):
        """The running task is about to stall the chip for up to ``ms``: a
        slot late by no more than that is a stall, not an overrun. Stalls
        announced in one slot add up (a log chunk and a collection in the
        same slot take the time of both)."""
        self._expect_us += ms * 1000

    def index(self, name):
        """Index of task ``name`` (for its counters), -1 if none."""
        for i in range(self._n):
            if self.names[i] == name:
                return i
        return -1

    def run_slot(self):
        """Run the tasks due in the current slot and collect; True if all went well."""
        if self._planned != self._n:
            self._build_plan()
        t = self._clock.ticks_us()
        return self._slot(t, t)

    def _slot(self, start, grid):
        # run_slot() from a slot's start tick and the grid's tick it was due
        # at (a slot woken late has less room); leaves the tick of its end
        # in _end_us
        clock = self._clock
        self.now_us = start
        self.now_ms = clock.ticks_ms()
        fns = self._fns
        runs = self.runs
        task_max = self.task_max_us
        ok = True
        t0 = start
        light = self._after_stall
        self._after_stall = False
        every = self._every
        budget = self._budget
        held = self._held
        k = self.slot % self._plan_slots
        n = self._passed[k]
        if n:
            self.deferred += n
        for i in self._plan[k]:
            b = budget[i]
            if light and (every[i] != 1 or b):
                # a task on a budget is not held here: in the next slot it
                # runs if it fits (forced in after a collection, the radio
                # overran the controller's slot on the emulated Pico 2), and
                # in the one after whatever it leaves
                self.deferred += 1
                continue
            if b:
                # the first time it does not fit it waits; held once, it
                # runs if it ends within the slot at all or the slot is a
                # planned stall already (lost anyway); held twice, it runs
                # whatever is left (its bytes must not wait longer). Forced
                # in at once, the radio ran after nav and the controller in
                # a slot a collection's aftermath had made late, and overran
                # it on the emulated Pico 2.
                end = (((t0 - grid + _TICKS_HALF) & _TICKS_MAX) - _TICKS_HALF) + b
                h = held[i]
                if end > self._limit_us and (h == 0 or (h == 1 and end > self.period_us
                                                        and not self._expect_us)):
                    held[i] = h + 1
                    self.deferred += 1
                    continue
                held[i] = 0
            n = self._stall_ms[i]
            if n:
                self.expect_delay_ms(n)
                self._owed[i] = 0
            try:
                fns[i]()
            except Exception as e:  # a failing task must not stop the loop
                ok = False
                self.task_errors[i] += 1
                if self.last_errors[i] is None:
                    print("task %s failed: %r" % (self.names[i], e))
                self.last_errors[i] = e
            t1 = clock.ticks_us()
            dt = ((t1 - t0 + _TICKS_HALF) & _TICKS_MAX) - _TICKS_HALF
            t0 = t1
            runs[i] += 1
            if dt > task_max[i]:
                task_max[i] = dt
        if self._owing and not light:
            t0 = self._run_owed(t0)
        if self._collect is not None:
            self._collect()
        t1 = clock.ticks_us()
        dt = ((t1 - t0 + _TICKS_HALF) & _TICKS_MAX) - _TICKS_HALF
        self.gc_us = dt
        if dt > self.gc_max_us:
            self.gc_max_us = dt
        self._end_us = t1
        return ok

    def _run_owed(self, t0):
        # the planned-stall tasks a skipped slot owes, after this slot's own,
        # in a slot of the parity of its phase (the collection's is odd:
        # the controller, whose flash saves stall the loop too, runs in
        # the even ones, and stalls back to back starve the IMU's reads)
        owed = self._owed
        left = False
        for i in range(self._n):
            if owed[i] and (self.slot - self._phase[i]) & 1:
                left = True
            elif owed[i]:
                owed[i] = 0
                self.expect_delay_ms(self._stall_ms[i])
                try:
                    self._fns[i]()
                except Exception as e:  # a failing task must not stop the loop
                    self.task_errors[i] += 1
                    if self.last_errors[i] is None:
                        print("task %s failed: %r" % (self.names[i], e))
                    self.last_errors[i] = e
                t1 = self._clock.ticks_us()
                dt = ((t1 - t0 + _TICKS_HALF) & _TICKS_MAX) - _TICKS_HALF
                t0 = t1
                self.runs[i] += 1
                if dt > self.task_max_us[i]:
                    self.task_max_us[i] = dt
        self._owing = left
        return t0

    def _owe(self, first, last):
        # slots first..last were skipped: a planned-stall task due in one of
        # them (the collection) is owed, or the heap would fill meanwhile
        # and collect inside a task, unannounced
        every = self._every
        phase = self._phase
        stall = self._stall_ms
        for i in range(self._n):
            if stall[i]:
                e = every[i]
                if first + (phase[i] - first) % e <= last:
                    self._owed[i] = 1
                    self._owing = True

    def run(self, cycles=-1):
        """Run slots until ``stop()`` or ``cycles`` slots (-1: for ever)."""
        clock = self._clock
        period = self.period_us
        if self._planned != self._n:
            self._build_plan()
        self._running = True
        self._deadline = clock.ticks_us()
        done = 0
        while self._running and done != cycles:
            start = clock.ticks_us()
            ok = self._slot(start, self._deadline)
            end = self._end_us
            work = ((end - start + _TICKS_HALF) & _TICKS_MAX) - _TICKS_HALF
            self.last_loop_us = work
            if work > self.max_loop_us:
                self.max_loop_us = work
            # load in permille, smoothed over ~8 slots
            self.load_permille += (work * 1000 // period - self.load_permille + 4) >> 3
            self.cycles += 1
            done += 1
            nxt = (self._deadline + period) & _TICKS_MAX
            late = ((end - nxt + _TICKS_HALF) & _TICKS_MAX) - _TICKS_HALF
            expected = self._expect_us
            self._expect_us = 0
            if late >= 0:
                missed = late // period
                if late < expected:
                    # a planned stall: back on the grid at the next slot's
                    # start rather than at once and late into the next
                    self.stalls += 1
                    missed += 1
                    self._after_stall = True
                else:
                    self.overruns += 1
                    self.consecutive_overruns += 1
                if missed:
                    self.skipped += missed
                    self._owe(self.slot + 1, self.slot + missed)
                    self.slot += missed
                    nxt = (nxt + missed * period) & _TICKS_MAX
            else:
                self.consecutive_overruns = 0
            self.slot += 1
            self._deadline = nxt
            if self.wdt is not None:
                if ok and self.consecutive_overruns < self.overrun_limit and (
                        self.health is None or self.health()):
                    self.wdt.feed()
                    self.wdt_feeds += 1
                else:
                    self.wdt_withheld += 1
            wait = ((nxt - clock.ticks_us() + _TICKS_HALF) & _TICKS_MAX) - _TICKS_HALF
            if wait > 0 and self._running and done != cycles:
                clock.sleep_us(wait)
        self._running = False

    def stop(self):
        """End ``run()`` after the current slot."""
        self._running = False

    def report(self):
        """The loop's figures as text, one line a task (allocates: on request)."""
        lines = ["loop %d Hz: %d cycles, %d overruns, %d planned stalls (%d slots skipped), max %d us, "
                 "load %d permille, gc max %d us, watchdog fed %d withheld %d"
                 % (1000000 // self.period_us, self.cycles, self.overruns, self.stalls, self.skipped,
                    self.max_loop_us,
                    self.load_permille, self.gc_max_us, self.wdt_feeds, self.wdt_withheld)]
        for i in range(self._n):
            lines.append("  %-10s every %3d ms: %d runs, max %d us, %d errors" % (
                self.names[i], self._every[i] * self.period_us // 1000, self.runs[i],
                self.task_max_us[i], self.task_errors[i]))
        return "\n".join(lines)
