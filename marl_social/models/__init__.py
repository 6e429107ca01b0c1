"""Decision models shared by acting and inferring.

Candidate rollouts, Boltzmann choice, the driver and pedestrian Q-models, path tracking. A human
plans with them; the robot models a human with the same code.
"""
