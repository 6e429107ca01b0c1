"""`python -m marl_social.cli`: the same as `marl-social`."""

import sys

from marl_social.cli.app import main

sys.exit(main())
