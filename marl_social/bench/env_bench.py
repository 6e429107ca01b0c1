"""Benchmarks (never timed unit tests): env steps per second vs number of agents.

Side by side with highway-env's intersection-multi-agent-v2 at the same agent count and
dt = 0.1 s.

Random actions: accelerations uniform over each car's full range; steering uniform within
STEER_FRACTION of its limit, so that cars stay roughly on the road (full-range random
steering sends every car off the road within a second and the benchmark would time an empty
world). Pedestrians: uniform velocity commands. Every agent's field of view is computed every
step. Episodes that end are reset inside the timed loop, as in a real rollout.
"""

from __future__ import annotations

import cProfile
import io
import pstats
import time
from dataclasses import dataclass

import numpy as np

from marl_social.envs.parallel import parallel_env
from marl_social.envs.policies import policies

STEER_FRACTION = 0.01


@dataclass(frozen=True)
class EnvBenchResult:
    """Throughput of one random-action rollout.

    Attributes:
        label: name of the configuration.
        n_agents: number of possible agents.
        steps: env steps timed.
        seconds: wall time of the timed steps, resets included [s].
        mean_live_agents: mean number of live agents per step.
        ray_queries_per_step: mean number of field-of-view ray queries per step.
    """

    label: str
    n_agents: int
    steps: int
    seconds: float
    mean_live_agents: float
    ray_queries_per_step: float

    @property
    def steps_per_s(self) -> float:
        return self.steps / self.seconds


def _action_bounds(env) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2) low / high of the random actions, in possible_agents order."""
    low = np.array([env.action_space(a).low for a in env.possible_agents], dtype=np.float64)
    high = np.array([env.action_space(a).high for a in env.possible_agents], dtype=np.float64)
    vehicle = np.array([env.agent_specs[a].kind == "vehicle" for a in env.possible_agents])
    low[vehicle, 1] *= STEER_FRACTION
    high[vehicle, 1] *= STEER_FRACTION
    return low, high


def _random_actions(env, rng: np.random.Generator, bounds=None) -> dict:
    low, high = bounds if bounds is not None else _action_bounds(env)
    acts = rng.uniform(low, high)
    index = {a: i for i, a in enumerate(env.possible_agents)}
    return {a: acts[index[a]] for a in env.agents}


def bench_env(scenario: str, n_steps: int, seed: int = 0, label: str | None = None,
              clock=time.perf_counter, **overrides) -> EnvBenchResult:
    """Steps/s of one scenario with random actions (see module docstring).

    clock: what times the steps (time.process_time: CPU time, on a shared machine).
    """
    env = parallel_env(scenario=scenario, max_cycles=100_000, **overrides)
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    for _ in range(10):  # warm-up
        if not env.agents:
            env.reset()
        env.step(_random_actions(env, rng))
    env.reset(seed=seed)
    bounds = _action_bounds(env)
    live, queries = 0, 0
    start = clock()
    for _ in range(n_steps):
        if not env.agents:
            env.reset()
        live += len(env.agents)
        env.step(_random_actions(env, rng, bounds))
        queries += env.last_fov.n_queries
    seconds = clock() - start
    return EnvBenchResult(label or scenario, len(env.possible_agents), n_steps, seconds,
                          live / n_steps, queries / n_steps)


def profile_env(scenario: str, n_steps: int, top: int = 15, **overrides) -> str:
    """CProfile of a random-action rollout, top functions by own time, as text."""
    env = parallel_env(scenario=scenario, max_cycles=100_000, **overrides)
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    bounds = _action_bounds(env)
    profiler = cProfile.Profile()
    profiler.enable()
    for _ in range(n_steps):
        if not env.agents:
            env.reset()
        env.step(_random_actions(env, rng, bounds))
    profiler.disable()
    buf = io.StringIO()
    pstats.Stats(profiler, stream=buf).sort_stats("tottime").print_stats(top)
    return buf.getvalue()


def import_time_s(repeats: int = 3) -> float:
    """Fastest of `repeats` fresh interpreters' `import marl_social` [s] (python -X importtime)."""
    import subprocess
    import sys

    best = float("inf")
    for _ in range(repeats):
        proc = subprocess.run([sys.executable, "-X", "importtime", "-c", "import marl_social"],
                              capture_output=True, text=True, check=True)
        last = [ln for ln in proc.stderr.splitlines() if ln.rstrip().endswith("| marl_social")]
        best = min(best, int(last[-1].split("|")[1]) * 1e-6)  # cumulative [us]
    return best


