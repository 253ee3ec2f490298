"""Board profiles: which pins and buses the vehicle's hardware is on.

One module a board (``pico2`` is the default); another board is another
module with the same names, never an edit elsewhere. ``load(name)`` imports
one; ``DEFAULT`` is what ``firmware/app.py`` uses when not told otherwise.
"""

DEFAULT = "pico2"


def load(name=None):
    """The profile module ``name`` (``DEFAULT`` if None); ValueError if unknown."""
    if name is None:
        name = DEFAULT
    full = "roboray.firmware.boards." + name
    try:
        return __import__(full, None, None, ("NAME",))
    except ImportError:
        raise ValueError("no board profile %r (expected firmware/boards/%s.py)" % (name, name))
