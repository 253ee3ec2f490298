"""A real MicroPython (the WebAssembly port under Node.js) for tests, benchmarks
and the software-in-the-loop twin."""

from .compare import assert_close_f32, check_same, differences, run_both
from .install import MicroPythonUnavailable
from .interpreter import InterpreterDied, MicroPython, MicroPythonError

__all__ = [
    "MicroPython", "MicroPythonError", "InterpreterDied", "MicroPythonUnavailable",
    "assert_close_f32", "check_same", "differences", "run_both",
]
