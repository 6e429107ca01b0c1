"""The subcommands of `marl-social`: demo, bench, reproduce, record, irl fit, maps, scenes, replay."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from marl_social.cli.overrides import parse_overrides
from marl_social.data import strict_json

DEFAULT_OUT = "marl_social_out"


def demo_overrides(args) -> dict:
    """The demo's scenario overrides: --planner and --pedestrian, then every --set."""
    options = {}
    if args.planner is not None:
        options["robot.planner"] = args.planner
    if args.pedestrian is not None:
        options["pedestrian"] = args.pedestrian
    given = [f"{k}={v}" for k, v in options.items()]
    return parse_overrides(args.scenario, given + list(args.set or ()))


def demo(args) -> int:
    """`marl-social demo`: one episode; a figure, an animation and the metrics.

    On a fresh install (no numba cache) the kernels compile first, side by side on the usable
    cores (agents/compile_kernels.compile_side_by_side), not one after the other within the
    episode's first step.
    """
    from marl_social.agents.compile_kernels import compile_side_by_side
    from marl_social.evaluation.run import run_episode
    from marl_social.scenarios import make_scenario
    from marl_social.viz.animation import write_animation
    from marl_social.viz.figures import EpisodeArrays, plot_episode
    from marl_social.viz.overlay import caption_frames, crosswalk_ahead

    overrides = demo_overrides(args)
    params = make_scenario(args.scenario, **overrides).params
    compile_side_by_side()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    res = run_episode(args.scenario, seed=args.seed, render=not args.no_animation,
                      max_cycles=args.max_cycles, **overrides)
    trace, metrics = res.trace, res.metrics
    pedestrian = getattr(params, "pedestrian", None)
    stem = "_".join(str(p) for p in (args.scenario, pedestrian, params.robot_planner)
                    if p is not None).replace("+", "_")
    beliefs = None
    if "p_pedestrian" in trace.extras:
        beliefs = {"robot's P(pedestrian): perceived or inferred": trace.extras["p_pedestrian"]}
    title = ", ".join([args.scenario] + ([f"pedestrian={pedestrian}"] if pedestrian else [])
                      + [f"robot: {params.robot_planner} planner"])
    figure = plot_episode(res.road_map, EpisodeArrays.from_trace(trace), out / f"{stem}.png",
                          title=title, beliefs=beliefs)
    print(f"figure:    {figure}")
    if not args.no_animation:
        frames = trace.frames
        if beliefs:  # the legend and the belief bar in a strip under the scene
            ahead = crosswalk_ahead(trace.states, trace.active, res.road_map,
                                    trace.names.index("robot_0"))
            frames = caption_frames(frames, trace.extras["p_pedestrian"],
                                    trace.extras["perceived"], ahead)
        else:
            frames = caption_frames(frames)
        gif = write_animation(frames, out / f"{stem}.gif", fps=10)
        print(f"animation: {gif}")
    (out / f"{stem}_metrics.json").write_text(strict_json.dumps(metrics, indent=2))
    print(f"metrics:   {out / f'{stem}_metrics.json'}")
    for key, value in metrics.items():
        print(f"  {key:<30} {value:.3f}" if isinstance(value, float) else f"  {key:<30} {value}")
    return 0


def bench(args) -> int:
    """`marl-social bench env | planners`."""
    from marl_social.bench.env_bench import bench_planners, run_env_benchmark

    if args.what == "planners":
        rows = bench_planners(scenario=args.scenario)
    else:
        rows = run_env_benchmark(tuple(args.agents), n_steps=args.steps, peer=not args.no_peer,
                                 profile=args.profile)
    if args.json:
        Path(args.json).write_text(strict_json.dumps(rows, indent=2))
    return 0


TABLE_AXES = ("robot_planner", "pedestrian")  # what the reproduce table sweeps itself


