#!/usr/bin/env python3
"""mujoco3_models.py: the MuJoCo 3 rows of `ostrich compare models --mujoco3`.

Runs the jobs that `ostrich compare models` wrote (one per model and control mode: the model
file, the start keyframe, the model's MuJoCo 2.2.2 timestep h0, the duration, the h-scales, the
reference trajectory and the controls) with the PyPI `mujoco` package (3.x), integrator
implicitfast and, where the package has it (MuJoCo >= 3.13), discrete. Writes rows in the CSV
columns of `compare models` (engine mujoco3-implicitfast, mujoco3-discrete).

The reference is the one `compare models` ran: stock MuJoCo 2.2.2 at h0 / 4 on the same
controls, read from the job's file, so every engine's error is against the same trajectory. The
error is compare_run.c's metric (cmp_trajectoryError), restated here: samples every 10 ms over
the common time span, linear interpolation; for a model whose first joint is free the base
position and yaw (sqrt(<|dp|^2> + (0.5 m RMS(dyaw))^2), yaw wrapped), else the RMS of |dqpos|.

The step size is h0 x scale; MuJoCo 3 compiles the model itself, so its own opt.timestep is
ignored like MuJoCo 2.2.2's. Exit status: 0 done, 2 bad usage, 3 the mujoco package (3.x) cannot
be imported.

usage: python3 compare/mujoco3_models.py --jobs JOBS.csv --out ROWS.csv
"""

import argparse
import csv
import math
import sys
import time

HEADER = ("model,engine,ctrl,h_scale,h,status,steps,simulated_s,converged_pct,"
          "unconverged_steps,failed_steps,max_penetration,wall_per_sim_s,error,reason").split(",")
SAMPLE_DT = 0.01      # CMP_SAMPLE_DT
YAW_LENGTH = 0.5      # CMP_YAW_LENGTH (m)
MAX_QVEL = 1e6        # MODELS_MAX_QVEL: |qvel| above which a run diverged


def wrap(a):
    """An angle wrapped to (-pi, pi], as cmp_wrapAngle."""
    w = math.fmod(a + math.pi, 2 * math.pi)
    if w <= 0:
        w += 2 * math.pi
    return w - math.pi


def yaw(q):
    """Yaw of a unit quaternion (w, x, y, z), as cmp_yaw."""
    return math.atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] * q[2] + q[3] * q[3]))


class Trajectory:
    """Samples (time, coordinates); a pose's yaw (index 3) kept continuous, as cmp_appendSample."""

    def __init__(self, pose):
        self.pose = pose
        self.time = []
        self.coord = []

    def append(self, t, c):
        c = list(c)
        if self.pose and self.coord:
            prev = self.coord[-1][3]
            c[3] = prev + wrap(c[3] - prev)
        self.time.append(t)
        self.coord.append(c)

    def at(self, t):
        """Coordinates at t, linearly interpolated and clamped, as cmp_sampleAt."""
        lo, hi = 0, len(self.time) - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if self.time[mid] <= t:
                lo = mid
            else:
                hi = mid
        span = self.time[hi] - self.time[lo]
        s = (t - self.time[lo]) / span if span > 0 else 0.0
        s = min(max(s, 0.0), 1.0)
        a, b = self.coord[lo], self.coord[hi]
        return [x + s * (y - x) for x, y in zip(a, b)]


def error(a, ref):
    """cmp_trajectoryError(a, ref, 10 ms)."""
    if not a.time or not ref.time or a.pose != ref.pose:
        return float("nan")
    t0 = max(a.time[0], ref.time[0])
    t1 = min(a.time[-1], ref.time[-1])
    if t1 < t0:
        return float("nan")
    n = int(math.floor((t1 - t0) / SAMPLE_DT + 1e-9)) + 1
    npos = 3 if a.pose else len(a.coord[0])
    sum_pos = sum_yaw = 0.0
    for k in range(n):
        t = t0 + k * SAMPLE_DT
        ca, cr = a.at(t), ref.at(t)
        sum_pos += sum((ca[j] - cr[j]) ** 2 for j in range(npos))
        if a.pose:
            sum_yaw += wrap(ca[3] - cr[3]) ** 2
    return math.sqrt(sum_pos / n + YAW_LENGTH ** 2 * sum_yaw / n)


def read_reference(path):
    """A trajectory written by cmp_writeTrajectory: time,x,y,z,yaw or time,qpos_0,..."""
    with open(path) as f:
        rows = list(csv.reader(f))
    tr = Trajectory(rows[0][1:] == ["x", "y", "z", "yaw"])
    for r in rows[1:]:
        tr.append(float(r[0]), [float(x) for x in r[1:]])
    return tr


def read_controls(path):
    """Zero-order-hold commands written by cmp_writeCommands: (times, rows)."""
    with open(path) as f:
        rows = list(csv.reader(f))[1:]
    return [float(r[0]) for r in rows], [[float(x) for x in r[1:]] for r in rows]


