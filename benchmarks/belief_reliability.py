"""How reliably the robot's belief reads the humans, on fresh seeds of the whole ranges.

For each scene and variant, over `--episodes` fresh seeds (from `--seed-base`, far from the
0-49 the claims tests use) of each scene's whole-range randomization (run.RANDOMIZATIONS:
"wide" for the occluded crosswalk, "t_intersection", "signalized_intersection"), it measures
the lines of "what it must show" of the belief's reliability:

* a human warned (its speed departs >= 1 m/s from the same seed without the hidden agent,
  evaluation/counterfactual.py, >= 0.5 s before the robot's first sight of the hidden agent;
  at the signal, where the hidden thing is the cross traffic's phase, before the robot pulls
  out): the belief exceeds 0.9 before that time; once above 0.9 it never falls below 0.5
  before it; it crosses 0.5 at most once before it;
* nothing hidden (no pedestrian, human beta 2-30; the cross traffic on green for the
  protected left): the belief stays below 0.5; with 1 m robot position noise the robot never
  brakes harder than 2 m/s^2;
* every cell: the robot brakes <= 4 m/s^2, its MPC's infeasible steps and of them the surprises
  (a comfortable stop one step earlier would have met the plan's bounds), collisions; the social
  robot's time to pass against the oracle's with nothing hidden.

Writes a JSON file and a Markdown table (and with --figure the reliability diagram,
marl_social/evaluation/belief_reliability.py). Runs on a process pool with a progress bar:

    PYTHONPATH=. python benchmarks/belief_reliability.py --episodes 40 --out results/reliability
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from marl_social.data import strict_json
from marl_social.evaluation.belief_reliability import (
    BEFORE_SIGHT_S,
    LEAD_S,
    SCENE_PAIRS,
    Cell,
    brier_score,
    plot_reliability,
    reliability_episode,
    reliability_points,
)
from marl_social.evaluation.reproduce import map_jobs

CW, T, SIG = "occluded_crosswalk", "t_intersection", "signalized_intersection"
PRESETS = {CW: "wide", T: "t_intersection", SIG: "signalized_intersection"}
CELLS = {
    "crosswalk social crossing": SCENE_PAIRS[CW][0],
    "crosswalk social waiting": Cell(CW, "social", {"pedestrian": "waiting"}, 150),
    "crosswalk social none": SCENE_PAIRS[CW][1],
    "crosswalk social none, 1 m noise": Cell(CW, "social", {"pedestrian": "none",
                                                             "robot_pos_noise_m": 1.0}, 200),
    "crosswalk oracle none": Cell(CW, "oracle", {"pedestrian": "none"}, 100),
    "T social near": SCENE_PAIRS[T][0],
    "T social far": Cell(T, "social", {"hidden_vehicle": "far"}, 150, preset=PRESETS[T]),
    "T social none": SCENE_PAIRS[T][1],
    "T oracle none": Cell(T, "oracle", {"hidden_vehicle": "none"}, 120, preset=PRESETS[T]),
    "signal social protected_left": SCENE_PAIRS[SIG][0],
    "signal social cross_green": SCENE_PAIRS[SIG][1],
    "signal conservative protected_left": Cell(SIG, "conservative",
                                               {"phase": "protected_left"}, 250,
                                               preset=PRESETS[SIG]),
}
# the reliability view: (present, absent) cells of the same seeds
RELIABILITY = {"occluded crosswalk": ("crosswalk social crossing", "crosswalk social none"),
               "T-intersection": ("T social near", "T social none"),
               "signalized (phase)": ("signal social protected_left",
                                      "signal social cross_green")}


def _warned(m: dict) -> bool:
    """A human warned >= LEAD_S before the reference (inf: warned, the reference never came)."""
    return bool(m["lead_s"] >= LEAD_S)  # nan (no counterfactual) compares False


def claim_lines(runs: dict) -> list[dict]:
    """The measured lines: (what, cell, of which episodes, k, n, rate, target, holds)."""
    lines = []

    def line(what, cell, eligible, ok, target):
        pool = [m for m in runs[cell] if eligible(m)]
        k = sum(bool(ok(m)) for m in pool)
        rate = k / len(pool) if pool else float("nan")
        lines.append({"what": what, "cell": cell, "n": len(pool), "k": k, "rate": rate,
                      "target": target, "holds": bool(pool) and rate >= target})

    def every(m):
        return True

    for cell in ("crosswalk social crossing", "T social near", "signal social protected_left"):
        ref = "the robot pulls out" if cell.startswith("signal") else "sight"
        lines_before = len(lines)
        line(f"warned >= {LEAD_S} s before {ref}: belief > 0.9 before {ref}", cell, _warned,
             lambda m: m["confident"], 0.95)
        line(f"warned, confident: once > 0.9 never < 0.5 before {ref}", cell,
             lambda m: _warned(m) and m["confident"], lambda m: m["holds"], 0.95)
        line(f"warned: crosses 0.5 at most once before {ref}", cell, _warned,
             lambda m: m["crossings"] <= 1, 0.95)
        assert len(lines) == lines_before + 3
    line("no pedestrian (human beta 2-30): belief < 0.5", "crosswalk social none", every,
         lambda m: m["max_belief"] < 0.5, 0.95)
    line("no hidden car: belief < 0.5", "T social none", every,
         lambda m: m["max_belief"] < 0.5, 0.95)
    line("cross traffic on green: belief in the protected left < 0.5 before the robot pulls "
         "out", "signal social cross_green", every, lambda m: m["max_belief"] < 0.5, 0.95)
    line("no pedestrian, 1 m robot position noise: brakes <= 2 m/s^2",
         "crosswalk social none, 1 m noise", every, lambda m: m["max_decel_mps2"] <= 2.0, 0.90)
    for cell in CELLS:
        line("brakes <= 4 m/s^2", cell, every, lambda m: m["max_decel_mps2"] <= 4.0, 0.95)
        line("no infeasible plan where a comfortable stop one step earlier would have met it",
             cell, every, lambda m: m["surprise_infeasible_steps"] == 0, 1.0)
    return lines


def cell_rows(runs: dict) -> list[dict]:
    """Per cell: episodes, collisions, infeasible MPC steps, hardest braking, time to pass."""
    rows = []
    for name, summaries in runs.items():
        infeasible = [m["mpc_infeasible_steps"] for m in summaries]
        t = np.array([m["time_to_pass_s"] for m in summaries])
        rows.append({"cell": name, "n": len(summaries),
                     "collisions": sum(m["robot_collision"] for m in summaries),
                     "infeasible_episodes": sum(k > 0 for k in infeasible),
                     "infeasible_steps": int(sum(infeasible)),
                     "surprise_steps": int(sum(m["surprise_infeasible_steps"]
                                               for m in summaries)),
                     "given_way_steps": int(sum(m["contingency_given_way_steps"]
                                                for m in summaries)),
                     "max_decel_mps2": float(max(m["max_decel_mps2"] for m in summaries)),
                     "warned": sum(_warned(m) for m in summaries)
                     if CELLS[name].counterfactual else None,
                     "time_to_pass_s": float(np.nanmean(t)) if np.isfinite(t).any()
                     else float("nan"), "never_passed": int(np.sum(~np.isfinite(t)))})
    return rows


def pass_ratios(runs: dict) -> list[dict]:
    """The social robot's mean time to pass over the oracle's, nothing hidden (target <= 1.05)."""
    out = []
    for social, oracle in (("crosswalk social none", "crosswalk oracle none"),
                           ("T social none", "T oracle none")):
        s = np.nanmean([m["time_to_pass_s"] for m in runs[social]])
        o = np.nanmean([m["time_to_pass_s"] for m in runs[oracle]])
        out.append({"social": social, "oracle": oracle, "social_s": float(s),
                    "oracle_s": float(o), "ratio": float(s / o), "holds": bool(s <= 1.05 * o)})
    return out


def reliability(runs: dict) -> dict:
    """Per scene: the Brier score of the belief at BEFORE_SIGHT_S before the reference."""
    out = {}
    for title, (present, absent) in RELIABILITY.items():
        p, y = reliability_points(runs[present], runs[absent])
        out[title] = {"brier": brier_score(p, y), "points": int(np.isfinite(p).sum())}
    return out


def markdown(results: dict) -> str:
    """The results as Markdown tables."""
    def pct(rate):
        return "-" if not np.isfinite(rate) else f"{100 * rate:.0f} %"

    lines = [(f"Belief reliability: {results['episodes']} episodes per cell, seeds "
              f"{results['seed_base']}-{results['seed_base'] + results['episodes'] - 1}, "
              f"{results['cpu_s'] / 60:.1f} CPU-min (`{results['command']}`)"), "",
             "| cell | line | k / n | rate | target | holds |", "|---|---|---|---|---|---|"]
    lines += [f"| {c['cell']} | {c['what']} | {c['k']} / {c['n']} | {pct(c['rate'])} | "
              f">= {100 * c['target']:.0f} % | {'yes' if c['holds'] else '**no**'} |"
              for c in results["claims"]]
    lines += ["", ("| cell | n | warned | collisions | MPC infeasible (episodes / steps / "
                   "surprises) | hidden car given way (steps) | "
                   "hardest braking [m/s^2] | time to pass [s] (never) |"),
              "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['cell']} | {r['n']} | {'-' if r['warned'] is None else r['warned']} | "
              f"{r['collisions']} | {r['infeasible_episodes']} / {r['infeasible_steps']} / "
              f"{r['surprise_steps']} | {r['given_way_steps']} | "
              f"{r['max_decel_mps2']:.2f} | {r['time_to_pass_s']:.2f} ({r['never_passed']}) |"
              for r in results["cells"]]
    lines += ["", "| nothing hidden | social [s] | oracle [s] | ratio | <= 1.05 |",
              "|---|---|---|---|---|"]
    lines += [f"| {r['social']} vs {r['oracle']} | {r['social_s']:.2f} | {r['oracle_s']:.2f} | "
              f"{r['ratio']:.3f} | {'yes' if r['holds'] else '**no**'} |"
              for r in results["pass_ratios"]]
    lines += ["", (f"Brier score of the belief {', '.join(f'{t:g}' for t in BEFORE_SIGHT_S)} s "
                   "before the reference, with and without the hidden agent (same seeds):"), "",
              "| scene | Brier | points |", "|---|---|---|"]
    lines += [f"| {title} | {r['brier']:.3f} | {r['points']} |"
              for title, r in results["reliability"].items()]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=40, help="episodes per cell")
    parser.add_argument("--seed-base", type=int, default=10_000, help="the first seed")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--cells", default="", help="comma-separated substrings of cell names")
    parser.add_argument("--out", type=Path, default=Path("belief_reliability"),
                        help="writes OUT.json and OUT.md (and OUT.png with --figure)")
    parser.add_argument("--figure", action="store_true", help="also the reliability diagram")
    args = parser.parse_args(argv)
    wanted = [w.strip() for w in args.cells.split(",") if w.strip()]
    cells = {n: c for n, c in CELLS.items() if not wanted or any(w in n for w in wanted)}
    seeds = range(args.seed_base, args.seed_base + args.episodes)
    jobs = [(name, cell, seed) for seed in seeds for name, cell in cells.items()]
    start_cpu, start = time.process_time(), time.perf_counter()
    import resource

    runs: dict = {name: [] for name in cells}
    for name, seed, summary, error in map_jobs(reliability_episode, jobs, args.workers):
        if error is not None:
            raise RuntimeError(f"{name} / seed {seed}: {error}")
        runs[name].append({**summary, "seed": seed})
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = time.process_time() - start_cpu + children.ru_utime + children.ru_stime
    complete = set(CELLS) <= set(cells)
    results = {"command": "python benchmarks/belief_reliability.py " + " ".join(argv or []),
               "episodes": args.episodes, "seed_base": args.seed_base,
               "wall_s": round(time.perf_counter() - start, 1), "cpu_s": round(cpu, 1),
               "claims": claim_lines(runs) if complete else [],
               "cells": cell_rows(runs),
               "pass_ratios": pass_ratios(runs) if complete else [],
               "reliability": reliability(runs) if complete else {},
               "episodes_by_cell": {n: [{k: v for k, v in m.items() if k != "belief"}
                                        for m in ms] for n, ms in runs.items()}}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".json").write_text(strict_json.dumps(results, indent=1) + "\n")
    text = markdown(results)
    args.out.with_suffix(".md").write_text(text)
    if args.figure and complete:
        plot_reliability({title: reliability_points(runs[a], runs[b])
                          for title, (a, b) in RELIABILITY.items()},
                         args.out.with_suffix(".png"))
    print(text)
    return results


if __name__ == "__main__":
    import sys

    main(sys.argv[1:])
