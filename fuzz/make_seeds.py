#!/usr/bin/env python3
"""Writes the seeds of the fuzz corpora: small generated BVH, ASF and AMC files and CSV
tables, plus copies of the repository's own samples (docs/adapters, the scenarios and
families, the CNN model's metadata). A target whose first byte chooses a mode gets its seed
with that byte in front.

Run from anywhere: python3 fuzz/make_seeds.py
"""
import glob
import os

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")


def write(target, name, text):
    d = os.path.join(ROOT, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "w", encoding="utf-8", newline="") as f:
        f.write(text)


# A cgspeed-named skeleton (the CMU BVH conversion's names), centimetres, Y up.
CHAINS = [
    ("Spine", [("Spine", (0, 10, 0)), ("Spine1", (0, 15, 0)), ("Neck1", (0, 20, 0)), ("Head", (0, 10, 0))]),
    ("LeftArm", [("LeftShoulder", (5, 18, 0)), ("LeftArm", (12, 0, 0)), ("LeftForeArm", (28, 0, 0)), ("LeftHand", (25, 0, 0)), ("LeftHandIndex1", (8, 0, 0))]),
    ("RightArm", [("RightShoulder", (-5, 18, 0)), ("RightArm", (-12, 0, 0)), ("RightForeArm", (-28, 0, 0)), ("RightHand", (-25, 0, 0)), ("RightHandIndex1", (-8, 0, 0))]),
    ("LeftLeg", [("LeftUpLeg", (9, -5, 0)), ("LeftLeg", (0, -42, 0)), ("LeftFoot", (0, -40, 0)), ("LeftToeBase", (0, -6, 12))]),
    ("RightLeg", [("RightUpLeg", (-9, -5, 0)), ("RightLeg", (0, -42, 0)), ("RightFoot", (0, -40, 0)), ("RightToeBase", (0, -6, 12))]),
]


