"""The fixed-rate loop on the virtual clock: rates, overruns, watchdog, gc."""

from __future__ import annotations

import pytest

from roboray.sim import twin

pytestmark = pytest.mark.micropython


@pytest.fixture(scope="module")
def board():
    mp = twin.interpreter()
    yield mp
    mp.close()


@pytest.fixture
def mp(board):
    twin.reset(board)
    board.exec(
        "import gc, machine, time\n"
        "from array import array\n"
        "from roboray.sim.twin.board import vclock\n"
        "from roboray.firmware.scheduler import Scheduler\n"
        "log = array('l', [0] * 4000)\n"
        "n = array('l', [0])\n"
        "def stamp():\n"
        "    log[n[0]] = time.ticks_ms()\n"
        "    n[0] += 1\n"
        "def stamps():\n"
        "    return list(log[:n[0]])\n"
        "def nothing():\n"
        "    pass\n"
        "def busy(us):\n"
        "    def work():\n"
        "        vclock.advance(us)\n"
        "    return work\n"
    )
    return board


def test_tasks_run_at_their_rates_and_phases(mp):
    mp.exec("s = Scheduler(vclock, 10)\n"
            "s.add('fast', nothing, 10)\ns.add('depth', stamp, 20, phase=1)\ns.add('slow', nothing, 100, phase=3)\n"
            "s.run(100)")
    assert mp.eval("[s.runs[0], s.runs[1], s.runs[2]]") == [100, 50, 10]
    assert mp.eval("stamps()[:4]") == [10, 30, 50, 70]   # every 20 ms, one slot in
    assert mp.eval("vclock.elapsed_us()") == 990000       # 100 slots, sleeping between them
    assert mp.eval("[s.overruns, s.skipped, s.cycles]") == [0, 0, 100]


def test_periods_must_fit_the_slot(mp):
    mp.exec("s = Scheduler(vclock, 10)")
    with pytest.raises(Exception, match="period 15 ms is not a multiple of the 10 ms slot"):
        mp.exec("s.add('x', nothing, 15)")
    with pytest.raises(Exception, match="phase 2 outside 0..1"):
        mp.exec("s.add('x', nothing, 20, phase=2)")


def test_an_overrun_is_counted_and_the_grid_is_kept(mp):
    # slot 5 takes 35 ms: slots 6, 7, 8 are lost; 9 runs at once, late
    mp.exec("s = Scheduler(vclock, 10)\n"
            "def sometimes():\n"
            "    if s.slot == 5:\n"
            "        vclock.advance(35000)\n"
            "s.add('work', sometimes, 10)\ns.add('every20', stamp, 20)\n"
            "s.run(20)")
    assert mp.eval("[s.overruns, s.skipped]") == [1, 2]
    assert mp.eval("s.max_loop_us") == 35000
    assert mp.eval("s.slot") == 22   # 20 slots run, 2 (60-80 ms) jumped over
    # slot 8 (80 ms) runs at once, 5 ms late; then the 20 ms task is back on its grid
    assert mp.eval("stamps()") == [0, 20, 40, 85] + list(range(100, 220, 20))
    assert mp.eval("s.consecutive_overruns") == 0


def test_each_task_the_collection_and_the_slot_are_timed(mp):
    # the work of a task, and of the collector, is what the clock moved while it ran
    mp.exec("s = Scheduler(vclock, 10, collect=busy(300))\n"
            "s.add('a', busy(3000), 10)\ns.add('idle', nothing, 10)\ns.add('b', busy(1200), 20, phase=1)\n"
            "s.run(6)")
    assert mp.eval("list(s.task_max_us[:3])") == [3000, 0, 1200]
    assert mp.eval("list(s.runs[:3])") == [6, 6, 3]
    assert mp.eval("[s.gc_us, s.gc_max_us, s.last_loop_us, s.max_loop_us]") == [300, 300, 4500, 4500]
    assert mp.eval("[s.overruns, vclock.elapsed_us()]") == [0, 50000 + 4500]   # the last slot: a, b, gc


