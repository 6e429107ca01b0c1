"""docs/claims.md, generated: `measure` the claims into a results file, `render` it as Markdown.

`measure` runs each paper scene's claim episodes and planner table through the reproduce
machinery (`claim_episode`, `run_table`) and writes the command, versions, seeds and numbers
as JSON; tests/evaluation/test_claims_report.py keeps the page equal to `render` of that file.
Entry points: the MEASURE and RENDER commands below.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from marl_social.data import strict_json
from marl_social.evaluation import reproduce, reproduce_intersection, reproduce_signal
from marl_social.evaluation.run import claim_episode
from marl_social.evaluation.stopping import PassedCrosswalk
from marl_social.sim.seeds import seed_argument

MEASURE = "python -m marl_social.evaluation.claims_report measure --out docs/claims/results.json"
RENDER = ("python -m marl_social.evaluation.claims_report render docs/claims/results.json"
          " > docs/claims.md")
# seeds per claim case and per table cell: the whole measure in well under 10 min on 2 cores
CLAIM_SEEDS = {"occluded_crosswalk": 30, "t_intersection": 10, "signalized_intersection": 10}
TABLE_SEEDS = {"occluded_crosswalk": 10, "t_intersection": 5, "signalized_intersection": 4}
TABLES = {"occluded_crosswalk": reproduce, "t_intersection": reproduce_intersection,
          "signalized_intersection": reproduce_signal}
TITLES = {"occluded_crosswalk": "The occluded crosswalk (paper Fig. 2)",
          "t_intersection": "The T-intersection (paper Fig. 1 b)",
          "signalized_intersection": "The signalized intersection (paper Fig. 1 c)"}
FORCED_MPS2 = 3.0  # braking forced on a human beyond this is hard [m/s^2]
LEAD_S = 0.5  # a human warned (evaluation/counterfactual.py) this long before counts [s]


def _claim(text: str, holds, measured: str, **values) -> dict:
    """One claim: its statement, whether it holds, and its numbers (`measured` formats them)."""
    return {"claim": text, "holds": bool(holds), "measured": measured,
            "values": {k: (round(float(v), 3) if isinstance(v, float | np.floating) else v)
                       for k, v in values.items()}}


def _run(function, jobs: list, workers: int) -> dict:
    """Episode summaries by (planner, variant), in seed order; an episode's error is raised."""
    return _by_case(reproduce.map_jobs(function, jobs, workers, progress=False))


def _by_case(results: list[tuple]) -> dict:
    """(planner, variant, seed, summary, error) tuples as {(planner, variant): [summary]}."""
    out: dict = {}
    for planner, variant, seed, summary, error in results:
        if error is not None:
            raise RuntimeError(f"{planner} / {variant} / seed {seed}: {error}")
        out.setdefault((planner, variant), []).append(summary)
    return out


def _col(runs: list[dict], key: str) -> np.ndarray:
    return np.array([float(m[key]) for m in runs])


