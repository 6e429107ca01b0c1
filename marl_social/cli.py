"""Command line: `marl-social demo | bench`."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

DEFAULT_OUT = "marl_social_out"


def _demo(args) -> int:
    import marl_social
    from marl_social.episode import record_episode
    from marl_social.metrics import episode_metrics
    from marl_social.render import plot_episode, write_animation

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    env = marl_social.parallel_env(scenario="occluded_crosswalk", pedestrian=args.pedestrian,
                                   render_mode=None if args.no_animation else "rgb_array",
                                   max_cycles=args.max_cycles)
    policies = marl_social.policies(env)
    trace = record_episode(env, policies, seed=args.seed, render=not args.no_animation)
    metrics = episode_metrics(trace, env.road_map)
    stem = f"occluded_crosswalk_{args.pedestrian}"
    figure = plot_episode(env.road_map, trace.names, trace.roles, trace.times_s, trace.states,
                          trace.active, trace.visible, out / f"{stem}.png",
                          title=f"occluded_crosswalk, pedestrian={args.pedestrian}: Boltzmann "
                                "human and pedestrian, cruise robot (unseen = absent)")
    print(f"figure:    {figure}")
    if not args.no_animation:
        gif = write_animation(trace.frames, out / f"{stem}.gif", fps=10)
        print(f"animation: {gif}")
    (out / f"{stem}_metrics.json").write_text(json.dumps(metrics, indent=2))
    print(f"metrics:   {out / f'{stem}_metrics.json'}")
    for key, value in metrics.items():
        print(f"  {key:<22} {value:.3f}" if isinstance(value, float) else f"  {key:<22} {value}")
    env.close()
    return 0


def _bench(args) -> int:
    from marl_social.bench import bench_humans, run_env_benchmark

    if args.what == "humans":
        rows = bench_humans()
    else:
        rows = run_env_benchmark(tuple(args.agents), n_steps=args.steps, peer=not args.no_peer,
                                 profile=args.profile)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))
    return 0


def _reproduce(args) -> int:
    from marl_social.reproduce import format_table, run_table, write_figures

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for path in write_figures(out):
        print(f"figure: {path}")
    rows = run_table(args.seeds, workers=args.workers)
    table = format_table(rows)
    (out / "table.md").write_text(table + "\n")
    (out / "table.json").write_text(json.dumps(rows, indent=2))
    print(f"\n{args.seeds} randomized seeds per cell (marl_social/run.randomized_overrides):\n")
    print(table)
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="marl-social", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    demo = sub.add_parser("demo", help="run the paper scenario; write an animation and a figure")
    demo.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT})")
    demo.add_argument("--pedestrian", default="crossing", choices=["crossing", "waiting", "none"])
    demo.add_argument("--seed", type=int, default=0)
    demo.add_argument("--max-cycles", type=int, default=200)
    demo.add_argument("--no-animation", action="store_true", help="figure only (faster)")
    demo.set_defaults(func=_demo)

    rep = sub.add_parser("reproduce", help="the paper's Figs. 3-6 and a table over seeds")
    rep.add_argument("--out", default=f"{DEFAULT_OUT}/reproduce")
    rep.add_argument("--seeds", type=int, default=20)
    rep.add_argument("--workers", type=int, default=2)
    rep.set_defaults(func=_reproduce)

    bench = sub.add_parser("bench", help="benchmarks: `bench env`, `bench humans`")
    bench.add_argument("what", choices=["env", "humans"])
    bench.add_argument("--agents", type=int, nargs="+", default=[3, 10, 30, 100])
    bench.add_argument("--steps", type=int, default=500)
    bench.add_argument("--no-peer", action="store_true", help="skip highway-env")
    bench.add_argument("--profile", action="store_true", help="print a cProfile breakdown")
    bench.add_argument("--json", help="also write the rows to this JSON file")
    bench.set_defaults(func=_bench)

    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
