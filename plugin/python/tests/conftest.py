"""Shared fixtures of the Python tests: the model directory and small MJCF models.

ctest runs these with PYTHONPATH=BUILD/python (the build tree's package) and OSTRICH_MODEL_DIR
= mjcf_models/; run by hand: PYTHONPATH=build/python python3 -m pytest plugin/python/tests.
"""

import os
import warnings

import pytest

MODEL_DIR = os.environ.get("OSTRICH_MODEL_DIR") or os.path.join(
    os.path.dirname(__file__), "..", "..", "..", "mjcf_models")

# a sphere on a free joint, no floor: free fall
FREE_BALL = """
<mujoco>
  <option timestep="0.01" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="ball" pos="0 0 1">
      <freejoint name="free"/>
      <geom name="ball_geom" type="sphere" size="0.1" mass="2"/>
    </body>
  </worldbody>
</mujoco>
"""

# a 2 kg box on a frictionless slide along x pushed by a motor (gear 1), gravity along z only
SLIDER = """
<mujoco>
  <option timestep="0.01" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="box" pos="0 0 1">
      <joint name="x" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.1 0.1 0.1" mass="2" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="push" joint="x" gear="1"/>
  </actuator>
  <sensor>
    <jointpos name="x_pos" joint="x"/>
    <framepos name="box_pos" objtype="body" objname="box"/>
  </sensor>
</mujoco>
"""

# a two-link arm hanging in a vertical plane, no contact, driven through activation dynamics:
# a position servo behind a first-order filter (tau 50 ms) on the shoulder, an integrator on
# the elbow
ACT_ARM = """
<mujoco>
  <option timestep="0.01" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0" damping="0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1" contype="0"
            conaffinity="0"/>
      <body name="lower" pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0" damping="0.1"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.5" contype="0"
              conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <general name="servo" joint="shoulder" dyntype="filter" dynprm="0.05" gainprm="20"
             biastype="affine" biasprm="0 -20 -2"/>
    <general name="push" joint="elbow" dyntype="integrator" gainprm="2"/>
  </actuator>
</mujoco>
"""


@pytest.fixture
def model_dir():
  return MODEL_DIR


def model_path(name):
  return os.path.join(MODEL_DIR, name)


def starved_box_plane(newton_iter):
  """box_plane.xml stepped at 20 ms with a Newton budget of newton_iter and no splitting, so a
  box thrown at its floor takes steps that do not converge."""
  with open(model_path("box_plane.xml")) as f:
    return f.read().replace(
        '<option timestep="0.002"/>',
        '<option timestep="0.002"/><custom>'
        f'<numeric name="ostrich/newton_iter" data="{newton_iter}"/>'
        '<numeric name="ostrich/split_depth" data="0"/>'
        '<numeric name="ostrich/timestep" data="0.02"/></custom>')


@pytest.fixture(autouse=True)
def _warnings_are_errors():
  """A warning a test does not expect (pytest.warns) fails it."""
  with warnings.catch_warnings():
    warnings.simplefilter("error")
    yield
