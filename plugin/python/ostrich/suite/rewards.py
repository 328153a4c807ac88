"""dm_control's reward shaping, `tolerance` and its sigmoids, as dm_control.utils.rewards defines
them, written over an array module `xp` (NumPy by default; torch works too: every operation used
has the same name there) so that a reward built from them can be differentiated by an adapter.

tolerance(x, bounds, margin, sigmoid, value_at_margin) is 1 where lower <= x <= upper; outside,
with margin > 0, sigmoid(d, value_at_margin) of the distance d to the nearest bound divided by
margin, so that the value at one margin from the bound is value_at_margin; with margin == 0, 0.
"""

import math

import numpy as np

DEFAULT_VALUE_AT_MARGIN = 0.1
SIGMOIDS = ("gaussian", "hyperbolic", "long_tail", "reciprocal", "cosine", "linear",
            "quadratic", "tanh_squared")


def _where(xp, cond, a, b):
  """xp.where with array arguments (older torch takes no Python scalars there)."""
  if xp is np:
    return np.where(cond, a, b)
  ref = a if hasattr(a, "shape") else b
  if not hasattr(a, "shape"):
    a = xp.full_like(ref, a)
  if not hasattr(b, "shape"):
    b = xp.full_like(ref, b)
  return xp.where(cond, a, b)


def sigmoids(x, value_at_1, kind, xp=np):
  """dm_control's `_sigmoids`: a function of x >= 0 that is 1 at 0 and value_at_1 at 1.

  value_at_1 must lie in (0, 1), or in [0, 1) for 'linear', 'cosine' and 'quadratic'.
  """
  if kind in ("cosine", "linear", "quadratic"):
    if not 0 <= value_at_1 < 1:
      raise ValueError(f"value_at_1 must be nonnegative and smaller than 1, got {value_at_1}")
  elif not 0 < value_at_1 < 1:
    raise ValueError(f"value_at_1 must be strictly between 0 and 1, got {value_at_1}")
  if kind == "gaussian":
    scale = math.sqrt(-2 * math.log(value_at_1))
    return xp.exp(-0.5 * (x * scale) ** 2)
  if kind == "hyperbolic":
    scale = math.acosh(1 / value_at_1)
    return 1 / xp.cosh(x * scale)
  if kind == "long_tail":
    scale = math.sqrt(1 / value_at_1 - 1)
    return 1 / ((x * scale) ** 2 + 1)
  if kind == "reciprocal":
    scale = 1 / value_at_1 - 1
    return 1 / (xp.abs(x) * scale + 1)
  if kind == "cosine":
    scaled = x * (math.acos(2 * value_at_1 - 1) / math.pi)
    inside = xp.abs(scaled) < 1
    safe = _where(xp, inside, scaled, 0.0)  # cos of an infinite distance would be NaN
    return _where(xp, inside, (1 + xp.cos(math.pi * safe)) / 2, 0.0)
  if kind == "linear":
    scaled = x * (1 - value_at_1)
    return _where(xp, xp.abs(scaled) < 1, 1 - scaled, 0.0)
  if kind == "quadratic":
    scaled = x * math.sqrt(1 - value_at_1)
    return _where(xp, xp.abs(scaled) < 1, 1 - scaled ** 2, 0.0)
  if kind == "tanh_squared":
    scale = math.atanh(math.sqrt(1 - value_at_1))
    return 1 - xp.tanh(x * scale) ** 2
  raise ValueError(f"unknown sigmoid {kind!r}; one of {', '.join(SIGMOIDS)}")


def tolerance(x, bounds=(0.0, 0.0), margin=0.0, sigmoid="gaussian",
              value_at_margin=DEFAULT_VALUE_AT_MARGIN, xp=np):
  """dm_control's `rewards.tolerance`: 1 inside [lower, upper], in (0, 1) outside.

  bounds may be infinite at either end or equal; margin 0 gives 0 outside the bounds, margin > 0
  the sigmoid of the distance to the nearest bound in margins, value_at_margin at one margin.
  A Python or NumPy scalar gives a float, an array an array (of xp).
  """
  lower, upper = bounds
  if lower > upper:
    raise ValueError("lower bound must be <= upper bound")
  if margin < 0:
    raise ValueError("margin must be non-negative")
  scalar = np.isscalar(x)
  if scalar and xp is not np:
    xp = np
  if scalar:
    x = np.float64(x)
  in_bounds = xp.logical_and(lower <= x, x <= upper)
  if margin == 0:
    value = _where(xp, in_bounds, xp.ones_like(x), xp.zeros_like(x))
  else:
    d = _where(xp, x < lower, lower - x, x - upper) / margin
    value = _where(xp, in_bounds, xp.ones_like(d), sigmoids(d, value_at_margin, sigmoid, xp))
  return float(value) if scalar else value
