"""The rp2 port on a Pico 2, as the virtual board shows it.

``host.mjs`` runs this in each new VM of the virtual board (power-on and
every reset), before ``boot.py``. MicroPython for the WebAssembly port;
``_vboard`` is host.mjs's module for this VM: ``config`` (JSON: the flash's
folder, its size in blocks, ``os.uname()``'s fields, the built-in modules
and their folder), ``used()`` (flash blocks in use), ``sync()`` (write the
flash back to the host) and ``reset()`` (restart the board once the program
ends). It leaves nothing in the REPL's globals.
"""


def _start():
    import builtins
    import json
    import os
    import sys
    import vfs

    import _vboard

    cfg = json.loads(_vboard.config)

    # The flash at "/": a VfsPosix rooted at its folder, so none of
    # Emscripten's own folders (/tmp, /home, /dev, /proc) show.
    vfs.umount("/")
    vfs.mount(vfs.VfsPosix(cfg["flash"]), "/")
    os.chdir("/")
    sys.path.clear()
    sys.path.extend(["", ".frozen", "/lib"])

    # The port's os wraps stat's tuple in a named one; rp2's is a tuple.
    stat = getattr(os, "__os_stat", os.stat)
    port_ilistdir = os.ilistdir
    os.stat = stat

    def ilistdir(path=""):
        # littlefs lists (name, type, inode, size); the port's VfsPosix only
        # the first three, so mpremote's ls showed every size as 0
        entries = port_ilistdir(path)
        sep = b"/" if isinstance(path, bytes) else "/"
        base = path if not path or path[-1:] == sep else path + sep
        return ((e[0], e[1], 0, 0 if e[1] & 0x4000 else stat(base + e[0])[6]) for e in entries)

    os.ilistdir = ilistdir

    write_back = _vboard.sync

    def sync():
        write_back()

    os.sync = sync

    blocks = cfg["blocks"]
    if blocks:
        used = _vboard.used
        block = cfg["block"]

        def statvfs(path):
            # littlefs's figures for a flash of `blocks` (the path must exist)
            stat(path)
            free = max(0, blocks - used())
            return (block, block, blocks, free, free, 0, 0, 0, 0, 255)

        os.statvfs = statvfs

    if cfg["uname"]:
        from collections import namedtuple

        # an unnamed namedtuple prints as rp2's attrtuple does
        answer = namedtuple("", ("sysname", "nodename", "release", "version", "machine"))(*cfg["uname"])

        def uname():
            return answer

        os.uname = uname

    read = sys.stdin.buffer.read
    echo = sys.stdout.buffer.write

    def line_input(prompt=""):
        # The port's input() reads a stdin it does not have (NULs, for
        # ever); this reads the serial line as rp2's readline does: echo,
        # Enter (CR) ends, backspace edits, Ctrl-D on an empty line is
        # EOFError, Ctrl-C (when kbd_intr let it through) KeyboardInterrupt.
        if prompt:
            echo(str(prompt))
        line = bytearray()
        while True:
            c = read(1)[0]
            if c == 13:
                echo(b"\r\n")
                return line.decode()
            if c == 3:
                raise KeyboardInterrupt
            if c == 4 and not line:
                raise EOFError
            if c in (8, 127):
                if line:
                    line = line[:-1]
                    echo(b"\b \b")
            elif c >= 32:
                line.append(c)
                echo(bytes((c,)))

    builtins.input = line_input

    # Built-in modules, imported now from a folder mounted only meanwhile:
    # importable everywhere after, visible nowhere, as a board's are.
    if cfg["builtins"]:
        vfs.mount(vfs.VfsPosix(cfg["builtins_dir"]), "/.builtins")
        sys.path.insert(0, "/.builtins")
        try:
            for name in cfg["builtins"]:
                __import__(name)
        finally:
            sys.path.pop(0)
            vfs.umount("/.builtins")
    machine = sys.modules.get("machine")
    if machine is not None:
        restart = _vboard.reset

        def reset():
            # rp2 reboots at once; here the program ends first (SystemExit)
            restart()
            raise SystemExit

        def soft_reset():
            raise SystemExit

        machine.reset = reset
        machine.soft_reset = soft_reset


try:
    _start()
finally:
    del _start
    __import__("sys").modules.pop("_vboard", None)
