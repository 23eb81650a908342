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
. "$(dirname "$0")/lib/apt-install-missing.sh"
apt_install_missing install-test-deps "${need[@]}"
