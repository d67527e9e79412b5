#!/usr/bin/env bash
# Set up a virtual environment from scratch (Python 3.11, package registries only) and run the tests.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m venv .venv
. .venv/bin/activate
python -m pip install --quiet --upgrade pip
python -m pip install --quiet torch==2.13.0          # CPU build; pinned before stable-baselines3
python -m pip install --quiet -e ".[test]"
ruff check vsa_gym agents baselines benchmarks tests
python -m pytest -q "$@"
