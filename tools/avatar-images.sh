#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Refreshes the avatar's pictures in docs/images from the browser test's screenshots (neutral,
# speaking: three visemes, smiling, surprised; full resolution, reflections on). Needs the release
# build (tools/bootstrap.sh build). Usage: tools/avatar-images.sh
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
ctest --preset release -R '^web\.avatar_browser$' --output-on-failure
shots=build/release/test-output/web-avatar
for name in neutral viseme-aa viseme-O viseme-FF smile surprised; do
  file="$shots/avatar-$name.jpg"
  size=$(wc -c < "$file")
  if [ "$size" -gt 204800 ]; then
    echo "$file is $size bytes, over 200 KB" >&2
    exit 1
  fi
  cp "$file" docs/images/
  echo "docs/images/avatar-$name.jpg ($size bytes)"
done
