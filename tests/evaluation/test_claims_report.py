"""docs/claims.md is the rendering of its results file, and a malformed file fails loudly."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from marl_social.evaluation.claims_report import render

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.fixture(scope="module")
def results() -> dict:
    return json.loads((DOCS / "claims" / "results.json").read_text())


def test_claims_page_is_the_rendering_of_its_results_file(results):
    """Regenerate with the command at the top of docs/claims.md when this fails."""
    assert (DOCS / "claims.md").read_text() == render(results)


def test_every_scene_has_measured_claims(results):
    for scene in ("occluded_crosswalk", "t_intersection", "signalized_intersection"):
        claims = results["scenes"][scene]["claims"]
        assert claims and all(isinstance(c["holds"], bool) for c in claims), scene


@pytest.mark.parametrize("damage", ["no scenes", "no scene", "no claim number", "not a dict"])
def test_render_refuses_a_malformed_results_file(results, damage):
    broken = copy.deepcopy(results)
    if damage == "no scenes":
        del broken["scenes"]
    elif damage == "no scene":
        del broken["scenes"]["t_intersection"]
    elif damage == "no claim number":
        broken["scenes"]["occluded_crosswalk"]["claims"][0]["values"] = {}
    else:
        broken = [broken]
    with pytest.raises(ValueError, match="malformed claims results"):
        render(broken)
