"""ostrich.suite.ab: the random-policy A/B of the suite's tasks and its command line (short
episodes). Needs dm_control's suite MJCF files (as test_suite.py); skipped, saying so, without."""

import io

import pytest

from ostrich import suite
from ostrich.suite import ab

try:
  SUITE_DIR = suite.find_suite_dir()
except FileNotFoundError as e:
  pytest.skip(f"dm_control's suite XML not found: {e}", allow_module_level=True)


def test_factors_keep_the_control_step():
  # walker: 10 physics steps per action; hopper 4; cartpole's physics step is its control step
  assert ab.factors_of("walker", "walk", [1, 2, 3, 4, 5, 10, 20], SUITE_DIR) == [1, 2, 5, 10]
  assert ab.factors_of("hopper", "stand", [1, 2, 4, 5], SUITE_DIR) == [1, 2, 4]
  assert ab.factors_of("cartpole", "swingup", [1, 5], SUITE_DIR) == [1]


def test_episode_is_seeded_and_counts_engine_steps():
  a = ab.episode("walker", "stand", "ostrich", 1, factor=5, steps=6, xml_dir=SUITE_DIR)
  b = ab.episode("walker", "stand", "ostrich", 1, factor=5, steps=6, xml_dir=SUITE_DIR)
  assert a["return"] == b["return"] and a["physics_timestep"] == pytest.approx(0.0125)
  assert a["engine_steps"] == 12 and 0 < a["return"] <= 6  # rewards lie in [0, 1]
  m = ab.episode("walker", "stand", "mujoco", 1, steps=6, xml_dir=SUITE_DIR)
  assert m["engine_steps"] == 60 and m["unconverged"] == 0


def test_cli_table_and_csv(tmp_path, capsys):
  path = tmp_path / "ab.csv"
  assert ab.main(["--task", "walker-stand,cartpole-balance", "--seeds", "2", "--steps", "3",
                  "--factors", "1,5", "--xml-dir", str(SUITE_DIR), "--csv", str(path)],
                 err=io.StringIO()) == 0
  out = capsys.readouterr().out.splitlines()
  assert out[0] == "| task | MuJoCo (h) | Ostrich (1 h) | Ostrich (5 h) |"
  walker = next(line for line in out if line.startswith("| walker-stand"))
  cartpole = next(line for line in out if line.startswith("| cartpole-balance"))
  assert walker.count("±") == 3 and cartpole.count("±") == 2 and cartpole.endswith("| — |")
  lines = path.read_text().splitlines()
  assert lines[0].split(",") == list(ab.CSV_FIELDS) and len(lines) == 1 + 2 * (3 + 2)


@pytest.mark.parametrize("args", [["--task", "nope-x"], ["--factors", "a"], ["--seeds", "0"],
                                  ["--csv", "/nonexistent/x.csv"]])
def test_cli_refuses_bad_arguments(args):
  err = io.StringIO()
  assert ab.main(["--xml-dir", str(SUITE_DIR)] + args, out=io.StringIO(), err=err) == 2
  assert err.getvalue().startswith("ostrich.suite.ab: ")
