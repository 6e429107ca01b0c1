"""The `marl-social` argument parser and entry point.

Every option's help shows its default (argparse.ArgumentDefaultsHelpFormatter); an unknown
planner, scenario, pedestrian variant or study name fails with a "did you mean" suggestion
(difflib); bad input fails with one line on stderr and exit code 2; a closed pipe (`marl-social
study --list | head -2`) ends quietly.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import replace
from importlib import metadata

from marl_social.agents.registry import ROBOT_PLANNERS
from marl_social.cli import commands
from marl_social.cli.overrides import (
    describe_params,
    did_you_mean,
    parse_overrides,
    scenario_class,
    unknown_name,
    variant_names,
)
from marl_social.cli.train import add_train
from marl_social.scenarios import SCENARIOS
from marl_social.sim.seeds import seed_argument

FORMATTER = argparse.ArgumentDefaultsHelpFormatter
SET_HELP = ("a setting NAME=VALUE, repeatable, applied last (e.g. --set human.blind=true "
            "--set robot.theta_hat=theta.json --set robot.mpc.w_speed=2); `marl-social params "
            "SCENARIO` lists them")
EXIT_BAD_INPUT = 2
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, what a shell reports for a closed pipe


def version() -> str:
    """The installed package's version (the source tree's if not installed)."""
    try:
        return metadata.version("marl-social")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a bare checkout
        from marl_social import __version__

        return __version__


def choice(kind: str, names):
    """An argparse `type` that accepts one of `names` and suggests the closest otherwise.

    Args:
        kind: what the names are, for the message ("planner", "scenario", ...).
        names: the valid names.
    """
    names = list(names)

    def check(value: str) -> str:
        if value not in names:
            raise argparse.ArgumentTypeError(str(unknown_name(kind, value, names)))
        return value

    check.__name__ = kind  # argparse names the type in its messages
    return check


def _add_scenario_options(parser, default_scenario: str = "occluded_crosswalk") -> None:
    parser.add_argument("--scenario", default=default_scenario,
                        type=choice("scenario", SCENARIOS), metavar="NAME",
                        help=f"scenario, one of {', '.join(SCENARIOS)}")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help=SET_HELP)


def _pedestrian_option(parser, default: str | None) -> None:
    names = variant_names("occluded_crosswalk", "pedestrian")
    parser.add_argument("--pedestrian", default=default, type=choice("pedestrian variant", names),
                        metavar="VARIANT", help=f"pedestrian variant, one of {', '.join(names)} "
                        "(scenarios with a pedestrian; None: the scenario's default)")


def _planner_help(text: str) -> str:
    return f"{text}, one of {', '.join(ROBOT_PLANNERS)}"


def _add_demo(sub) -> None:
    demo = sub.add_parser("demo", formatter_class=FORMATTER,
                          help="run one episode; write an animation, a figure and its metrics",
                          description="Run one episode with the built-in planners; write an "
                          "animation, a figure and the metrics.")
    demo.add_argument("--out", default=commands.DEFAULT_OUT, help="output folder")
    _add_scenario_options(demo)
    _pedestrian_option(demo, None)
    demo.add_argument("--planner", default=None, type=choice("planner", ROBOT_PLANNERS),
                      metavar="NAME", help=_planner_help("the robot's planner (None: the "
                                                         "scenario's default)"))
    demo.add_argument("--seed", type=seed_argument, default=0, help="episode seed")
    demo.add_argument("--max-cycles", type=int, default=200, help="step limit")
    demo.add_argument("--no-animation", action="store_true", help="figure only (faster)")
    demo.set_defaults(func=commands.demo)


def _add_reproduce(sub) -> None:
    rep = sub.add_parser("reproduce", formatter_class=FORMATTER,
                         help="the paper's Figs. 3-6 and a table over seeds",
                         description="The paper's Figs. 3-6 and a table of every planner and "
                         "pedestrian variant over randomized seeds.")
    rep.add_argument("--out", default=f"{commands.DEFAULT_OUT}/reproduce", help="output folder")
    rep.add_argument("--seeds", type=int, default=20, help="randomized seeds per table cell")
    rep.add_argument("--workers", type=int, default=2, help="parallel processes")
    rep.add_argument("--scenario", default="occluded_crosswalk",
                     type=choice("scenario", ("occluded_crosswalk", "t_intersection",
                                              "signalized_intersection")),
                     metavar="NAME", help="the paper's crosswalk (Figs. 3-6), the "
                     "T-intersection (Fig. 1 b) or the signalized intersection (Fig. 1 c)")
    rep.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help=SET_HELP + "; on top of each seed's randomization")
    rep.set_defaults(func=commands.reproduce)


def _add_bench(sub) -> None:
    bench = sub.add_parser("bench", formatter_class=FORMATTER,
                           help="benchmarks: `bench env`, `bench planners`",
                           description="Benchmarks of the env's step and the planners.")
    bench.add_argument("what", choices=["env", "planners"], help="what to time")
    bench.add_argument("--agents", type=int, nargs="+", default=[3, 10, 30, 100],
                       help="agent counts (env)")
    bench.add_argument("--steps", type=int, default=500, help="steps per agent count (env)")
    bench.add_argument("--no-peer", action="store_true", help="skip highway-env")
    bench.add_argument("--profile", action="store_true", help="print a cProfile breakdown")
    bench.add_argument("--scenario", default="occluded_crosswalk",
                       choices=["occluded_crosswalk", "t_intersection", "signalized_intersection"],
                       help="the scenario whose planners are timed (planners)")
    bench.add_argument("--json", help="also write the rows to this JSON file")
    bench.set_defaults(func=commands.bench)


def _add_record(sub) -> None:
    rec = sub.add_parser("record", formatter_class=FORMATTER,
                         help="record human demonstrations for inverse optimal control",
                         description="Record human demonstrations (npz, "
                         "marl_social/data/demonstrations.py) or decisions for `irl fit`.")
    rec.add_argument("-o", "--out", default=f"{commands.DEFAULT_OUT}/demos.npz",
                     help="output file")
    _add_scenario_options(rec)
    rec.add_argument("--episodes", type=int, default=20, help="episodes to record")
    rec.add_argument("--seed0", type=seed_argument, default=0, help="first seed")
    _pedestrian_option(rec, None)
    rec.add_argument("--robot-planner", default="cruise", type=choice("planner", ROBOT_PLANNERS),
                     metavar="NAME", help=_planner_help("the robot's planner"))
    rec.add_argument("--human-beta", type=float, default=None,
                     help="the humans' rationality (None: the scenario's default)")
    rec.add_argument("--max-cycles", type=int, default=150, help="step limit per episode")
    rec.add_argument("--segment-steps", type=int, default=30, help="steps per demonstration")
    rec.add_argument("--stride", type=int, default=10, help="steps between segment starts")
    rec.add_argument("--workers", type=int, default=1, help="parallel processes")
    rec.add_argument("--decisions", action="store_true",
                     help="record every human decision (what its discrete choice depends on, "
                          "marl_social/data/decisions.py) for the exact discrete-choice fit")
    rec.add_argument("--synthetic", action="store_true",
                     help="near-rational continuous demonstrations with a known theta instead "
                          "(agents/irl/synthetic.py)")
    rec.add_argument("--theta", type=float, nargs=6, default=[0.0, 1.0, 0.1, 0.1, 1.0, 1000.0],
                     help="--synthetic: the demonstrator's weights "
                          "(marl_social.sim.costs.FEATURE_NAMES)")
    rec.add_argument("--beta", type=float, default=10.0, help="--synthetic: its rationality")
    rec.add_argument("--segments", type=int, default=100, help="--synthetic: how many")
    rec.set_defaults(func=commands.record)


def _add_irl(sub) -> None:
    irl = sub.add_parser("irl", formatter_class=FORMATTER,
                         help="inverse optimal control: `irl fit DEMOS -o theta.json`",
                         description="Inverse optimal control of the humans' cost weights.")
    irl_sub = irl.add_subparsers(dest="irl_command", required=True, metavar="{fit}")
    fit = irl_sub.add_parser("fit", formatter_class=FORMATTER,
                             help="fit theta to demonstrations (Laplace approximation) or to "
                                  "recorded decisions (exact discrete-choice likelihood)")
    fit.add_argument("demos", nargs="+", help=".npz from `record` (demonstrations: Laplace fit; "
                     "`record --decisions`: discrete-choice fit), or INTERACTION-format .csv")
    fit.add_argument("-o", "--out", default=f"{commands.DEFAULT_OUT}/theta.json",
                     help="the fit's JSON file (use it as --set robot.theta_hat=FILE)")
    fit.add_argument("--features", nargs="+", default=None,
                     help="features to fit (None: speed accel jerk safety crosswalk)")
    fit.set_defaults(func=commands.irl_fit)


def _add_maps(sub) -> None:
    maps = sub.add_parser("maps", formatter_class=FORMATTER,
                          help="real maps: `maps list`, `maps show NAME --figure PATH`",
                          description="Lanelet2 maps as the simulator sees them (needs "
                                      "`pip install -e \".[maps]\"`).")
    maps_sub = maps.add_subparsers(dest="maps_command", required=True, metavar="{list,show}")
    maps_sub.add_parser("list", formatter_class=FORMATTER, help="the built-in maps")
    show = maps_sub.add_parser("show", formatter_class=FORMATTER,
                               help="a map's summary: lanes, crosswalks, stop lines, signals, "
                                    "occluders, what could not be mapped")
    show.add_argument("map", help="a built-in map's name or a Lanelet2 .osm file")
    show.add_argument("--origin", type=float, nargs=2, metavar=("LAT", "LON"), default=None,
                      help="UTM origin [deg] (None: a built-in map's own, else the file's)")
    show.add_argument("--figure", default=None, metavar="PATH",
                      help="also save a figure of the whole map as the simulator sees it")
    maps.set_defaults(func=commands.maps)


def _add_scenes(sub) -> None:
    scenes = sub.add_parser("scenes", formatter_class=FORMATTER,
                            help="where each situation can be built on a map (map_scene's "
                                 "element=ID), and why not elsewhere",
                            description="The elements of a Lanelet2 map where "
                                        "`--scenario map_scene` builds each situation.")
    scenes.add_argument("map", help="a built-in map's name or a Lanelet2 .osm file")
    scenes.add_argument("--json", action="store_true",
                        help='print the buildable ones as [{"element": ID, "situation": NAME}]')
    scenes.set_defaults(func=commands.scenes)


def _add_replay(sub) -> None:
    rep = sub.add_parser("replay", formatter_class=FORMATTER,
                         help="an INTERACTION recording's vehicles replayed on their map, the "
                              "robot planning among them",
                         description="Replay the vehicles of a vehicle_tracks_*.csv on its "
                                     "Lanelet2 map (log replay, their own fields of view) with "
                                     "the robot on a route through one of the map's crosswalks.")
    rep.add_argument("map", help="the recording's Lanelet2 .osm map (or a built-in map's name)")
    rep.add_argument("tracks", help="the recording's vehicle_tracks_*.csv")
    rep.add_argument("--element", type=int, default=0,
                     help="the crosswalk the robot's route goes through (0: the first "
                          "buildable; `marl-social scenes MAP`)")
    rep.add_argument("--start-frame", type=int, default=0,
                     help="the replay's first frame (0: the recording's first)")
    rep.add_argument("--steps", type=int, default=600, help="step limit (10 Hz)")
    rep.add_argument("--planner", default="social", help="the robot's planner")
    rep.add_argument("--seed", type=int, default=0, help="the env's and the robot's seed")
    rep.add_argument("--out", help="also draw the episode (PNG)")
    rep.set_defaults(func=commands.replay)


def _add_params(sub) -> None:
    params = sub.add_parser("params", formatter_class=FORMATTER,
                            help="list a scenario's settings (for --set)",
                            description="List a scenario's settings: the dotted names --set takes, "
                                        "their types, units, defaults and meaning.")
    params.add_argument("scenario", nargs="?", default="occluded_crosswalk",
                        type=choice("scenario", SCENARIOS), help="scenario name")
    params.add_argument("--json", action="store_true",
                        help="a JSON object {name: {type, unit, default, doc}} (for tools)")
    params.set_defaults(func=lambda args: print(describe_params(args.scenario, args.json)) or 0)


def _add_study(sub) -> None:
    from marl_social.studies.runner import register_cli

    study = register_cli(sub)
    study.formatter_class = FORMATTER
    for action in study._actions:  # every option's help shows its default
        if action.help is None and action.choices:
            action.help = f"one of {', '.join(map(str, action.choices))}"
        elif action.help is None and action.dest != "help":
            action.help = action.dest.replace("_", " ")
    study.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help=SET_HELP + "; added to the spec's [fixed] parameters")
    study.set_defaults(func=_study, study_func=study.get_default("func"))


def _study(args) -> int:
    """`marl-social study` with --set: the spec's [fixed] parameters plus the overrides."""
    from marl_social.studies.runner import builtin_specs, load_spec

    if args.spec and not args.list and not os.path.exists(args.spec):
        names = sorted(builtin_specs())
        if args.spec not in names:
            raise unknown_name("study", args.spec, names)
    if args.set and args.spec and not args.list and not args.analyze_only:
        spec = load_spec(args.spec, validate=False)
        overrides = parse_overrides(spec.scenario, args.set)
        swept = [k for k in overrides if k in spec.grid or k in spec.random]
        if swept:
            raise ValueError(f"--set {swept[0]}: the study sweeps it ({spec.section_of(swept[0])});"
                             " set parameters it does not sweep")
        if "robot_planner" in overrides:
            raise ValueError("--set robot_planner: a study sweeps its spec's planners")
        args.spec = replace(spec, fixed={**spec.fixed, **overrides})
    return args.study_func(args)


