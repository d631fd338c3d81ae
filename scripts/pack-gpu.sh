#!/usr/bin/env bash
# Packs built binaries and the libraries the GPU machines lack into .devrt/ (see
# ../shared/gpu/README.md): the shared pack-runtime.sh, plus toml++, libepoxy and libpng (the
# render stage's), which it does not carry.
# Usage: scripts/pack-gpu.sh BINARY...
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/../shared/gpu/pack-runtime.sh" "$root/.devrt" "$@"
for lib in $(ldd "$@" | awk '/libtomlplusplus|libepoxy|libpng16/ {print $3}' | sort -u); do
  cp -L "$lib" "$root/.devrt/lib/"
done
