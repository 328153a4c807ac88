"""Physics: views of mjModel / mjData, named indexing, loading errors, stepping with both engines,
options and statistics (plugin/python/ostrich/physics.py, named.py, ost_python.c)."""

import os
import warnings

import numpy as np
import pytest

import ostrich
from conftest import FREE_BALL, SLIDER, model_path


def test_views_are_the_data_itself():
  physics = ostrich.Physics.from_xml_path(model_path("cartpole.xml"))
  assert physics.data.qpos.shape == (2,) and physics.data.xpos.shape == (3, 3)
  assert np.shares_memory(physics.data.qpos, physics.data.qpos)
  # a qpos written through a view is what MuJoCo's kinematics (C) sees
  physics.named.data.qpos["slider"] = 0.5
  physics.named.data.qpos["hinge"] = np.pi / 2
  physics.forward()
  assert physics.named.data.xpos["cart"][0] == pytest.approx(0.5, abs=1e-15)
  # the pole hangs from the cart's centre, rotated about y by pi/2: its tip at x + 1
  tip = physics.named.data.xpos["pole"] + physics.data.xmat[2].reshape(3, 3) @ [0, 0, 1]
  np.testing.assert_allclose(tip, [1.5, 0, 1], atol=1e-12)
  # model arrays: body_mass from the MJCF, written through and read back by name and id
  assert physics.named.model.body_mass["pole"] == pytest.approx(0.1)
  physics.named.model.body_mass["pole"] = 0.25
  assert physics.model.body_mass[physics.id("body", "pole")] == 0.25


def test_ctrl_and_step_through_views():
  physics = ostrich.Physics.from_xml_string(SLIDER)
  physics.named.data.ctrl["push"] = 4.0
  physics.named.data.qpos["x"] = 0.3
  h = physics.timestep
  assert physics.step() == 0 and physics.converged
  # backward Euler on a 2 kg slide pushed by 4 N: v+ = h F / m, x+ = x- + h v+
  v = h * 4.0 / 2.0
  assert physics.named.data.qvel["x"] == pytest.approx(v, rel=1e-12)
  assert physics.named.data.qpos["x"] == pytest.approx(0.3 + h * v, rel=1e-12)
  assert physics.data.time == pytest.approx(h)
  # sensors by name: Ostrich publishes mjData at the new state
  assert physics.named.data.sensordata["x_pos"] == pytest.approx(0.3 + h * v, rel=1e-12)
  np.testing.assert_allclose(physics.named.data.sensordata["box_pos"], [0.3 + h * v, 0, 1],
                             rtol=1e-12)


def test_named_indexing_widths_lists_and_integers():
  physics = ostrich.Physics.from_xml_string(FREE_BALL)
  qpos = physics.named.data.qpos
  assert qpos["free"].shape == (7,)  # a free joint: position and quaternion
  np.testing.assert_array_equal(qpos["free"], [0, 0, 1, 1, 0, 0, 0])
  assert physics.named.data.qvel["free"].shape == (6,)
  np.testing.assert_array_equal(physics.named.data.xquat["ball"], [1, 0, 0, 0])
  qpos["free"] = [1, 2, 3, 0, 1, 0, 0]
  np.testing.assert_array_equal(physics.data.qpos, [1, 2, 3, 0, 1, 0, 0])
  assert qpos[2] == 3 and qpos.names == ["free"]
  cartpole = ostrich.Physics.from_xml_path(model_path("cartpole.xml"))
  cartpole.data.qpos[:] = [0.1, 0.2]
  np.testing.assert_array_equal(cartpole.named.data.qpos[["hinge", "slider"]], [0.2, 0.1])
  np.testing.assert_array_equal(cartpole.named.data.xpos["cart", 2], 1.0)
  assert cartpole.names("actuator") == ["push"]


