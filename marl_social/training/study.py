"""The learned-robot study: does the social belief, as an observation, help a learned robot?

    marl-social train study --out runs/learned-robot

The robot learns (PPO, training/trainer.py) among the built-in human and pedestrian on the
occluded crosswalk, each episode a crossing, waiting or absent pedestrian under the "wide"
randomization, once with its own observation ("ego") and once with its social belief too
("ego+belief", envs/belief_observation.py): the same budget and `len(seeds)` training seeds
each. Every final checkpoint is then evaluated on fresh seeds of each variant
(learned.evaluate_checkpoint), next to the social planner and the oracle on the same episodes.

Writes to `out`: runs/<observation>_seed<k>/ (each run's log and checkpoints), study.json (the
settings, every run's log and every table row, how much each "ego+belief" robot's acceleration
depends on its belief (`belief_sensitivity`), the wall and CPU time), table.md and
return_vs_steps.png (the mean episode return against env steps, every run and each
observation's mean).
"""

from __future__ import annotations

import json
import multiprocessing as mp
import resource
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from marl_social.training.scene import ROBOT, SceneSettings
from marl_social.training.trainer import PPOSettings, TrainSettings, checkpoints, read_log

OBSERVATIONS = ("ego", "ego+belief")


@dataclass(frozen=True)
class StudySettings:
    """The study's budget.

    Attributes:
        out: the study's folder.
        seeds: training seeds per observation.
        iterations: PPO iterations per run.
        batch: env steps per iteration.
        eval_seeds: evaluation episodes per (run, variant).
        workers: runs (and evaluation processes) at once.
        collision_penalty: the scene's collision penalty in training (the env's reward).
        baselines: built-in robot planners evaluated on the same episodes.
    """

    out: str = "runs/learned-robot"
    seeds: tuple = (0, 1, 2)
    iterations: int = 40
    batch: int = 2000
    eval_seeds: int = 30
    workers: int = 2
    collision_penalty: float = 10_000.0
    baselines: tuple = ("social", "oracle")


def run_settings(study: StudySettings, observation: str, seed: int) -> TrainSettings:
    """One training run of the study."""
    scene = SceneSettings(observation=observation, variants=("crossing", "waiting", "none"),
                          randomize="wide",
                          overrides={"collision_penalty": study.collision_penalty})
    return TrainSettings(scene=scene, ppo=PPOSettings(train_batch_size=study.batch),
                         iterations=study.iterations, env_runners=0, checkpoint_every=10,
                         out=str(Path(study.out) / "runs" / f"{observation}_seed{seed}"),
                         seed=seed, progress=False, cpus=1)


def _train(settings: TrainSettings) -> str:
    from marl_social.training.trainer import train

    done = checkpoints(Path(settings.out))
    if done and int(done[-1].name.split("_")[-1]) >= settings.iterations:
        return str(done[-1])  # finished earlier: the study resumes where it stopped
    result = train(replace(settings, resume=bool(done)))
    return str(result.checkpoint)


def _evaluate(job: tuple) -> list[dict]:
    from marl_social.training.learned import evaluate_checkpoint

    checkpoint, n_seeds = job
    return evaluate_checkpoint(checkpoint, n_seeds=n_seeds, baselines=(), workers=1)


def run_study(study: StudySettings) -> dict:
    """Train every run, evaluate every final checkpoint and the baselines; write the outputs."""
    from marl_social.evaluation.reproduce import VARIANTS, run_episodes, summarize, table_rows
    from marl_social.training.learned import EVAL_SEED0

    out = Path(study.out)
    out.mkdir(parents=True, exist_ok=True)
    wall0, cpu0 = time.time(), _cpu_s()
    runs = [run_settings(study, obs, seed) for obs in OBSERVATIONS for seed in study.seeds]
    ctx = mp.get_context("spawn")
    with ctx.Pool(study.workers) as pool:
        finals = pool.map(_train, runs, chunksize=1)
    train_wall_s = time.time() - wall0
    with ctx.Pool(study.workers) as pool:
        learned_rows = pool.map(_evaluate, [(c, study.eval_seeds) for c in finals], chunksize=1)
    seeds = range(EVAL_SEED0, EVAL_SEED0 + study.eval_seeds)
    baseline_rows = table_rows(
        run_episodes([(p, v, s) for p in study.baselines for v in VARIANTS for s in seeds],
                     study.workers),
        study.baselines, VARIANTS, summarize) if study.baselines else []
    sensitivity = {str(r.seed): belief_sensitivity(c) for r, c in zip(runs, finals)
                   if r.scene.observation == "ego+belief"}
    result = {
        "settings": {**study.__dict__, "seeds": list(study.seeds),
                     "baselines": list(study.baselines)},
        "belief_sensitivity": sensitivity,
        "runs": [{"observation": r.scene.observation, "seed": r.seed, "checkpoint": c,
                  "log": read_log(Path(r.out)), "table": rows}
                 for r, c, rows in zip(runs, finals, learned_rows)],
        "baselines": baseline_rows,
        "train_wall_s": train_wall_s,
        "wall_s": time.time() - wall0,
        "cpu_s": _cpu_s() - cpu0,
    }
    (out / "study.json").write_text(json.dumps(result, indent=1, default=_json_default))
    (out / "table.md").write_text(study_table(result))
    plot_returns(result, out / "return_vs_steps.png")
    return result


