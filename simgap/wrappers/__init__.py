"""simgap.wrappers."""
