# shellcheck shell=bash
# Sourced by scripts that need a Python module from a Debian package (python3-h5py,
# python3-numpy): Debian installs it for the system's python3, which another python3
# on the PATH (pyenv, a virtual environment) may hide.
#   usage: python=$(python_with MODULE PACKAGE) || exit 1

# Prints the first python3 that imports MODULE (the PATH's, then /usr/bin's); else
# says which package to install and fails.
python_with() {
  local module=$1 package=$2 candidate
  for candidate in python3 /usr/bin/python3; do
    if "$candidate" -c "import $module" 2>/dev/null; then
      echo "$candidate"
      return 0
    fi
  done
  echo "error: python3 has no $module" >&2
  echo "hint: apt-get install -y $package" >&2
  return 1
}
