"""The PettingZoo environment.

The world (true state, one step of physics, perception and costs), the parallel and AEC envs,
the built-in policies of an env and the autopilot wrapper.
"""
