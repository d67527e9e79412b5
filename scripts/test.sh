#!/usr/bin/env bash
# Set up from scratch and run the linter and the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/setup.sh
ruff check vsa_gym agents baselines benchmarks tests
# one pytest-xdist worker per core (PYTEST_WORKERS=0: in this process); -q comes from pyproject addopts (a second
# -q would hide the "N passed" line)
python -m pytest -n "${PYTEST_WORKERS:-auto}" "$@"
