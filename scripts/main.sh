#!/usr/bin/env bash
# Set up from scratch and run the main job: reproduce both papers, compute the vsaUT-II datasheet,
# and identify the shipped EMPS and CED records. Everything lands in out/.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/setup.sh
mkdir -p out
vsa-gym reproduce all --out out/reproduce
vsa-gym datasheet vsaut2 --json out/datasheet_vsaut2.json
vsa-gym data check emps
vsa-gym identify emps --json out/identify_emps.json --out out/identify_emps
vsa-gym data check ced
vsa-gym identify ced --json out/identify_ced.json --out out/identify_ced
echo "main job done: see out/"
