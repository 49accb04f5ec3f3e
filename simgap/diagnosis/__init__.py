"""simgap.diagnosis."""
