#!/usr/bin/env bash
# The test command (README, "Two commands"; CI runs it through .ci/run).
#
#   bash tests/run.sh            the fast tier (everything not marked slow)
#   bash tests/run.sh --slow     the slow tier only (tests marked @pytest.mark.slow)
#
# Further arguments go to pytest.  Installs the system tools the tests need
# from Debian when they are missing and it may (root, or sudo without a
# password), then the project with its test extra, then runs pytest on every
# core (pytest-xdist).  A missing tool is an error (exit 2), never a skip.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

tier=(-m "not slow")
if [[ "${1:-}" == "--slow" ]]; then
  tier=(-m slow)
  shift
fi

# clang and gcc/g++: the generated C is compiled with each of them (make: examples/c);
# pdflatex: `derive latex --pdf` compiles the report;
# pdftoppm, pdftotext: the PDF pages are rendered and their text checked.
PACKAGES=(clang texlive-latex-base texlive-latex-recommended texlive-fonts-recommended poppler-utils)
missing_tools() {
  missing=()
  for tool in clang pdflatex pdftoppm pdftotext g++; do
    command -v "$tool" >/dev/null 2>&1 || missing+=("$tool")
  done
  command -v cc >/dev/null 2>&1 || command -v gcc >/dev/null 2>&1 || missing+=("cc")
  command -v make >/dev/null 2>&1 || missing+=("make")
}
missing_tools
if [[ " ${missing[*]} " == *" cc "* || " ${missing[*]} " == *" g++ "* ]]; then
  PACKAGES+=(gcc g++)
fi
if [[ " ${missing[*]} " == *" make "* ]]; then
  PACKAGES+=(make)
fi

if ((${#missing[@]})); then
  sudo=()
  if [[ "$(id -u)" != 0 ]] && command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
    sudo=(sudo -n)
  fi
  if command -v apt-get >/dev/null 2>&1 && { [[ "$(id -u)" == 0 ]] || ((${#sudo[@]})); }; then
    echo "tests/run.sh: installing ${PACKAGES[*]} from Debian (missing: ${missing[*]}; the tests compile the generated C with gcc, clang and g++, compile the LaTeX report and check its PDF)"
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      "${PACKAGES[@]}" >/dev/null
    missing_tools
  fi
  if ((${#missing[@]})); then
    echo "tests/run.sh: missing ${missing[*]}; install the Debian packages ${PACKAGES[*]} (e.g. as root: apt-get install ${PACKAGES[*]})" >&2
    exit 2
  fi
fi

export PIP_ROOT_USER_ACTION=ignore
python3 -m pip install -q -e '.[test]'
exec python3 -m pytest -q -n auto "${tier[@]}" "$@"
