"""Peer speed benchmark: highway-env ``intersection-multi-agent-v2``.

Measures how many environment steps per second (wall clock) highway-env's
multi-agent intersection scene sustains when configured like the
``marl-social`` simulator, so the two can be compared at equal vehicle counts.

Configuration (overrides passed to ``gymnasium.make``; everything else is the
environment's default)
----------------------------------------------------------------------------
* ``simulation_frequency = 10`` [Hz] and ``policy_frequency = 10`` [Hz]:
  one physics sub-step of dt = 0.1 s per ``env.step`` call.
* ``controlled_vehicles = N``: every vehicle in the scene is an agent.
* ``initial_vehicle_count = 0`` and ``spawn_probability = 0.0``: no
  background (IDM) traffic at reset nor during the episode.
* ``offscreen_rendering = True``, ``real_time_rendering = False``,
  ``manual_control = False``, ``show_trajectories = False`` and
  ``render_mode=None``: nothing is ever drawn and no window is opened.
  Note that in highway-env ``offscreen_rendering = True`` is the setting that
  *prevents* a window (it means "render to an off-screen surface if asked
  to"); with ``render_mode=None`` the viewer is never even created.
* Action and observation keep the multi-agent defaults of the environment:
  ``{"type": "MultiAgentAction", "action_config": {"type":
  "DiscreteMetaAction", "longitudinal": True, "lateral": False,
  "target_speeds": [0, 4.5, 9]}}`` (target speeds in m/s, so the joint
  action space is ``Tuple(Discrete(3) x N)``) and ``MultiAgentObservation``
  of ``Kinematics`` (15 nearest vehicles x 7 features per agent), computed
  by the environment on every step together with rewards and info.
* ``duration`` keeps its default of 13 s, i.e. episodes are truncated after
  130 steps.

Rollout protocol
----------------
Random joint actions from ``env.action_space.sample()``. highway-env rebuilds
its action space on every reset, so the action space is re-seeded after each
reset from a generator derived from ``seed``; the scene itself is seeded once
with ``env.reset(seed=seed)``. A few warm-up steps run before timing. Inside
the timed loop only ``env.step`` calls are counted, but the wall time
(``time.perf_counter``) includes the resets that happen whenever an episode
ends, as in a real rollout.

Caveats (checked against highway-env 1.12.1 / gymnasium 1.x)
-----------------------------------------------------------
* Episode end. The ``-v1`` id wraps the env in ``MultiAgentWrapper``, which
  returns ``terminated`` as a per-agent tuple (agent crashed or arrived) and
  drops the env-level flag (which would end the episode as soon as *any*
  controlled vehicle crashes). A non-empty tuple is always truthy, so a
  naive ``terminated or truncated`` would reset after every single step.
  Here an episode is over when ``all(terminated) or truncated``.
* Crashed vehicles are not removed: highway-env forces them to brake to a
  standstill (zero steering) and they stay in the scene as collidable
  obstacles; arrived agents also stay and keep driving. Controlled vehicles
  are never cleared, so the scene always holds the N agents.
* Placement. highway-env puts controlled vehicle ``i`` on approach lane
  ``i % 4`` at a longitudinal position of about 65 m +/- 5 m (normal) from
  the lane start, with no overlap check between controlled vehicles. For
  N <= 4 this is fine; for N >= 5 several agents share a lane around the same
  spot, so many of them overlap at reset and are marked crashed on the first
  step (measured: ~1 of 5, ~7 of 10, ~29 of 30, ~99 of 100). All N vehicles
  are nevertheless in the scene and are simulated, collision-checked and
  observed every step, so the per-step cost still reflects N vehicles, but
  the traffic is a pile-up rather than free-flowing. There is no config key
  to change the spawn positions. A fall-back with fewer agents plus
  background traffic cannot reach larger N either: the intersection spawner
  keeps >= 15 m between vehicles and caps the scene at roughly 15 vehicles
  after reset and ~35 in steady state with ``spawn_probability = 1``, and the
  count is random. Hence N controlled vehicles are used for every N.
  Because every agent of such a pile-up soon counts as terminated, episodes
  are also much shorter than 130 steps for large N (5 and 6 resets per 300
  steps were measured at N = 30 and N = 100), so reset time weighs more.
* Cost profile. About 90 % of a step is the per-agent ``Kinematics``
  observation (built with pandas, ~8-9 ms per agent per step on the test
  machine); the physics sub-step is a few ms, with an O(N^2) pairwise
  collision check. Throughput therefore falls roughly as 1/N.
* "Challenger" vehicle. ``IntersectionEnv._make_vehicles`` always adds one
  IDM vehicle (spawn probability hard-coded to 1, not configurable); it is
  removed by the env only if it lands within 20 m of a controlled vehicle,
  which practically always happens for N >= 4 but not for N < 4. To keep exactly N
  vehicles, any non-controlled vehicle left after a reset is removed from
  ``env.unwrapped.road.vehicles`` (done inside the timed loop for mid-run
  resets; the cost is negligible).
* ``-v2`` is highway-env's newest version of the env (``-v1`` now warns that it is out of
  date); the goals of docs/benchmarks.md were set against ``-v1``, whose step was ~15 %
  slower.
"""

from __future__ import annotations

import copy
import importlib.util
import time
import warnings

