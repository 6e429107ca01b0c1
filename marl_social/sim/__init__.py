"""The simulation core: data types and pure physics.

Agent specs, road map, geometry mirrors, footprints, dynamics, costs, the observation layout and
the episode trace. Imports nothing else of the project.
"""
