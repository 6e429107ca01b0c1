"""`python -m marl_social`: the same as `marl-social`."""

import sys

from marl_social.cli import main

sys.exit(main())
