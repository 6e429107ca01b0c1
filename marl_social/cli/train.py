"""`marl-social train`: multi-agent PPO on RLlib, `train eval CHECKPOINT`, `train study`.

Needs the [rllib] extra (`pip install -e ".[rllib]"`); without it each command fails with one
line naming the extra. docs/rl.md has the recipes.
"""

from __future__ import annotations

import sys

from marl_social.agents.registry import ROBOT_PLANNERS
from marl_social.evaluation.reproduce import VARIANTS
from marl_social.scenarios import SCENARIOS
from marl_social.training.scene import CONTROLS, LEARNERS, OBSERVATIONS

EXIT_BAD_INPUT = 2


def add_train(sub, formatter, set_help: str) -> None:
    """The `train` subcommand (and its `eval` and `study`) on the CLI's subparsers."""
    from marl_social.training.study import StudySettings
    from marl_social.training.trainer import PPOSettings, TrainSettings

    run, ppo = TrainSettings(), PPOSettings()
    train = sub.add_parser(
        "train", formatter_class=formatter,
        help="multi-agent PPO on Ray RLlib: `train`, `train eval CHECKPOINT`, `train study`",
        description="Multi-agent PPO on Ray RLlib's current API stack (needs pip install -e "
                    "\".[rllib]\"; docs/rl.md). Options go before `eval` / `study`.")
    train.add_argument("--scenario", default="occluded_crosswalk", choices=SCENARIOS,
                       metavar="NAME", help="scenario")
    train.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help=set_help)
    train.add_argument("--learn", default="robot", choices=LEARNERS,
                       help="who learns: the robot among the built-in humans, the human drivers "
                            "(one shared policy; the robot on its planner), or both")
    train.add_argument("--observation", default="ego", choices=OBSERVATIONS,
                       help="the robot's observation: its own, or with its social belief")
    train.add_argument("--control", default="accel", choices=CONTROLS,
                       help="a learner's action: its acceleration (steering by pure pursuit "
                            "along its route, as the built-in planners) or both")
    train.add_argument("--variants", nargs="+", default=[], choices=VARIANTS, metavar="VARIANT",
                       help="pedestrian variants drawn per episode (none given: the scenario's)")
    train.add_argument("--randomize", default="", metavar="PRESET",
                       help="randomization preset drawn per episode (e.g. wide, paper; '': none)")
    train.add_argument("--max-cycles", type=int, default=200, help="step limit per episode")
    train.add_argument("--iterations", type=int, default=run.iterations,
                       help="training iterations in total")
    train.add_argument("--batch", type=int, default=ppo.train_batch_size,
                       help="env steps per iteration")
    train.add_argument("--minibatch", type=int, default=ppo.minibatch_size,
                       help="steps per gradient step")
    train.add_argument("--epochs", type=int, default=ppo.num_epochs, help="passes per batch")
    train.add_argument("--lr", type=float, default=ppo.lr, help="learning rate")
    train.add_argument("--env-runners", type=int, default=run.env_runners,
                       help="env runner processes (0: sample in this process)")
    train.add_argument("--envs-per-runner", type=int, default=run.envs_per_runner,
                       help="env copies per env runner")
    train.add_argument("--address", default=None,
                       help="a running Ray cluster: HOST:PORT of `ray start --head`, auto, or "
                            "ray://HOST:10001 (None: a private local instance; docs/ray.md)")
    train.add_argument("--checkpoint-every", type=int, default=run.checkpoint_every,
                       help="iterations between checkpoints (and after the last)")
    train.add_argument("--resume", action="store_true",
                       help="continue the run in --out from its newest checkpoint")
    train.add_argument("--out", default="runs/train", help="the run's folder")
    train.add_argument("--seed", type=int, default=0, help="seeds the env runners and networks")
    train.add_argument("--no-progress", action="store_true", help="no progress bar")
    train.set_defaults(func=train_command)

    commands = train.add_subparsers(dest="train_command", metavar="{eval,study}")
    ev = commands.add_parser("eval", formatter_class=formatter,
                             help="the reproduce table of a checkpoint's learned robot")
    ev.add_argument("checkpoint", help="<out>/checkpoints/iter_<n> of a run")
    ev.add_argument("--seeds", type=int, default=20, help="episodes per variant")
    ev.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS,
                    metavar="VARIANT", help="pedestrian variants")
    ev.add_argument("--baselines", nargs="*", default=["social"], choices=ROBOT_PLANNERS,
                    metavar="PLANNER", help="built-in robot planners on the same episodes")
    ev.add_argument("--workers", type=int, default=1, help="processes")
    ev.set_defaults(func=eval_command)

    study = StudySettings()
    st = commands.add_parser("study", formatter_class=formatter,
                             help="learned robot with and without the belief features")
    st.add_argument("--out", dest="study_out", default=study.out, help="the study's folder")
    st.add_argument("--seeds", type=int, default=len(study.seeds),
                    help="training seeds per observation")
    st.add_argument("--iterations", dest="study_iterations", type=int,
                    default=study.iterations, help="iterations per run")
    st.add_argument("--batch", dest="study_batch", type=int, default=study.batch,
                    help="env steps per iteration")
    st.add_argument("--eval-seeds", type=int, default=study.eval_seeds,
                    help="evaluation episodes per (run, variant)")
    st.add_argument("--workers", type=int, default=study.workers, help="runs at once")
    st.set_defaults(func=study_command)


