#!/usr/bin/env bash
# Runs a command with the ranks' GPU work side by side through CUDA MPS (the Multi-Process
# Service: one server context for all the ranks' processes, no time slices), the way a job runs
# several ranks on one GPU in production. Starts a private MPS control daemon (pipes and logs in
# a temporary folder; the GPU's compute mode and other settings untouched), runs the command, and
# stops it. After `. .devrt/prelude.sh`, from the project root.
# Usage: jobs/gpu/with_mps.sh COMMAND [ARGS...]
set -uo pipefail
if ! command -v nvidia-cuda-mps-control > /dev/null; then
  echo "nvidia-cuda-mps-control not found: MPS is not installed on this machine" >&2
  exit 2
fi
dir=$(mktemp -d)
export CUDA_MPS_PIPE_DIRECTORY=$dir/pipe CUDA_MPS_LOG_DIRECTORY=$dir/log
mkdir -p "$CUDA_MPS_PIPE_DIRECTORY" "$CUDA_MPS_LOG_DIRECTORY"
nvidia-cuda-mps-control -d || { echo "MPS control daemon did not start" >&2; exit 2; }
trap 'echo quit | nvidia-cuda-mps-control; sleep 1; rm -rf "$dir"' EXIT
echo "MPS on (pipes in $CUDA_MPS_PIPE_DIRECTORY)"
"$@"
