#!/usr/bin/env python3
"""gen_terrain.py: writes the sum-of-sinusoids terrain used by the terrain scenes.

Outputs (in mjcf_models/ unless another folder is given as the first argument):
  terrain_sinusoid.bin  MuJoCo height field, custom binary format: int32 nrow, int32 ncol, then
                        nrow*ncol float32 elevations in [0, 1], row-major, row r at
                        y = -12 + 24 r / (nrow-1), column c at x = -12 + 24 c / (ncol-1).
  terrain_sinusoid.obj  the same surface as a triangle mesh (OBJ, shared vertices), triangulated
                        exactly as MuJoCo 2.2.2's height-field collision splits each cell:
                        cell (r, c) -> {(r+1,c), (r,c), (r+1,c+1)} and {(r,c), (r,c+1), (r+1,c+1)}
                        (both counter-clockwise seen from +z), vertex z = hmin + data * (hmax-hmin)
                        computed from the float32 data, so both files describe one surface.
It also prints the hfield size and geom z that the XML files use (hmin, hmax - hmin).
Terrain: h(x, y) = w(r) * sum_k a_k sin(kx_k x + ky_k y + phi_k), wavelengths 3.5-7 m, peak about
0.12 m, and w(r) a smoothstep that is 0 within 1.2 m of the origin (the robot starts on a flat
patch at z = 0) and 1 beyond 3.7 m. Python 3 standard library only.
"""
import math
import os
import struct
import sys

NROW = NCOL = 80        # samples per side: 79 x 79 cells, 12,482 triangles
HALF = 12.0             # half extent (m): 24 x 24 m
BASE = 0.5              # hfield base depth below the lowest sample (m), hfield size[3]
# (amplitude m, wavelength m, direction angle rad, phase rad)
WAVES = [(0.050, 7.0, 0.00, 0.3), (0.040, 5.0, 1.57, 1.1),
         (0.030, 3.5, 0.79, 2.0), (0.025, 4.3, 2.40, 0.7)]
R0, R1 = 1.2, 3.7       # flat disc radius and end of the blend (m)


def height(x, y):
  s = 0.0
  for a, lam, ang, phi in WAVES:
    k = 2 * math.pi / lam
    s += a * math.sin(k * (math.cos(ang) * x + math.sin(ang) * y) + phi)
  t = min(max((math.hypot(x, y) - R0) / (R1 - R0), 0.0), 1.0)
  return s * t * t * (3 - 2 * t)


def f32(v):
  return struct.unpack('<f', struct.pack('<f', v))[0]


def main():
  out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
      os.path.dirname(os.path.abspath(__file__)), '..', 'mjcf_models')
  h = [[height(-HALF + 2 * HALF * c / (NCOL - 1), -HALF + 2 * HALF * r / (NROW - 1))
        for c in range(NCOL)] for r in range(NROW)]
  hmin = min(min(row) for row in h)
  hmax = max(max(row) for row in h)
  # round the scale so that the XML carries it exactly
  hmin = float('%.6f' % hmin)
  span = float('%.6f' % (hmax - hmin))
  data = [[min(max(f32((v - hmin) / span), 0.0), 1.0) for v in row] for row in h]

  with open(os.path.join(out, 'terrain_sinusoid.bin'), 'wb') as f:
    f.write(struct.pack('<ii', NROW, NCOL))
    for row in data:
      f.write(struct.pack('<%df' % NCOL, *row))

  with open(os.path.join(out, 'terrain_sinusoid.obj'), 'w') as f:
    f.write('# gen_terrain.py: %dx%d sum-of-sinusoids terrain, hfield triangulation\n'
            % (NROW, NCOL))
    for r in range(NROW):
      for c in range(NCOL):
        x = -HALF + 2 * HALF * c / (NCOL - 1)
        y = -HALF + 2 * HALF * r / (NROW - 1)
        f.write('v %.9g %.9g %.9g\n' % (x, y, hmin + data[r][c] * span))
    for r in range(NROW - 1):
      for c in range(NCOL - 1):
        v00 = r * NCOL + c + 1          # OBJ indices are 1-based
        v01 = v00 + 1
        v10 = v00 + NCOL
        v11 = v10 + 1
        f.write('f %d %d %d\n' % (v10, v00, v11))
        f.write('f %d %d %d\n' % (v00, v01, v11))
  print('hfield size="%g %g %r %g", geom pos z=%r, %d triangles'
        % (HALF, HALF, span, BASE, hmin, 2 * (NROW - 1) * (NCOL - 1)))


if __name__ == '__main__':
  main()
