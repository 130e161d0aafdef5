#!/usr/bin/env bash
# Builds the kiss3d viewer and checks that it starts and draws under Xvfb with Mesa's
# software drivers (no GPU, no display), saving screenshots: the screen-space water (its own
# wgpu passes, run by Mesa's lavapipe) and the points. Not part of the default CI run
# (kiss3d/wgpu add a long build: ~13 min on 2 cores); .ci/run calls it when
# RAPIER_SPH_CI_VIEWER=1. Run by hand: bash .ci/viewer_check.sh [OUT.png]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-target/viewer_screenshot.png}
if ! command -v xvfb-run >/dev/null 2>&1; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq xvfb xauth mesa-vulkan-drivers libgl1-mesa-dri
fi
cargo build --release --locked --features viewer --example viewer
xvfb-run -a -s "-screen 0 1280x800x24" "${CARGO_TARGET_DIR:-target}/release/examples/viewer" scenes/dam_break.ron \
  --frames 30 --screenshot "$out"
test -s "$out"
echo "viewer drew 30 frames under Xvfb; screenshot: $out"
# The obstacle course file: emitter, sink, named sensor, kinematic wheel, dynamic crates.
course="${out%.png}_obstacle_course.png"
xvfb-run -a -s "-screen 0 1280x800x24" "${CARGO_TARGET_DIR:-target}/release/examples/viewer" scenes/obstacle_course.ron \
  --frames 30 --screenshot "$course"
test -s "$course"
echo "viewer drew 30 frames of the obstacle course under Xvfb; screenshot: $course"
# The older drawing (speed-coloured points) still works.
points="${out%.png}_points.png"
xvfb-run -a -s "-screen 0 1280x800x24" "${CARGO_TARGET_DIR:-target}/release/examples/viewer" scenes/dam_break.ron \
  --frames 10 --points --screenshot "$points"
test -s "$points"
echo "viewer drew 10 frames of points under Xvfb; screenshot: $points"
