"""The loop's collection, and the order the collector marks the heap in.

MicroPython's collector marks depth first: it scans an object, pushes every
unmarked heap object it points to onto its mark stack, and goes on with the
last one pushed. The stack holds 64 entries on the rp2 port
(``MICROPY_ALLOC_GC_STACK_SIZE``). An object met when the stack is full is
marked but not scanned, and once the roots are done the collector walks the
whole allocation table and scans every marked block again
(``gc_deal_with_stack_overflow`` in ``py/gc.c``): on the emulated Pico 2
that pass was 1.06 M of a collection's 1.9 M instructions (18 of 32 ms).

The stack fills when the objects waiting along one path add up, and the
firmware's objects are wide and connected: a module's globals push all its
imports, functions and classes at once, an instance all its attributes; an
instance leads to its class, the class's methods to their module, the
module's globals to everything it imported, and the application's module
to the vehicle and every part of it. Marked top down from the
application's globals, those (30), the vehicle's (15), the navigation's
(5), the estimator's (26) and its attitude filter's (21) were waiting at
once.

The roots are marked in a fixed order, and the first on the heap is the
globals of the module whose function called ``gc.collect()``
(``mp_state_thread.dict_globals``; ``dict_locals`` before it is
``__main__``'s dict, a static one). That module is this one (``collect``),
and its globals hold ``_first``: the firmware's modules and instances in a
chain of pairs ``(rest, obj)`` (a pair's ``rest`` is pushed before its
``obj``, so ``obj`` is marked with all it leads to while one entry waits,
then the rest). ``prepare()`` orders them by a walk of what each points to
(a module's globals, an instance's attributes and class, a class's or a
function's module, the items of tuples, lists and dicts), in Tarjan's
strongly connected components: a component after every one it leads to,
so by the time the collector reaches an object, what it points to is
marked but its own leaves (numbers, strings, buffers). Objects on one
cycle (a module and the instance of its class it holds: the application
and the vehicle) are marked from the first of them reached.

What the walk cannot see into, a bound method or a closure (but a closure
a module holds, a wrapper standing in for its function), may lead to any
object not yet marked, the vehicle itself for a task bound to it: the
objects holding one, and those above them, come after all the others, top
down, each then reaching from above the holders below it with all they
point to marked. Objects made after ``prepare()`` are reached through their
holders. A container still pushes all its items at once, so the firmware
keeps none with many heap items (the parameter table keeps its names in one
bytes object, not a list of them).

On the emulated Pico 2 (``bench board``: ``gc_ms`` against
``gc_ms_unordered``, the same heap before ``prepare()``), a collection no
longer overflows its stack; ``tests/test_rp2350_gc.py`` holds it to one
pass. ``prepare()`` runs once at start-up, before the watchdog (a few
hundred ms on the chip: ``gc_order_prepare_ms``), and leaves the chain in
the lowest free blocks, since the sweep walks the heap up to the highest
block in use.
"""

import gc
import sys
from array import array

_first = None


