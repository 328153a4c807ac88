"""The flat C library (libostrich_python.so, plugin/python/ost_python.c) through ctypes.

The library sits beside this file, in the build tree (BUILD/python/ostrich) and in an install
alike; OSTRICH_PYTHON_LIB names another one. It links libostrich and libmujoco, so the public
functions of ostrich.h (ost_nparam, ost_paramAddress, ost_batch*) are reached through the same
handle. Only these declarations know C signatures; nothing here knows a MuJoCo struct layout.
"""

import ctypes
import os

import numpy as np

_here = os.path.dirname(os.path.abspath(__file__))
_path = os.environ.get("OSTRICH_PYTHON_LIB") or os.path.join(_here, "libostrich_python.so")
try:
  lib = ctypes.CDLL(_path)
except OSError as e:
  raise ImportError(
      f"ostrich: cannot load its C library {_path}: {e}. Build it (cmake --build BUILD) and "
      "import the package from BUILD/python, or install it (cmake --install BUILD)") from e

_p = ctypes.c_void_p
_i = ctypes.c_int
_s = ctypes.c_char_p
_d = ctypes.POINTER(ctypes.c_double)
_ip = ctypes.POINTER(ctypes.c_int)

_SIGNATURES = {
    # name: (restype, argtypes)
    "ostpy_init": (_i, []),
    "ostpy_takeWarning": (_s, []),
    "ostpy_load": (_p, [_s, _i, ctypes.c_char_p, _i]),
    "ostpy_free": (None, [_p]),
    "ostpy_model": (_p, [_p]),
    "ostpy_data": (_p, [_p]),
    "ostpy_error": (_s, [_p]),
    "ostpy_size": (_i, [_p, _s]),
    "ostpy_array": (_i, [_p, _i, _s, ctypes.POINTER(_p), _ip, _ip, _ip,
                         ctypes.POINTER(ctypes.c_char_p)]),
    "ostpy_arrayNames": (_s, [_i]),
    "ostpy_objType": (_i, [_s]),
    "ostpy_name": (_s, [_p, _i, _i]),
    "ostpy_fieldNames": (_s, [_i]),
    "ostpy_getOptions": (None, [_p, _d]),
    "ostpy_setOptions": (_i, [_p, _d]),
    "ostpy_stats": (_i, [_p, _i, _d]),
    "ostpy_step": (_i, [_p, _i, _i]),
    "ostpy_forward": (_i, [_p]),
    "ostpy_reset": (_i, [_p, _i]),
    "ostpy_tapeCreate": (_p, [_p, _i]),
    "ostpy_tapeFree": (None, [_p]),
    "ostpy_tapeError": (_s, [_p]),
    "ostpy_rollout": (_i, [_p, _p, _i, _d, _d, _d, _d, _ip]),
    "ostpy_backward": (_i, [_p, _p, _i, _i, _i, _d, _d, _d, _d, _d, _d]),
    "ostpy_mujocoRollout": (_i, [_p, _i, _i, _d, _d, _d, _d]),
    "ostpy_mujocoLinearRollout": (_i, [_p, _i, _i, _d, ctypes.c_double, _d, _d, _d, _d]),
    "ostpy_linearBackward": (_i, [_i, _i, _i, _d, _d, _d, _d, _d]),
    "ostpy_coordToTangent": (None, [_p, _i, _d, _d, _d]),
    "ostpy_tangentToCoord": (None, [_p, _i, _d, _d, _d]),
    # ostrich.h, through the same handle
    "ost_nparam": (_i, [_p]),
    "ost_paramAddress": (_i, [_p, _i]),
    "ost_lastError": (_s, [_p]),
    "ost_batchCreate": (_p, [_p, _i, _s, ctypes.c_char_p, _i]),
    "ost_batchDelete": (None, [_p]),
    "ost_batchWorlds": (_i, [_p]),
    "ost_batchSetState": (_i, [_p, _d, _d]),
    "ost_batchGetState": (_i, [_p, _d, _d]),
    "ost_batchSetCtrl": (_i, [_p, _d]),
    "ost_batchStep": (_i, [_p]),
    "ost_batchRollout": (_i, [_p, _i, _d, _d, _d]),
    "ost_batchRolloutAct": (_i, [_p, _i, _d, _d, _d, _d]),
    "ost_batchSetAct": (_i, [_p, _d]),
    "ost_batchGetAct": (_i, [_p, _d]),
    "ostpy_batchBackward": (_i, [_p, _i, _i, _d, _d, _d, _d, _d, _d]),
    "ost_batchKeepCheckpoints": (_i, [_p, _i]),
    "ost_batchStatus": (_i, [_p, _ip]),
    "ost_batchUnconverged": (_i, [_p, _ip]),
    "ost_batchError": (_s, [_p]),
}
for _name, (_res, _args) in _SIGNATURES.items():
  _f = getattr(lib, _name)
  _f.restype = _res
  _f.argtypes = _args

MUJOCO_VERSION = lib.ostpy_init()  # also installs MuJoCo's recording error handlers

# ostStatus (ostrich.h)
OK = 0
ERR_NOT_CONVERGED = 7
WARN_FIRST = 100
WARN_NOT_CONVERGED = 100

# ostStatusBit (ostrich.h)
NOT_CONVERGED_BIT = 1
STATUS_BITS = {1: "not converged", 2: "capacity overflow", 4: "non-finite value",
               8: "M + h D not positive definite", 16: "initial violation kept"}


def dptr(a):
  """Pointer to a C-contiguous float64 array (None for None)."""
  if a is None:
    return None
  assert a.dtype == np.float64 and a.flags.c_contiguous
  return a.ctypes.data_as(_d)


def iptr(a):
  """Pointer to a C-contiguous int32 array (None for None)."""
  if a is None:
    return None
  assert a.dtype == np.int32 and a.flags.c_contiguous
  return a.ctypes.data_as(_ip)


def text(b):
  """A C string from the library as str."""
  return b.decode("utf-8", "replace") if b else ""


def field_names(which):
  """ostpy_fieldNames(which) as a list: 0 options, 1 stats, 2 totals."""
  return [n for n in text(lib.ostpy_fieldNames(which)).split(",") if n]