def _fail(err: Exception) -> int:
    print(f"marl-social train: error: {err}", file=sys.stderr)
    return EXIT_BAD_INPUT


def train_settings(args):
    """The TrainSettings of `marl-social train`'s arguments."""
    from marl_social.cli.overrides import parse_overrides
    from marl_social.training import PPOSettings, SceneSettings, TrainSettings

    scene = SceneSettings(scenario=args.scenario, learn=args.learn,
                          observation=args.observation, control=args.control,
                          max_cycles=args.max_cycles, variants=tuple(args.variants),
                          randomize=args.randomize,
                          overrides=parse_overrides(args.scenario, args.set))
    ppo = PPOSettings(train_batch_size=args.batch, minibatch_size=args.minibatch,
                      num_epochs=args.epochs, lr=args.lr)
    return TrainSettings(scene=scene, ppo=ppo, iterations=args.iterations,
                         env_runners=args.env_runners, envs_per_runner=args.envs_per_runner,
                         address=args.address, checkpoint_every=args.checkpoint_every,
                         out=args.out, seed=args.seed, resume=args.resume,
                         progress=not args.no_progress)


def train_command(args) -> int:
    """`marl-social train`: train, then print where the log and checkpoint are."""
    from marl_social.training import TrainingError, train

    try:
        settings = train_settings(args)
        if settings.scene.randomize:
            from marl_social.evaluation.run import RANDOMIZATIONS

            if settings.scene.randomize not in RANDOMIZATIONS:
                raise ValueError(f"--randomize {settings.scene.randomize!r}: one of "
                                 f"{sorted(RANDOMIZATIONS)}")
        result = train(settings)
    except (TrainingError, ValueError, TypeError) as err:
        return _fail(err)
    last = result.rows[-1] if result.rows else {}
    print(f"{len(result.rows)} iterations in {result.out}: log {result.out / 'progress.csv'}, "
          f"checkpoint {result.checkpoint}; last mean return {last.get('return_mean', 'nan')}")
    return 0


def eval_command(args) -> int:
    """`marl-social train eval CHECKPOINT`: the reproduce table of the learned robot."""
    from marl_social.evaluation.reproduce import format_table
    from marl_social.training import TrainingError
    from marl_social.training.learned import evaluate_checkpoint

    try:
        rows = evaluate_checkpoint(args.checkpoint, n_seeds=args.seeds, variants=args.variants,
                                   baselines=tuple(args.baselines), workers=args.workers)
    except (TrainingError, ValueError) as err:
        return _fail(err)
    print(format_table(rows))
    errors = [e for row in rows for e in row["errors"]]
    if errors:
        print(f"{len(errors)} episode(s) failed, first: {errors[0]}", file=sys.stderr)
        return 1
    return 0


def study_command(args) -> int:
    """`marl-social train study`: the learned-robot study (training/study.py)."""
    from marl_social.training import TrainingError
    from marl_social.training.study import StudySettings, run_study, study_table

    study = StudySettings(out=args.study_out, seeds=tuple(range(args.seeds)),
                          iterations=args.study_iterations, batch=args.study_batch,
                          eval_seeds=args.eval_seeds, workers=args.workers)
    try:
        result = run_study(study)
    except (TrainingError, ValueError) as err:
        return _fail(err)
    print(study_table(result))
    print(f"wall {result['wall_s']:.0f} s (training {result['train_wall_s']:.0f} s), "
          f"CPU {result['cpu_s']:.0f} s; outputs in {study.out}")
    return 0
