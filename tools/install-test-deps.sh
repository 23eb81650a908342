#!/usr/bin/env bash
# Debian packages some tests use: Chromium (web-viewer screenshot test), iproute2
# (network namespaces for the WAN tests), EGL and Mesa's GL drivers (the renderer's
# offscreen tests draw through EGL; llvmpipe when there is no GPU). Installs only what is missing, only as root;
# otherwise says what it skipped — those tests then skip with the reason.
set -euo pipefail
# mediapipe without its dependencies: it requires opencv-contrib-python, which would install a
# second cv2 over opencv-python-headless; the `body` extra lists its real dependencies.
python -m pip install --quiet --no-deps 'mediapipe==1.2.2'
need=()
command -v chromium >/dev/null 2>&1 || need+=(chromium)
command -v ip >/dev/null 2>&1 || need+=(iproute2)
ldconfig -p 2>/dev/null | grep -q 'libEGL.so.1' || need+=(libegl1)
[ -n "$(ls /usr/lib/*/dri/swrast_dri.so 2>/dev/null)" ] || need+=(libgl1-mesa-dri)
if [ ${#need[@]} -eq 0 ]; then
  echo "install-test-deps: nothing to install"
  exit 0
fi
if [ "$(id -u)" -ne 0 ] || ! command -v apt-get >/dev/null 2>&1; then
  echo "install-test-deps: not root or no apt-get; skipping ${need[*]} (their tests will skip)"
  exit 0
fi
echo "install-test-deps: installing ${need[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
