"""RoboRay MicroPython: the one configuration (``mpconfig_roboray.h``) and
its builds' recipes and committed artefacts (``host/``: the twin's
interpreter; ``pico2/``: the Pico 2 firmware). A package only so that an
installed ``roboray`` carries the files (pyproject.toml's package-data)."""
