"""The simulation core: data types and pure physics (agent specs, road map, geometry mirrors,
footprints, dynamics, costs, the observation layout, the episode trace). Imports nothing else of
the project.
"""
