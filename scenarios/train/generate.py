#!/usr/bin/env python3
"""Writes the training scenes of nomen-cnn (`nomen train cnn`) in this folder.

Disjoint from the evaluation scenes of `nomen experiment imu-table` (scenarios/imu_*.toml):
- clips: no walk_02_01, walk_131_01, walk_131_02 (nor any other clip of CMU subjects 2 and 131:
  no run_02_03, no hop_131_03); the training motion is walk_veer_16_11 (CMU subject 16),
  jumps_01_01 (subject 1), wave_141_16 (subject 141) and the salsa pairs (subjects 60, 61);
- people: subject names t1..tN, never the evaluation's ana, ben, ...;
- seeds: the training scenes are simulated with seeds 101 and up (the table uses 1).
Every person wears a full body-area network so every site is trained. One camera, so camera
track ids are unambiguous for labelling. Run: `python3 scenarios/train/generate.py`.
"""
import os

HERE = os.path.dirname(os.path.abspath(__file__))
HEAD = """[room]
size_m = [8.0, 6.0, 3.0]

[[cameras]]
id = "kinect_front"
position_m = [4.0, 0.2, 1.6]
look_at_m = [4.0, 3.5, 1.0]
"""
BAN = ["left_wrist", "right_wrist", "left_ankle", "right_ankle", "pelvis"]


def loop_path(i, laps=14):
    cx, cy = 4.0, 2.9
    hx = 0.8 + 0.3 * (i % 4)
    hy = 0.55 + 0.25 * ((i // 2) % 3)
    c = [(cx - hx, cy - hy), (cx + hx, cy - hy), (cx + hx, cy + hy), (cx - hx, cy + hy)]
    if i % 2:
        c.reverse()
    c = c[i % 4:] + c[:i % 4]
    pts = c * laps + [c[0]]
    return "[" + ", ".join(f"[{x:.2f}, {y:.2f}]" for x, y in pts) + "]"


def person(i, motion):
    wears = ", ".join(f'{{ device = "t{i}_{s}", kind = "imu", site = "{s}" }}' for s in BAN)
    return f'[[people]]\nid = "q{i}"\nsubject = "t{i}"\nmotion = {{ {motion} }}\nwears = [{wears}]\n'


def write(name, description, people):
    text = f'name = "{name}"\ndescription = "{description}"\nduration_s = 60.0\nseed = 101\n\n{HEAD}'
    text += "".join("\n" + p for p in people)
    with open(os.path.join(HERE, f"{name}.toml"), "w") as f:
        f.write(text)


# Six people on one veering walk at different phases, some mirrored, different statures.
write("train_veer_6", "nomen-cnn training: 6 people walking loops on one clip (walk_veer_16_11) at different phases, some mirrored; full body-area networks.",
      [person(i + 1, f'clip = "walk_veer_16_11", path = {loop_path(i)}, phase_s = {0.43 * i:.2f}'
              + (", mirror = true" if i % 3 == 2 else "") + f", height_m = {1.60 + 0.05 * i:.2f}")
       for i in range(6)])
# Walkers among people moving in place (jumps, waving).
mixed = [person(1, f'clip = "walk_veer_16_11", path = {loop_path(0)}, phase_s = 0.00'),
         person(2, f'clip = "walk_veer_16_11", path = {loop_path(1)}, phase_s = 0.61, mirror = true'),
         person(3, 'clip = "wave_141_16", position = [2.6, 4.6], heading_rad = -1.6'),
         person(4, 'clip = "wave_141_16", position = [5.4, 4.6], heading_rad = -1.5, phase_s = 1.3, mirror = true'),
         person(5, 'clip = "jumps_01_01", position = [4.0, 4.9], heading_rad = -1.57')]
write("train_mixed_5", "nomen-cnn training: 2 walkers (walk_veer_16_11) among people waving and jumping in place; full body-area networks.", mixed)
# Two salsa couples (each pair keeps its shared frame and clock).
salsa = [person(1, 'clip = "salsa_a_60_01", clip_frame = { offset_m = [2.8, 3.2], yaw_rad = 0.0 }'),
         person(2, 'clip = "salsa_b_61_01", clip_frame = { offset_m = [2.8, 3.2], yaw_rad = 0.0 }'),
         person(3, 'clip = "salsa_a_60_10", clip_frame = { offset_m = [5.2, 3.2], yaw_rad = 0.0 }'),
         person(4, 'clip = "salsa_b_61_10", clip_frame = { offset_m = [5.2, 3.2], yaw_rad = 0.0 }')]
write("train_salsa_4", "nomen-cnn training: two salsa couples, each in its take's shared frame; full body-area networks.", salsa)
