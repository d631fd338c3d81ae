#!/usr/bin/env bash
# p5_ranks_share.sh with the ranks' work running side by side on the GPU through CUDA MPS
# (with_mps.sh). After `. .devrt/prelude.sh`, from the project root.
# Usage: jobs/gpu/p5_ranks_share_mps.sh KNITFLOW [STEPS] [LISTS]
set -uo pipefail
here="$(dirname "$0")"
exec bash "$here/with_mps.sh" bash "$here/p5_ranks_share.sh" "$@"