def reproduce(args) -> int:
    """`marl-social reproduce`: the paper's figures and the table over randomized seeds."""
    if args.scenario in INTERSECTION_MODULES:
        return _reproduce_intersection(args)
    if args.scenario != "occluded_crosswalk":
        raise ValueError(f"--scenario {args.scenario}: reproduce knows occluded_crosswalk "
                         "(Figs. 3-6), t_intersection (Fig. 1 b) and signalized_intersection "
                         "(Fig. 1 c)")
    from marl_social.evaluation.reproduce import format_table, run_table, write_figures

    overrides = parse_overrides("occluded_crosswalk", args.set)
    fixed_axes = [k for k in TABLE_AXES if k in overrides]
    if fixed_axes:
        raise ValueError(f"--set {fixed_axes[0]}: the table sweeps {' and '.join(TABLE_AXES)} "
                         "itself; set other parameters")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for path in write_figures(out):
        print(f"figure: {path}")
    rows = run_table(args.seeds, workers=args.workers, overrides=overrides)
    table = format_table(rows)
    (out / "table.md").write_text(table + "\n")
    (out / "table.json").write_text(strict_json.dumps(rows, indent=2))
    _reliability_figure(args, out)
    fixed = "".join(f", {k}={v}" for k, v in overrides.items())
    print(f"\n{args.seeds} randomized seeds per cell (marl_social/run.randomized_overrides"
          f"{fixed}):\n")
    print(table)
    return 0


def _reliability_figure(args, out: Path) -> None:
    """The belief's reliability diagram over the table's seeds (belief_reliability.py).

    With and without what the scene hides, the same seeds.
    """
    from marl_social.evaluation.belief_reliability import write_reliability_figure

    path, brier = write_reliability_figure(args.scenario, out, range(args.seeds), args.workers)
    print(f"figure: {path} (Brier score {brier:.3f})")


# the reproduce module of each intersection scenario (figures, table, randomization)
INTERSECTION_MODULES = {"t_intersection": "reproduce_intersection",
                        "signalized_intersection": "reproduce_signal"}


def _reproduce_intersection(args) -> int:
    """`marl-social reproduce --scenario t_intersection | signalized_intersection`: Fig. 1 b / c."""
    import importlib

    module_name = INTERSECTION_MODULES[args.scenario]
    module = importlib.import_module(f"marl_social.evaluation.{module_name}")
    format_table, run_table, write_figures = (module.format_table, module.run_table,
                                              module.write_figures)
    if args.set:
        raise ValueError(f"--set: reproduce --scenario {args.scenario} sweeps its own "
                         f"randomization (evaluation/{module_name}.py); run "
                         f"`marl-social demo --scenario {args.scenario} --set ...` for one "
                         "episode")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for path in write_figures(out):
        print(f"figure: {path}")
    rows = run_table(args.seeds, workers=args.workers)
    table = format_table(rows)
    (out / "table.md").write_text(table + "\n")
    (out / "table.json").write_text(strict_json.dumps(rows, indent=2))
    _reliability_figure(args, out)
    print(f"\n{args.seeds} randomized seeds per cell "
          f"(marl_social/evaluation/{module_name}.randomized_overrides):\n")
    print(table)
    return 0


def record(args) -> int:
    """`marl-social record`: human demonstrations or decisions to a file."""
    from marl_social.data.demonstrations import save_demonstrations

    _check_output_file(args.out, "-o/--out")
    if not args.synthetic:
        _recording_overrides(args)  # bad --set values fail before any episode
    if args.decisions:
        return _record_decisions(args)
    if args.synthetic:
        from marl_social.agents.irl.synthetic import near_rational_demonstrations

        theta = np.array(args.theta, dtype=np.float64) * args.beta
        demos = near_rational_demonstrations(theta, args.segments, seed=args.seed0,
                                             n_steps=args.segment_steps)
    else:
        from marl_social.evaluation.record import Segments, record_demonstrations

        demos = record_demonstrations(
            args.scenario, range(args.seed0, args.seed0 + args.episodes),
            _recording_overrides(args), max_cycles=args.max_cycles,
            segments=Segments(args.segment_steps, args.stride), workers=args.workers,
            progress=True)
    if not demos:
        print("no demonstration segments recorded (episodes too short?)", file=sys.stderr)
        return 1
    path = save_demonstrations(args.out, demos)
    print(f"{len(demos)} demonstrations ({demos[0].n_steps} steps of {demos[0].dt_s} s) -> {path}")
    return 0


