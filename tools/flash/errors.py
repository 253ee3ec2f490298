"""The failures of building and flashing a user can act on.

Each is a :class:`~roboray.tools.cli.CliError`: the command prints its
message as one line and exits 1. The message says what happened and what
to do, never how the code got there.
"""

from __future__ import annotations

from roboray.tools.cli import CliError


class FlashError(CliError):
    """Base of every flashing failure."""


class BuildError(FlashError):
    """The board code does not compile, or the build folder cannot be used."""


class NoBoardFound(FlashError):
    """``--port auto`` found no board, or several to choose from."""


class PortUnavailable(FlashError):
    """The port does not exist, is busy or may not be opened by this user."""


class BoardNotAnswering(FlashError):
    """The port opened but no MicroPython REPL answered on it."""


class ConnectionLost(FlashError):
    """The board stopped answering in the middle of a command."""


class BoardError(FlashError):
    """Code the flashing tool ran on the board raised (a file-system error)."""


class IncompatibleBoard(FlashError):
    """The board's MicroPython cannot load this build's .mpy files."""


class NotEnoughSpace(FlashError):
    """The board's file system cannot hold the files to copy."""


class ShadowedModule(FlashError):
    """A file the tool does not own would hide a module of the build."""


class HashMismatch(FlashError):
    """A file read back on the board differs from what was sent."""


class AppDidNotStart(FlashError):
    """After the reset the application did not report the deployed version."""
