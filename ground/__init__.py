"""Ground station: MAVLink telemetry and commands over a serial radio or UDP."""
