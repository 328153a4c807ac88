"""Physics: one MuJoCo model and its data, stepped by Ostrich or by MuJoCo.

Arrays are zero-copy NumPy views of mjModel and mjData (their pointers and shapes come from
MuJoCo's mjxmacro.h tables through the C library), so writing through a view writes the model or
the data itself. A view keeps its Physics' C memory alive.
"""

import ctypes
import warnings

import numpy as np

from . import _lib
from .errors import NotConvergedWarning, OstrichError, check, forward_mujoco_warnings
from .named import Axis, Named

_lib_ = _lib.lib
_DTYPES = {0: np.float64, 1: np.int32, 2: np.float32, 3: np.uint8, 4: np.uint8}
_ENGINES = {"ostrich": 0, "mujoco": 1}


class _Handle:
  """Owns the C physics (ostpyPhysics); freed when the last Physics or view lets go. Also owns
  the tapes no rollout uses any more (rollout.py's _Tape), kept for the next rollouts: a new
  tape makes its own mjData and, at its first backward pass, its own copy of the model."""

  def __init__(self, ptr):
    self.ptr = ptr
    self.spare_tapes = {}  # checkpoint -> [ostpyTape pointers]

  def __del__(self, free=_lib_.ostpy_free, free_tape=_lib_.ostpy_tapeFree):  # bound now: module
    for tapes in self.spare_tapes.values():                    # globals may be gone at exit
      for tape in tapes:
        free_tape(tape)  # before the model they point to
    self.spare_tapes = {}
    if self.ptr:
      free(self.ptr)
      self.ptr = None


class _Struct:
  """physics.data or physics.model: every array of mjxmacro.h's table as an attribute."""

  def __init__(self, physics, is_data):
    object.__setattr__(self, "_physics", physics)
    object.__setattr__(self, "_is_data", is_data)
    object.__setattr__(self, "_views", {})
    names = _lib.text(_lib_.ostpy_arrayNames(1 if is_data else 0)).split(",")
    object.__setattr__(self, "_names", [n for n in names if n])

  def _view(self, name):
    """(view, row-count name) of array `name`; AttributeError if there is none."""
    cached = self._views.get(name)
    if cached is not None:
      return cached
    ptr, rows, cols, kind = ctypes.c_void_p(), ctypes.c_int(), ctypes.c_int(), ctypes.c_int()
    rowdim = ctypes.c_char_p()
    if _lib_.ostpy_array(self._physics._handle.ptr, 1 if self._is_data else 0,
                         name.encode(), ctypes.byref(ptr), ctypes.byref(rows),
                         ctypes.byref(cols), ctypes.byref(kind), ctypes.byref(rowdim)):
      what = "mjData" if self._is_data else "mjModel"
      raise AttributeError(f"{what} has no array {name!r}")
    dtype = _DTYPES.get(kind.value)
    if dtype is None:
      raise AttributeError(f"{name!r} is an array of structs, not exposed")
    shape = (rows.value,) if cols.value == 1 else (rows.value, cols.value)
    n = rows.value * cols.value
    if n == 0 or not ptr.value:
      view = np.zeros(shape, dtype=dtype)
      view.flags.writeable = False
    else:
      buf = (ctypes.c_byte * (n * np.dtype(dtype).itemsize)).from_address(ptr.value)
      buf._owner = self._physics._handle  # the view keeps the C memory alive
      view = np.frombuffer(buf, dtype=dtype).reshape(shape)
    entry = (view, _lib.text(rowdim.value))
    self._views[name] = entry
    return entry

  def __getattr__(self, name):
    if name == "time":
      return float(self._view("time")[0][0])
    if name == "ncon" and self._is_data:  # contacts found by MuJoCo's collision (read only)
      return int(self._view("ncon")[0][0])
    if name == "timestep":  # model.opt.timestep
      return float(self._view("opt.timestep")[0][0])
    if name == "gravity":
      return self._view("opt.gravity")[0][0]
    return self._view(name)[0]

  def __setattr__(self, name, value):
    if name == "time":
      self._view("time")[0][0] = value
    elif name == "ncon" and self._is_data:
      raise AttributeError("data.ncon is read only")
    elif name == "timestep":
      self._view("opt.timestep")[0][0] = value
    else:
      view = self._view(name if name != "gravity" else "opt.gravity")[0]
      view[...] = np.reshape(value, view.shape) if name == "gravity" else value

  def __dir__(self):
    extra = ["time"] if self._is_data else ["timestep", "gravity"]
    return self._names + extra


