"""The emulated RP2350: our MicroPython port for QEMU (``port/``), its recipe
(``build.sh``), the built image (``image/``) and the calibration that turns
its instruction counts into RP2350 time (``calibration.py``)."""
