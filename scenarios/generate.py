#!/usr/bin/env python3
"""Writes the scenario library in this folder.

The TOML files are the source of truth and are committed; this script only documents how the
regular ones (N people with wrist IMUs or body-area networks) were laid out, and re-creates
them: `python3 scenarios/generate.py` from the project root. Field meanings: docs/scenarios.md.
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))

ROOM = "[room]\nsize_m = [8.0, 6.0, 3.0]\n"
CAM_FRONT = """[[cameras]]
id = "kinect_front"
position_m = [4.0, 0.2, 1.6]
look_at_m = [4.0, 3.5, 1.0]
"""
CAM_BACK = """[[cameras]]
id = "kinect_back"
position_m = [4.0, 5.8, 1.6]
look_at_m = [4.0, 2.5, 1.0]
"""
# Walking clips of different people, and the same clip reused at other phases (the hard case).
WALKS = ["walk_02_01", "walk_131_02", "walk_02_01", "walk_131_01",
         "walk_02_01", "walk_131_02", "walk_02_01", "walk_131_01"]
BAN = ["left_wrist", "right_wrist", "left_ankle", "right_ankle", "pelvis"]


def loop_path(i, n, laps=14):
    """A rectangle inside the front camera's view, different per person, alternating direction."""
    cx, cy = 4.0, 2.8
    hx = 0.9 + 0.35 * (i % 4)
    hy = 0.6 + 0.25 * ((i // 2) % 3)
    corners = [(cx - hx, cy - hy), (cx + hx, cy - hy), (cx + hx, cy + hy), (cx - hx, cy + hy)]
    if i % 2:
        corners.reverse()
    start = i % 4
    corners = corners[start:] + corners[:start]
    pts = (corners * laps) + [corners[0]]
    return "[" + ", ".join(f"[{x:.2f}, {y:.2f}]" for x, y in pts) + "]"


def person(i, clip, subject, wears, path, phase=0.0, mirror=False, height=None, extra=""):
    lines = [f'[[people]]\nid = "p{i + 1}"']
    if subject:
        lines.append(f'subject = "{subject}"')
    motion = f'clip = "{clip}", path = {path}, phase_s = {phase:.2f}'
    if mirror:
        motion += ", mirror = true"
    if height:
        motion += f", height_m = {height:.2f}"
    motion += extra
    lines.append(f"motion = {{ {motion} }}")
    if wears:
        items = ", ".join(f'{{ device = "{d}", kind = "{k}", site = "{s}" }}' for d, k, s in wears)
        lines.append(f"wears = [{items}]")
    return "\n".join(lines) + "\n"


NAMES = ["ana", "ben", "cleo", "dan", "eva", "finn", "gia", "hugo", "ines", "jon", "kai", "lea"]


def imu_scene(n, network, duration_s=60, laps=14, suffix=""):
    kind = "full body-area network (wrists, ankles, pelvis)" if network == "ban" else "one wrist IMU"
    out = [f'name = "imu_{network}_{n}{suffix}"',
           f'description = "{n} people walking loops under one camera{" (two for 8)" if n >= 8 else ""}, each with {kind}; several share a clip at different phases{"; " + str(duration_s) + " s" if suffix else ""}."',
           f"duration_s = {float(duration_s)}", "seed = 1", "", ROOM, CAM_FRONT]
    if n >= 8:
        out.append(CAM_BACK)
    for i in range(n):
        s = NAMES[i]
        sites = BAN if network == "ban" else ["left_wrist" if i % 2 == 0 else "right_wrist"]
        wears = [(f"{s}_{site}", "imu", site) for site in sites]
        out.append(person(i, WALKS[i], s, wears, loop_path(i, n, laps), phase=0.37 * i,
                          mirror=(i % 3 == 2)))
    return "\n".join(out)


def write(name, text):
    with open(os.path.join(HERE, name + ".toml"), "w") as f:
        f.write(text.rstrip() + "\n")


def main():
    for n in [2, 3, 4, 5, 8]:
        write(f"imu_wrist_{n}", imu_scene(n, "wrist"))
        write(f"imu_ban_{n}", imu_scene(n, "ban"))
    # The 8-person scenes three times as long: what the engine settles to once the clock
    # offsets had time to be found. 44 laps last the 180 s, except the first person's small
    # loop, which ends at 175 s (at 56 s in the 60-s scenes).
    for network in ["wrist", "ban"]:
        write(f"imu_{network}_8_long", imu_scene(8, network, 180, 44, "_long"))


if __name__ == "__main__":
    main()
