#!/usr/bin/env bash
# Fetches three@$VERSION from the npm registry, checks the tarball's integrity and copies the
# files the viewer embeds. After a version change, update README.md and the hashes in
# src/assets.rs.
set -euo pipefail
VERSION=${1:-0.187.0}
INTEGRITY=${2:-sha512-Qiu7R+Cmh8CstZsY1uJOSWnVlfo7ZtNLV7mF8Jltk3LB3AtDu9cRZlcnRKkAk8Y4z6KKw35z7Y7Urd7jWY8etA==}
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"
npm pack --silent "three@$VERSION" >/dev/null 2>&1
actual="sha512-$(openssl dgst -sha512 -binary "three-$VERSION.tgz" | base64 -w0)"
if [ "$actual" != "$INTEGRITY" ]; then
  echo "three-$VERSION.tgz: integrity $actual, expected $INTEGRITY" >&2
  exit 1
fi
tar xzf "three-$VERSION.tgz"
cp package/build/three.module.js package/build/three.core.js package/LICENSE "$here/"
sha256sum "$here/three.module.js" "$here/three.core.js" "$here/LICENSE"
