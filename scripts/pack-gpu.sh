#!/usr/bin/env bash
# Packs built binaries and the libraries the GPU machines lack into .devrt/ (see
# ../shared/gpu/README.md): the shared pack-runtime.sh, plus toml++, libepoxy and libpng (the
# render stage's), which it does not carry.
# Usage: [PACK_XZ=1] scripts/pack-gpu.sh BINARY...
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/../shared/gpu/pack-runtime.sh" "$root/.devrt" "$@"
# The commit at packing (the recipe builds just before), for the jobs' records: the GPU machine's
# copy of the tree may carry an older history (a study's CSV named the session's first commit).
# "+changes" where src/ or apps/ differ from it.
commit=$(git -C "$root" rev-parse --short HEAD)
git -C "$root" diff --quiet HEAD -- src apps || commit="$commit+changes"
echo "$commit" > "$root/.devrt/commit"
for lib in $(ldd "$@" | awk '/libtomlplusplus|libepoxy|libpng16/ {print $3}' | sort -u); do
  cp -L "$lib" "$root/.devrt/lib/"
done
# PACK_XZ=1: the binaries in one .devrt/bin.tar.xz instead (unpack on the GPU machine with
# `tar xJf .devrt/bin.tar.xz -C .devrt/bin`). The test programs each link the whole library
# (~20 MB, mostly the same device code), so a dictionary larger than all of them together finds
# the repeats: 26 binaries, 286 MB, went into 11 MB (xz's default dictionary: 57 MB, over the
# 64 MiB a call carries).
if [ "${PACK_XZ:-0}" = 1 ]; then
  (cd "$root/.devrt/bin" && tar cf - . | xz -T1 --lzma2=preset=6,dict=320MiB) \
    > "$root/.devrt/bin.tar.xz"
  find "$root/.devrt/bin" -type f -delete
fi
