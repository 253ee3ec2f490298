"""Subcommands of ``roboray-sim``, one module a topic."""