def test_name_errors():
  physics = ostrich.Physics.from_xml_path(model_path("cartpole.xml"))
  with pytest.raises(KeyError, match="no joint named 'slide'.*'slider', 'hinge'"):
    physics.named.data.qpos["slide"]
  with pytest.raises(KeyError, match="no body named 'torso'"):
    physics.named.model.body_mass["torso"] = 1
  with pytest.raises(KeyError, match="no actuator named"):
    physics.named.data.ctrl[["push", "pull"]]
  with pytest.raises(AttributeError, match="mjData has no array 'qpoz'"):
    physics.data.qpoz
  with pytest.raises(KeyError, match="no Ostrich option 'newton'"):
    physics.set_options(newton=3)
  with pytest.raises(ValueError, match="engine 'bullet'"):
    physics.step(engine="bullet")


def test_bad_xml_raises_with_mujocos_message(tmp_path):
  with pytest.raises(ostrich.OstrichError, match="XML parse error") as e:
    ostrich.Physics.from_xml_string("<mujoco><worldbody></mujoco>")
  assert e.value.status == 1
  with pytest.raises(ostrich.OstrichError, match="unrecognized attribute: 'sizee'"):
    ostrich.Physics.from_xml_string(
        "<mujoco><worldbody><geom type='sphere' sizee='1'/></worldbody></mujoco>")
  with pytest.raises(ostrich.OstrichError, match="cannot load the model"):
    ostrich.Physics.from_xml_path(tmp_path / "missing.xml")


def test_refused_option_raises_with_ostrichs_message():
  physics = ostrich.Physics.from_xml_string(SLIDER.replace(
      "<worldbody>", "<custom><numeric name='ostrich/no_such' data='1'/></custom><worldbody>"))
  with pytest.raises(ostrich.OstrichError, match="unknown ostrich option 'no_such'"):
    physics.step()
  assert physics.data.time == 0  # a failed step leaves the state as it was


@pytest.mark.parametrize("engine", ["ostrich", "mujoco"])
def test_free_fall_matches_backward_euler(engine):
  physics = ostrich.Physics.from_xml_string(FREE_BALL)
  h, g = physics.model.timestep, physics.model.gravity.copy()
  physics.named.data.qvel["free"] = [0.5, 0, 1, 0, 0, 0]
  for _ in range(3):
    q, v = physics.data.qpos.copy(), physics.data.qvel.copy()
    assert physics.step(engine=engine) == 0
    # v+ = v- + h g, q+ = q- + h v+ (MuJoCo's Euler is the same semi-implicit update here)
    np.testing.assert_allclose(physics.data.qvel[:3], v[:3] + h * g, rtol=0, atol=1e-13)
    np.testing.assert_allclose(physics.data.qpos[:3], q[:3] + h * physics.data.qvel[:3],
                               rtol=0, atol=1e-13)
    np.testing.assert_allclose(physics.data.qpos[3:], [1, 0, 0, 0], atol=1e-15)
  assert physics.data.time == pytest.approx(3 * h)
  assert bool(physics.stats) == (engine == "ostrich")


def test_engines_differ_on_contact_and_reset():
  # a box dropped on its floor: Ostrich's hard contact against MuJoCo's soft one
  results = {}
  for engine in ("ostrich", "mujoco"):
    physics = ostrich.Physics.from_xml_path(model_path("box_plane.xml"))
    physics.step(200, engine=engine)
    results[engine] = physics.data.qpos[2]
    assert np.isfinite(physics.data.qpos).all()
    physics.reset()
    assert physics.data.time == 0 and physics.data.qpos[2] == physics.model.qpos0[2]
  assert results["ostrich"] == pytest.approx(0.1, abs=1e-4)   # hard contact: the box rests
  assert results["mujoco"] == pytest.approx(0.1, abs=1e-2)
  with pytest.raises(ostrich.OstrichError, match="keyframe 3 out of range"):
    physics.reset(3)


