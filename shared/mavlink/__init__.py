"""MAVLink 2 for the board: allocation-free codec, signing and the vehicle's endpoint.

- ``messages``: the message table, generated from pymavlink's common.xml
  by ``tools/mavgen.py`` (ids, CRC_EXTRA, lengths, struct formats, names).
- ``crc``: the X.25 (CRC-16/MCRF4XX) checksum MAVLink frames carry.
- ``frame``: ``Writer``, which frames a payload packed in place with
  ``struct.pack_into`` (MAVLink 2 or 1, truncated, optionally signed).
- ``parser``: ``Parser``, a state machine fed a byte or a buffer at a time
  that validates, resynchronises and counts.
- ``signing``: MAVLink 2 message signing with replay protection.
- ``endpoint``: the vehicle side of the link (parameters, commands,
  telemetry streams, heartbeat) over an injected transport;
- ``mission``: the mission protocol, the landing target as a mission
  (home and one NAV_LAND), for the endpoint.
"""