def prepare():
    """Order the firmware's modules and instances for the collector (once,
    after the vehicle is built: it allocates). Returns how many."""
    global _first
    if sys.implementation.name != "micropython":
        return 0
    _first = None
    modules = sys.modules
    # the types the walk tells apart, as locals: compared with ``is``, a
    # few instructions each where a dict keyed by type compares a user
    # class by its __eq__
    t_int = int
    t_float = float
    t_str = str
    t_bool = bool
    t_none = type(None)
    t_bytes = bytes
    t_array = type(array("b"))
    t_module = type(sys)
    t_type = type
    t_function = type(prepare)
    t_tuple = tuple
    t_list = list
    t_dict = dict
    t_bound = type(_Probe().method)
    t_closure = type(_closure())
    module_of = {}
    for name in modules:
        m = modules[name]
        d = getattr(m, "__dict__", None)   # a port's native stand-in may have none
        if type(d) is t_dict:
            module_of[id(d)] = m
    # Tarjan's strongly connected components over what the walk sees: a
    # component comes out after every component it leads to, so the
    # collector, marking in that order, meets little that is unmarked. The
    # objects of one cycle (a module and the instance of its class it
    # holds, the vehicle and its application) are marked from the first of
    # them to be reached, their root, which is put first.
    # per object met, by id: [when met, the earliest open object it leads
    # back to, whether it holds (itself or below) what the walk cannot see
    # into]; when met is -1 once its component is out
    info = {}
    members = []    # open components' objects (Tarjan's stack)
    path = []       # the walk: objects, their info, iterators over their children
    infos = []
    kids = []
    comps = []      # components, each a list, root first, and whether they hold
    n = 0
    for name in modules:
        root = modules[name]
        d = getattr(root, "__dict__", None)
        if type(d) is not t_dict or "__file__" not in d or id(root) in info:    # built in, or done
            continue
        info[id(root)] = [n, n, False]
        n += 1
        members.append(root)
        path.append(root)
        infos.append(info[id(root)])
        kids.append(iter(list(d.values())))
        while path:
            o = path[-1]
            io = infos[-1]
            nxt = None
            own = o.__dict__ if type(o) is t_module else None    # a module's own functions
            for k in kids[-1]:    # an iterator: the next pass resumes after a descent
                t = type(k)
                if t is t_int or t is t_str or t is t_float or t is t_bool or t is t_none or t is t_array \
                        or t is t_bytes:
                    continue
                if t is t_function:
                    # a function leads to its module
                    g = k.__globals__
                    if g is own:
                        continue
                    k = module_of.get(id(g))
                    if k is None or k is o:
                        continue
                elif t is t_type:
                    # a class too (its methods are its module's)
                    d = getattr(k, "__dict__", None)    # a built-in type may have none
                    k = modules.get(d.get("__module__")) if type(d) is t_dict else None
                    if k is None or k is o:
                        continue
                elif t is t_bound:
                    io[2] = True
                    continue
                elif t is t_closure:
                    # a closure a module holds stands in for one of its
                    # functions (a wrapper); anywhere else it may hold anything
                    if own is None:
                        io[2] = True
                    continue
                elif t is t_module:
                    if "__file__" not in k.__dict__:
                        continue    # built in: not on the heap
                elif t is not t_tuple and t is not t_list and t is not t_dict \
                        and type(getattr(k, "__dict__", None)) is not t_dict:
                    continue    # a native object: a buffer, a file, a built-in function
                ik = info.get(id(k))
                if ik is None:
                    nxt = k
                    break
                if ik[0] >= 0:
                    # open: a cycle back to it
                    if ik[0] < io[1]:
                        io[1] = ik[0]
                elif ik[2]:
                    io[2] = True
            if nxt is not None:
                ik = [n, n, False]
                info[id(nxt)] = ik
                n += 1
                members.append(nxt)
                path.append(nxt)
                infos.append(ik)
                t = type(nxt)
                if t is t_module:
                    kids.append(iter(list(nxt.__dict__.values())))
                elif t is t_tuple or t is t_list:
                    kids.append(iter(nxt))
                elif t is t_dict:
                    kids.append(iter(list(nxt.values())))
                else:
                    c = list(nxt.__dict__.values())
                    c.append(t)    # its class: its module
                    kids.append(iter(c))
                continue
            path.pop()
            infos.pop()
            kids.pop()
            if path:
                ip = infos[-1]
                if io[1] < ip[1]:
                    ip[1] = io[1]
                if io[2]:
                    ip[2] = True
            if io[1] == io[0]:
                # o is a component's root: its members are above it on the stack
                comp = []
                h = False
                while True:
                    x = members.pop()
                    ix = info[id(x)]
                    ix[0] = -1     # out
                    h = h or ix[2]
                    t = type(x)
                    if t is not t_tuple and t is not t_list and t is not t_dict:
                        comp.append(x)    # a module or an instance
                    if x is o:
                        break
                comp.reverse()    # the root first
                if h:
                    for x in comp:
                        info[id(x)][2] = True
                if comp:
                    comps.append((comp, h))
    # The collector's order, flat: a component after all it leads to, but
    # what holds a reference the walk cannot see into (a bound method, a
    # closure), itself or below, comes last, top down: by then what those
    # references lead to is marked, but for the holders themselves, which
    # each reaches from above, its own table all that is left of it.
    order = []
    for c in comps:
        if not c[1]:
            order.extend(c[0])
    for k in range(len(comps) - 1, -1, -1):
        if comps[k][1]:
            order.extend(comps[k][0])
    info = members = path = infos = kids = module_of = comps = c = comp = o = root = nxt = d = k = None
    # The walk's own objects go before the chain is made, so the chain
    # takes the lowest free blocks (the sweep walks the allocation table up
    # to the highest block in use); that collection is marked from a first
    # chain, made where the walk left off and dropped after it (``order``
    # holds only what the chain marks first).
    _first = _chain(order)
    gc.collect()
    _first = None
    _first = _chain(order)
    return len(order)


