"""Visualization: live frames of a world, animations and the paper-style episode figure."""
