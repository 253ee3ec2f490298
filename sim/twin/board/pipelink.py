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


def connect(fd_in, fd_out):
    """Use the inherited pipes ``fd_in`` (answers) and ``fd_out`` (requests)."""
    global _in, _out
    _in = open("/dev/fd/%d" % fd_in, "rb")
    _out = open("/dev/fd/%d" % fd_out, "wb")


def request(text):
    _out.write(text + "\n")
    head = _in.read(8)
    if len(head) < 8:
        raise SystemExit(0)   # the twin went away: nothing left to simulate
    n = int(head)
    data = _in.read(n)
    while len(data) < n:   # a pipe may hand over a long answer in parts
        more = _in.read(n - len(data))
        if not more:
            raise SystemExit(0)
        data += more
    return data.decode()
