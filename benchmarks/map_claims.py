"""The built-in scenes' claims on every buildable crosswalk and junction of a map (map_scene).

Per crosswalk, 20 seeds of the "wide" randomization (evaluation/run.randomized_overrides):
the social robot with a crossing pedestrian (and the humans' counterfactual warning), and the
social, oracle and conservative robots without a pedestrian. Printed per crosswalk and over all
of them together: collisions, yields, the belief before sight where a human warned (lead >=
0.5 s), the mean times to pass. Per junction (--situation junction), 20 seeds of
JUNCTION_RANGES with the social robot and the hidden car: collisions, the hardest braking it
forced on a human (others_max_decel_mps2), and how often it passed the junction.

    python benchmarks/map_claims.py [MAP] [--situation crosswalk|junction] [--seeds N]
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from marl_social.evaluation.reproduce import map_jobs
from marl_social.evaluation.run import randomized_overrides, run_episode

LEAD_S = 0.5  # a human warned at least this long before the robot saw the pedestrian [s]
CASES = (("social", "crossing"), ("social", "none"), ("oracle", "none"),
         ("conservative", "none"))
QUICK_CASES = CASES[:3]  # --quick: without the conservative robot (minutes per episode at
# a crosswalk where it never passes: it plans for every hypothesis it cannot rule out)
HORIZON = {"crossing": 200, "none": 150}
# the junction's randomization: the hidden car's start [m] and speed [m/s], the robot's and
# the sensors' initial speeds [m/s], the sensors' start [m] and rationality
JUNCTION_RANGES = {"hidden_m": (25.0, 40.0), "hidden_speed_mps": (6.0, 11.0),
                   "junction_robot_speed_mps": (2.0, 7.0), "sensor_speed_mps": (3.0, 7.0),
                   "human_start_m": (8.0, 25.0), "human_beta": (2.0, 30.0)}
JUNCTION_STEPS = 250
PASSED_BEYOND_M = 10.0  # the robot passed the junction: this far past its conflict point [m]


def junction_overrides(seed: int) -> dict:
    """One seed's draw of JUNCTION_RANGES (uniform, in that order, generator 20_000 + seed)."""
    rng = np.random.default_rng(20_000 + seed)
    return {key: float(rng.uniform(lo, hi)) for key, (lo, hi) in JUNCTION_RANGES.items()}


def one_junction(job: tuple) -> dict:
    """One junction episode's metrics: job = (map, element, seed)."""
    warnings.simplefilter("ignore")
    map_name, element, seed = job
    from marl_social.maps.scenes import SceneError
    from marl_social.scenarios.map_scene import MapScene
    from marl_social.sim.road_map import Route

    overrides = {"map": map_name, "situation": "junction", "element": element,
                 **junction_overrides(seed)}
    try:
        MapScene(**overrides)
    except SceneError:  # this draw's hidden car starts where nothing hides it
        return {"element": element, "unbuildable": True}
    res = run_episode("map_scene", seed=seed, max_cycles=JUNCTION_STEPS,
                      robot_planner="social", **overrides)
    plan = MapScene(**overrides).plan
    trace = res.trace
    robot = trace.index("robot_0")
    last = np.flatnonzero(trace.active[:, robot])[-1]
    s_end = float(Route(plan.robot.points).project(trace.states[last:last + 1, robot, :2])[0][0])
    passed = s_end > plan.robot.crossing_m + PASSED_BEYOND_M
    return {"element": element, "passed": bool(passed), **res.metrics}


def junction_summary(rows: list[dict]) -> dict:
    """The junction lines' numbers over rows (draws the scene cannot be built with left out)."""
    skipped = sum(bool(r.get("unbuildable")) for r in rows)
    rows = [r for r in rows if not r.get("unbuildable")]
    return {"episodes": len(rows), "draws_not_buildable": skipped,
            "collisions": int(sum(bool(r["collision"]) for r in rows)),
            "max_forced_decel": float(max(r["others_max_decel_mps2"] for r in rows)),
            "forced_over_3": int(sum(r["others_max_decel_mps2"] > 3.0 for r in rows)),
            "passed": int(sum(r["passed"] for r in rows)),
            "robot_max_decel": float(max(r["max_decel_mps2"] for r in rows))}


def one(job: tuple) -> dict:
    """One episode's metrics: job = (map, element, planner, pedestrian, seed)."""
    warnings.simplefilter("ignore")
    map_name, element, planner, pedestrian, seed = job
    res = run_episode("map_scene", seed=seed, max_cycles=HORIZON[pedestrian],
                      counterfactual=pedestrian == "crossing", map=map_name, element=element,
                      robot_planner=planner, pedestrian=pedestrian,
                      **randomized_overrides(seed, "wide"))
    return {"element": element, "case": (planner, pedestrian), **res.metrics}


def summary(rows: list[dict]) -> dict:
    """The claims' numbers over rows (one crosswalk's or all)."""
    def pick(case, key):
        return np.array([r[key] for r in rows if r["case"] == case], dtype=np.float64)

    crossing = [r for r in rows if r["case"] == ("social", "crossing")]
    warned = [r for r in crossing if r["warning_lead_s"] >= LEAD_S]
    social, oracle, conservative = (pick((p, "none"), "time_to_pass_s")
                                    for p in ("social", "oracle", "conservative"))
    return {
        "episodes": len(crossing),
        "collisions": int(sum(bool(r["robot_collision"]) for r in crossing)),
        "yielded": int(sum(bool(r["yielded"]) for r in crossing)),
        "warned": len(warned),
        "confident_before_seen": int(sum(bool(r["belief_confident_before_seen"])
                                         for r in warned)),
        "max_decel_crossing": float(pick(("social", "crossing"), "max_decel_mps2").max()),
        "social_none_s": float(np.mean(social)), "oracle_none_s": float(np.mean(oracle)),
        "social_over_oracle": float(np.mean(social) / np.mean(oracle)),
        "conservative_over_oracle": float(np.mean(np.where(np.isfinite(conservative),
                                                           conservative, np.inf))
                                          / np.mean(oracle)),
        "not_passed": int(sum(~np.isfinite(np.concatenate([social, oracle])))),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("map", nargs="?", default="karlsruhe")
    parser.add_argument("--situation", default="crosswalk", choices=("crosswalk", "junction"))
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--quick", action="store_true", help="no conservative robot")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    from marl_social.maps import load_map
    from marl_social.maps.listing import scene_listing

    elements = [e.element for e in scene_listing(load_map(args.map))
                if e.situation == args.situation and not e.reason]
    if args.situation == "junction":
        rows = map_jobs(one_junction, [(args.map, el, s) for el in elements
                                       for s in range(args.seeds)], args.workers, progress=True)
        for el in elements:
            print(el, junction_summary([r for r in rows if r["element"] == el]))
        print("all", junction_summary(rows))
        return
    jobs = [(args.map, el, p, v, s) for el in elements
            for p, v in (QUICK_CASES if args.quick else CASES) for s in range(args.seeds)]
    rows = map_jobs(one, jobs, args.workers, progress=True)
    for el in elements:
        print(el, summary([r for r in rows if r["element"] == el]))
    print("all", summary(rows))


if __name__ == "__main__":
    main()
