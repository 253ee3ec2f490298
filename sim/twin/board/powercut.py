"""Cut the power in the middle of a file operation, deterministically.

MicroPython code for the twin and the tests. ``PowerCutFiles(files, cut_at)``
wraps a file-system object with the ``Files`` interface of
``firmware/param_store.py`` (``open``, ``rename``, ``remove``, ``exists``)
and counts every step that changes flash: opening a file for writing
(which truncates it), each ``write``, each ``close`` of a written file,
each ``rename`` and ``remove``. At step ``cut_at`` (1-based) the power goes:
an open for writing has already truncated the file, a write puts only the
first half of its bytes on flash, a close, rename or remove does not happen,
and ``PowerCut`` (a ``BaseException``, which the
firmware's own error handling cannot catch) is raised. From then on every
operation raises ``PowerCut``: the board is dead until the test or the twin
"reboots" it with a fresh store on the plain file system. ``cut_at=0``
never cuts and just counts ``steps``.
"""


class PowerCut(BaseException):
    """The supply went at this point of a file operation."""


class _File:
    def __init__(self, owner, f, counted=True):
        self._owner = owner
        self._f = f
        self._counted = counted

    def write(self, data, off=0, n=-1):
        # (buf, off, n): part of a buffer, as MicroPython's streams take it
        # (firmware/flightlog/files.py), passed on as it came
        owner = self._owner
        size = len(data) - off if n < 0 else n
        if owner.board_time is not None:
            owner.board_time.flash("write", size)
        if owner.step(self._counted):
            self._f.write(memoryview(data)[off:off + size // 2])
            self._f.close()
            raise PowerCut("power cut writing %d bytes" % size)
        if off == 0 and n < 0:
            return self._f.write(data)
        return self._f.write(data, off, size)

    def read(self, *args):
        self._owner.alive()
        return self._f.read(*args)

    def close(self):
        owner = self._owner
        if owner.dead:
            self._f.close()  # the host file; the board is already off
            raise PowerCut("power is off")
        if owner.board_time is not None:
            owner.board_time.flash("close")
        if owner.step(self._counted):
            self._f.close()
            raise PowerCut("power cut closing the file")
        self._f.close()


class PowerCutFiles:
    """A ``Files`` wrapper that cuts the power at step ``cut_at``."""

    def __init__(self, files, cut_at=0):
        self._files = files
        self.cut_at = cut_at
        self.steps = 0
        self.dead = False
        #: ``boardtime.BoardTime`` whose ``flash(kind, nbytes=0)`` charges
        #: each flash-changing step's stall to the board's time, or None
        #: (the object, not its bound method: the firmware's collector
        #: orders what it can see, ``firmware/collector.py``).
        self.board_time = None
        #: Only steps on paths holding this count towards ``cut_at`` (the
        #: twin: the parameter file, whose save ``powercut:N`` cuts at its
        #: N-th step); None: every step. The others still charge their
        #: stall, and fail once the power is off.
        self.counted = None

    def _counts(self, path):
        return self.counted is None or self.counted in path

    def alive(self):
        if self.dead:
            raise PowerCut("power is off")

    def step(self, counted=True):
        """Count one flash-changing step; True when the power goes now."""
        self.alive()
        if not counted:
            return False
        self.steps += 1
        if self.cut_at and self.steps == self.cut_at:
            self.dead = True
            return True
        return False

    def open(self, path, mode):
        if "w" in mode or "a" in mode:
            f = self._files.open(path, mode)  # truncated even if the cut comes now
            if self.board_time is not None:
                self.board_time.flash("open")
            counted = self._counts(path)
            if self.step(counted):
                f.close()
                raise PowerCut("power cut opening %s" % path)
            return _File(self, f, counted)
        self.alive()
        return self._files.open(path, mode)

    def rename(self, old, new):
        if self.board_time is not None:
            self.board_time.flash("rename")
        if self.step(self._counts(old)):
            raise PowerCut("power cut before renaming %s" % old)
        self._files.rename(old, new)

    def remove(self, path):
        if self.board_time is not None:
            self.board_time.flash("remove")
        if self.step(self._counts(path)):
            raise PowerCut("power cut before removing %s" % path)
        self._files.remove(path)

    def exists(self, path):
        self.alive()
        return self._files.exists(path)

    def mkdir(self, path):
        if self.board_time is not None:
            self.board_time.flash("open")   # a metadata commit, as creating a file
        if self.step(self._counts(path)):
            raise PowerCut("power cut before making %s" % path)
        self._files.mkdir(path)

    def listdir(self, path):
        self.alive()
        return self._files.listdir(path)

    def stat(self, path):
        self.alive()
        return self._files.stat(path)

    def statvfs(self, path):
        self.alive()
        return self._files.statvfs(path)
