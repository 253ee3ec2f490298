"""The MicroPython application that flies the vehicle."""