def _add_teach(sub) -> None:
    teach = sub.add_parser("teach", formatter_class=FORMATTER,
                           help="the teaching app: the simulator live in the browser",
                           description="Serve the teaching app (needs the teach extra: "
                           'pip install -e ".[teach]"; docs/teach.md).')
    teach.add_argument("--host", default="127.0.0.1",
                       help="address to bind (loopback: only this machine)")
    teach.add_argument("--port", type=int, default=8765, help="TCP port")
    teach.add_argument("--open", action="store_true", help="open the page in the browser")
    teach.add_argument("--max-sessions", type=int, default=4,
                       help="tabs playing at once; more get a busy page")
    teach.set_defaults(func=_teach)


def _teach(args) -> int:
    from marl_social.teach.launch import serve

    return serve(args.host, args.port, args.open, args.max_sessions)


def build_parser() -> argparse.ArgumentParser:
    """The `marl-social` parser with every subcommand."""
    parser = argparse.ArgumentParser(
        prog="marl-social", formatter_class=FORMATTER,
        description="marl-social: a PettingZoo multi-agent driving simulator with socially "
                    "perceptive planners (Sun et al., IEEE IV 2019).",
        epilog="`marl-social SUBCOMMAND --help` shows each subcommand's options.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="SUBCOMMAND",
                                title="subcommands")
    for add in (_add_demo, _add_reproduce, _add_record, _add_irl, _add_study, _add_bench,
                _add_params, _add_maps, _add_scenes, _add_replay, _add_teach):
        add(sub)
    add_train(sub, FORMATTER, SET_HELP)
    return parser


def _quiet_broken_pipe() -> int:
    """Point stdout at devnull so the interpreter's final flush does not fail again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    return EXIT_BROKEN_PIPE


def main(argv=None) -> int:
    """Run `marl-social` with `argv` (default sys.argv[1:]); returns the exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        return args.func(args)
    except BrokenPipeError:  # the reader (e.g. `head`) closed the pipe: not an error
        return _quiet_broken_pipe()
    except (ValueError, OSError) as err:  # bad input or file: one line, no traceback
        print(f"marl-social {args.command}: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT


__all__ = ["build_parser", "did_you_mean", "main", "scenario_class", "version"]