def control_at(times, ctrl, t):
    """The row in force at t (the last whose time is <= t, else the first), as cmp_commandAt."""
    lo, hi = 0, len(times) - 1
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if times[mid] <= t:
            lo = mid
        else:
            hi = mid - 1
    return ctrl[lo]


def state(d, pose):
    """The trajectory coordinates of d: base pose or qpos."""
    if pose:
        return [d.qpos[0], d.qpos[1], d.qpos[2], yaw(d.qpos[3:7])]
    return list(d.qpos)


def run(mujoco, m, job, integrator, scale, ref, times, ctrl):
    """One run; returns the row's fields (status, steps, simulated, penetration, wall, error,
    reason)."""
    h = float(job["h0"]) * scale
    m.opt.timestep = h
    m.opt.integrator = integrator
    d = mujoco.MjData(m)
    key = int(job["key"])
    if 0 <= key < m.nkey:
        mujoco.mj_resetDataKeyframe(m, d, key)
    tr = Trajectory(ref.pose)
    tr.append(d.time, state(d, ref.pose))
    nstep = int(math.floor(float(job["duration"]) / h + 0.5))
    bad = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
           mujoco.mjtWarning.mjWARN_BADQACC)
    status, reason, steps, wall, pen = "ok", "", 0, 0.0, 0.0
    for k in range(nstep):
        if m.nu:
            d.ctrl[:] = control_at(times, ctrl, d.time)
        start = time.perf_counter()
        mujoco.mj_step(m, d)
        wall += time.perf_counter() - start
        finite = all(math.isfinite(x) for x in d.qpos) and all(math.isfinite(x) for x in d.qvel)
        if not finite or any(d.warning[w].number for w in bad):
            status, reason = "diverged", "non-finite or diverged state after step %d" % (k + 1)
            break
        big = [i for i in range(m.nv) if abs(d.qvel[i]) > MAX_QVEL]
        if big:
            status = "diverged"
            reason = "|qvel[%d]| = %.3g > %g after step %d" % (big[0], abs(d.qvel[big[0]]),
                                                             MAX_QVEL, k + 1)
            break
        steps += 1
        if d.ncon:
            pen = max(pen, -min(d.contact.dist[:d.ncon]))
        tr.append(d.time, state(d, ref.pose))
    simulated = tr.time[-1]
    return (status, steps, simulated, max(pen, 0.0),
            wall / simulated if simulated > 0 else float("nan"), error(tr, ref), reason)


def number(x, fmt):
    return fmt % x if isinstance(x, (int, float)) and math.isfinite(x) else ""


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--jobs", required=True, help="jobs CSV written by `ostrich compare models`")
    p.add_argument("--out", required=True, help="rows CSV to write")
    a = p.parse_args()
    try:
        import mujoco
    except ImportError:
        print("mujoco3_models.py: the python package mujoco is not installed", file=sys.stderr)
        return 3
    if int(mujoco.__version__.split(".")[0]) < 3:
        print("mujoco3_models.py: mujoco %s is not 3.x" % mujoco.__version__, file=sys.stderr)
        return 3
    integrators = [("implicitfast", mujoco.mjtIntegrator.mjINT_IMPLICITFAST)]
    if hasattr(mujoco.mjtIntegrator, "mjINT_DISCRETE"):
        integrators.append(("discrete", mujoco.mjtIntegrator.mjINT_DISCRETE))

    with open(a.jobs) as f:
        jobs = list(csv.DictReader(f))
    with open(a.out, "w", newline="") as f:
        out = csv.writer(f, lineterminator="\n")
        out.writerow(HEADER)
        for job in jobs:
            engines = ["mujoco3-" + name for name, _ in integrators]
            try:
                m = mujoco.MjModel.from_xml_path(job["path"])
            except Exception as e:  # a model MuJoCo 3 rejects is a row, not a crash
                for engine in engines:
                    out.writerow([job["model"], engine, job["ctrl"]] + [""] * 2 + ["load_failed"] +
                                 [""] * 8 + [" ".join(str(e).split())])
                continue
            ref = read_reference(job["ref"])
            times, ctrl = read_controls(job["ctrl_file"])
            for (name, integrator), engine in zip(integrators, engines):
                for scale in [float(x) for x in job["h_scales"].split()]:
                    start = time.perf_counter()
                    status, steps, sim, pen, wps, err, reason = run(mujoco, m, job, integrator,
                                                                    scale, ref, times, ctrl)
                    if time.perf_counter() - start > 1:
                        print("mujoco3_models.py: %s %s %s h x%g: %.1f s" %
                              (job["model"], engine, job["ctrl"], scale,
                               time.perf_counter() - start), file=sys.stderr)
                    out.writerow([job["model"], engine, job["ctrl"], "%g" % scale,
                                  "%.10g" % (float(job["h0"]) * scale), status, steps,
                                  number(sim, "%.10g"), "", "", 0, number(pen, "%.6g"),
                                  number(wps, "%.6g"), number(err, "%.6g"), reason])
            f.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
