#!/usr/bin/env python3
"""Writes tests/data/mocap/arm_swing.bvh (the armpit / pinch-point scene character_shirt.json).

The skeleton is the CMU one of 01_01.bvh (its HIERARCHY section copied unchanged: T-pose rest, arms along
+-x). The motion is synthetic: the body stands still; both arms start raised sideways (40 degrees below horizontal,
the pose the shirt is fitted to, so it is wide), swing down to 80 degrees below horizontal (against the
sides of the torso, catching the shirt between arm and torso: the armpit pinch) in 0.25 s while the forearms
bend 30 degrees, hold 0.3 s, rise back to 40 degrees in 0.7 s, three times. 120 frames per second.

    python3 scenes/tools/make_arm_swing_bvh.py   (from the repository root)
"""
import math
import re

SRC = "tests/data/mocap/01_01.bvh"
DST = "tests/data/mocap/arm_swing.bvh"
FPS = 120

text = open(SRC).read()
hierarchy = text[: text.index("MOTION")]
joints = []  # (name, channel count) in file order
name = None
for line in hierarchy.splitlines():
    m = re.match(r"\s*(ROOT|JOINT)\s+(\S+)", line)
    if m:
        name = m.group(2)
    m = re.match(r"\s*CHANNELS\s+(\d+)", line)
    if m:
        joints.append((name, int(m.group(1))))


def smooth(s):
    s = min(max(s, 0.0), 1.0)
    return s * s * (3 - 2 * s)


def arm_angle(t):
    """Degrees below horizontal and forearm bend at time t (s)."""
    up, down = 40.0, 80.0
    hold0 = 0.25  # s at the start: the shirt settles
    cycle = 0.25 + 0.3 + 0.7
    if t < hold0:
        return up, 0.0
    k = int((t - hold0) // cycle)
    if k >= 3:
        return up, 0.0
    u = t - hold0 - k * cycle
    if u < 0.25:
        s = smooth(u / 0.25)
        return up + (down - up) * s, 30.0 * math.sin(math.pi * s)
    if u < 0.55:
        return down, 0.0
    return down + (up - down) * smooth((u - 0.55) / 0.7), 0.0


duration = 0.25 + 3 * 1.25 + 0.25
frames = int(duration * FPS) + 1
rows = []
for f in range(frames):
    a, bend = arm_angle(f / FPS)
    values = []
    for jname, n in joints:
        v = [0.0] * n
        # Channel order: [Xpos Ypos Zpos] Zrot Yrot Xrot.
        if jname == "Hips":
            v[1] = 17.0
        elif jname == "LeftArm":
            v[0] = -a
        elif jname == "RightArm":
            v[0] = a
        elif jname == "LeftForeArm":
            v[1] = bend
        elif jname == "RightForeArm":
            v[1] = -bend
        values += v
    rows.append(" ".join("%.5f" % x for x in values))
with open(DST, "w") as out:
    out.write(hierarchy)
    out.write("MOTION\nFrames: %d\nFrame Time: %.8f\n" % (frames, 1.0 / FPS))
    out.write("\n".join(rows) + "\n")
print("wrote", DST, frames, "frames")