def test_watchdog_is_fed_only_while_the_loop_is_healthy(mp):
    mp.exec("w = machine.WDT(timeout=100)\nhealthy = [True]\n"
            "s = Scheduler(vclock, 10, wdt=w, overrun_limit=3, health=lambda: healthy[0])\n"
            "s.add('x', nothing, 10)\ns.run(50)")
    assert mp.eval("s.wdt_feeds") == 50
    assert mp.eval("machine.twin.wdt_expired()") is False
    mp.exec("healthy[0] = False\ns.run(20)")    # the failsafes veto: 200 ms unfed
    assert mp.eval("s.wdt_withheld") == 20
    assert mp.eval("machine.twin.wdt_expired()") is True


def test_a_limping_loop_starves_the_watchdog(mp):
    mp.exec("w = machine.WDT(timeout=1000)\n"
            "s = Scheduler(vclock, 10, wdt=w, overrun_limit=3)\n"
            "s.add('slow', busy(12000), 10)\ns.run(10)")
    assert mp.eval("s.overruns") == 10
    assert mp.eval("s.wdt_feeds") == 2   # the first two overruns are tolerated
    assert mp.eval("s.wdt_withheld") == 8


def test_a_failing_task_is_counted_reported_and_the_loop_goes_on(mp):
    mp.exec("w = machine.WDT(timeout=1000)\n"
            "def bad():\n    raise ValueError('boom')\n"
            "s = Scheduler(vclock, 10, wdt=w)\ns.add('bad', bad, 20)\ns.add('ok', nothing, 10)")
    out = mp.exec("s.run(10)")
    assert out.count("task bad failed: ValueError('boom',)") == 1  # printed once, not every time
    assert mp.eval("[s.task_errors[0], s.runs[1]]") == [5, 10]
    assert mp.eval("s.wdt_withheld") == 5     # no feed in a slot where a task raised


def test_one_collection_each_slot_after_its_tasks(mp):
    # (The WebAssembly port cannot free memory from inside a running program,
    # so the order of events is what is checked here, not the heap.)
    mp.exec("events = []\n"
            "s = Scheduler(vclock, 10, collect=lambda: events.append('gc'))\n"
            "s.add('a', lambda: events.append('a'), 10)\ns.add('b', lambda: events.append('b'), 20)\n"
            "s.run(4)")
    assert mp.eval("events") == ["a", "b", "gc", "a", "gc", "a", "b", "gc", "a", "gc"]
    mp.exec("s = Scheduler(vclock, 10)")
    assert mp.eval("s._collect is gc.collect") is True


def test_a_slot_of_allocation_free_tasks_allocates_nothing(mp):
    mp.exec("s = Scheduler(vclock, 10)\ns.add('a', nothing, 10)\ns.add('b', stamp, 20)")
    assert mp.alloc_bytes("s.run_slot(); s.slot += 1") == 0


def test_ticks_wrapping_around_does_not_disturb_the_loop(mp):
    mp.exec("vclock.reset(start_us=(1 << 30) - 25000)\n"
            "s = Scheduler(vclock, 10)\ns.add('x', nothing, 10)\ns.run(10)")
    assert mp.eval("[s.overruns, s.skipped, s.max_loop_us]") == [0, 0, 0]
    assert mp.eval("vclock.elapsed_us()") == 90000


def test_report_names_every_task(mp):
    mp.exec("s = Scheduler(vclock, 10, reset_cause=machine.WDT_RESET)\n"
            "s.add('imu', nothing, 10)\ns.add('depth', nothing, 20)\ns.run(4)")
    text = mp.eval("s.report()")
    assert text.splitlines()[0].startswith("loop 100 Hz: 4 cycles, 0 overruns")
    assert "imu        every  10 ms: 4 runs" in text and "depth      every  20 ms: 2 runs" in text
    assert mp.eval("s.reset_cause") == 3