def crosswalk_claims(seeds: list[int], workers: int) -> list[dict]:
    """The occluded crosswalk's claims (tests/evaluation/test_robot_claims.py's cases)."""
    horizon, until = {"crossing": 200, "none": 100, "waiting": 150}, {"crossing": None}
    cases = [("social", "crossing"), ("aggressive", "crossing"), ("oracle", "crossing"),
             ("social", "none"), ("oracle", "none"), ("conservative", "none"),
             ("social", "waiting"), ("oracle", "waiting")]
    r = _run(claim_episode, [(p, v, s, horizon[v], {}, until.get(v, PassedCrosswalk),
                              (p, v) == ("social", "crossing"))
                             for p, v in cases for s in seeds], workers)
    social, n = r[("social", "crossing")], len(seeds)
    warned = [m for m in social if m["warning_lead_s"] >= LEAD_S]
    k_decel = int(np.sum(_col(warned, "max_decel_mps2") <= 4.0))
    k_jerk = int(np.sum(_col(warned, "max_jerk_mps3") <= 10.0))
    delay = [m["robot_moves_again_s"] - m["pedestrian_clears_lane_s"] for m in social
             if np.isfinite(m["pedestrian_clears_lane_s"])]
    k_go = int(np.sum(np.nan_to_num(delay, nan=np.inf) <= 1.0))
    k_oracle = int(np.sum(_col(r[("oracle", "crossing")], "max_decel_mps2") <= 3.0))
    bad = sum(bool(m["robot_collision"]) or not m["yielded"] or m["max_decel_mps2"] > 5.0
              for m in r[("aggressive", "crossing")])
    t = {case: float(np.mean(_col(r[case], "time_to_pass_s"))) for case in cases[3:]}
    t_cons = float(np.mean(np.nan_to_num(_col(r[("conservative", "none")], "time_to_pass_s"),
                                         nan=np.inf)))
    confident = [m for m in warned if m["belief_confident_before_seen"] == 1.0]
    low = int(np.sum(_col(r[("social", "none")], "p_pedestrian_at_crosswalk") < 0.1))
    k_conf_all = int(np.sum(_col(social, "belief_confident_before_seen") == 1.0))
    return [
        _claim("social, crossing pedestrian: never collides, always yields",
               not any(m["robot_collision"] for m in social) and all(m["yielded"] for m in social),
               "{collisions} collisions, yielded in {yielded} of {n}", n=n,
               collisions=sum(bool(m["robot_collision"]) for m in social),
               yielded=sum(bool(m["yielded"]) for m in social)),
        _claim("social, warned (a human's speed departs >= 1 m/s from the same seed's without "
               "the pedestrian >= 0.5 s before the robot sees it): brakes <= 4 m/s^2 in >= 90 %",
               k_decel >= 0.9 * len(warned),
               "{k} of {n} warned seeds", k=k_decel, n=len(warned)),
        _claim("social, warned: jerk <= 10 m/s^3 in >= 90 %", k_jerk >= 0.9 * len(warned),
               "{k} of {n} warned seeds", k=k_jerk, n=len(warned)),
        _claim("social moves again within 1 s of the pedestrian clearing its lane in >= 90 %",
               k_go >= 0.9 * n, "{k} of {n} seeds", k=k_go, n=n),
        _claim("oracle brakes <= 3 m/s^2 in >= 95 %", k_oracle >= 0.95 * n,
               "{k} of {n} seeds", k=k_oracle, n=n),
        _claim("aggressive collides, fails to yield or brakes > 5 m/s^2 in most seeds",
               bad > 0.5 * n, "{k} of {n} seeds", k=bad, n=n),
        _claim("no pedestrian: social within 5 % of the oracle's time to pass",
               t[("social", "none")] <= 1.05 * t[("oracle", "none")],
               "{social:.2f} s vs {oracle:.2f} s", social=t[("social", "none")],
               oracle=t[("oracle", "none")]),
        _claim("no pedestrian: the conservative robot >= 20 % slower than the oracle",
               t_cons >= 1.2 * t[("oracle", "none")], "{conservative:.2f} s vs {oracle:.2f} s",
               conservative=t_cons, oracle=t[("oracle", "none")]),
        _claim("waiting pedestrian: social within 10 % of the oracle's time to pass",
               t[("social", "waiting")] <= 1.10 * t[("oracle", "waiting")],
               "{social:.2f} s vs {oracle:.2f} s", social=t[("social", "waiting")],
               oracle=t[("oracle", "waiting")]),
        _claim("social, warned: belief > 0.9 before the robot sees the pedestrian in >= 95 %",
               len(confident) >= 0.95 * len(warned), "{k} of {n} warned seeds",
               k=len(confident), n=len(warned)),
        _claim("social, every seed: belief > 0.9 before the robot sees the pedestrian in >= 90 %",
               k_conf_all >= 0.9 * n, "{k} of {n} seeds (many humans give no warning)",
               k=k_conf_all, n=n),
        _claim("no pedestrian: belief < 0.1 on reaching the crosswalk in >= 90 %",
               low >= 0.9 * n, "{k} of {n} seeds", k=low, n=n),
    ]