def _chain(order):
    # nested pairs (rest, obj), order[0] outermost: marked first
    chain = None
    for k in range(len(order) - 1, -1, -1):
        chain = (chain, order[k])
    return chain


class _Probe:
    # what a bound method's type is
    def method(self):
        pass


def _closure():
    # what a closure's type is
    x = None

    def inner():
        return x
    return inner


def collect():
    """One collection, marked from ``_first`` (see the module docstring)."""
    gc.collect()


def floats_boxed():
    """True where a float result takes a heap block (stock MicroPython,
    ``MICROPY_OBJ_REPR_A``: 16 bytes each, ~400 a flight slot, so the loop
    must collect every few hundred ms) or off MicroPython; False on
    RoboRay's build (``MICROPY_OBJ_REPR_C``: a float is the object word
    itself, so two equal results are the same object)."""
    if sys.implementation.name != "micropython":
        return True
    a = float("1.5")     # made at run time: not one shared constant
    return a is not float("1.5")


#: On RoboRay's build: the bytes a flight slot is taken to leave at most,
#: for the heap's estimate. The heap is not read in flight: ``gc.mem_free()``
#: and ``gc.mem_alloc()`` both walk the whole allocation table (~17.6 ms on
#: a Pico 2, ``py/modgc.c`` ``gc_info``). ``roboray-sim bench board``
#: counts what an armed slot leaves (``flight_alloc_bytes_per_slot``, a few
#: bytes on average; docs/design/board-time.md); this bound is several
#: times that, so the estimate runs low before the heap does: ~250 kB free
#: at 32 B a slot lasts a minute of flight before three quarters of it may
#: be used.
SLOT_BYTES = 32
#: At rest (disarmed, or armed and still on the bottom): a collection at
#: most this often (slots; 1 s), in a slot a flash write of the log stalls
#: anyway (so it adds no stalled slot), or once half the free heap may be
#: used (then a planned stall of its own, announced, that costs no dive).
REST_SLOTS = 100


class Collections:
    """When RoboRay's build collects: at rest, in a slot a flash write
    stalls anyway; in flight never, unless the heap's estimate is low.

    ``free``: the heap free after a collection (bytes; read at rest, where
    the walk of ``gc.mem_free()`` costs nothing the dive needs), ``slot``
    the scheduler's slot then. ``due(slot, resting, flashed)`` says from the
    slots since then times ``SLOT_BYTES``: 0 (none), 1 (at rest: in a slot
    the log wrote to flash, ``flashed``, ``REST_SLOTS`` on; or once half the
    free heap may be used) or 2 (in flight, three quarters may be used: the
    heap is low, an event the firmware reports). ``done(slot, free, low)``
    after the collection. Integers only: a call allocates nothing."""

    def __init__(self, free, slot=0):
        self.free = free
        self.last = slot
        #: Collections made, and those made in flight because the estimate was low.
        self.count = 0
        self.low = 0

    def due(self, slot, resting, flashed):
        n = slot - self.last
        if resting:
            return 1 if (flashed and n >= REST_SLOTS) or n * SLOT_BYTES >= self.free >> 1 else 0
        return 2 if n * SLOT_BYTES >= self.free - (self.free >> 2) else 0

    def done(self, slot, free, low):
        self.last = slot
        if free >= 0:
            self.free = free
        self.count += 1
        if low:
            self.low += 1
