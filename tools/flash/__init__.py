"""Building the board code with mpy-cross and deploying it with mpremote's transport."""