def run_env_benchmark(agent_counts=(3, 10, 30, 100), n_steps: int = 500, peer: bool = True,
                      profile: bool = False, echo=print, vector: bool = True) -> list[dict]:
    """The `marl-social bench env` job. Returns one row per configuration.

    The paper scenario's peer is highway-env with its 3 agents; with `vector`, a last row
    compares vector_env on 2 processes with one autopilot env (marl_social/bench/vector_bench.py).
    """
    rows = []
    configs = [("paper scenario (occluded_crosswalk)", "occluded_crosswalk", 3, {})]
    configs += [(f"long_road n={n}", "long_road", n,
                 {"n_vehicles": n, "terminate_on_collision": False}) for n in agent_counts]
    peer_fn = None
    if peer:
        from marl_social.bench import highway as bench_highway

        if bench_highway.highway_env_available():
            peer_fn = bench_highway.highway_env_steps_per_second
        else:
            echo("highway-env not installed (pip install 'marl-social[bench]'): no peer column")
    echo(f"{'configuration':<38}{'agents':>7}{'live':>7}{'steps/s':>10}{'us/agent':>10}"
         f"{'rays/step':>10}{'highway-env':>13}{'ratio':>8}")
    for label, scenario, n, overrides in configs:
        steps = max(50, n_steps // max(1, n // 10))
        res = bench_env(scenario, steps, label=label, **overrides)
        us_per_agent = 1e6 / (res.steps_per_s * res.mean_live_agents)  # per live agent-step
        row = {"configuration": label, "agents": n, "live_agents": res.mean_live_agents,
               "steps_per_s": res.steps_per_s, "us_per_agent_step": us_per_agent,
               "ray_queries_per_step": res.ray_queries_per_step}
        peer_txt, ratio_txt = "", ""
        if peer_fn is not None:
            peer_res = peer_fn(n, n_steps=max(30, steps // 4))
            row["highway_env_steps_per_s"] = peer_res["steps_per_s"]
            row["highway_env_vehicles"] = peer_res["n_vehicles_in_scene"]
            row["ratio"] = res.steps_per_s / peer_res["steps_per_s"]
            peer_txt = f"{peer_res['steps_per_s']:.1f}"
            ratio_txt = f"{row['ratio']:.1f}x"
        echo(f"{label:<38}{n:>7}{res.mean_live_agents:>7.1f}{res.steps_per_s:>10.1f}"
             f"{us_per_agent:>10.0f}{res.ray_queries_per_step:>10.1f}{peer_txt:>13}{ratio_txt:>8}")
        rows.append(row)
    if vector:
        from marl_social.bench.vector_bench import bench_vector

        rows.append(bench_vector(echo=echo))
    seconds = import_time_s()
    echo(f"import marl_social: {seconds:.2f} s (fastest of 3 fresh interpreters; goal < 1 s)")
    rows.append({"configuration": "import marl_social", "import_s": seconds})
    if profile:
        echo("\nprofile, paper scenario (top functions by own time):")
        echo(profile_env("occluded_crosswalk", 2000))
        echo("\nprofile, long_road n=30:")
        echo(profile_env("long_road", 300, n_vehicles=30, terminate_on_collision=False))
    return rows


def timed(function, durations_s: list, clock=time.perf_counter):
    """`function`, appending each call's duration [s] on `clock` to durations_s.

    Args:
        function: the callable to time.
        durations_s: the list the durations are appended to [s].
        clock: wall clock (default) or e.g. time.thread_time (CPU time of this thread).
    """
    def timed_call(*args, **kwargs):
        t0 = clock()
        out = function(*args, **kwargs)
        durations_s.append(clock() - t0)
        return out
    return timed_call


# the situation each scenario's planner benchmark runs: the one its claims are about
PLANNER_BENCH_SITUATIONS = {
    "occluded_crosswalk": {"pedestrian": "crossing"},
    "t_intersection": {"hidden_vehicle": "near"},
    "signalized_intersection": {"phase": "protected_left"},
}


def bench_planners(n_episodes: int = 3, robot_planner: str = "social", echo=print,
                   scenario: str = "occluded_crosswalk") -> dict:
    """Decision times of the built-in planners and env steps/s on a scenario (default: the paper's).

    `scenario` is a key of PLANNER_BENCH_SITUATIONS (the crosswalk with a crossing pedestrian,
    the T-intersection with a near hidden car, the signalized intersection on the protected
    left); the pedestrian's line is left out where there is none.

    Decision times of the robot, human driver and pedestrian planners (also in thread CPU
    time, which waiting to be scheduled on a busy machine does not inflate; the robot's also
    split into its belief update and its MPC solve), and env steps/s end to end with every agent on
    its built-in planner; with highway-env installed, the robot's
    decision also as a multiple of one highway-env ``intersection-multi-agent-v2`` step with 3
    agents measured in the same run. Returns the numbers; prints a table.
    """
    if scenario not in PLANNER_BENCH_SITUATIONS:
        raise ValueError(f"bench planners: scenario {scenario!r} must be one of "
                         f"{tuple(PLANNER_BENCH_SITUATIONS)}")
    # the planners' and the belief's compiled kernels load once per process (~1-2 s from
    # numba's cache; a cold cache compiles them): not inside the timing
    from marl_social.models import kernel_loading
    from marl_social.perception.belief import compiled

    kernel_loading.load()
    compiled.kernels()

    decide: dict[str, list] = {}
    mpc_s: list[float] = []  # the robot's MPC solve alone, within its decision
    belief_s: list[float] = []  # the robot's belief update (tracking, own sensors, social)
    # the robot's decision in this thread's CPU time: on a machine shared with other work the
    # wall-clock median also counts the time the process waited to be scheduled
    decide_cpu: dict[str, list] = {}  # the decisions in thread CPU time
    steps, loop_s = 0, 0.0
    for ep in range(n_episodes):
        env = parallel_env(scenario=scenario, robot_planner=robot_planner,
                           **PLANNER_BENCH_SITUATIONS[scenario])
        for a in ("robot_0", "human_0", "pedestrian_0"):
            if a in env.possible_agents:
                decide.setdefault(a, [])
        pols = policies(env)
        for i, p in enumerate(pols.values()):
            p.reset(ep * 10 + i)
        robot_solver = getattr(pols.get("robot_0"), "solver", None)
        if robot_solver is not None:  # time the MPC alone, apart from the belief update
            robot_solver.plan = timed(robot_solver.plan, mpc_s)
        robot_belief = getattr(pols.get("robot_0"), "belief", None)
        if robot_belief is not None:
            robot_belief.update = timed(robot_belief.update, belief_s)
        obs, _ = env.reset(seed=ep)
        while env.agents:
            t_loop = time.perf_counter()
            actions = {}
            for a in env.agents:
                t0, c0 = time.perf_counter(), time.thread_time()
                actions[a] = pols[a](obs[a])
                if a in decide:
                    decide[a].append(time.perf_counter() - t0)
                if a in decide:
                    decide_cpu.setdefault(a, []).append(time.thread_time() - c0)
            obs, *_ = env.step(actions)
            loop_s += time.perf_counter() - t_loop
            steps += 1
    out = {f"{a}_decision_ms_median": 1e3 * float(np.median(v)) for a, v in decide.items()}
    out.update({f"{a}_decision_ms_p99": 1e3 * float(np.percentile(v, 99))
                for a, v in decide.items()})
    out["steps_per_s_all_planners"] = steps / loop_s
    if mpc_s:
        out["robot_0_mpc_ms_median"] = 1e3 * float(np.median(mpc_s))
        out["robot_0_mpc_ms_p99"] = 1e3 * float(np.percentile(mpc_s, 99))
    for a, v in decide_cpu.items():
        out[f"{a}_decision_cpu_ms_median"] = 1e3 * float(np.median(v))
        out[f"{a}_decision_cpu_ms_p99"] = 1e3 * float(np.percentile(v, 99))
    if belief_s:
        out["robot_0_belief_ms_median"] = 1e3 * float(np.median(belief_s))
        out["robot_0_belief_ms_p99"] = 1e3 * float(np.percentile(belief_s, 99))
    echo(f"robot ({robot_planner}) decision  median {out['robot_0_decision_ms_median']:.3f} ms   "
         f"p99 {out['robot_0_decision_ms_p99']:.3f} ms")
    if "robot_0" in decide_cpu:
        echo(f"  in thread CPU time     median {out['robot_0_decision_cpu_ms_median']:.3f} ms   "
             f"p99 {out['robot_0_decision_cpu_ms_p99']:.3f} ms")
    if mpc_s:
        echo(f"  of which the MPC (QP)  median {out['robot_0_mpc_ms_median']:.3f} ms   "
             f"p99 {out['robot_0_mpc_ms_p99']:.3f} ms")
    if belief_s:
        echo(f"  of which the belief    median {out['robot_0_belief_ms_median']:.3f} ms   "
             f"p99 {out['robot_0_belief_ms_p99']:.3f} ms")
    for a, label in (("human_0", "human driver decision "), ("pedestrian_0", "pedestrian decision   ")):
        if a in decide:
            echo(f"{label}  median {out[f'{a}_decision_ms_median']:.3f} ms   "
                 f"p99 {out[f'{a}_decision_ms_p99']:.3f} ms")
            echo(f"  in thread CPU time     median {out[f'{a}_decision_cpu_ms_median']:.3f} ms   "
                 f"p99 {out[f'{a}_decision_cpu_ms_p99']:.3f} ms")
    where = "paper scenario" if scenario == "occluded_crosswalk" else scenario
    echo(f"{where}, every agent on its built-in planner: "
         f"{out['steps_per_s_all_planners']:.1f} env steps/s ({steps} steps)")
    from marl_social.bench import highway as bench_highway

    if bench_highway.highway_env_available():
        peer = bench_highway.highway_env_steps_per_second(3, n_steps=300)
        step_ms = 1e3 / peer["steps_per_s"]
        out["highway_env_step_ms"] = step_ms
        out["robot_decision_per_highway_step_median"] = out["robot_0_decision_ms_median"] / step_ms
        out["robot_decision_per_highway_step_p99"] = out["robot_0_decision_ms_p99"] / step_ms
        echo(f"highway-env {bench_highway.ENV_ID}, 3 agents: {step_ms:.3f} ms per step "
             f"(same run); robot decision = {out['robot_decision_per_highway_step_median']:.2f} "
             f"(median), {out['robot_decision_per_highway_step_p99']:.2f} (p99) highway-env "
             "steps")
    else:
        echo("highway-env not installed (pip install 'marl-social[bench]'): no peer ratio")
    return out
