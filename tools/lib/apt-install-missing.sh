# Sourced by tools/install-*-deps.sh: `apt_install_missing LABEL PACKAGE...` installs the
# Debian packages given (the caller lists only missing ones), only as root with apt-get;
# otherwise it says what it skipped, and the tests or runs needing them skip with the reason.
apt_install_missing() {
  local label=$1
  shift
  if [ $# -eq 0 ]; then
    echo "$label: nothing to install"
    return 0
  fi
  if [ "$(id -u)" -ne 0 ] || ! command -v apt-get >/dev/null 2>&1; then
    echo "$label: not root or no apt-get; skipping $* (what needs them will skip)"
    return 0
  fi
  echo "$label: installing $*"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}
