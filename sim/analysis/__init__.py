"""Analyses of the model: the thesis's reduced model and tables (chapter 3),
steady descents with drag and their modes, the reachable glide, stability
maps and controllability (sec. 4.1)."""