def test_due_table_follows_tasks_added_between_slots_and_phases(mp):
    # the due-task table is rebuilt when tasks were added after a slot ran
    mp.exec("s = Scheduler(vclock, 10)\ns.add('a', nothing, 10)\ns.run(3)\n"
            "s.add('b', stamp, 30, phase=2)\ns.add('c', nothing, 50, phase=4)\ns.run(30)")
    assert mp.eval("[s.runs[0], s.runs[1], s.runs[2]]") == [33, 10, 6]
    # 'b' is due at slots 5, 8, 11, ... (phase 2 of 3); the first run(3)
    # does not sleep after its last slot, so slot 3 starts at 20 ms
    assert mp.eval("stamps()[:3]") == [40, 70, 100]


def test_periods_whose_common_multiple_is_too_long_are_refused(mp):
    mp.exec("s = Scheduler(vclock, 10)\ns.add('a', nothing, 70)\ns.add('b', nothing, 130)")
    with pytest.raises(Exception, match="repeat only every 1729 slots"):
        mp.exec("s.add('c', nothing, 190)")


def test_a_planned_stall_resumes_on_the_grid_with_a_slot_of_the_every_slot_tasks(mp):
    # slot 5 announces and takes a 35 ms stall: counted as a stall, not an
    # overrun; slots 6, 7 and 8 (the one it ended in) are skipped and the
    # loop resumes on its grid at slot 9 (90 ms), which runs only the tasks
    # due every slot: the 20 ms task due then waits for its next turn (110 ms)
    mp.exec("s = Scheduler(vclock, 10)\n"
            "def sometimes():\n"
            "    if s.slot == 5:\n"
            "        s.expect_delay_ms(50)\n"
            "        vclock.advance(35000)\n"
            "s.add('work', sometimes, 10)\ns.add('every20', stamp, 20, phase=1)\n"
            "s.run(12)")
    assert mp.eval("[s.overruns, s.stalls, s.skipped, s.deferred]") == [0, 1, 3, 1]
    assert mp.eval("s.slot") == 15
    assert mp.eval("stamps()") == [10, 30, 85, 110, 130]


def test_a_task_on_a_budget_waits_for_the_next_slot_when_it_would_not_fit(mp):
    # a 10 ms slot ends by 9 ms: after 7 ms of work a task that may take
    # 3 ms waits for the next slot, and runs there whatever it leaves
    mp.exec("s = Scheduler(vclock, 10)\n"
            "s.add('heavy', busy(7000), 10)\ns.add('radio', stamp, 10, budget_us=3000)\n"
            "s.run(4)")
    assert mp.eval("s.deferred") == 2 and mp.eval("s.runs[1]") == 2
    assert mp.eval("stamps()") == [17, 37]          # every other slot, after the heavy task
    assert mp.eval("s.overruns") == 0
    mp.exec("s2 = Scheduler(vclock, 10)\n"
            "s2.add('light', busy(2000), 10)\ns2.add('radio', nothing, 10, budget_us=3000)\ns2.run(5)")
    assert mp.eval("[s2.deferred, s2.runs[1]]") == [0, 5]


def test_a_task_that_is_a_planned_stall_runs_with_the_every_slot_tasks_only(mp):
    # the 'gc' task (every 5 slots, phase 2) stalls 25 ms: announced before
    # each call, so a stall and not an overrun; its slot runs only it and
    # the every-slot task (the 20 ms one due then waits), and the slot after
    # it runs only the every-slot task, as after any planned stall
    mp.exec("s = Scheduler(vclock, 10)\n"
            "events = []\n"
            "def ev(name):\n"
            "    def f():\n"
            "        events.append((s.slot, name))\n"
            "    return f\n"
            "def stall():\n"
            "    events.append((s.slot, 'gc'))\n"
            "    vclock.advance(25000)\n"
            "s.add('nav', ev('nav'), 10)\ns.add('depth', ev('depth'), 20)\n"
            "s.add('gc', stall, 50, phase=2, stall_ms=40)\n"
            "s.run(6)")
    assert [tuple(e) for e in mp.eval("events")] == [(0, "nav"), (0, "depth"), (1, "nav"), (2, "nav"), (2, "gc"),
                                                     (5, "nav"), (6, "nav"), (6, "depth"), (7, "nav"), (7, "gc")]
    # slot 2 passed over depth; each stall skipped 2 slots
    assert mp.eval("[s.overruns, s.stalls, s.skipped, s.deferred]") == [0, 2, 4, 1]


