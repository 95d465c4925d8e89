#!/usr/bin/env bash
# The fuzzing campaign (not in CI). Usage: scripts/fuzz.sh [INPUTS] [PROGRAMS]
#   INPUTS   generated inputs for the front end, lowering and both back ends
#            (arbitrary bytes, token soups, mutated repository files): tests/fuzz.rs
#   PROGRAMS random well-typed programs, interpreter and JIT side by side, in
#            both color models: tests/random_programs.rs
# Findings (panics, disagreements, hangs over TSL_FUZZ_TIMEOUT seconds) are
# saved under fuzz-failures/ and fail the run. TSL_FUZZ_SEED and
# TSL_FUZZ_JOBS choose the seed and the number of workers.
set -euo pipefail
cd "$(dirname "$0")/.."
inputs=${1:-1000000}
programs=${2:-2000}
TSL_FUZZ_INPUTS=$inputs cargo test --release --test fuzz -- --ignored --nocapture fuzz
PROPTEST_CASES=$((programs / 2)) cargo test --release --test random_programs -- random_programs_agree
