"""models/driver.rule_abiding_totals in numpy, as it stood before its compiled call."""

from __future__ import annotations

import numpy as np

from marl_social.models.candidates import CandidateEvaluation, collision_free_totals
from marl_social.models.driver import DriverModel, RoadRules


def rule_abiding_totals(ev: CandidateEvaluation, model: DriverModel, s0: float,
                        rules: RoadRules | None) -> np.ndarray:
    """(L, A, C) the totals of the plans that keep the rules, inf for the others, in numpy."""
    totals = collision_free_totals(ev)
    # every plan keeping the rules leaves the totals as they are (np.where of all-True picks them)
    if rules is None or (rules.stop_s_m is None and ev.curve_excess_mps is None):
        return totals
    ok = None  # (A, C) the plans that keep the rules; None: every plan
    if rules.stop_s_m is not None:
        front = s0 + ev.travel_m[..., -1] + 0.5 * model.vehicle.length_m  # (A, C)
        overshoot = np.maximum(front - rules.stop_s_m, 0.0)
        ok = overshoot <= overshoot.min()
    if ev.curve_excess_mps is not None:
        excess = np.maximum(ev.curve_excess_mps, 0.0)
        if ok is not None:
            excess = np.where(ok, excess, np.inf)
        within = excess <= excess.min()
        ok = within if ok is None else ok & within
    if ok is None or ok.all():
        return totals
    kept = np.where(ok, totals, np.inf)
    hopeless = ~np.isfinite(kept).any(axis=(-1, -2), keepdims=True)
    return np.where(hopeless, totals, kept)

