#!/usr/bin/env bash
# Debian packages the peers benchmark (tools/bench/bench_peers.py) uses: the mosquitto MQTT
# broker. The Python clients come with `pip install -e '.[bench]'`. Installs only what is
# missing, only as root; otherwise says what it skipped (the MQTT run and its smoke test then
# skip with the reason). The broker is only run by the benchmark, on 127.0.0.1, per run.
set -euo pipefail
need=()
command -v mosquitto >/dev/null 2>&1 || [ -x /usr/sbin/mosquitto ] || need+=(mosquitto)
if [ ${#need[@]} -eq 0 ]; then
  echo "install-bench-deps: nothing to install"
  exit 0
fi
if [ "$(id -u)" -ne 0 ] || ! command -v apt-get >/dev/null 2>&1; then
  echo "install-bench-deps: not root or no apt-get; skipping ${need[*]} (the MQTT run will skip)"
  exit 0
fi
echo "install-bench-deps: installing ${need[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
