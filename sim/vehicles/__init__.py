"""Vehicle parameter files. ``reference.py`` is the thesis's vehicle; copy it,
edit it and pass it with ``--vehicle FILE.py`` to any ``roboray-sim`` command."""
