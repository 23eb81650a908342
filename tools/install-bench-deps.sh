#!/usr/bin/env bash
# Debian packages the peers benchmark (tools/bench/bench_peers.py) uses: the mosquitto MQTT
# broker. The Python clients come with `pip install -e '.[bench]'`. Installs only what is
# missing, only as root; otherwise says what it skipped (the MQTT run and its smoke test then
# skip with the reason). The broker is only run by the benchmark, on 127.0.0.1, per run.
set -euo pipefail
need=()
command -v mosquitto >/dev/null 2>&1 || [ -x /usr/sbin/mosquitto ] || need+=(mosquitto)
. "$(dirname "$0")/lib/apt-install-missing.sh"
apt_install_missing install-bench-deps "${need[@]}"
