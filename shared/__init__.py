"""Board code shared by the vehicle and the simulator: estimator, controllers,
mode logic, MAVLink codec. Runs unchanged on CPython and MicroPython."""