def _recording_overrides(args) -> dict:
    """--robot-planner, --pedestrian and --human-beta, then every --set (validated)."""
    given = [f"robot.planner={args.robot_planner}"]
    if args.pedestrian is not None:
        given.append(f"pedestrian={args.pedestrian}")
    if args.human_beta is not None:
        given.append(f"human.beta={args.human_beta!r}")
    return parse_overrides(args.scenario, given + list(args.set or ()))


def _record_decisions(args) -> int:
    from marl_social.data.decisions import save_decisions
    from marl_social.evaluation.record import record_decisions

    decisions = record_decisions(
        args.scenario, range(args.seed0, args.seed0 + args.episodes), _recording_overrides(args),
        max_cycles=args.max_cycles, workers=args.workers, progress=True)
    if decisions is None:
        print("no human decisions recorded (no human driver in the scenario?)", file=sys.stderr)
        return 1
    path = save_decisions(args.out, decisions)
    print(f"{len(decisions)} decisions of {len(set(decisions.agent))} human driver(s) -> {path}")
    return 0


def _load_fit_data(paths):
    """Demonstrations (list) or, if every file is a decision file, a DecisionSet."""
    from marl_social.data.decisions import DecisionSet, is_decision_file, load_decisions
    from marl_social.data.demonstrations import load_demonstrations

    for path in paths:
        if not Path(path).exists():
            raise FileNotFoundError(f"irl fit: {path} does not exist")
        if Path(path).is_dir():
            raise ValueError(f"irl fit: {path} is a directory, not a data file")
    kinds = [is_decision_file(p) for p in paths]
    if all(kinds):
        return DecisionSet.concatenate([load_decisions(p) for p in paths])
    if any(kinds):
        raise ValueError("irl fit: mix of decision files (`record --decisions`) and "
                         "demonstrations; fit them separately")
    demos = []
    for path in paths:
        if str(path).lower().endswith(".csv"):
            from marl_social.data.interaction import load_interaction

            demos += load_interaction([path])
        else:
            demos += load_demonstrations(path)
    return demos


def _check_output_file(path, option: str) -> None:
    """Fail before any work if the output file `path` (given as `option`) is a directory."""
    if Path(path).is_dir():
        raise ValueError(f"{option} {path}: is a directory; give a file name")


def irl_fit(args) -> int:
    """`marl-social irl fit`: theta from demonstrations or decisions."""
    from marl_social.agents.irl.laplace import FITTABLE, cosine_similarity, fit_theta

    _check_output_file(args.out, "-o/--out")
    data = _load_fit_data(args.demos)
    fitted = tuple(args.features or FITTABLE)
    if isinstance(data, list):
        result = fit_theta(data, fitted=fitted)
        truth = np.array([d.theta_true for d in data])
        n_what = f"{len(data)} demonstrations"
    else:
        from marl_social.agents.irl.choice import fit_choice_theta

        result = fit_choice_theta(data, fitted=fitted)
        truth = data.theta_true * data.beta_true[:, None]  # the choice fit recovers beta * theta
        n_what = f"{len(data)} decisions (discrete choice, exact likelihood)"
    if np.all(np.isfinite(truth)) and np.allclose(truth, truth[0]):
        result.extra["cosine_to_true"] = cosine_similarity(result.theta, truth[0],
                                                           result.fitted)
        rest = tuple(f for f in result.fitted if f != "crosswalk")
        if rest != result.fitted and len(rest) > 1:  # the crosswalk weight dominates the norm
            result.extra["cosine_to_true_without_crosswalk"] = cosine_similarity(
                result.theta, truth[0], rest)
    path = result.save(args.out)
    print(f"fitted {n_what} in {result.fit_time_s:.2f} s (converged: {result.converged}"
          + (f"; {result.n_regularized} Hessians regularized)" if isinstance(data, list)
             else ")"))
    for name, w, d in zip(result.to_json()["features"], result.theta, result.direction):
        if np.isfinite(w):
            print(f"  {name:<10} theta {w:12.4f}   direction {d:8.4f}")
    print(f"  scale (rationality) {result.scale:.4f}")
    if "cosine_to_true" in result.extra:
        print(f"  cosine to the demonstrators' true theta: {result.extra['cosine_to_true']:.4f}")
    if "cosine_to_true_without_crosswalk" in result.extra:
        print("  cosine without the crosswalk weight:     "
              f"{result.extra['cosine_to_true_without_crosswalk']:.4f}")
    print(f"-> {path}  (use it as the robot's model: robot_theta_hat={path})")
    if not isinstance(data, list):
        from marl_social.agents.irl.laplace import robot_model_from_fit

        _, beta_hat = robot_model_from_fit(result.to_json())
        print(f"   the scale is in the robot's units: add robot_beta_hat={beta_hat:.4g} to use "
              "the learned rationality too")
    if not (result.converged and np.isfinite(result.scale)):
        print(f"error: the fit did not converge ({result.message}); {path} holds its last "
              "iterate, marked converged: false", file=sys.stderr)
        return 1
    return 0


