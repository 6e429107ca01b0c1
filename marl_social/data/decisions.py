"""Recorded decisions of the simulator's human drivers, for discrete-choice IRL.

The IRL is agents/irl/choice.py.

A simulated human driver (agents/human.py) decides every simulator step by sampling one of A
first accelerations from softmax(-beta * Q*), with Q*(u) = min over the allowed continuations c
of theta . features[u, c] (eq. 8, 11). A decision record holds exactly what that choice depends
on — the feature totals of every candidate, computed from the human's *own* tracks, which
continuations it allowed (collision-free), and the index it sampled — so the likelihood of
its choices is exact, not a Laplace approximation.

File format (`save_decisions` / `load_decisions`): one NumPy ``.npz`` archive (no pickles):

==================  ==============  ==========================================================
key                 shape / dtype   meaning
==================  ==============  ==========================================================
format              () str          "marl-social-decisions/1"
features            (N, A, C, F) f8 per-feature totals of each candidate (sim/costs
                                    FEATURE_NAMES order) [simulator-step cost units]
allowed             (N, A, C) bool  the continuations the driver could choose
chosen              (N,) int64      index of the first action it sampled
first_actions_mps2  (A,) f8         the candidate first accelerations [m/s^2]
theta_true          (N, F) f8       the driver's true cost weights
beta_true           (N,) f8         its true rationality
agent, source       (N,) str        who decided, and in which episode
t_s                 (N,) f8         simulation time of the decision [s]
==================  ==============  ==========================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from marl_social.data.archive import FLAGS, NUMBERS, TEXT, is_archive_of, read_npz, short_reason
from marl_social.sim.costs import N_FEATURES

ARCHIVE_FIELDS = {  # the arrays of an archive and the dtype kinds each may hold
    "features": NUMBERS, "allowed": FLAGS, "chosen": "iu", "first_actions_mps2": NUMBERS,
    "theta_true": NUMBERS, "beta_true": NUMBERS, "agent": TEXT, "source": TEXT, "t_s": NUMBERS}
FORMAT = "marl-social-decisions/1"


@dataclass
class DecisionSet:
    """N recorded decisions (see module docstring for the fields and their shapes)."""

    features: np.ndarray
    allowed: np.ndarray
    chosen: np.ndarray
    first_actions_mps2: np.ndarray
    theta_true: np.ndarray
    beta_true: np.ndarray
    agent: np.ndarray
    source: np.ndarray
    t_s: np.ndarray

    def __post_init__(self):
        self.features = np.asarray(self.features, dtype=np.float64)
        self.allowed = np.asarray(self.allowed, dtype=bool)
        self.chosen = np.asarray(self.chosen, dtype=np.int64)
        self.first_actions_mps2 = np.asarray(self.first_actions_mps2, dtype=np.float64)
        self.theta_true = np.asarray(self.theta_true, dtype=np.float64)
        self.beta_true = np.asarray(self.beta_true, dtype=np.float64)
        self.agent = np.asarray(self.agent, dtype=str)
        self.source = np.asarray(self.source, dtype=str)
        self.t_s = np.asarray(self.t_s, dtype=np.float64)
        n = len(self.chosen)
        if self.features.ndim != 4 or self.features.shape[-1] != N_FEATURES:
            raise ValueError(f"decisions: features must be (N, A, C, {N_FEATURES}), got "
                             f"{self.features.shape}")
        shapes = {"features": self.features.shape[:1], "allowed": self.allowed.shape[:1],
                  "theta_true": self.theta_true.shape[:1], "beta_true": self.beta_true.shape,
                  "agent": self.agent.shape, "source": self.source.shape, "t_s": self.t_s.shape}
        for name, shape in shapes.items():
            if shape != (n,):
                raise ValueError(f"decisions: {name} has {shape[0] if shape else 0} rows, "
                                 f"chosen has {n}")
        if self.allowed.shape != self.features.shape[:3]:
            raise ValueError(f"decisions: allowed must be {self.features.shape[:3]}, got "
                             f"{self.allowed.shape}")
        if self.first_actions_mps2.shape != self.features.shape[1:2]:
            raise ValueError("decisions: first_actions_mps2 must have one entry per first action")
        if not np.all(np.isfinite(self.features)):
            raise ValueError("decisions: features must be finite")
        if n and (self.chosen.min() < 0 or self.chosen.max() >= self.features.shape[1]):
            raise ValueError("decisions: chosen index out of range")
        if n and not self.allowed[np.arange(n), self.chosen].any(axis=-1).all():
            raise ValueError("decisions: a chosen first action has no allowed continuation")

    def __len__(self) -> int:
        return len(self.chosen)

    def subset(self, index) -> DecisionSet:
        """The decisions at `index` (array of indices or a boolean mask)."""
        return DecisionSet(self.features[index], self.allowed[index], self.chosen[index],
                           self.first_actions_mps2, self.theta_true[index],
                           self.beta_true[index], self.agent[index], self.source[index],
                           self.t_s[index])

    @classmethod
    def concatenate(cls, parts: list[DecisionSet]) -> DecisionSet:
        if not parts:
            raise ValueError("decisions: nothing to concatenate")
        if any(p.features.shape[1:] != parts[0].features.shape[1:]
               or not np.array_equal(p.first_actions_mps2, parts[0].first_actions_mps2)
               for p in parts):
            raise ValueError("decisions: parts have different candidate sets")
        cat = lambda name: np.concatenate([getattr(p, name) for p in parts])
        return cls(cat("features"), cat("allowed"), cat("chosen"), parts[0].first_actions_mps2,
                   cat("theta_true"), cat("beta_true"), cat("agent"), cat("source"), cat("t_s"))


def save_decisions(path, decisions: DecisionSet) -> Path:
    """Write `decisions` to an .npz archive (format in the module docstring)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:
        np.savez_compressed(
            f, format=np.array(FORMAT), features=decisions.features, allowed=decisions.allowed,
            chosen=decisions.chosen, first_actions_mps2=decisions.first_actions_mps2,
            theta_true=decisions.theta_true, beta_true=decisions.beta_true,
            agent=decisions.agent, source=decisions.source, t_s=decisions.t_s)
    return path


def is_decision_file(path) -> bool:
    """True for an .npz written by save_decisions (False for other files, damaged or empty)."""
    return is_archive_of(path, FORMAT)


def load_decisions(path) -> DecisionSet:
    """Read an archive written by save_decisions (clear errors naming the file otherwise)."""
    path = Path(path)
    data = read_npz(path, "decision", FORMAT, ARCHIVE_FIELDS)
    try:
        return DecisionSet(**{k: data[k] for k in ARCHIVE_FIELDS})
    except ValueError as err:
        raise ValueError(f"{path}: {err}") from None
    except (TypeError, IndexError, OverflowError) as err:
        raise ValueError(f"{path}: inconsistent decision archive ({short_reason(err)})") from None
