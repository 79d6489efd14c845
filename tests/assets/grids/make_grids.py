"""Writes the small OpenVDB test grids the tests read, with Debian's python3-openvdb
(OpenVDB 10; run with /usr/bin/python3 from the repository root):
  smoke.vdb     a 24^3 FloatGrid "density": a soft ball of smoke, 1 at its centre, 0 outside
  constant.vdb  a 16^3 FloatGrid "density" of 1 everywhere (the homogeneous case)
  vector.vdb    a Vec3SGrid "velocity" (a grid type the loader must refuse)
  affine.vdb    an 8^3 FloatGrid of 1 under a rotated AffineMap transform (vdb-rs cannot parse it)
  half.vdb      a row of 8 voxels of 0.5 saved as half floats (vdb-rs misreads them: refused)
  tiles.vdb     a 1024^3 box of 1 held as tiles (2^30 voxels once dense: refused)
  extremes.vdb  two voxels at x = -2^31 and 2^31 - 1 (a span past i32: refused)
  duplicate.vdb two grids both named "density" (OpenVDB writes them as "density\\x1e0" and
                "density\\x1e1"; the test renames the second to make a true repeat)"""
import math
import pyopenvdb as vdb

smoke = vdb.FloatGrid()
smoke.name = "density"
acc = smoke.getAccessor()
n = 24
for i in range(n):
    for j in range(n):
        for k in range(n):
            x, y, z = ((c + 0.5) / n * 2 - 1 for c in (i, j, k))
            r = math.sqrt(x * x + y * y + z * z)
            wisp = 0.5 + 0.5 * math.sin(7 * x) * math.sin(5 * y + 1) * math.sin(6 * z + 2)
            v = max(0.0, 1.0 - r) * wisp
            if v > 0:
                acc.setValueOn((i, j, k), v)
vdb.write("tests/assets/grids/smoke.vdb", grids=[smoke])



def cube(n, value):
    """A FloatGrid "density" whose n^3 voxels from the origin are all active at `value`."""
    grid = vdb.FloatGrid()
    grid.name = "density"
    acc = grid.getAccessor()
    for i in range(n):
        for j in range(n):
            for k in range(n):
                acc.setValueOn((i, j, k), value)
    return grid


constant = cube(16, 1.0)
vdb.write("tests/assets/grids/constant.vdb", grids=[constant])

vector = vdb.Vec3SGrid()
vector.name = "velocity"
vector.getAccessor().setValueOn((0, 0, 0), (1.0, 0.0, 0.0))
vdb.write("tests/assets/grids/vector.vdb", grids=[vector])

affine = cube(8, 1.0)
c, s = math.cos(0.3), math.sin(0.3)
affine.transform = vdb.createLinearTransform([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0.5, 0.25, 0, 1]])
vdb.write("tests/assets/grids/affine.vdb", grids=[affine])

half = vdb.FloatGrid()
half.name = "density"
acc = half.getAccessor()
for i in range(8):
    acc.setValueOn((i, 0, 0), 0.5)
half.saveFloatAsHalf = True
vdb.write("tests/assets/grids/half.vdb", grids=[half])

tiles = vdb.FloatGrid()
tiles.name = "density"
tiles.fill((0, 0, 0), (1023, 1023, 1023), 1.0)
vdb.write("tests/assets/grids/tiles.vdb", grids=[tiles])

extremes = vdb.FloatGrid()
extremes.name = "density"
acc = extremes.getAccessor()
acc.setValueOn((-2**31, 0, 0), 1.0)
acc.setValueOn((2**31 - 1, 0, 0), 1.0)
vdb.write("tests/assets/grids/extremes.vdb", grids=[extremes])

first, second = vdb.FloatGrid(), vdb.FloatGrid()
first.name = second.name = "density"
first.getAccessor().setValueOn((0, 0, 0), 1.0)
second.getAccessor().setValueOn((1, 0, 0), 1.0)
vdb.write("tests/assets/grids/duplicate.vdb", grids=[first, second])
