"""Indexing arrays by object name, as dm_control's `physics.named.data.qpos['slider']`.

An array's rows belong to objects of one kind, known from the name of its row count in MuJoCo's
mjxmacro.h tables (nbody: bodies, nq: joints by their qpos addresses, nv: joints by their dof
addresses, nsensordata: sensors by sensor_adr and sensor_dim, ...). A name selects its object's
rows: one row (an integer index) for objects of width 1, a slice for wider ones (a free joint's 7
qpos or 6 dofs, a ball joint's 4 or 3, a sensor's dim). A list of names selects the
concatenation of their rows; integers, slices and arrays index as in NumPy.
"""

import numpy as np

# row count -> (object kind, how its rows are addressed)
_ROW_KINDS = {
    "nbody": "body", "njnt": "joint", "ngeom": "geom", "nsite": "site", "ncam": "camera",
    "nlight": "light", "nmesh": "mesh", "nhfield": "hfield", "nmat": "material",
    "neq": "equality", "ntendon": "tendon", "nu": "actuator", "nsensor": "sensor",
    "nkey": "key", "nq": "joint", "nv": "joint", "nsensordata": "sensor", "nmocap": "body",
    "na": "actuator",
}

_FREE, _BALL = 0, 1  # mjtJoint


class Axis:
  """The map from names to row indices of arrays whose row count is `rowdim`."""

  def __init__(self, physics, rowdim):
    self.rowdim = rowdim
    self.kind = _ROW_KINDS.get(rowdim)
    self._rows = {}  # name -> int or slice
    if self.kind is None:
      return
    names = physics.names(self.kind)
    model = physics.model
    if rowdim in ("nq", "nv"):
      adr = model.jnt_qposadr if rowdim == "nq" else model.jnt_dofadr
      width = {_FREE: 7, _BALL: 4} if rowdim == "nq" else {_FREE: 6, _BALL: 3}
      for j, name in enumerate(names):
        w = width.get(int(model.jnt_type[j]), 1)
        self._add(name, int(adr[j]), w)
    elif rowdim == "nsensordata":
      for i, name in enumerate(names):
        self._add(name, int(model.sensor_adr[i]), int(model.sensor_dim[i]))
    elif rowdim == "nmocap":
      for b, name in enumerate(names):
        if model.body_mocapid[b] >= 0:
          self._add(name, int(model.body_mocapid[b]), 1)
    elif rowdim == "na":
      # MuJoCo 2.2.2: the actuators with activation dynamics come last, in order
      nu, na = len(names), physics.size("na")
      for i, name in enumerate(names[nu - na:]):
        self._add(name, i, 1)
    else:
      for i, name in enumerate(names):
        self._add(name, i, 1)

  def _add(self, name, adr, width):
    if name:
      self._rows[name] = adr if width == 1 else slice(adr, adr + width)

  def names(self):
    """The names this axis knows, in row order."""
    return list(self._rows)

  def index(self, key):
    """The NumPy index of a name, a list of names, or anything NumPy takes."""
    if isinstance(key, str):
      return self._lookup(key)
    if isinstance(key, (list, tuple)) and key and all(isinstance(k, str) for k in key):
      rows = []
      for k in key:
        r = self._lookup(k)
        rows.extend(range(r.start, r.stop) if isinstance(r, slice) else [r])
      return np.array(rows, dtype=np.intp)
    return key

  def _lookup(self, name):
    try:
      return self._rows[name]
    except KeyError:
      if self.kind is None:
        raise KeyError(f"rows of this array ({self.rowdim}) have no names: index them by "
                       "integer") from None
      known = ", ".join(repr(n) for n in list(self._rows)[:20]) or "none (all unnamed)"
      raise KeyError(f"no {self.kind} named {name!r}; the model's named {self.kind}s: "
                     f"{known}") from None


class NamedArray:
  """A NumPy array (zero-copy view) indexed along its rows by object name."""

  def __init__(self, array, axis, name):
    self._array = array
    self._axis = axis
    self._name = name

  def __getitem__(self, key):
    if isinstance(key, tuple) and key and not all(isinstance(k, str) for k in key):
      return self._array[(self._axis.index(key[0]),) + key[1:]]
    return self._array[self._axis.index(key)]

  def __setitem__(self, key, value):
    if isinstance(key, tuple) and key and not all(isinstance(k, str) for k in key):
      self._array[(self._axis.index(key[0]),) + key[1:]] = value
    else:
      self._array[self._axis.index(key)] = value

  def __array__(self, dtype=None):
    return self._array if dtype is None else self._array.astype(dtype)

  def __len__(self):
    return len(self._array)

  @property
  def array(self):
    """The underlying view."""
    return self._array

  @property
  def names(self):
    """The row names."""
    return self._axis.names()

  def __repr__(self):
    return f"NamedArray({self._name}, {self._axis.kind or self._axis.rowdim}, {self._array!r})"


class NamedStruct:
  """physics.named.data / physics.named.model: each array as a NamedArray."""

  def __init__(self, struct):
    self._struct = struct

  def __getattr__(self, name):
    if name.startswith("_"):
      raise AttributeError(name)
    array, rowdim = self._struct._view(name)
    return NamedArray(array, self._struct._physics._axis(rowdim), name)

  def __dir__(self):
    return self._struct.__dir__()


class Named:
  """physics.named: .data and .model."""

  def __init__(self, physics):
    self.data = NamedStruct(physics.data)
    self.model = NamedStruct(physics.model)