def intersection_claims(seeds: list[int], workers: int) -> list[dict]:
    """The T-intersection's claims (tests/evaluation/test_intersection_claims.py's cases)."""
    horizon = {"none": 120, "near": 150}
    cases = [("social", "none"), ("oracle", "none"), ("conservative", "none"),
             ("social", "near"), ("oracle", "near"), ("aggressive", "near")]
    jobs = [(p, v, s, horizon[v], {}, (p, v) == ("social", "near")) for p, v in cases
            for s in seeds]
    results = reproduce.map_jobs(reproduce_intersection.claim_episode, jobs, workers, False)
    reproduce_intersection.add_held_back(results)
    r = _by_case(results)
    n = len(seeds)

    def time_to_pass(case):  # a robot that never passed counts as the episode's length
        t = _col(r[case], "time_to_pass_s")
        return float(np.mean(np.where(np.isfinite(t), t, horizon[case[1]] * 0.1)))

    t = {case: time_to_pass(case) for case in cases[:3]}
    never = int(np.sum(np.isnan(_col(r[("conservative", "none")], "time_to_pass_s"))))
    near = {p: r[(p, "near")] for p in ("social", "oracle", "aggressive")}
    forced = {p: int(np.sum(_col(near[p], "others_max_decel_mps2") > FORCED_MPS2)) for p in near}
    hits = {p: sum(bool(m["robot_collision"]) for m in near[p]) for p in near}
    bad = sum(bool(m["robot_collision"]) or m["others_max_decel_mps2"] > FORCED_MPS2
              for m in near["aggressive"])
    warned = [m for m in near["social"] if m["warning_lead_s"] >= LEAD_S]
    early = sum(m["belief_09_s"] < np.nan_to_num(m["robot_first_sees_v3_s"], nan=np.inf)
                for m in warned)
    claims = [
        _claim("no hidden car: social within 10 % of the oracle's time to clear the junction",
               t[("social", "none")] <= 1.10 * t[("oracle", "none")],
               "{social:.2f} s vs {oracle:.2f} s", social=t[("social", "none")],
               oracle=t[("oracle", "none")]),
        _claim("no hidden car: social >= 25 % sooner than the conservative robot",
               t[("social", "none")] <= 0.75 * t[("conservative", "none")],
               "{social:.2f} s vs {conservative:.2f} s (it never went in {never} of {n})",
               social=t[("social", "none")], conservative=t[("conservative", "none")],
               never=never, n=n)]
    claims += [_claim(f"V3 near: {p} never collides, never forces braking > 3 m/s^2",
                      hits[p] == 0 and forced[p] == 0,
                      "{collisions} collisions, forced in {forced} of {n}",
                      collisions=hits[p], forced=forced[p], n=n) for p in ("social", "oracle")]
    return claims + [
        _claim("V3 near: the aggressive robot collides or forces braking > 3 m/s^2 in most "
               "seeds", bad > 0.5 * n, "{k} of {n} seeds", k=bad, n=n),
        _claim("V3 near, a left-turner warned (its speed departs >= 1 m/s from the same seed's "
               "without V3 >= 0.5 s before the robot sees V3): belief > 0.9 before the robot "
               "sees V3 in >= 90 %", bool(warned) and early >= 0.9 * len(warned),
               "{k} of {n} warned seeds", k=int(early), n=len(warned))]


def signal_claims(seeds: list[int], workers: int) -> list[dict]:
    """The signalized intersection's claims (tests/evaluation/test_signal_claims.py's cases)."""
    cases = [("social", "protected_left"), ("conservative", "protected_left"),
             ("oracle", "protected_left"), ("social", "cross_green"),
             ("aggressive", "cross_green")]
    r = _run(reproduce_signal.claim_episode,
             [(p, v, s, reproduce_signal.MAX_CYCLES, (p, v) == ("social", "protected_left"))
              for p, v in cases for s in seeds], workers)
    n, limit_s = len(seeds), reproduce_signal.MAX_CYCLES * 0.1

    def turn(case):  # never pulling out counts as the episode's length
        t = _col(r[case], "turn_s")
        return float(np.mean(np.where(np.isfinite(t), t, limit_s))), int(np.sum(~np.isfinite(t)))

    (social, _), (cons, never), (oracle, _) = (turn(c) for c in cases[:3])
    collisions = sum(bool(m["collision"]) for c in cases if c[0] == "social" for m in r[c])
    worst = float(np.max(_col(r[("social", "cross_green")], "others_max_decel_mps2")))
    bad = sum(bool(m["collision"]) or m["others_max_decel_mps2"] > FORCED_MPS2
              for m in r[("aggressive", "cross_green")])
    warned = [m for m in r[("social", "protected_left")]
              if m["first_warned_s"] <= np.nan_to_num(m["turn_s"], nan=np.inf) - LEAD_S]
    early = sum(m["belief_09_s"] < np.nan_to_num(m["turn_s"], nan=np.inf) for m in warned)
    return [
        _claim("protected left: social pulls out >= 2 s sooner than the conservative robot",
               cons - social >= 2.0, "{social:.2f} s vs {conservative:.2f} s (it never pulled "
               "out in {never} of {n})", social=social, conservative=cons, never=never, n=n),
        _claim("protected left: social within 15 % of the oracle", social <= 1.15 * oracle,
               "{social:.2f} s vs {oracle:.2f} s", social=social, oracle=oracle),
        _claim("social: no collision (both phases)", collisions == 0,
               "{k} collisions in {n} episodes", k=collisions, n=2 * n),
        _claim("cross traffic on green: social never forces braking > 3 m/s^2",
               worst <= FORCED_MPS2, "hardest forced braking {worst:.2f} m/s^2", worst=worst),
        _claim("cross traffic on green: the aggressive robot collides or forces braking > 3 "
               "m/s^2 in most seeds", bad > 0.5 * n, "{k} of {n} seeds", k=bad, n=n),
        _claim("protected left, a human warned (its speed departs >= 1 m/s from the same "
               "seed's on cross green >= 0.5 s before the robot pulls out): belief > 0.9 in "
               "the protected left before the robot pulls out in >= 95 %",
               bool(warned) and early >= 0.95 * len(warned), "{k} of {n} warned seeds",
               k=int(early), n=len(warned))]