class Physics:
  """A MuJoCo 2.2.2 model and its data; step(engine='ostrich' | 'mujoco').

  physics.data.qpos, physics.model.body_mass, ...: zero-copy views. physics.named.data.qpos
  ['slider']: the same by name. physics.step() advances one step with Ostrich (default) or
  MuJoCo; errors raise OstrichError with Ostrich's or MuJoCo's message, a step that did not
  converge warns (NotConvergedWarning) and clears physics.converged.
  """

  def __init__(self, handle):
    self._handle = handle
    self._axes = {}
    self.model = _Struct(self, False)
    self.data = _Struct(self, True)
    self.named = Named(self)
    self.status = _lib.OK          # status of the last step() call
    self.converged = True          # whether the last step() converged (Ostrich)
    self._option_names = _lib.field_names(0)

  @classmethod
  def from_xml_path(cls, path):
    """Load an MJCF file; OstrichError with MuJoCo's message if it does not load."""
    return cls._load(str(path), 0)

  @classmethod
  def from_xml_string(cls, xml):
    """Load MJCF text (assets by path relative to the current directory)."""
    return cls._load(xml, 1)

  @classmethod
  def _load(cls, src, is_string):
    err = ctypes.create_string_buffer(1024)
    ptr = _lib_.ostpy_load(src.encode(), is_string, err, len(err))
    forward_mujoco_warnings(stacklevel=4)
    if not ptr:
      raise OstrichError(f"cannot load the model: {_lib.text(err.value)}", 1)
    return cls(_Handle(ptr))

  # ---- names and sizes

  def size(self, name):
    """An mjModel size: 'nq', 'nv', 'nu', 'nbody', ... (KeyError if unknown)."""
    n = _lib_.ostpy_size(self._handle.ptr, name.encode())
    if n < 0:
      raise KeyError(f"mjModel has no size {name!r}")
    return n

  @property
  def nq(self):
    return self.size("nq")

  @property
  def nv(self):
    return self.size("nv")

  @property
  def nu(self):
    return self.size("nu")

  @property
  def na(self):
    return self.size("na")

  def names(self, kind):
    """Names of every object of a kind ('body', 'joint', 'geom', 'site', 'actuator', 'sensor',
    'tendon', 'camera', 'key', ...), in id order; '' for an unnamed one."""
    objtype = _lib_.ostpy_objType(kind.encode())
    if objtype < 0:
      raise KeyError(f"no object kind {kind!r}")
    count = {"body": "nbody", "joint": "njnt", "dof": "nv", "geom": "ngeom", "site": "nsite",
             "camera": "ncam", "light": "nlight", "mesh": "nmesh", "hfield": "nhfield",
             "material": "nmat", "equality": "neq", "tendon": "ntendon", "actuator": "nu",
             "sensor": "nsensor", "numeric": "nnumeric", "key": "nkey"}[kind]
    return [_lib.text(_lib_.ostpy_name(self._handle.ptr, objtype, i))
            for i in range(self.size(count))]

  def id(self, kind, name):
    """Id of the object of `kind` named `name`; KeyError if there is none."""
    names = self.names(kind)
    if name not in names:
      raise KeyError(f"no {kind} named {name!r}")
    return names.index(name)

  def _axis(self, rowdim):
    axis = self._axes.get(rowdim)
    if axis is None:
      axis = self._axes[rowdim] = Axis(self, rowdim)
    return axis

  # ---- stepping

  def step(self, nstep=1, engine="ostrich"):
    """Advance nstep steps with Ostrich (ost_step) or MuJoCo (mj_step); return the status.

    0: every step converged; 100 (OST_WARN_NOT_CONVERGED): the state advanced but a step's
    residual stayed above tol (a NotConvergedWarning is raised and physics.converged is False);
    an error raises OstrichError and leaves the state of the failed step as it was.
    """
    if engine not in _ENGINES:
      raise ValueError(f"engine {engine!r}: use 'ostrich' or 'mujoco'")
    status = _lib_.ostpy_step(self._handle.ptr, _ENGINES[engine], int(nstep))
    forward_mujoco_warnings()
    self.status = status
    self.converged = status == _lib.OK
    check(status, _lib.text(_lib_.ostpy_error(self._handle.ptr)), "step failed")
    if status >= _lib.WARN_FIRST:
      residual = self.stats.get("residual", float("nan"))
      warnings.warn(NotConvergedWarning(
          f"t = {self.data.time:.6g} s: step not converged (residual {residual:.3g} m/s above "
          f"tol {self.options['tol']:.3g}); the state advanced"), stacklevel=2)
    return status

  def forward(self):
    """mj_forward: positions, velocities and forces of the current state."""
    check(_lib_.ostpy_forward(self._handle.ptr), _lib.text(_lib_.ostpy_error(self._handle.ptr)))

  def reset(self, key=None):
    """Reset to qpos0 at rest, or to keyframe `key` (index or name), then mj_forward."""
    if isinstance(key, str):
      key = self.id("key", key)
    status = _lib_.ostpy_reset(self._handle.ptr, -1 if key is None else int(key))
    check(status, _lib.text(_lib_.ostpy_error(self._handle.ptr)), "reset")

  # ---- options and statistics

  @property
  def options(self):
    """Ostrich's options of this data (ostOptions fields) as a dict; set with set_options."""
    out = np.zeros(len(self._option_names))
    _lib_.ostpy_getOptions(self._handle.ptr, _lib.dptr(out))
    ints = {"newton_iter", "pcr_iter", "k_min", "linesearch", "warmstart", "split_depth",
            "deep_splits", "geometry"}
    return {n: int(v) if n in ints else float(v) for n, v in zip(self._option_names, out)}

  def set_options(self, **options):
    """Change Ostrich's options for the following steps, e.g. set_options(newton_iter=8);
    geometry takes "mujoco" or "native" (or ostOptions' number, 0 or 1)."""
    current = self.options
    for name, value in options.items():
      if name not in current:
        raise KeyError(f"no Ostrich option {name!r}; options: {', '.join(current)}")
      if name == "geometry" and isinstance(value, str):
        providers = {"mujoco": 0, "native": 1}  # OST_GEOMETRY_MUJOCO, OST_GEOMETRY_NATIVE
        if value not in providers:
          raise ValueError(f"geometry: {value!r}, expected 'mujoco' or 'native'")
        value = providers[value]
      current[name] = value
    values = np.array([float(current[n]) for n in self._option_names])
    status = _lib_.ostpy_setOptions(self._handle.ptr, _lib.dptr(values))
    check(status, _lib.text(_lib_.ostpy_error(self._handle.ptr)), "set_options")

  def _fields(self, which):
    names = _lib.field_names(which)
    out = np.zeros(len(names))
    if _lib_.ostpy_stats(self._handle.ptr, which, _lib.dptr(out)):
      return {}
    return {n: (float(v) if n.startswith(("residual", "max_", "initial", "worst")) else int(v))
            for n, v in zip(names, out)}

  @property
  def stats(self):
    """The last Ostrich step's ostStats as a dict ({} before the first Ostrich step)."""
    return self._fields(1)

  @property
  def totals(self):
    """ostTotals since the first Ostrich step as a dict ({} before it)."""
    return self._fields(2)

  @property
  def timestep(self):
    """The step size Ostrich takes: ostrich/timestep if set, else opt.timestep."""
    h = self.options["timestep"]
    return h if h > 0 else self.model.timestep

  def _model_ptr(self):
    return _lib_.ostpy_model(self._handle.ptr)
