"""MicroPython code of the twin: the emulated board the firmware runs on.

``vclock`` (the ``time`` module on a virtual clock), ``machine`` (a Pico 2's
peripherals with the twin's side exposed), the emulated I2C devices
(``ms5837_device``, ``lsm6dsox_device``, ``lis3mdl_device``) and
``powercut`` (file operations that lose power). Everything here runs inside
the interpreter that runs the firmware; ``roboray.sim.twin.install`` copies
it there.
"""