def belief_sensitivity(checkpoint: str, n_seeds: int = 5) -> dict:
    """How much an "ego+belief" robot's acceleration depends on its belief features.

    Replays the robot's observations of crossing-pedestrian episodes (seeds EVAL_SEED0, ...,
    the learned robot driving) through its policy three times: with the belief it held, with
    "no hidden agent" (all mass on "none", arrival ARRIVAL_HORIZON_S) and with "a pedestrian
    about to step in" (all mass on the present hypothesis that arrives first, at its arrival
    time). Returns the mean acceleration [m/s^2] of each, the mean absolute difference between
    the last two and the number of observations.

    Args:
        checkpoint: a checkpoint of a run trained with observation="ego+belief".
        n_seeds: episodes.
    """
    from marl_social.envs.belief_observation import ARRIVAL_HORIZON_S
    from marl_social.evaluation.rollout import record_episode
    from marl_social.training.learned import EVAL_SEED0, learned_scene

    recorded: list[np.ndarray] = []
    for seed in range(EVAL_SEED0, EVAL_SEED0 + n_seeds):
        env, pols = learned_scene(checkpoint, "crossing", seed)
        planner = pols[ROBOT]
        if planner.features is None:
            raise ValueError(f"{checkpoint}: not a run with observation='ego+belief'")
        pols[ROBOT] = _Recording(planner, recorded)
        record_episode(env, pols, seed=seed)
        env.close()
    features = planner.features
    size = features.layout.size
    arrival_s, _ = features._arrivals()
    present = np.array([h.present for h in features.belief.hypotheses])
    first = int(np.flatnonzero(present)[np.argmin(arrival_s[present])])
    clear = np.zeros(features.size, np.float32)
    clear[0], clear[-1] = 1.0, ARRIVAL_HORIZON_S
    coming = np.zeros(features.size, np.float32)
    coming[first], coming[-1] = 1.0, arrival_s[first]
    accel: dict[str, list[float]] = {"as_held": [], "no_hidden_agent": [],
                                     "pedestrian_coming": []}
    for full in recorded:
        ego = full[:size]
        for key, belief in (("as_held", full[size:]), ("no_hidden_agent", clear),
                            ("pedestrian_coming", coming)):
            accel[key].append(float(planner.act_on(np.concatenate([ego, belief]), ego)[0]))
    out = {f"mean_accel_{k}_mps2": float(np.mean(v)) for k, v in accel.items()}
    out["mean_abs_change_mps2"] = float(np.mean(np.abs(np.subtract(
        accel["pedestrian_coming"], accel["no_hidden_agent"]))))
    out["observations"] = len(recorded)
    return out


class _Recording:
    """A LearnedPlanner that keeps every full observation (ego + belief) it acts on."""

    needs_truth = False

    def __init__(self, planner, recorded: list):
        self.planner, self.recorded = planner, recorded

    def reset(self, seed=None):
        self.planner.reset(seed)

    def __call__(self, obs):
        full = np.concatenate([obs, self.planner.features(obs)])
        self.recorded.append(full)
        return self.planner.act_on(full, obs)


def _cpu_s() -> float:
    """CPU time of this process and its finished children [s] (the runs' Ray workers too)."""
    me, kids = (resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def _json_default(value):
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    raise TypeError(f"not JSON: {type(value).__name__}")


COLUMNS = (("collision", "collision_rate", "{:.0%}"), ("hard brake", "hard_brake_rate", "{:.0%}"),
           ("yielded", "yield_rate", "{:.0%}"), ("time to pass [s]", "time_to_pass_s", "{:.2f}"),
           ("mean speed [m/s]", "mean_speed_mps", "{:.2f}"))


def study_table(result: dict) -> str:
    """Markdown: per (robot, variant) the mean (min-max over training seeds) of each column."""
    lines = ["| robot | pedestrian | episodes | " + " | ".join(t for t, _, _ in COLUMNS) + " |",
             "|---|---|---|" + "---|" * len(COLUMNS)]
    for obs in OBSERVATIONS:
        runs = [r for r in result["runs"] if r["observation"] == obs]
        for variant in ("crossing", "waiting", "none"):
            rows = [row for r in runs for row in r["table"] if row["variant"] == variant
                    and row["n"] > 0]
            if not rows:
                continue
            cells = []
            for _, key, fmt in COLUMNS:
                values = np.array([row[key] for row in rows], float)
                cells.append(f"{fmt.format(np.nanmean(values))} "
                             f"({fmt.format(np.nanmin(values))}–{fmt.format(np.nanmax(values))})"
                             if np.isfinite(values).any() else "–")
            lines.append(f"| learned, {obs} | {variant} | {sum(r['n'] for r in rows)} | "
                         + " | ".join(cells) + " |")
    for row in result["baselines"]:
        if row["n"] == 0:
            continue
        cells = [fmt.format(row[key]) for _, key, fmt in COLUMNS]
        lines.append(f"| {row['planner']} | {row['variant']} | {row['n']} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def plot_returns(result: dict, path: Path) -> Path:
    """The mean episode return against env steps: every run thin, each observation's mean."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for obs, color in zip(OBSERVATIONS, ("tab:blue", "tab:orange")):
        logs = [r["log"] for r in result["runs"] if r["observation"] == obs and r["log"]]
        for log in logs:
            ax.plot([row["env_steps"] for row in log], [row["return_mean"] for row in log],
                    color=color, alpha=0.3, lw=1)
        n = min(len(log) for log in logs) if logs else 0
        if n:
            steps = [row["env_steps"] for row in logs[0][:n]]
            mean = np.nanmean([[row["return_mean"] for row in log[:n]] for log in logs], axis=0)
            ax.plot(steps, mean, color=color, lw=2.5, label=f"{obs} (mean of {len(logs)} seeds)")
    ax.set_xlabel("env steps")
    ax.set_ylabel("mean episode return (reward x 1e-3)")
    ax.set_title("Learned robot on the occluded crosswalk")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
