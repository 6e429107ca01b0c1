"""`python -m marl_social.studies SPEC ...`: the same as `marl-social study SPEC ...`."""

import sys

from marl_social.studies.runner import main

sys.exit(main())