def bvh(num_frames, frame_time_s):
    lines = ["HIERARCHY", "ROOT Hips", "{", "  OFFSET 0 0 0",
             "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    num_channels = 6
    for _, chain in CHAINS:
        depth = 1
        # The spine's chest is the arms' parent in a real file; a flat tree keeps this short.
        for name, off in chain:
            pad = "  " * depth
            lines += [f"{pad}JOINT {name}", f"{pad}{{", f"{pad}  OFFSET {off[0]} {off[1]} {off[2]}",
                      f"{pad}  CHANNELS 3 Zrotation Xrotation Yrotation"]
            num_channels += 3
            depth += 1
        pad = "  " * depth
        lines += [f"{pad}End Site", f"{pad}{{", f"{pad}  OFFSET 0 5 0", f"{pad}}}"]
        for d in range(depth - 1, 0, -1):
            lines.append("  " * d + "}")
    lines += ["}", "MOTION", f"Frames: {num_frames}", f"Frame Time: {frame_time_s}"]
    for k in range(num_frames):
        values = [0.0, 95.0, 2.0 * k] + [0.0] * (num_channels - 3)
        values[5] = 3.0 * k  # a little yaw
        lines.append(" ".join(f"{v:g}" for v in values))
    return "\n".join(lines) + "\n"


write("bvh", "two_frames.bvh", bvh(2, 0.0333333))
write("bvh", "three_frames_120hz.bvh", bvh(3, 0.00833333))
write("bvh", "arm_only.bvh", "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n  JOINT LeftArm\n  {\n    OFFSET 10 0 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 20 0 0\n    }\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.01\n0 90 0 0 0 0 10 0 0\n")

# CMU ASF bone names; lengths in CMU's units (0.45 in per unit is the `length` unit).
BONES = [
    ("lhipjoint", "root", (0.65, -0.71, 0.25), 2.5, ""), ("lfemur", "lhipjoint", (0.34, -0.94, 0), 7.6, "rx ry rz"),
    ("ltibia", "lfemur", (0.34, -0.94, 0), 7.3, "rx"), ("lfoot", "ltibia", (0, 0, 1), 2.3, "rx rz"),
    ("ltoes", "lfoot", (0, 0, 1), 1.1, "rx"),
    ("rhipjoint", "root", (-0.65, -0.71, 0.25), 2.5, ""), ("rfemur", "rhipjoint", (-0.34, -0.94, 0), 7.6, "rx ry rz"),
    ("rtibia", "rfemur", (-0.34, -0.94, 0), 7.3, "rx"), ("rfoot", "rtibia", (0, 0, 1), 2.3, "rx rz"),
    ("rtoes", "rfoot", (0, 0, 1), 1.1, "rx"),
    ("lowerback", "root", (0, 1, 0), 2.0, "rx ry rz"), ("upperback", "lowerback", (0, 1, 0), 2.0, "rx ry rz"),
    ("thorax", "upperback", (0, 1, 0), 2.0, "rx ry rz"), ("lowerneck", "thorax", (0, 1, 0), 1.5, "rx ry rz"),
    ("upperneck", "lowerneck", (0, 1, 0), 1.5, "rx ry rz"), ("head", "upperneck", (0, 1, 0), 1.5, "rx ry rz"),
    ("lclavicle", "thorax", (1, 0.2, 0), 3.4, "ry rz"), ("lhumerus", "lclavicle", (1, 0, 0), 5.0, "rx ry rz"),
    ("lradius", "lhumerus", (1, 0, 0), 3.4, "rx"), ("lwrist", "lradius", (1, 0, 0), 1.7, "ry"),
    ("lhand", "lwrist", (1, 0, 0), 0.7, "rx rz"),
    ("rclavicle", "thorax", (-1, 0.2, 0), 3.4, "ry rz"), ("rhumerus", "rclavicle", (-1, 0, 0), 5.0, "rx ry rz"),
    ("rradius", "rhumerus", (-1, 0, 0), 3.4, "rx"), ("rwrist", "rradius", (-1, 0, 0), 1.7, "ry"),
    ("rhand", "rwrist", (-1, 0, 0), 0.7, "rx rz"),
]
asf = [":version 1.10", ":name VICON", ":units", "  mass 1.0", "  length 0.45", "  angle deg", ":root",
       "   order TX TY TZ RX RY RZ", "   axis XYZ", "   position 0 0 0", "   orientation 0 0 0", ":bonedata"]
for i, (name, _, d, length, dof) in enumerate(BONES, 1):
    asf += ["  begin", f"     id {i}", f"     name {name}", f"     direction {d[0]} {d[1]} {d[2]}",
            f"     length {length}", "     axis 0 0 0  XYZ"]
    if dof:
        asf.append(f"    dof {dof}")
    asf.append("  end")
children = {}
for name, parent, *_ in BONES:
    children.setdefault(parent, []).append(name)
asf += [":hierarchy", "  begin"] + [f"    {p} {' '.join(c)}" for p, c in children.items()] + ["  end"]
asf_text = "\n".join(asf) + "\n"
amc = [":FULLY-SPECIFIED", ":DEGREES"]
for k in (1, 2):
    amc.append(f"{k}")
    amc.append(f"root {k * 0.5} 16.7 -30.1 -2.5 {k * 2.0} -3.0")
    for name, _, _, _, dof in BONES:
        if dof:
            amc.append(f"{name} " + " ".join(f"{1.5 * k:g}" for _ in dof.split()))
amc_text = "\n".join(amc) + "\n"
write("asf_amc", "two_frames.asf_amc", asf_text + "%%AMC%%\n" + amc_text)
write("asf_amc", "skeleton_only.asf_amc", asf_text)

write("csv_imu", "xio.csv", "Time (s),Gyroscope X (deg/s),Gyroscope Y (deg/s),Gyroscope Z (deg/s),"
      "Accelerometer X (g),Accelerometer Y (g),Accelerometer Z (g),Magnetometer X (uT),Magnetometer Y (uT),Magnetometer Z (uT)\n"
      "0.000,0.1,-0.2,0.3,0.01,0.02,1.00,20,5,-40\n0.010,0.2,-0.1,0.2,0.02,0.01,0.99,20,5,-40\n"
      "0.020,0.1,0.0,0.1,0.00,0.00,1.01,,,\n")
write("csv_imu", "snake.csv", "t_ms,accel_x_mps2,accel_y_mps2,accel_z_mps2,gyro_x_dps,gyro_y_dps,gyro_z_dps\n"
      "0,0.1,0.2,9.8,1,2,3\n10,0.1,0.2,9.7,1,2,3\n20,0.0,0.1,9.9,0,1,2\n")
write("csv_imu", "ns.csv", "timestamp_ns,accX (m/s^2),accY (m/s^2),accZ (m/s^2),gyroX (rad/s),gyroY (rad/s),gyroZ (rad/s)\n"
      "1000000000,0,0,9.81,0,0,0\n1010000000,0,0,9.81,0,0,0.01\n")
write("csv_imu", "accel_only.csv", "t (s),acc_x (g),acc_y (g),acc_z (g)\n0.00,0.01,0.02,1.00\n0.08,0.02,0.01,0.99\n0.16,0.00,0.00,1.01\n")
write("csv_fixes", "fixes.csv", "t (s),tag,x (m),y (m),z (m),quality\n0.0,tag-1,1.0,2.0,1.1,0.9\n0.1,tag-1,1.05,2.0,1.1,\n0.1,tag-2,3.0,1.0,1.2,1\n")
write("csv_fixes", "fixes_mm.csv", "t_ms,tag,x [mm],y [mm],z [mm]\n0,a,1000,2000,1100\n100,a,1010,2000,1100\n")
joints = ["pelvis", "head", "left_wrist", "right_wrist"]
rows = ["t (s),camera,track,joint,x (m),y (m),z (m),confidence,state"]
for k in range(2):
    for j, name in enumerate(joints):
        rows.append(f"{k / 30:.4f},cam-1,1,{name},{0.1 * j},{1.0 + 0.01 * k},{3.0},0.9,tracked")
write("csv_skeletons", "joint_rows_canonical.csv", "\x00" + "\n".join(rows) + "\n")
header = ["t (s)", "camera", "track"] + [f"{j}_{a}" for j in joints for a in ("x", "y", "z")]
write("csv_skeletons", "skeleton_rows_canonical.csv", "\x05" + ",".join(header) + "\n"
      + "0.0,cam-1,2," + ",".join("1.0" for _ in range(12)) + "\n"
      + "0.0333,cam-1,2," + ",".join("1.01" for _ in range(12)) + "\n")
write("csv_skeletons", "joint_rows_kinect_v2.csv", "\x01t_ms,camera,track,joint,x,y,z\n0,k,1,SpineBase,0,1,3\n0,k,1,Head,0,1.7,3\n")

write("mot", "gt.txt", "1,1,100,200,50,120,1,1,1\n1,2,300,200,50,120,1,1,1\n2,1,102,200,50,120,1,1,1\n")
write("mot", "det.txt", "1,-1,100.5,199,50,121,0.9,-1,-1,-1\n2,-1,103,201,49,118,0.8,-1,-1,-1\n")
write("calib_points", "pairs.csv", "# camera x y z, world x y z (m)\n0 0 3 1 2 0\n1 0 3 2 2 0\n0 1 3 1 2 1\n1 1 4 2 3 1\n")
write("fit_csv", "broad.csv", "\x00t_s,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z,mag_x,mag_y,mag_z,movement,opt_quat_w,opt_quat_x,opt_quat_y,opt_quat_z\n"
      "0.0,0,0,9.81,0,0,0,20,0,-40,0,1,0,0,0\n0.01,0,0,9.81,0,0,0.1,20,0,-40,1,1,0,0,0\n")
write("fit_csv", "lias_uwb.csv", "\x02" + "\n".join(
    "12:00:0%d.000," % k + ",".join("%.2f" % (1.0 + 0.1 * i) for i in range(24)) for k in range(3)) + "\n")
write("fit_csv", "kolakowski.csv", "\x04,ts,x,heading,y,rssi_1,rssi_2,rssi_3,rssi_4,rssi_5,rssi_6\n0,0.0,1.0,0,2.0,-60,-61,-62,,-70,-71\n1,0.1,1.1,0,2.0,-60,-61,-62,-65,-70,-71\n")
write("fit_csv", "anchors.csv", "\x05id,x,y,z\n1,0,0,2.5\n2,5,0,2.5\n3,5,5,2.5\n")
write("multiview", "openpose.json", "\x00" + '{"version":1.3,"people":[{"pose_keypoints_2d":[100,200,0.9,110,210,0.8]}]}')
write("multiview", "camera.toml", "\x01" + '[[cameras]]\nid = "cam-1"\nwidth_px = 640\nheight_px = 480\nfx_px = 500\nfy_px = 500\ncx_px = 320\ncy_px = 240\n')
write("mqtt_payload", "imu.txt", 'nomen/in/imu/imu-1\n{"type":"imu","t":1000000000,"device":"imu-1","accel_mps2":[0,0,9.81],"gyro_radps":[0,0,0]}')
write("mqtt_payload", "imu_accel_only.txt", 'nomen/in/imu/watch-1\n{"type":"imu","t":1000000000,"device":"watch-1","accel_mps2":[0.3,-1.2,9.7]}')
write("mqtt_payload", "registry.txt", 'nomen/in/registry\n{"subjects":[],"cameras":[]}')
write("mqtt_payload", "pozyx.txt", 'nomen/in/vendor/pozyx/site\n[{"tagId":"30331","timestamp":1615984968.5,"success":true,"data":{"coordinates":{"x":1200,"y":-350,"z":1100}}}]')
write("engine_config", "empty.toml", "")
write("engine_config", "some.toml", "window_s = 4.0\nhop_s = 0.5\n")
write("serve_config", "empty.toml", "")
write("serve_config", "queue.toml", "queue_capacity = 64\n")
write("rssi_model", "garbage.json", '{"antennas":[]}')
write("family_toml", "empty.toml", 'name = "f"\n')


REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def copy(target, path, prefix=b""):
    d = os.path.join(ROOT, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(REPO, path), "rb") as f:
        data = f.read()
    with open(os.path.join(d, os.path.basename(path)), "wb") as f:
        f.write(prefix + data)


copy("azure_kinect", "docs/adapters/azure_kinect_offline.json")
copy("tracker", "docs/adapters/tracker_overhead.csv", b"\x02")
copy("tracker", "docs/adapters/tracker_overhead.jsonl", b"\x01")
copy("pozyx", "docs/adapters/pozyx_tags.jsonl", b"\x00")
copy("sewio", "docs/adapters/sewio_feed.jsonl", b"\x00")
copy("impinj", "docs/adapters/impinj_speedway.jsonl")
copy("zebra", "docs/adapters/zebra_iotc.jsonl")
copy("cnn_model", "models/cnn_small.json", b"\x00")
for path in ["scenarios/handshake.toml", "scenarios/uwb_1.toml", "scenarios/rfid_crosswalk.toml",
             "scenarios/imu_wrist_2.toml", "scenarios/belmonte_lost_redetected.toml",
             "scenarios/hospital_room.toml", "scenarios/crosswalk_1t1u_opposite.toml"]:
    copy("scenario_toml", path)
for path in sorted(glob.glob(os.path.join(REPO, "scenarios/families/*.toml")))[:6]:
    copy("family_toml", os.path.relpath(path, REPO))

# A recording: a registry with every kind of device, and a message of every input kind.
REGISTRY = ('{"subjects":[{"id":"ana","wears":[{"device":"ana_imu","kind":"imu","site":"left_wrist"},'
            '{"device":"ana_tag","kind":"uwb_tag","site":"chest"},{"device":"ana_rfid","kind":"rfid_tag","site":"chest"}]}],'
            '"cameras":[{"id":"cam","fps_hz":30.0}],"anchors":[{"id":"a1","position_m":[0.0,0.0,2.5]}],'
            '"antennas":[{"id":"ant","position_m":[3.0,0.0,2.0],"boresight":[-1.0,0.0,0.0]}]}')
lines = ['{"type":"header","format":"nomen-recording","version":1,"registry":' + REGISTRY + ',"meta":{"seed":1}}']
for k in range(6):
    t = k * 33_333_333
    lines.append('{"type":"skeleton","t":%d,"camera":"cam","track":1,"joints":{"pelvis":{"position_m":[0.1,1.0,2.5]},'
                 '"left_wrist":{"position_m":[0.3,1.1,2.4],"confidence":0.8,"state":"inferred"}}}' % t)
    lines.append('{"type":"imu","t":%d,"device":"ana_imu","accel_mps2":[0.1,-0.2,9.81],"gyro_radps":[0.01,0.0,-0.3],"mag_ut":[15.3,0.4,-41.1]}' % (t + 1))
    lines.append('{"type":"rtls_fix","t":%d,"tag":"ana_tag","position_m":[1.0,2.0,1.3],"quality":0.9}' % (t + 2))
    lines.append('{"type":"uwb_range","t":%d,"tag":"ana_tag","anchor":"a1","range_m":3.25}' % (t + 3))
    lines.append('{"type":"rssi","t":%d,"tag":"ana_rfid","antenna":"ant","rssi_dbm":-61.5,"phase_rad":1.5}' % (t + 4))
write("recording", "every_kind.jsonl", "\n".join(lines) + "\n")
write("recording", "no_registry.jsonl", '{"type":"header","format":"nomen-recording","version":1,"registry":null}\n'
      '{"type":"identified","t":0,"camera":"cam","track":1,"identity":{"subject":"ana"},"confidence":0.9,'
      '"decision":{"rule":"assigned","decided_at":5,"named":{"subject":"ana","score":0.5}}}\n'
      '{"type":"truth_tag","t":1,"tag":"ana_tag","position_m":[1.0,2.0,1.3]}\n')


def mcap(messages):
    """An unchunked MCAP file (https://mcap.dev/spec) of `messages`, (topic, JSON text) pairs,
    each topic its own JSON channel; no summary section."""
    import struct

    def string(s):
        b = s.encode()
        return struct.pack("<I", len(b)) + b

    def record(opcode, content):
        return struct.pack("<BQ", opcode, len(content)) + content

    out = bytearray(b"\x89MCAP0\r\n")
    out += record(0x01, string("nomen") + string("make_seeds.py"))
    channels = {}
    for topic, _ in messages:
        if topic not in channels:
            channels[topic] = len(channels) + 1
            out += record(0x03, struct.pack("<H", channels[topic]) + string(topic) + string("jsonschema")
                          + string('{"type":"object"}'))
            out += record(0x04, struct.pack("<HH", channels[topic], channels[topic]) + string(topic)
                          + string("json") + struct.pack("<I", 0))
    for k, (topic, text) in enumerate(messages):
        out += record(0x05, struct.pack("<HIQQ", channels[topic], k, 1000 + k, 1000 + k) + text.encode())
    out += record(0x0F, struct.pack("<I", 0))
    out += record(0x02, struct.pack("<QQI", 0, 0, 0))
    out += b"\x89MCAP0\r\n"
    return bytes(out)


# The recording above as MCAP: the registry, then every input on its kind's channel.
inputs = [("nomen/in/registry", REGISTRY)]
for line in lines[1:]:
    kind = line.split('"type":"', 1)[1].split('"', 1)[0]
    inputs.append(("nomen/in/" + kind, line))
os.makedirs(os.path.join(ROOT, "mcap"), exist_ok=True)
with open(os.path.join(ROOT, "mcap", "every_kind.mcap"), "wb") as f:
    f.write(mcap(inputs))
