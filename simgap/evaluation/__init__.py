"""simgap.evaluation."""
