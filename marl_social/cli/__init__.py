"""Command line: `marl-social demo | reproduce | record | irl fit | study | bench | params`.

`marl-social --help` lists every subcommand; `marl-social SUBCOMMAND --help` shows each option
with its default. Scenario parameters are set with a repeatable `--set KEY=VALUE`
(marl_social/cli/overrides.py).
"""

from marl_social.cli.app import build_parser, main

__all__ = ["build_parser", "main"]
