#!/usr/bin/env bash
# README's short tour, command by command, in order, as written there: `scripts/tour.sh` from the
# repository's root runs it with `target/release/nomen` (`NOMEN=path` for another build) and
# writes everything under `out/`. `TOUR=quick` (what `.ci/run` uses, with the debug build)
# leaves out the commands that take minutes (marked `long` below) and says which it left out.
# Needs `../shared/data`; a test keeps README's tour and this script the same commands.
set -euo pipefail
cd "$(dirname "$0")/.."

NOMEN=${NOMEN:-target/release/nomen}
[ -x "$NOMEN" ] || { echo "$NOMEN not found: cargo build --release -p nomen-cli (or set NOMEN)" >&2; exit 2; }
[ -d ../shared/data/mocap/cmu ] || { echo "skipping the tour: shared data not found at ../shared/data" >&2; exit 0; }
MODE=${TOUR:-full}

nomen() { "$NOMEN" "$@"; }
step() { printf '\n== %s\n' "$*"; }
# `long CMD...`: a command that takes minutes; run in full mode only.
long() {
  if [ "$MODE" = quick ]; then
    printf '\n== (left out in quick mode) %s\n' "$*"
  else
    step "$@"
    "$@"
  fi
}
# `run CMD...`: print and run.
run() { step "$@"; "$@"; }

mkdir -p out

# Simulate a scene from the library and evaluate a result against its ground truth.
run nomen simulate scenarios/imu_wrist_4.toml --out out/w4 --seed 1
run nomen run out/w4/recording.jsonl --out out/w4/result.jsonl
step "nomen config defaults > out/nomen.toml"
nomen config defaults > out/nomen.toml
# A live stream on stdin: decisions come out as they are made.
step "nomen run - --live --out - < out/w4/recording.jsonl | tail -n 1"
nomen run - --live --out - < out/w4/recording.jsonl | tail -n 1
run nomen eval --truth out/w4/truth.jsonl --result out/w4/result.jsonl --plots out/w4/plots
run nomen explain out/w4/result.jsonl --track 261 --at 12

# Scene families and the held-out identity benchmark.
run nomen scenes generate --family intruders --count 10 --out out/intruders
run nomen bench identity --split validation --family wrist_8 --count 2
long nomen bench identity --split validation
long nomen bench identity --split test

# De Marchi's Tables III/IV on simulated scenes.
long nomen experiment imu-table --network full

# Motion capture → skeleton recording (+ ground truth).
run nomen mocap convert ../shared/data/mocap/cmu/18_01.bvh ../shared/data/mocap/cmu/19_01.bvh \
  --scale 0.0564444 --out out/hs/recording.jsonl --truth out/hs/truth.jsonl
run nomen mocap convert ../shared/data/mocap/cmu/60_01_scaled.bvh --fps 60 --scale 1.4 --out out/salsa.jsonl
run nomen mocap convert ../shared/data/mocap/cmu-asfamc/02_05.amc --asf ../shared/data/mocap/cmu-asfamc/02.asf \
  --scale 0.0564444 --out out/punch.jsonl

# CSV and vendor formats → recording.
run nomen import imu ../shared/data/imu/xio/sensor_data.csv --device xio --out out/xio.jsonl
run nomen import skeletons docs/samples/kinect_v2_joints.csv --joint-set kinect-v2 --out out/kinect.jsonl
# Files as devices write them, and one session assembled from them (docs/import.md).
run nomen import imu docs/samples/watch_batched.csv --device watch --timezone +02:00 --out out/watch.jsonl
run nomen import fixes docs/samples/tag_fixes.tsv --timezone +02:00 --out out/tag.jsonl
run nomen import imu ../shared/data/imu/broad/07_undisturbed_fast_rotation_B.csv --device broad \
  --units docs/samples/broad_units.toml --out out/broad.jsonl
run nomen assemble --registry docs/samples/registry.toml out/watch.jsonl out/tag.jsonl --out out/session.jsonl
run nomen import azure-kinect docs/adapters/azure_kinect_offline.json --camera kinect --out out/kinect_bt.jsonl
run nomen import tracker docs/adapters/tracker_overhead.csv --camera counter --scale 0.0153 --z-m 1.7 --out out/counter.jsonl
run nomen import pozyx docs/adapters/pozyx_tags.jsonl --out out/pozyx.jsonl

# Check recordings line by line.
run nomen validate out/hs/recording.jsonl
run nomen validate --skip-bad out/kinect.jsonl

# Evaluate the demo's baseline (written by `nomen demo`, run first when missing).
[ -f out/demo/scene/baseline.jsonl ] || run nomen demo --out out/demo
run nomen eval --truth out/demo/scene/truth.jsonl --result out/demo/scene/baseline.jsonl --json --plots out/plots

# MOT metrics on MOTChallenge files.
run nomen eval mot --gt ../shared/data/mot/TUD-Campus/gt.txt --test ../shared/data/mot/TUD-Campus/test.txt \
  --format motchallenge --iou 0.5 --json

# Fit sensor noise models to real recordings.
run nomen fit all ../shared/data

# Other identity methods, pose refinement, calibration.
run nomen simulate scenarios/uwb_2.toml --out out/u2 --seed 1
run nomen run out/u2/recording.jsonl --method baptizo --out out/u2/baptizo.jsonl
run nomen simulate scenarios/crosswalk_calibration.toml --out out/cal --seed 1
run nomen calibrate rssi out/cal/recording.jsonl --model directional --out out/rssi_model.json
run nomen simulate scenarios/crosswalk_1t.toml --out out/cw --seed 1
run nomen run out/cw/recording.jsonl --method llorca --rssi-model out/rssi_model.json --out out/cw/llorca.jsonl
run nomen simulate scenarios/hospital_room.toml --out out/h --seed 1
run nomen run out/h/recording.jsonl --refine-joints --environment out/h/obstacles.obj --out out/h/refined.jsonl
run nomen run out/w4/recording.jsonl --cnn models/cnn_small --out out/w4/cnn.jsonl
run nomen simulate scenarios/uwb_1.toml --out out/u1 --seed 1
run nomen calibrate frames out/u1/recording.jsonl --out out/u1/calibration.toml
run nomen run out/u1/recording.jsonl --calibration out/u1/calibration.toml --out out/u1/calibrated.jsonl
run nomen calibrate confidence --scenes out/w4 out/u2

# One command per paper table.
long nomen experiment imu-table --network wrist
long nomen experiment belmonte
long nomen experiment ghosting
long nomen experiment crosswalk
long nomen experiment triangulation
long nomen experiment occlusion --out out/occ
long nomen experiment faults --plots out/faults

# Train De Marchi's CNN on simulated scenes.
long nomen simulate scenarios/train/train_mixed_5.toml --out out/train/train_mixed_5 --seed 101
long nomen simulate scenarios/train/train_salsa_4.toml --out out/train/train_salsa_4 --seed 101
long nomen simulate scenarios/train/train_veer_6.toml --out out/train/train_veer_6 --seed 101
long nomen train cnn --scenes out/train/* --out out/cnn

printf '\nthe tour ran (%s mode)\n' "$MODE"
