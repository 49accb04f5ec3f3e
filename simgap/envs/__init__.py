"""simgap.envs."""
