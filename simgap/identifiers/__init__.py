"""simgap.identifiers."""
