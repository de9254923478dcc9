#!/usr/bin/env bash
# The cargo runner for the board: seal the image (its CRC-32, checked by the
# firmware at start-up and in the background), then flash it and stream its
# log through a debug probe.
set -euo pipefail
"$(dirname "$0")/seal-image.py" "$1"
exec probe-rs run --chip STM32F405RGTx "$@"
