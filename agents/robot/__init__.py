"""The robot: the social-perception planner (planner) and its contingency MPC (mpc)."""
