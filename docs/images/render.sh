#!/usr/bin/env bash
# The README's pictures, rendered by robosim itself on the headless adapter (Mesa llvmpipe
# where there is no GPU). Regenerate from the repository root: bash docs/images/render.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release -q
R=./target/release/robosim
$R render puma560 --joints puma560=25,35,-135,0,55,0 \
  --from -1.5,1.55,1.25 --at 0.05,0,0.55 --size 800x600 --edges --out docs/images/puma560.png
$R render surgical_positioner_cell --joints positioner=0,40,-100,0,60,0 \
  --from 0.95,-0.75,0.55 --at 0.12,0,0.1 --size 800x600 --edges --collisions \
  --out docs/images/surgical_positioner.png
$R render space_station --size 1200x800 --out docs/images/space_station.png
