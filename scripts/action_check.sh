#!/usr/bin/env bash
# Run `rapidc check --format github` on the given paths (default: .) for the GitHub Action in
# action.yml. Errors become workflow annotations; the exit status is rapidc's (0 clean, 1 errors,
# 2 usage or I/O error). RAPIDC_COMMAND (check or lint) and RAPIDC_ARGS (extra options) are optional.
set -euo pipefail

command="${RAPIDC_COMMAND:-check}"
case "$command" in
  check|lint) ;;
  *) echo "action_check.sh: RAPIDC_COMMAND must be check or lint, not '$command'" >&2; exit 2 ;;
esac
read -r -a extra <<< "${RAPIDC_ARGS:-}"
if [ "$#" -eq 0 ]; then
  set -- .
fi
# `python -m rapid_dsl` rather than the `rapidc` script: works even when pip's script folder is not on PATH.
exec "${PYTHON:-python}" -m rapid_dsl "$command" --format github "${extra[@]}" "$@"
