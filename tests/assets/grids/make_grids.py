"""Writes the small OpenVDB test grids the tests read, with Debian's python3-openvdb
(OpenVDB 10; run with /usr/bin/python3 from the repository root):
  smoke.vdb     a 24^3 FloatGrid "density": a soft ball of smoke, 1 at its centre, 0 outside
  constant.vdb  a 16^3 FloatGrid "density" of 1 everywhere (the homogeneous case)
  vector.vdb    a Vec3SGrid "velocity" (a grid type the loader must refuse)"""
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

constant = vdb.FloatGrid()
constant.name = "density"
acc = constant.getAccessor()
for i in range(16):
    for j in range(16):
        for k in range(16):
            acc.setValueOn((i, j, k), 1.0)
vdb.write("tests/assets/grids/constant.vdb", grids=[constant])

vector = vdb.Vec3SGrid()
vector.name = "velocity"
vector.getAccessor().setValueOn((0, 0, 0), (1.0, 0.0, 0.0))
vdb.write("tests/assets/grids/vector.vdb", grids=[vector])
