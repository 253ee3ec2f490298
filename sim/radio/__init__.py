"""The radio link through water, from physics.

- ``water``: the water as a radio sees it: its permittivity at its
  temperature (with its own Debye dielectric loss), the attenuation of a
  plane wave in it, its intrinsic impedance and the loss crossing the
  surface; ``WATERS`` names the waters ``--water`` takes.
- ``radios``: the radios' datasheet figures (``sik-433``, ``sik-915``,
  ``hc12-433``) and the buildable vehicle's own.
- ``link``: the link budget from the ground antenna through the air and the
  surface to the vehicle's antenna at a depth, the margin, the frame loss
  with fading, the reach; ``Channel`` loses frames by it, deterministic for
  a seed, for the twin and the campaigns.

``docs/design/radio-water.md`` has the equations, their sources and how
close they come to published measurements.
"""
