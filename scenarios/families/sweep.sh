#!/usr/bin/env bash
# Sweeps one engine option over the identity benchmark's validation split: for each value, the
# option is written into a config file (on top of BASE, an engine config TOML, if given) and
# `nomen bench identity --split validation` prints its table. The engine's defaults are chosen
# with this command and the tables it prints are quoted where a default is documented.
#
#   scenarios/families/sweep.sh rejection_threshold 0.15 0.25 0.3 [-- --count 4 --family F ...]
#   BASE=my.toml NOMEN=target/dist/nomen scenarios/families/sweep.sh camera_exclusion_margin 0 0.2
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: $0 OPTION VALUE... [-- BENCH-ARGS...]" >&2; exit 2; }
option=$1; shift
values=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do values+=("$1"); shift; done
[ $# -gt 0 ] && shift
nomen=${NOMEN:-target/release/nomen}
[ -x "$nomen" ] || { echo "$nomen not found: cargo build --release -p nomen-cli (or set NOMEN)" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for value in "${values[@]}"; do
  config="$tmp/$option-$value.toml"
  # The option first: a top-level key must come before BASE's tables.
  { echo "$option = $value"; if [ -n "${BASE:-}" ]; then grep -v "^$option *=" "$BASE" || true; fi; } > "$config"
  echo "== $option = $value"
  "$nomen" bench identity --split validation --config "$config" "$@" | grep '^|'
done