import numpy as np

ENV_ID = "intersection-multi-agent-v2"
SIM_FREQUENCY_HZ = 10  # physics rate [Hz] -> dt = 0.1 s
POLICY_FREQUENCY_HZ = 10  # decision rate [Hz] -> one physics step per env.step
N_WARMUP_STEPS = 5


def highway_env_available() -> bool:
    """Return True iff ``import highway_env`` works."""
    if importlib.util.find_spec("highway_env") is None:
        return False
    try:
        import highway_env  # noqa: F401
    except (ImportError, OSError):
        return False
    return True


def _make_config(n_vehicles: int) -> dict:
    """Config overrides giving exactly ``n_vehicles`` controlled vehicles."""
    return {
        "simulation_frequency": SIM_FREQUENCY_HZ,
        "policy_frequency": POLICY_FREQUENCY_HZ,
        "controlled_vehicles": n_vehicles,
        "initial_vehicle_count": 0,
        "spawn_probability": 0.0,
        "offscreen_rendering": True,
        "real_time_rendering": False,
        "manual_control": False,
        "show_trajectories": False,
    }


def _reset(env, rng: np.random.Generator, seed: int | None = None) -> None:
    """Reset, drop the non-controlled "challenger" vehicle, re-seed actions."""
    env.reset(seed=seed)
    base = env.unwrapped
    controlled = base.controlled_vehicles
    base.road.vehicles = [v for v in base.road.vehicles if v in controlled]
    # The action space object is rebuilt by every reset: seed the new one.
    env.action_space.seed(int(rng.integers(2**31 - 1)))


def _rollout(n_vehicles: int, n_steps: int, seed: int, clock=time.perf_counter) -> dict:
    """Run the timed random rollout (timed by clock); return detailed statistics."""
    import gymnasium as gym
    import highway_env  # noqa: F401  (registers the environments)

    if n_vehicles < 1:
        raise ValueError("n_vehicles must be >= 1")
    if n_steps < 1:
        raise ValueError("n_steps must be >= 1")

    config = _make_config(n_vehicles)
    with warnings.catch_warnings():  # "-v1 is out of date": kept on purpose, see docstring
        warnings.simplefilter("ignore", DeprecationWarning)
        env = gym.make(ENV_ID, config=copy.deepcopy(config), render_mode=None)
    try:
        base = env.unwrapped
        rng = np.random.default_rng(seed)
        _reset(env, rng, seed=seed)
        n_in_scene = len(base.road.vehicles)
        n_controlled = len(base.controlled_vehicles)

        def one_step() -> bool:
            _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            return bool(all(terminated) or truncated)

        for _ in range(N_WARMUP_STEPS):
            if one_step():
                _reset(env, rng)

        crashed_at_start = sum(v.crashed for v in base.controlled_vehicles)
        n_resets = 0
        min_count = max_count = len(base.road.vehicles)
        t0 = clock()
        for _ in range(n_steps):
            done = one_step()
            count = len(base.road.vehicles)
            min_count = min(min_count, count)
            max_count = max(max_count, count)
            if done:
                _reset(env, rng)
                n_resets += 1
        elapsed_s = clock() - t0
    finally:
        env.close()

    return {
        "steps_per_s": n_steps / elapsed_s,
        "n_vehicles_in_scene": n_in_scene,
        "n_controlled": n_controlled,
        "config": config,
        "elapsed_s": elapsed_s,
        "n_resets": n_resets,
        "min_vehicles_during_run": min_count,
        "max_vehicles_during_run": max_count,
        "crashed_after_warmup": crashed_at_start,
    }


def highway_env_steps_per_second(n_vehicles: int, n_steps: int = 300, seed: int = 0,
                                 clock=time.perf_counter) -> dict:
    """Env steps per second of highway-env's ``intersection-multi-agent-v2``.

    Returns {"steps_per_s": float, "n_vehicles_in_scene": int, "n_controlled": int,
    "config": dict}.

    Time ``n_steps`` random-action steps (dt = 0.1 s each) of
    ``intersection-multi-agent-v2`` with ``n_vehicles`` controlled vehicles
    and no background traffic (see the module docstring for the exact setup
    and caveats). ``steps_per_s`` is env steps per wall-clock second, resets
    included; ``n_vehicles_in_scene`` is ``len(env.unwrapped.road.vehicles)``
    right after the first reset; ``config`` holds the overrides passed to
    ``gymnasium.make``. clock times the steps (time.process_time: CPU time, resets included;
    steps_per_s is then per CPU second).
    """
    stats = _rollout(n_vehicles, n_steps, seed, clock)
    return {
        "steps_per_s": stats["steps_per_s"],
        "n_vehicles_in_scene": stats["n_vehicles_in_scene"],
        "n_controlled": stats["n_controlled"],
        "config": stats["config"],
    }


if __name__ == "__main__":
    if not highway_env_available():
        raise SystemExit("highway-env is not installed")
    print(f"{'N':>5} {'steps/s':>10} {'in scene':>9} {'controlled':>10}")
    for n in (3, 10, 30, 100):
        res = highway_env_steps_per_second(n)
        print(
            f"{n:>5} {res['steps_per_s']:>10.1f} "
            f"{res['n_vehicles_in_scene']:>9} {res['n_controlled']:>10}"
        )
