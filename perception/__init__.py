"""Perception: fields of view, sensors, tracking and beliefs, installed as marl_social.perception."""
