#!/usr/bin/env bash
# Create .venv (Python 3.11, package registries only) and install vsa-gym with its test and RL extras.
# Sourced by scripts/main.sh and scripts/test.sh; safe to re-run.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
. .venv/bin/activate
python -m pip install --quiet --upgrade pip
python -m pip install --quiet torch==2.13.0          # the CPU build; pinned before stable-baselines3 pulls torch
python -m pip install --quiet -e ".[test]"
