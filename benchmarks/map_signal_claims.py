"""The signal situation's line on a map's traffic lights (map_scene, situation="signal").

Per buildable traffic light (`marl-social scenes MAP`), 20 seeds of the built-in signalized
intersection's randomization (evaluation/run.RANDOMIZATIONS["signalized_intersection"]: the
cross traffic's number, start, gap and speed, the left-turners' number, start and rationality,
the time already spent in the phase, the robot's start), half of them in each phase variant,
with the social robot: collisions, how often it forced a human to brake harder than
FORCED_BRAKE_MPS2 (others_max_decel_mps2), the hardest such braking, and how often it turned
(its front PASSED_BEYOND_M past its line).

    python benchmarks/map_signal_claims.py [MAP] [--seeds N] [--workers N]
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from marl_social.evaluation.reproduce import map_jobs
from marl_social.evaluation.run import randomized_overrides, run_episode

PHASES = ("protected_left", "cross_green")
STEPS = 200
FORCED_BRAKE_MPS2 = 3.0
PASSED_BEYOND_M = 10.0


def one_signal(job: tuple) -> dict:
    """One episode's metrics: job = (map, element, seed); the phase alternates with the seed."""
    warnings.simplefilter("ignore")
    map_name, element, seed = job
    from marl_social.maps.scenes import SceneError
    from marl_social.scenarios.map_scene import MapScene
    from marl_social.sim.road_map import Route

    overrides = {"map": map_name, "situation": "signal", "element": element,
                 "phase": PHASES[seed % 2],
                 **randomized_overrides(seed, "signalized_intersection")}
    try:
        scene = MapScene(**overrides)
    except SceneError:  # this draw's cars start where the map has no room for them
        return {"element": element, "unbuildable": True}
    res = run_episode("map_scene", seed=seed, max_cycles=STEPS, robot_planner="social",
                      **overrides)
    trace = res.trace
    robot = trace.index("robot_0")
    last = np.flatnonzero(trace.active[:, robot])[-1]
    s_end = float(Route(scene.plan.robot.points).project(
        trace.states[last:last + 1, robot, :2])[0][0])
    return {"element": element, "phase": overrides["phase"], "seed": seed,
            "passed": bool(s_end > scene.plan.robot.crossing_m + PASSED_BEYOND_M),
            **res.metrics}


def summary(rows: list[dict]) -> dict:
    """The signal line's numbers over rows (draws the scene cannot be built with left out)."""
    skipped = sum(bool(r.get("unbuildable")) for r in rows)
    rows = [r for r in rows if not r.get("unbuildable")]
    return {"episodes": len(rows), "draws_not_buildable": skipped,
            "collisions": int(sum(bool(r["collision"]) for r in rows)),
            "forced_over_3": int(sum(r["others_max_decel_mps2"] > FORCED_BRAKE_MPS2
                                     for r in rows)),
            "max_forced_decel": float(max((r["others_max_decel_mps2"] for r in rows),
                                          default=0.0)),
            "passed": int(sum(r["passed"] for r in rows))}


def main() -> None:
    warnings.simplefilter("ignore")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("map", nargs="?", default="karlsruhe")
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    from marl_social.maps import load_map
    from marl_social.maps.listing import scene_listing

    elements = [e.element for e in scene_listing(load_map(args.map))
                if e.situation == "signal" and not e.reason]
    jobs = [(args.map, element, seed) for element in elements for seed in range(args.seeds)]
    rows = map_jobs(one_signal, jobs, args.workers)
    for element in elements:
        mine = [r for r in rows if r["element"] == element]
        print(f"signal {element}: {summary(mine)}")
        for r in mine:
            if not r.get("unbuildable") and (r["collision"]
                                             or r["others_max_decel_mps2"] > FORCED_BRAKE_MPS2):
                print(f"   seed {r['seed']} {r['phase']}: collision={r['collision']} "
                      f"forced {r['others_max_decel_mps2']:.1f} m/s^2")


if __name__ == "__main__":
    main()