def test_options_stats_and_unconverged_step_warns():
  physics = ostrich.Physics.from_xml_path(model_path("box_plane.xml"))
  assert physics.stats == {} and physics.totals == {}
  physics.set_options(newton_iter=1, split_depth=0)
  assert physics.options["newton_iter"] == 1
  with pytest.warns(ostrich.NotConvergedWarning, match="not converged"):
    status = physics.step(30)
  assert status == 100 and not physics.converged
  assert physics.totals["unconverged"] >= 1 and physics.totals["steps"] == 30
  physics.set_options(newton_iter=64)
  assert physics.step() == 0 and physics.converged and physics.stats["status"] == 0


def test_split_bound_options():
  """split_depth 6 and deep_splits 6 by default; a step that fails takes 2^3 substeps freely
  and at most deep_splits more (core/ost_step.h OST_SPLIT_FREE), whatever split_depth: with one
  Newton iterate the box's first step fails at every level down to 3, and some deeper."""
  physics = ostrich.Physics.from_xml_path(model_path("box_plane.xml"))
  assert physics.options["split_depth"] == 6 and physics.options["deep_splits"] == 6
  with pytest.raises(ostrich.OstrichError, match="deep_splits must be in"):
    physics.set_options(deep_splits=-1)
  for deep in (0, 2):
    physics.reset()
    physics.set_options(newton_iter=1, split_depth=10, deep_splits=deep)
    with pytest.warns(ostrich.NotConvergedWarning):
      physics.step()
    substeps = physics.stats["substeps"]
    assert substeps == 8 if deep == 0 else 8 < substeps <= 8 + deep



def test_cold_retry_option_and_counts():
  """The planar legs of tests/models at h = 0.07 s under the controls of test_ost_step.c's
  test_coldRetry (xorshift64 from seed 1835, held 3 steps): its 56th step stalls from the warm
  start (a warning with cold_retry 0) and converges after one cold retry (the default)."""
  path = os.path.join(model_path(""), "..", "tests", "models", "planar_legs.xml")
  for retry in (0, 1):
    physics = ostrich.Physics.from_xml_path(path)
    assert physics.options["cold_retry"] == 1
    # split_depth 3 (halving six times also gets past the stall, more slowly)
    physics.set_options(timestep=0.07, cold_retry=retry, split_depth=3)
    x = (1835 * 0x9E3779B97F4A7C15 + 1) % 2**64
    for k in range(100):
      if k % 3 == 0:
        for i in range(physics.nu):
          x ^= (x << 13) % 2**64
          x ^= x >> 7
          x ^= (x << 17) % 2**64
          physics.data.ctrl[i] = 2 * ((x >> 11) * 2.0**-53) - 1
      with warnings.catch_warnings():
        warnings.simplefilter("ignore", ostrich.NotConvergedWarning)
        physics.step()
    totals = physics.totals
    if retry:
      assert totals["unconverged"] == 0 and totals["retries"] >= 1
    else:
      assert totals["unconverged"] >= 1 and totals["retries"] == 0


def test_views_keep_their_memory_alive():
  import gc
  physics = ostrich.Physics.from_xml_path(model_path("cartpole.xml"))
  physics.data.qpos[:] = [0.25, -0.5]
  qpos, mass = physics.data.qpos, physics.named.model.body_mass
  del physics
  gc.collect()
  np.testing.assert_array_equal(qpos, [0.25, -0.5])  # the C data is freed with its last view
  assert mass["pole"] == pytest.approx(0.1)


def test_ncon_counts_mujocos_contacts():
  physics = ostrich.Physics.from_xml_string(FREE_BALL.replace(
      "<worldbody>", '<worldbody><geom name="floor" type="plane" size="5 5 0.1"/>'))
  physics.forward()
  assert physics.data.ncon == 0  # the ball (radius 0.1) 1 m above the floor
  physics.named.data.qpos["free"] = [0, 0, 0.05, 1, 0, 0, 0]  # 5 cm into the floor
  physics.forward()
  assert physics.data.ncon == 1  # sphere-plane: one contact
  with pytest.raises(AttributeError, match="read only"):
    physics.data.ncon = 0
