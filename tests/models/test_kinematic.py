"""Closed-form CV / CA / CT motion over a horizon equals stepping the models' transitions."""

import numpy as np
import pytest

from swarmtrack.models import make_model
from swarmtrack.models.kinematic import kinematic_motion


@pytest.mark.parametrize("model", ["cv", "ca", "ct"])
@pytest.mark.parametrize("omega", [0.0, 1e-9, 0.15, -2.0])
def test_motion_after_each_tau_equals_the_models_transition_with_that_period(model, omega):
    rng = np.random.default_rng(4)
    state = rng.normal(size=(3, 4))
    motion = np.column_stack([rng.normal(size=(3, 2)), np.full(3, omega)])
    tau = np.array([0.2, 0.4, 1.0, 4.0])
    out = kinematic_motion(state, model, motion, tau)
    extra = {"cv": slice(0, 0), "ca": slice(0, 2), "ct": slice(2, 3)}[model]
    x0 = np.concatenate([state, motion[:, extra]], axis=1)
    for k, t in enumerate(tau):
        np.testing.assert_allclose(out[:, k], make_model(model, t).f(x0)[:, :4], rtol=1e-12, atol=1e-12)


def test_an_unknown_model_is_refused():
    with pytest.raises(ValueError, match="unknown kinematic model 'fs'"):
        kinematic_motion(np.zeros((1, 4)), "fs", np.zeros((1, 3)), np.ones(1))