def test_after_a_planned_stall_a_task_on_a_budget_still_waits_when_it_would_not_fit(mp):
    # even slots are heavy (7 ms), the radio takes 3 ms on a 3 ms budget.
    # Slot 1 stalls 15 ms (the held radio runs after it, at 25 ms); slot 2
    # is skipped, slot 3 runs light (the radio passed over), and in slot 4,
    # heavy, the radio waits again rather than end the slot late: it runs
    # at 50 ms, in slot 5
    mp.exec("s = Scheduler(vclock, 10)\n"
            "def work():\n"
            "    if s.slot == 1:\n"
            "        s.expect_delay_ms(30)\n"
            "        vclock.advance(15000)\n"
            "    elif s.slot % 2 == 0:\n"
            "        vclock.advance(7000)\n"
            "def radio():\n"
            "    stamp()\n"
            "    vclock.advance(3000)\n"
            "s.add('work', work, 10)\ns.add('radio', radio, 10, budget_us=3000)\n"
            "s.run(5)")
    assert mp.eval("stamps()") == [25, 50]
    assert mp.eval("[s.overruns, s.stalls, s.skipped]") == [0, 1, 1]


def test_a_held_task_on_a_budget_waits_once_more_rather_than_overrun_a_slot(mp):
    # slot 0 is heavy (7 ms): the radio (3 ms budget) waits. Slot 1 is
    # heavier still (8.5 ms, no stall announced): forced in, the radio would
    # end it at 11.5 ms, an overrun; it waits once more and runs in slot 2
    # (at 21 ms), forced there whatever is left
    mp.exec("s = Scheduler(vclock, 10)\n"
            "def work():\n"
            "    vclock.advance((7000, 8500, 1000, 1000)[s.slot])\n"
            "def radio():\n"
            "    stamp()\n"
            "    vclock.advance(3000)\n"
            "s.add('work', work, 10)\ns.add('radio', radio, 10, budget_us=3000)\n"
            "s.run(4)")
    assert mp.eval("stamps()") == [21, 31]
    assert mp.eval("[s.overruns, s.deferred]") == [0, 2]


def test_a_collection_whose_slot_another_stall_skipped_runs_after_it(mp):
    # the collection is due at slot 4; slot 2 stalls 25 ms (a flash save),
    # so slots 3 and 4 are skipped and slot 5 runs light: the collection
    # runs at the end of slot 6, not 300 ms later (the heap would fill
    # meanwhile and collect inside a task, unannounced)
    mp.exec("s = Scheduler(vclock, 10)\n"
            "events = []\n"
            "def work():\n"
            "    events.append((s.slot, 'work'))\n"
            "    if s.slot == 2:\n"
            "        s.expect_delay_ms(30)\n"
            "        vclock.advance(25000)\n"
            "def collect():\n"
            "    events.append((s.slot, 'gc'))\n"
            "s.add('work', work, 10)\ns.add('gc', collect, 300, phase=4, stall_ms=40)\n"
            "s.run(6)")
    assert [tuple(e) for e in mp.eval("events")] == [(0, "work"), (1, "work"), (2, "work"), (5, "work"),
                                                     (6, "work"), (6, "gc"), (7, "work")]
    assert mp.eval("[s.runs[1], s.stalls, s.overruns]") == [1, 1, 0]