CLAIMS = {"occluded_crosswalk": crosswalk_claims, "t_intersection": intersection_claims,
          "signalized_intersection": signal_claims}


def _git_commit() -> str:
    """The measuring code's commit (git describe), "unknown" outside a git checkout."""
    try:
        return subprocess.run(["git", "describe", "--always", "--dirty"], capture_output=True,
                              text=True, check=True, cwd=Path(__file__).parent).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def measure(out: Path | str, workers: int = 2, seed0: int = 0) -> dict:
    """Run every scene's claims and table, write the results file and return it.

    Args:
        out: the JSON file to write (its folder is made).
        workers: processes for the episodes.
        seed0: the first seed (claims run CLAIM_SEEDS[scene] seeds from it; tables
            TABLE_SEEDS[scene] seeds from 0, as `marl-social reproduce` does).
    """
    import marl_social

    start = time.perf_counter()
    scenes = {}
    for scene, module in TABLES.items():
        seeds = list(range(seed0, seed0 + CLAIM_SEEDS[scene]))
        scenes[scene] = {"claim_seeds": [seeds[0], seeds[-1]],
                         "claims": CLAIMS[scene](seeds, workers),
                         "table_seeds": TABLE_SEEDS[scene],
                         "table": module.run_table(TABLE_SEEDS[scene], workers, progress=False)}
    results = {"command": MEASURE, "marl_social": marl_social.__version__,
               "git": _git_commit(), "python": platform.python_version(),
               "numpy": np.__version__, "workers": workers,
               "wall_s": round(time.perf_counter() - start, 1), "scenes": scenes}
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(strict_json.dumps(results, indent=1) + "\n")
    return results


def render(results: dict) -> str:
    """docs/claims.md from a results file's contents (its nulls: numbers not measured, NaN).

    Raises:
        ValueError: the results lack a scene, a key or a claim's number.
    """
    if isinstance(results, dict):
        results = strict_json.nulls_as_nan(results)
    try:
        lines = ["# Claims, measured", "",
                 (f"Generated by `{results['command']}` then `{RENDER}` (marl-social "
                 f"{results['marl_social']}, {results['git']}, Python {results['python']}, "
                 f"numpy {results['numpy']}; {results['workers']} processes, "
                 f"{results['wall_s'] / 60:.1f} min). Never edit this page by hand: rerun "
                 "the two commands. Most claims are also tests on 50 seeds "
                 "(`tests/evaluation/test_*claims.py`, `tests/perception/belief/test_claims.py`"
                 "); fewer seeds here keep this measurement under ten minutes on 2 cores."),
                 ""]
        for scene, title in TITLES.items():
            s = results["scenes"][scene]
            lo, hi = s["claim_seeds"]
            lines += [f"## {title}", "", f"Claims over seeds {lo}-{hi} per case:", "",
                      "| claim | holds | measured |", "|---|---|---|"]
            lines += [f"| {c['claim']} | {'yes' if c['holds'] else '**no**'} | "
                      f"{c['measured'].format(**c['values'])} |" for c in s["claims"]]
            lines += ["", (f"Every planner x variant over seeds 0-{s['table_seeds'] - 1} "
                           f"(`marl-social reproduce --scenario {scene} --seeds "
                           f"{s['table_seeds']}`):"), "", TABLES[scene].format_table(s["table"]),
                      ""]
    except (KeyError, TypeError, IndexError, AttributeError) as err:
        raise ValueError(f"malformed claims results: {type(err).__name__}: {err}") from err
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    """`measure --out FILE [--workers N]` or `render FILE` (the page on stdout)."""
    parser = argparse.ArgumentParser(prog="python -m marl_social.evaluation.claims_report")
    sub = parser.add_subparsers(dest="action", required=True)
    m = sub.add_parser("measure", help="run the claims' episodes into a results file")
    m.add_argument("--out", type=Path, default=Path("docs/claims/results.json"))
    m.add_argument("--workers", type=int, default=2)
    m.add_argument("--seed0", type=seed_argument, default=0)
    r = sub.add_parser("render", help="print docs/claims.md from a results file")
    r.add_argument("results", type=Path)
    args = parser.parse_args(argv)
    if args.action == "measure":
        results = measure(args.out, args.workers, args.seed0)
        print(f"wrote {args.out} in {results['wall_s']:.0f} s", file=sys.stderr)
    else:
        sys.stdout.write(render(json.loads(args.results.read_text())))


if __name__ == "__main__":
    main()
