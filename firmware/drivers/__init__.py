"""Drivers for the vehicle's hardware, bus or pin injected (micropython-lib style).

``ms5837`` (depth), ``lsm6dsox`` (accelerometer, gyroscope), ``lis3mdl``
(magnetometer), ``servo`` (wings), ``radio`` (telemetry UART), ``battery``
(voltage divider on the ADC), ``leak`` (digital probe); ``health`` is the
error bookkeeping every sensor driver shares and the failsafes read.
"""
