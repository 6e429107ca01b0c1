"""Agents: costs and planners, installed as marl_social.agents."""
