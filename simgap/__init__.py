"""simgap: the gap between a simulator and the real system it stands for."""
