"""Dynamics model, analyses and the software-in-the-loop twin (CPython, numpy)."""
