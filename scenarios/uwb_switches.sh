#!/usr/bin/env bash
# UWB identity on the scene of eight tagged people among four untagged
# (`uwb_8_among_untagged.toml`) under an engine configuration: the scene simulated at seeds 1..N,
# run and evaluated; prints per seed and pooled over the seeds the frames correct, identity
# switches (per camera, METRICS.md) and switches per hour of wearers seen, and the share of the
# untagged people's frames that carry a name.
#
#   scenarios/uwb_switches.sh [CONFIG.toml] [N]       (N = 10; NOMEN=target/release/nomen)
set -euo pipefail
cd "$(dirname "$0")/.."
config=${1:-}
seeds=${2:-10}
nomen=${NOMEN:-target/release/nomen}
[ -x "$nomen" ] || { echo "$nomen not found: cargo build --release -p nomen-cli (or set NOMEN)" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for seed in $(seq 1 "$seeds"); do
  d="$tmp/$seed"
  "$nomen" simulate scenarios/uwb_8_among_untagged.toml --out "$d" --seed "$seed" 2>/dev/null
  "$nomen" run "$d/recording.jsonl" --out "$d/result.jsonl" ${config:+--config "$config"} 2>/dev/null
  "$nomen" eval --truth "$d/truth.jsonl" --result "$d/result.jsonl" --json > "$d/eval.json"
done
python3 - "$tmp" "$seeds" <<'PY'
import json, sys
tmp, seeds = sys.argv[1], int(sys.argv[2])
print(f"{'seed':>4} {'correct':>8} {'switches':>8} {'switch/h':>8} {'nothing->':>9}")
frames = correct = switches = nothing = named = 0
seen_s = 0.0
for seed in range(1, seeds + 1):
    m = json.load(open(f"{tmp}/{seed}/eval.json"))
    # Hours of wearers seen, per camera: the appearances' spans, as `nomen bench identity` counts them.
    s = sum(a["end_s"] - a["start_s"] for scene in m["per_scene"].values() for a in scene["appearances"])
    a = m["anonymous_people"]
    frames += m["num_frames"]; correct += m["identification"]["num_correct"]
    switches += m["id_switches"]; seen_s += s
    nothing += a["num_frames"]; named += a["num_wrong_subject"]
    print(f"{seed:>4} {100 * m['identification']['num_correct'] / m['num_frames']:7.2f}% {m['id_switches']:>8} "
          f"{3600 * m['id_switches'] / s:8.1f} {100 * a['num_wrong_subject'] / a['num_frames']:8.2f}%")
print(f"{'all':>4} {100 * correct / frames:7.2f}% {switches:>8} {3600 * switches / seen_s:8.1f} {100 * named / nothing:8.2f}%")
PY