def maps(args) -> int:
    """`marl-social maps list | show MAP [--figure PATH]`."""
    import warnings

    from marl_social.maps import BUILTIN_MAPS, MapConversionWarning, load_map
    from marl_social.maps.figure import plot_map
    from marl_social.maps.summary import describe

    if args.maps_command == "list":
        for name, builtin in BUILTIN_MAPS.items():
            print(f"{name:<12} {builtin.description}")
        return 0
    with warnings.catch_warnings():  # the summary lists what was not mapped
        warnings.simplefilter("ignore", MapConversionWarning)
        loaded = load_map(args.map, origin=args.origin)
    print(describe(args.map, loaded))
    if args.figure:
        print(f"figure: {plot_map(*loaded, args.figure, title=f'map {args.map}')}")
    return 0



def scenes(args) -> int:
    """`marl-social scenes MAP [--json]`: map_scene's elements per situation, and why not."""
    import json
    import warnings

    from marl_social.maps import MapConversionWarning, load_map
    from marl_social.maps.listing import scene_listing

    with warnings.catch_warnings():  # `maps show` lists what was not mapped
        warnings.simplefilter("ignore", MapConversionWarning)
        entries = scene_listing(load_map(args.map))
    if args.json:
        print(json.dumps([{"element": e.element, "situation": e.situation}
                          for e in entries if not e.reason]))
        return 0
    for situation in sorted({e.situation for e in entries}, key=[e.situation for e in
                                                                   entries].index):
        built = [e for e in entries if e.situation == situation and not e.reason]
        print(f"{situation}: {len(built)} buildable"
              + (f" ({', '.join(str(e.element) for e in built)})" if built else ""))
        refused = [e for e in entries if e.situation == situation and e.reason]
        if len({e.reason for e in refused}) == 1 and len(refused) > 1:  # one reason for all
            print(f"  not its {len(refused)} elements: {refused[0].reason}")
            continue
        for e in refused:
            print(f"  not {e.element}: {e.reason}")
    return 0


def replay(args) -> int:
    """`marl-social replay MAP TRACKS`: a recording's vehicles replayed, the robot planning."""
    import warnings

    from marl_social.evaluation.map_replay import ReplayRun, replay_summary, run_replay
    from marl_social.maps import MapConversionWarning

    if args.out:
        _check_output_file(args.out, "--out")
    overrides = {"element": args.element, "start_frame": args.start_frame,
                 "robot_planner": args.planner}
    run = ReplayRun(args.map, args.tracks, max_steps=args.steps, seed=args.seed,
                    overrides=overrides)
    with warnings.catch_warnings():  # `maps show` lists what was not mapped
        warnings.simplefilter("ignore", MapConversionWarning)
        result = run_replay(run)
    print(replay_summary(run, result))
    if args.out:
        from marl_social.viz.figures import EpisodeArrays, plot_episode

        beliefs = ({"P(pedestrian) (robot belief)": result.trace.extras["p_pedestrian"]}
                   if "p_pedestrian" in result.trace.extras else None)
        path = plot_episode(result.road_map, EpisodeArrays.from_trace(result.trace), args.out,
                            title=f"replay {Path(args.tracks).name}", beliefs=beliefs)
        print(f"figure: {path}")
    return 0
