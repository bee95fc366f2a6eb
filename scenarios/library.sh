#!/usr/bin/env bash
# The shipped library's figures under an engine configuration: each scene simulated at seeds
# 1..N, run and evaluated; prints frames correct and (where someone wears nothing) the share of
# their frames left anonymous, per scene, pooled over the seeds.
#
#   scenarios/library.sh [CONFIG.toml] [N]       (N = 5; NOMEN=target/release/nomen)
set -euo pipefail
cd "$(dirname "$0")/.."
config=${1:-}
seeds=${2:-5}
nomen=${NOMEN:-target/release/nomen}
[ -x "$nomen" ] || { echo "$nomen not found: cargo build --release -p nomen-cli (or set NOMEN)" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
scenes="imu_ban_8 imu_wrist_4 imu_wrist_5 imu_wrist_8 belmonte_one_without_band belmonte_lost_redetected hospital_room uwb_8_among_untagged"
printf '%-28s %9s %10s\n' scene correct anonymous
for scene in $scenes; do
  dirs=()
  for seed in $(seq 1 "$seeds"); do
    d="$tmp/$scene-$seed"
    "$nomen" simulate "scenarios/$scene.toml" --out "$d" --seed "$seed" 2>/dev/null
    "$nomen" run "$d/recording.jsonl" --out "$d/result.jsonl" ${config:+--config "$config"} 2>/dev/null
    dirs+=("$d")
  done
  # Pooled over the seeds: counts summed from each seed's evaluation.
  python3 - "$scene" "${dirs[@]}" <<'PY'
import json, subprocess, sys, os
scene, dirs = sys.argv[1], sys.argv[2:]
nomen = os.environ.get("NOMEN", "target/release/nomen")
frames = correct = nothing = anon = 0
for d in dirs:
    out = subprocess.run([nomen, "eval", "--truth", f"{d}/truth.jsonl", "--result", f"{d}/result.jsonl", "--json"],
                         capture_output=True, text=True, check=True).stdout
    m = json.loads(out)
    frames += m["num_frames"]; correct += m["identification"]["num_correct"]
    a = m["anonymous_people"]; nothing += a["num_frames"]; anon += a["num_correct"]
print(f"{scene:<28} {100*correct/frames:8.2f}% {('%9.2f%%' % (100*anon/nothing)) if nothing else '        -'}")
PY
done
