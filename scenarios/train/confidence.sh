#!/usr/bin/env bash
# Refits the engine's confidence maps (nomen_engine::ConfidenceMap::fitted) from the scenes
# they were fitted on, and prints one as a [confidence_map] table: nomen's motion score's by
# default, another's with a config that sets it (motion_score = "de_marchi" or "belmonte").
#
# The scenes: the CNN's training scenes of this folder (seeds 1-4), the library's IMU,
# Belmonte-Hernandez, hospital and UWB scenes at seeds from 1001 on, which none of the
# figures of the engine README use (they use seeds 1-144), and the first three scenes of every
# scene family's validation split (docs/benchmark.md; the test split stays out).
#
# Usage: scenarios/train/confidence.sh [OUT_DIR [CONFIG]]
#   (OUT_DIR default: out/confidence; needs ../shared/data)
set -euo pipefail
cd "$(dirname "$0")/../.."
out="${1:-out/confidence}"
config=()
if [ -n "${2:-}" ]; then config=(--config "$2"); fi
cargo build --release -q -p nomen-cli
nomen=target/release/nomen
mkdir -p "$out"
scenes=()
sim_file() { # scenario-file out-dir [--seed S]
    local file=$1 dir=$2
    shift 2
    if [ ! -f "$dir/truth.jsonl" ]; then
        local log
        if ! log=$("$nomen" simulate "$file" "$@" --out "$dir" 2>&1); then
            echo "$log" >&2
            exit 1
        fi
    fi
    scenes+=("$dir")
}
sim() { # scenario seed
    sim_file "scenarios/$1" "$out/$(basename "$1" .toml)_$2" --seed "$2"
}
for f in train/train_mixed_5 train/train_salsa_4 train/train_veer_6; do
    for s in 1 2 3 4; do sim "$f.toml" "$s"; done
done
for f in imu_ban_2 imu_ban_3 imu_ban_4 imu_ban_5 imu_ban_8 imu_wrist_2 imu_wrist_3 imu_wrist_4 \
    imu_wrist_5 imu_wrist_8 belmonte_two_banded_one_lost belmonte_lost_redetected; do
    for s in 1001 1002 1003; do sim "$f.toml" "$s"; done
done
for s in $(seq 1001 1030); do sim belmonte_one_without_band.toml "$s"; done
for f in uwb_8_among_untagged hospital_room; do
    for s in 1001 1002; do sim "$f.toml" "$s"; done
done
for family in $("$nomen" scenes list | awk 'NF { print $1 }'); do
    dir="$out/families/$family"
    if [ ! -d "$dir" ]; then
        "$nomen" scenes generate --family "$family" --split validation --count 3 --out "$dir" >/dev/null
    fi
    for f in "$dir"/*.toml; do sim_file "$f" "${f%.toml}"; done
done
"$nomen" calibrate confidence --scenes "${scenes[@]}" "${config[@]}"
