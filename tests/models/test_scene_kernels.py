"""The compiled constant-velocity scene (models/scene_kernels.py) equals numpy's, bit for bit.

ScenePrediction.from_tracks of a TrackSet (whose xy and velocity are strided views of one
table, as perception/tracking.Tracker builds them) against TrackSet.predict_xy and the
repeated headings; every magnitude, signed zeros, non-finite values, no tracks.
"""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.models.scene_prediction import ScenePrediction
from marl_social.perception.tracking import TrackSet


def _tracks(table: np.ndarray) -> TrackSet:
    m = len(table)
    return TrackSet(np.arange(m), table[:, 0:2], table[:, 2:4], np.zeros(m), table[:, 5],
                    table[:, 6], table[:, 7] > 0.5, np.ones(m, bool), np.zeros(m), table[:, 4],
                    np.zeros((m, 2, 2)))


def _same(got: np.ndarray, want: np.ndarray) -> bool:
    return got.shape == want.shape and got.dtype == want.dtype and got.tobytes() == want.tobytes()


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_obj=st.integers(0, 12), n_t=st.integers(1, 20),
       scale=st.sampled_from([1e-300, 1e-3, 1.0, 30.0, 1e200]), specials=st.booleans())
def test_constant_velocity_scene_equals_numpy(seed, n_obj, n_t, scale, specials):
    rng = np.random.default_rng(seed)
    table = rng.normal(size=(n_obj, 8)) * scale
    table[:, 5:7] = rng.uniform(0.5, 5.0, (n_obj, 2))
    if specials and n_obj:
        flat = table[:, :5].reshape(-1)
        picks = rng.integers(0, flat.size, 3)
        flat[picks] = rng.choice([0.0, -0.0, np.inf, -np.inf, np.nan], 3)
        table[:, :5] = flat.reshape(n_obj, 5)
    times = np.cumsum(rng.uniform(0.05, 0.5, n_t))
    tracks = _tracks(table)
    scene = ScenePrediction.from_tracks(tracks, times)
    with np.errstate(all="ignore"):  # inf x 0, overflow: the same values either way
        want_xy = tracks.predict_xy(times)[None]
    assert _same(scene.xy, want_xy)
    assert _same(scene.heading, tracks.heading_rad[None, :, None].repeat(n_t, axis=2))
    assert scene.mask.shape == (1, n_obj) and scene.mask.all() and scene.mask.flags.writeable
    assert _same(scene.radius_m, 0.5 * np.hypot(tracks.length_m, tracks.width_m)[None])
