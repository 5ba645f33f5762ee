#!/usr/bin/env bash
# Issue 15's probes against a built capsflow: tools/probe_inputs.sh [BINARY]
# (default build/src/app/capsflow). The probes live in probe_inputs.py (standard library only).
exec python3 "$(dirname "$0")/probe_inputs.py" "$@"
