#!/usr/bin/env bash
# Validates deploy/k8s/*.yaml without a cluster (run by .ci/run): installs the official
# Kubernetes Python client, pinned, into target/k8s-venv (once), and runs check.py.
# Where it cannot install (no python3 venv, no PyPI access) it says so loudly and exits
# 0, unless WAVETRACE_REQUIRE_K8S_CHECK=1. An invalid manifest exits 1.
set -euo pipefail
cd "$(dirname "$0")/../.."
venv=target/k8s-venv
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c 'import kubernetes, yaml' 2>/dev/null; then
  if ! { python3 -m venv "$venv" && "$venv/bin/pip" install -q --disable-pip-version-check kubernetes==37.0.2; } >&2; then
    echo "######## KUBERNETES MANIFEST CHECK NOT RUN: cannot install the kubernetes client ########" >&2
    [ "${WAVETRACE_REQUIRE_K8S_CHECK:-0}" = 1 ] && exit 1
    exit 0
  fi
fi
"$venv/bin/python" deploy/k8s/check.py deploy/k8s/*.yaml
