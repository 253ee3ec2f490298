"""``hostlink`` over two pipes, for interpreters that run as a plain process.

The WebAssembly port has ``hostlink`` built in (``tools/micropython/host.mjs``);
MicroPython's unix port and CPython do not. This module is that link for the
unix port (``runner.MicroPythonUnixBoard``), with the same contract:
``request(text)`` sends one request and returns the next answer not yet
read, which the twin may have sent ahead.

On the wire: a request is its text and a newline (the twin reads lines); an
answer is its length as eight ASCII digits, then its bytes. A length, not a
newline, because a line has to be read a byte at a time (one system call
each on the unix port) where two reads of known size are two calls. The
firmware's own output goes to stdout as on a board's console; the link
never does.

MicroPython code (``open`` of ``/dev/fd/N``: the pipes the twin passed down).
"""

_in = None
_out = None
_head = bytearray(8)
_buf = bytearray(4096)


def connect(fd_in, fd_out):
    """Use the inherited pipes ``fd_in`` (answers) and ``fd_out`` (requests)."""
    global _in, _out
    _in = open("/dev/fd/%d" % fd_in, "rb")
    _out = open("/dev/fd/%d" % fd_out, "wb")


def _fill(mv):
    # Read exactly len(mv) bytes into mv. The same allocations whether the
    # pipe hands the answer over at once or in parts: on the emulated
    # RP2350 the twin's own garbage shares the heap with the firmware's, and
    # a heap laid out differently from one run to the next would change what
    # the firmware's allocations cost (its time is counted), so a run would
    # not repeat exactly. A slice is made only when a read came up short.
    n = len(mv)
    got = _in.readinto(mv)
    while got is not None and got < n:
        more = _in.readinto(mv[got:])
        if not more:
            break
        got += more
    if not got or got < n:
        raise SystemExit(0)   # the twin went away: nothing left to simulate


def request(text):
    global _buf
    _out.write(text)
    _out.write("\n")
    _fill(_head)
    n = int(_head)
    if n > len(_buf):
        _buf = bytearray(n + 1024)   # a longer answer than any before
    mv = memoryview(_buf)[:n]
    _fill(mv)
    return str(mv, "utf-8")
