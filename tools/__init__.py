"""Developer tools: flashing, the MicroPython interpreter for tests, CLI plumbing."""
