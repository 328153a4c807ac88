"""The Python example of README.md runs as shown, from the repository's root, and says what its
comments say."""

import contextlib
import io
import os

import numpy as np
import pytest

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..")


def test_readme_example_runs(monkeypatch):
  with open(os.path.join(ROOT, "README.md")) as f:
    readme = f.read()
  code = readme.split("\n## Python\n")[1].split("```python\n")[1].split("```")[0]
  monkeypatch.chdir(ROOT)
  scope = {}
  out = io.StringIO()
  with contextlib.redirect_stdout(out):
    exec(compile(code, "README.md", "exec"), scope)
  physics, grads, traj = scope["physics"], scope["grads"], scope["traj"]
  assert out.getvalue().count("\n") == 2
  assert physics.data.time == pytest.approx(51 * 0.02)  # one step, then the rollout's 50
  assert traj.qpos.shape == (51, 2) and traj.converged
  # pushing the cart right (gear 10 along +x) moves its final position right
  assert grads.ctrl.shape == (50, 1) and np.all(grads.ctrl[:, 0] > 0)
  assert np.isfinite(grads.theta).all()

