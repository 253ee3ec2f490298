"""Identification: the vehicle learnt from its own dive's flight log.

``roboray-sim identify`` (``sim/commands/identify.py``) runs these:

- ``log``: the DataFlash log read (pymavlink's DFReader): inputs, outputs,
  the release, the stretch before the bottom, where the input is unknown;
- ``parameters``: the uncertain parameters as the fit moves them, mapped
  onto a vehicle file's fields;
- ``shooting``: the model flown over the log's segments (multiple
  shooting), many vehicles in one compiled batch, and the residuals;
- ``fit``: least squares, covariance, identifiability;
- ``descent``: the firmware's dead-reckoning descent model fitted to the
  identified vehicle (the ``DR_*`` parameters);
- ``outputs``: the fitted vehicle file, the parameter file, the plot.

docs/design/identification.md says why it is done this way and what it
recovers on the twin.
"""
